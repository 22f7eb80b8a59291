"""pik_mj.robot.Robot: names, limbs, angle vectors, frames, mass, centroid."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from fd import fd_jacobian

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Limb, Robot
from pik_mj.robot.loading import load_model


@pytest.fixture(scope="module")
def humanoid() -> Robot:
    return Robot.from_model("sample_humanoid")


def _random_pose(robot: Robot, rng: np.random.Generator) -> None:
    lower, upper = robot.joint_limits()
    lower = np.where(np.isfinite(lower), lower, -1.0)
    upper = np.where(np.isfinite(upper), upper, 1.0)
    robot.set_angle_vector(rng.uniform(lower, upper))
    if robot.has_floating_base:
        robot.set_root_pose(rng.normal(size=3), rng.normal(size=4))


def _fresh_forward(model: mujoco.MjModel, qpos: np.ndarray) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    return data


# ------------------------------------------------------------ names, limbs
@pytest.mark.parametrize(
    ("name", "njoints", "root", "limbs"),
    [
        ("three_dof_arm", 3, "l1", ["arm"]),
        (
            "sample_humanoid",
            30,
            "pelvis",
            ["rarm", "larm", "rleg", "lleg", "torso", "head"],
        ),
        ("dm_humanoid", 21, "torso", ["rarm", "larm", "rleg", "lleg", "torso"]),
        (
            "dm_humanoid_cmu",
            56,
            "root",
            ["rarm", "larm", "rleg", "lleg", "torso", "head"],
        ),
    ],
)
def test_load_names_and_limbs(name, njoints, root, limbs):
    robot = Robot.from_model(name)
    assert len(robot.joint_names) == njoints
    assert robot.root_body == root
    assert list(robot.limbs) == limbs
    assert robot.has_floating_base == (name != "three_dof_arm")
    model = robot.model
    for limb in robot.limbs.values():
        # Every limb joint is a hinge of the robot, on the chain to the end frame.
        chain = robot.joint_list(limb.end_frame, limb.end_frame_type)
        assert set(limb.joints) <= set(chain)
        assert list(limb.joints) == [j for j in chain if j in limb.joints]
        first = model.joint(limb.joints[0])
        assert model.body(first.bodyid[0]).name == limb.root_body
    assert f"root_body={root!r}" in repr(robot)


def test_sample_humanoid_limb_table(humanoid):
    assert humanoid.limb("rarm") == Limb(
        "rarm",
        (
            "rarm_shoulder_p",
            "rarm_shoulder_r",
            "rarm_shoulder_y",
            "rarm_elbow_p",
            "rarm_wrist_y",
            "rarm_wrist_r",
            "rarm_wrist_p",
        ),
        "rarm_end",
        "site",
        "rarm_upper",
    )
    assert humanoid.limb("lleg").end_frame == "lleg_end"
    assert humanoid.limb("torso").joints == ("torso_waist_p", "torso_waist_y")
    assert humanoid.limb("head").end_frame == "head_end"


def test_dm_humanoid_limbs_reach_their_ends():
    robot = Robot.from_model("dm_humanoid")
    assert robot.limb("rleg").joints == (
        "right_hip_x",
        "right_hip_z",
        "right_hip_y",
        "right_knee",
        "right_ankle_y",
        "right_ankle_x",
    )
    assert (robot.limb("rleg").end_frame, robot.limb("rleg").end_frame_type) == (
        "right_foot",
        "body",
    )
    assert robot.limb("larm").end_frame == "left_hand"
    assert robot.link_list("right_foot", "body") == [
        "torso",
        "lower_waist",
        "pelvis",
        "right_thigh",
        "right_shin",
        "right_foot",
    ]


def test_unknown_limb_lists_limbs(humanoid):
    with pytest.raises(UnknownName) as err:
        humanoid.limb("tail")
    assert err.value.kind == "limb"
    assert err.value.valid == sorted(humanoid.limbs)
    assert "rarm" in str(err.value)


def test_root_body_in_scene_is_the_robot_not_the_kettle():
    for name, root in (("three_dof_arm", "l1"), ("sample_humanoid", "pelvis")):
        robot = Robot.from_model(name, environment="room", at=(0.4, 0.0, 0.0))
        assert robot.root_body == root
        assert "kettle_free" not in robot.joint_names
        assert robot.joint_names == Robot.from_model(name).joint_names
    arm_in_room = Robot.from_model("three_dof_arm", environment="room")
    assert arm_in_room.mass == pytest.approx(Robot.from_model("three_dof_arm").mass)
    kettle = Robot(arm_in_room.model, root_body="kettle")
    assert kettle.mass == pytest.approx(1.0, abs=0.05) and kettle.limbs == {}
    with pytest.raises(InvalidInput, match="top-level"):
        Robot(arm_in_room.model, root_body="l2")
    with pytest.raises(UnknownName):
        Robot(arm_in_room.model, root_body="nope")


# ----------------------------------------------------------- angle vectors
def test_angle_vector_round_trip_and_kinematics_current(humanoid):
    rng = np.random.default_rng(1)
    lower, upper = humanoid.joint_limits()
    q = rng.uniform(lower, upper)
    humanoid.set_angle_vector(q)
    np.testing.assert_array_equal(humanoid.angle_vector(), q)
    # The configuration's kinematics match a fresh mj_forward of the same qpos.
    data = _fresh_forward(humanoid.model, humanoid.configuration.q)
    for site in ("rarm_end", "lleg_end", "head_end"):
        np.testing.assert_allclose(humanoid.data.site(site).xpos, data.site(site).xpos)
        X = humanoid.frame_pose(site, "site")
        np.testing.assert_allclose(X.translation(), data.site(site).xpos, atol=1e-12)
        np.testing.assert_allclose(
            X.rotation().as_matrix(), data.site(site).xmat.reshape(3, 3), atol=1e-12
        )
    # By name, a subset, in any order; the others stay.
    names = ["rleg_knee_p", "head_neck_y"]
    humanoid.set_angle_vector([0.7, -0.2], names)
    np.testing.assert_array_equal(humanoid.angle_vector(names), [0.7, -0.2])
    np.testing.assert_array_equal(
        humanoid.angle_vector(["lleg_knee_p"]),
        q[[humanoid.joint_names.index("lleg_knee_p")]],
    )
    assert humanoid.data.joint("rleg_knee_p").qpos[0] == 0.7
    humanoid.reset_pose()


def test_angle_vector_errors(humanoid):
    n = len(humanoid.joint_names)
    with pytest.raises(InvalidInput, match="shape"):
        humanoid.set_angle_vector(np.zeros(n - 1))
    with pytest.raises(InvalidInput, match="NaN"):
        humanoid.set_angle_vector(np.full(n, np.nan))
    with pytest.raises(UnknownName) as err:
        humanoid.angle_vector(["rleg_knee"])
    assert "rleg_knee_p" in str(err.value)
    with pytest.raises(InvalidInput, match="free joint"):
        humanoid.set_angle_vector([0.0], ["root"])
    with pytest.raises(InvalidInput):
        humanoid.angle_vector("rleg_knee_p")


def test_ball_joint_is_rejected_clearly():
    model = mujoco.MjModel.from_xml_string(
        """<mujoco><compiler angle="radian"/><worldbody>
        <body name="a"><joint name="ball" type="ball"/><geom size="0.1"/>
          <body name="b" pos="0 0 -0.3"><joint name="hinge" axis="0 1 0"/>
            <geom size="0.1"/></body></body></worldbody></mujoco>"""
    )
    robot = Robot(model)
    assert robot.joint_names == ["hinge"]
    with pytest.raises(InvalidInput, match="BALL"):
        robot.angle_vector(["ball"])
    lower, upper = robot.joint_limits()
    assert lower[0] == -np.inf and upper[0] == np.inf


# ------------------------------------------------------------- root, reset
def test_root_pose(humanoid):
    humanoid.set_root_pose([0.1, 0.2, 0.9], [2.0, 0.0, 0.0, 2.0])
    p, quat = humanoid.root_pose()
    np.testing.assert_allclose(p, [0.1, 0.2, 0.9])
    np.testing.assert_allclose(quat, [np.sqrt(0.5), 0, 0, np.sqrt(0.5)])
    # The pelvis x axis now points along world y.
    X = humanoid.frame_pose("pelvis", "body")
    np.testing.assert_allclose(X.rotation().as_matrix()[:, 0], [0, 1, 0], atol=1e-12)
    with pytest.raises(InvalidInput, match="zero"):
        humanoid.set_root_pose([0, 0, 1], [0, 0, 0, 0])
    with pytest.raises(InvalidInput, match="shape"):
        humanoid.set_root_pose([0, 0], [1, 0, 0, 0])
    humanoid.reset_pose()
    arm = Robot.from_model("three_dof_arm")
    with pytest.raises(InvalidInput, match="free joint"):
        arm.set_root_pose([0, 0, 0], [1, 0, 0, 0])
    p, quat = arm.root_pose()
    np.testing.assert_array_equal(p, 0)
    np.testing.assert_array_equal(quat, [1, 0, 0, 0])


def test_reset_pose_uses_keyframe_or_qpos0(humanoid):
    humanoid.set_angle_vector(np.zeros(len(humanoid.joint_names)))
    humanoid.reset_pose()
    model = humanoid.model
    np.testing.assert_array_equal(
        humanoid.configuration.q, model.key_qpos[model.key("reset_pose").id]
    )
    assert humanoid.angle_vector(["rleg_knee_p"])[0] == pytest.approx(0.4)
    arm = Robot.from_model("three_dof_arm")
    arm.set_angle_vector([0.1, 0.2, 0.3])
    arm.reset_pose()
    np.testing.assert_array_equal(arm.configuration.q, arm.model.qpos0)


# ---------------------------------------------------------- link lists
def test_link_list_three_dof_arm():
    arm = Robot.from_model("three_dof_arm")
    assert arm.link_list("end") == ["l1", "l2", "l3", "l4"]
    assert arm.link_list("l3", "body") == ["l1", "l2", "l3"]
    assert arm.link_list("l2_box", "geom") == ["l1", "l2"]
    assert arm.joint_list("end") == ["joint0", "joint1", "joint2"]
    assert arm.joint_list("l3", "body") == ["joint0", "joint1"]
    with pytest.raises(UnknownName) as err:
        arm.link_list("tip")
    assert err.value.valid == ["end"]
    with pytest.raises(InvalidInput, match="frame_type"):
        arm.link_list("end", "joint")


def test_link_list_humanoid_and_frames_off_the_robot(humanoid):
    assert humanoid.link_list("rleg_end") == [
        "pelvis",
        "rleg_thigh",
        "rleg_shank",
        "rleg_foot",
    ]
    assert humanoid.link_list("larm_end")[:3] == ["pelvis", "torso_chest", "larm_upper"]
    scene = Robot.from_model("sample_humanoid", environment="room")
    with pytest.raises(InvalidInput, match="not on the robot"):
        scene.link_list("kettle_handle")


# -------------------------------------------------------- mass and centroid
def _brute_force_com(robot: Robot) -> tuple[float, np.ndarray]:
    model, data = robot.model, robot.data
    bodies = [b for b in range(model.nbody) if model.body_rootid[b] == robot.root_body_id]
    m = model.body_mass[bodies]
    return float(m.sum()), (m[:, None] * data.xipos[bodies]).sum(axis=0) / m.sum()


def test_mass_and_com_against_brute_force():
    rng = np.random.default_rng(2)
    for robot in (
        Robot.from_model("sample_humanoid"),
        Robot.from_model("sample_humanoid", environment="room"),
        Robot.from_model("dm_humanoid", environment="room"),
    ):
        _random_pose(robot, rng)
        mass, com = _brute_force_com(robot)
        assert robot.mass == pytest.approx(mass, rel=1e-12)
        np.testing.assert_allclose(robot.com(), com, atol=1e-12)
    assert Robot.from_model("sample_humanoid").mass == pytest.approx(58.5)
    # In the room, the kettle is not part of the robot.
    scene = Robot.from_model("sample_humanoid", environment="room")
    assert scene.mass == pytest.approx(58.5)
    assert not np.allclose(scene.com(), scene.data.subtree_com[0])


@pytest.mark.parametrize(
    ("name", "environment"),
    [("sample_humanoid", None), ("dm_humanoid", None), ("sample_humanoid", "room")],
)
def test_com_jacobian_against_finite_differences(name, environment):
    model = (
        load_model(name)
        if environment is None
        else Robot.from_model(name, environment=environment, at=(0.3, -0.2, 0.7)).model
    )
    robot = Robot(model)
    _random_pose(robot, np.random.default_rng(3))
    J_com = robot.com_jacobian()
    q0 = robot.configuration.q
    J_fd = fd_jacobian(model, q0, lambda _: robot.com(), configuration=robot.configuration)
    np.testing.assert_allclose(J_com, J_fd, atol=1e-6)
    # Translating the floating base moves the centroid one to one.
    dof = model.jnt_dofadr[model.joint("root").id]
    np.testing.assert_allclose(J_com[:, dof : dof + 3], np.eye(3), atol=1e-12)
    if environment is not None:  # the kettle's columns are zero
        k = model.jnt_dofadr[model.joint("kettle_free").id]
        assert np.all(J_com[:, k : k + 6] == 0)


def test_joint_limits(humanoid):
    lower, upper = humanoid.joint_limits(["rleg_knee_p", "rarm_elbow_p"])
    np.testing.assert_array_equal(lower, [0.0, -2.5])
    np.testing.assert_array_equal(upper, [2.5, 0.0])
    lower, upper = humanoid.joint_limits()
    assert lower.shape == upper.shape == (30,) and np.all(lower < upper)
    with pytest.raises(UnknownName):
        humanoid.joint_limits(["nope"])


def test_repr(humanoid):
    text = repr(humanoid)
    for part in ("sample_humanoid", "pelvis", "joints=30", "58.500 kg", "rarm"):
        assert part in text
