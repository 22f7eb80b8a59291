"""Faults at the library's entrances: each input is refused where it enters, naming
what is wrong, instead of surfacing later as a wrong number or a wrong blame.

* an MJCF with a NaN loads only to fail at ``hold`` blaming a servo gain: now the
  load names the element and its field;
* a description whose ``rarm.joints`` names a left-elbow joint built a nonsense arm,
  and a description of another model was ignored: both refused;
* a camera on ``mj_kinematics`` data projected a point dead ahead to NaN (its pose was
  never computed): the pose is computed where the camera is used;
* the ZMP of foot sensors 20 ms into a fall (no contact) was a number: now None;
* a ``FrameTask`` built on one model converged on another model's configuration;
* a NaN in a middle waypoint was blamed on a "duration".
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie
from test_sensors import FEET, standing_scene

from pik_mj import Robot, Scene, solve
from pik_mj.exceptions import InvalidInput
from pik_mj.robot.camera import Camera
from pik_mj.robot.description import RobotDescription
from pik_mj.robot.loading import check_finite, load_model, model_path
from pik_mj.robot.sensors import RobotSensors, zmp_from_force_sensors
from pik_mj.tasks.frame import FrameTask

NAN_BODY = """
<mujoco model="nanbot">
  <compiler angle="radian"/>
  <worldbody>
    <body name="torso" pos="{pos}">
      <freejoint/>
      <geom name="trunk" type="box" size="0.1 0.1 0.2"/>
      <body name="arm" pos="0 0.2 0">
        <joint name="shoulder" axis="0 1 0" range="{range}"/>
        <geom name="upper" type="capsule" fromto="0 0 0 0 0 -0.3" size="0.03"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


# ------------------------------------------------------------------ model files
@pytest.mark.parametrize(
    ("pos", "joint_range", "named"),
    [
        ("nan 0 1", "-1 1", r"body 'torso': body_pos = \[nan, 0.0, 1.0\]"),
        ("0 0 1", "-1 inf", r"joint 'shoulder': jnt_range = \[-1.0, inf\]"),
    ],
)
def test_a_model_with_nan_or_inf_is_refused_at_load_naming_the_element(
    tmp_path, monkeypatch, pos, joint_range, named
):
    """Before: the model loaded (MuJoCo only warns) and the first error came at the
    hold, blaming a servo gain."""
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its NaN warning to ./MUJOCO_LOG.TXT
    path = tmp_path / "nanbot.xml"
    path.write_text(NAN_BODY.format(pos=pos, range=joint_range))
    with pytest.raises(InvalidInput, match=named):
        load_model(path)
    with pytest.raises(InvalidInput, match=f"model 'nanbot'.*{named}"):
        Robot.from_model(path)


@pytest.mark.parametrize(
    "name",
    ["sample_humanoid", "dm_humanoid", "dm_humanoid_cmu", "unitree_g1", "unitree_h1", "booster_t1"],
)
def test_every_shipped_and_menagerie_humanoid_is_finite(name):
    """The check refuses nothing that MuJoCo's humanoids hold (no field is
    legitimately infinite)."""
    if name.startswith(("unitree", "booster")):
        requires_menagerie(name)
    check_finite(load_model(name), name)  # raises on a false alarm


# ------------------------------------------------------------------ descriptions
def test_a_described_joint_off_the_limbs_chain_is_refused():
    """Before: ``rarm.joints`` ending with a left-arm joint built a right arm that
    moved the left wrist."""
    robot = Robot.from_model("sample_humanoid")
    rarm, larm = robot.limbs["rarm"], robot.limbs["larm"]
    joints = [*rarm.joints[:-1], larm.joints[-1]]
    described = RobotDescription.from_dict(
        {"limbs": {"rarm": {"end": rarm.end_frame, "joints": joints}}}
    )
    with pytest.raises(
        InvalidInput,
        match=rf"limbs.rarm.joints: joint '{larm.joints[-1]}' .* not on the chain.*"
        rf"'{rarm.joints[-1]}'",
    ):
        Robot.from_model("sample_humanoid", description=described)
    # the right joints are accepted, and give the same limb as the tree
    good = RobotDescription.from_dict(
        {"limbs": {"rarm": {"end": rarm.end_frame, "joints": list(rarm.joints)}}}
    )
    assert Robot.from_model("sample_humanoid", description=good).limbs["rarm"] == rarm


def test_a_menagerie_right_arm_described_with_a_left_elbow_is_refused():
    requires_menagerie("unitree_h1")
    model = load_model("unitree_h1")
    names = [model.joint(j).name for j in range(model.njnt)]
    left_elbow = next(n for n in names if "left" in n and "elbow" in n)
    right = [n for n in names if n.startswith("right_") and ("shoulder" in n or "elbow" in n)]
    described = RobotDescription.from_dict(
        {"limbs": {"rarm": {"end": "right_elbow_link", "joints": [*right[:-1], left_elbow]}}}
    )
    with pytest.raises(InvalidInput, match=f"joint '{left_elbow}'.*not on the chain"):
        Robot.from_model("unitree_h1", description=described)


def test_a_description_of_another_model_is_refused():
    """Before: the description's ``model`` was ignored without a word."""
    described = RobotDescription.from_dict({"model": "dm_humanoid"})
    with pytest.raises(InvalidInput, match=r"description is for model 'dm_humanoid'.*sample"):
        Robot.from_model("sample_humanoid", description=described)
    # the same model by name or by path is the same model
    same = RobotDescription.from_dict({"model": "sample_humanoid"})
    by_path = Robot.from_model(model_path("sample_humanoid"), description=same)
    assert by_path.model.nq == Robot.from_model("sample_humanoid").model.nq
    # without a model, the description's is used
    assert Robot.from_model(None, description=described).model.nq == load_model("dm_humanoid").nq


# ------------------------------------------------------------------ cameras
CAMERA_ON_A_BODY = """
<mujoco>
  <worldbody>
    <body name="head" pos="0 0 1">
      <freejoint/>
      <geom type="sphere" size="0.05" contype="0" conaffinity="0"/>
      <camera name="eye" pos="0.06 0 0" xyaxes="0 -1 0 0 0 1" fovy="60" resolution="320 240"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_camera_on_kinematics_only_data_projects_a_point_dead_ahead():
    """``mj_kinematics`` does not compute camera poses: before, a point 1.5 m ahead
    projected to NaN with depth -0 and "not visible". The reference: the camera
    frame from the body's pose by hand, and MuJoCo's own pose after ``mj_forward``."""
    model = mujoco.MjModel.from_xml_string(CAMERA_ON_A_BODY)
    data = mujoco.MjData(model)
    data.qpos[:3] = [0.3, -0.2, 1.1]
    data.qpos[3:7] = [np.cos(0.2), 0.0, 0.0, np.sin(0.2)]  # yawed 0.4 rad
    mujoco.mj_kinematics(model, data)
    camera = Camera(model, "eye")
    R_WB = data.xmat[1].reshape(3, 3)
    p_WC = data.xpos[1] + R_WB @ np.array([0.06, 0.0, 0.0])
    ahead = p_WC + 1.5 * R_WB[:, 0]  # the camera looks along the head's x
    (u, v), depth = camera.project(data, ahead)
    assert depth == pytest.approx(1.5, abs=1e-9)
    assert (u, v) == pytest.approx((160.0, 120.0), abs=1e-6)
    assert camera.visibility(data, ahead).visible
    p, R = camera.pose(data)
    reference = mujoco.MjData(model)
    reference.qpos[:] = data.qpos
    mujoco.mj_forward(model, reference)
    np.testing.assert_allclose(p, reference.cam_xpos[0], atol=1e-12)
    np.testing.assert_allclose(R, reference.cam_xmat[0].reshape(3, 3), atol=1e-12)


# ------------------------------------------------------------------ sensors
def test_the_sensor_zmp_of_a_falling_robot_is_none():
    """20 ms into a fall nothing touches the feet: the compensated readings still
    say ``m_foot g`` up per foot (the compensation alone), which made a ZMP."""
    model, data = standing_scene(duration=0.05)
    feet = [RobotSensors.from_model(model).force_sensor(f) for f in FEET]
    assert zmp_from_force_sensors(model, data, feet) is not None  # standing: loaded
    assert all(f.loaded(model, data) for f in feet)
    data.qpos[2] += 0.5  # lifted half a metre: a fall
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    for _ in range(round(0.02 / model.opt.timestep)):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    weight = [-model.body_subtreemass[model.body(f.body).id] * model.opt.gravity[2] for f in feet]
    fz = [f.contact_wrench(model, data).force[2] for f in feet]
    np.testing.assert_allclose(fz, weight, rtol=0.05)  # what the old ZMP was built on
    assert min(fz) > 1.0  # above the threshold
    assert not any(f.loaded(model, data) for f in feet)
    assert zmp_from_force_sensors(model, data, feet) is None


# ------------------------------------------------------------------ tasks
def test_a_frame_task_solved_on_another_models_configuration_is_refused():
    """Before: it converged (27 iterations) on the other model's bodies."""
    built_on = Robot.from_model("sample_humanoid")
    other = Robot.from_model("dm_humanoid")
    target = (np.array([0.3, -0.2, 1.0]), np.array([1.0, 0.0, 0.0, 0.0]))
    task = FrameTask(built_on.configuration, "rarm_end", target, rotation_axis=False)
    q0 = other.configuration.q.copy()
    with pytest.raises(InvalidInput, match=r"built on model 'sample_humanoid'.*'humanoid'"):
        solve(other.configuration, [[], [task]], stop=50)
    np.testing.assert_array_equal(other.configuration.q, q0)
    # a copy of the model it was built on (the same MJCF compiled again) is that model
    copy = Robot.from_model("sample_humanoid")
    result = solve(copy.configuration, [[], [task]], stop=50)
    assert result.converged


# ------------------------------------------------------------------ paths
def test_a_nan_in_a_middle_waypoint_names_the_waypoint_and_the_joint():
    """Before: "duration must be a finite number > 0, got nan"."""
    robot = Robot.from_model("sample_humanoid")
    scene = Scene.from_robot(robot)
    q = np.tile(robot.configuration.q, (5, 1))
    joint = robot.limbs["rarm"].joints[2]
    q[3, robot.model.joint(joint).qposadr[0]] = np.nan
    with pytest.raises(InvalidInput, match=rf"waypoint 3 of 5 .*joint '{joint}'.* = nan"):
        scene.play(q)
