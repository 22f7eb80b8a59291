"""Robots as their MJCF ships them (issue 14): small humanoids written here, each
with one thing the project used to refuse or mis-read, built with
``Robot.from_model`` and ``Scene.from_robot`` and nothing else, reaching with
the right hand (both feet fixed, the CoM over them) and holding the pose 3 s in
physics:

* an unnamed free joint, unnamed bodies and geoms, and other top-level bodies
  (a crate before the robot in the MJCF, a post after it);
* its own position actuators (they are the hold's servos);
* hinges without a range;
* an ``<equality joint>`` coupling (kept by the IK at level 0 and by the physics);
* a zero pose floating 21 mm above the floor (put down);
* soles that touch the floor only through explicit ``<contact><pair>``\\ s;
* limbs the tree does not give: a clear error before any work, and a robot
  description that supplies them.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from pik_mj import HoldCriteria, Robot, Scene, fullbody_inverse_kinematics
from pik_mj.exceptions import LimbsNotFound, UnknownName
from pik_mj.robot import GROUND_TOLERANCE, STANDING_KEYFRAME
from pik_mj.robot.couplings import find_couplings
from pik_mj.robot.description import load_description
from pik_mj.robot.ground import floor_gap
from pik_mj.scenario import Stature

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def _leg(side: str, y: float, joint: str, sole: str) -> str:
    return f"""
      <body name="{side}leg_thigh" pos="0 {y} -0.05">
        <joint name="{side}leg_hip_r" axis="1 0 0" {joint}/>
        <joint name="{side}leg_hip_p" axis="0 1 0" {joint}/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.03" mass="1.5"/>
        <body name="{side}leg_shank" pos="0 0 -0.25">
          <joint name="{side}leg_knee_p" axis="0 1 0" {joint}/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.25" size="0.025" mass="1"/>
          <body name="{side}leg_foot" pos="0 0 -0.25">
            <joint name="{side}leg_ankle_p" axis="0 1 0" {joint}/>
            <joint name="{side}leg_ankle_r" axis="1 0 0" {joint}/>
            <geom {sole} type="box" size="0.08 0.045 0.02" pos="0.02 0 -0.02" mass="0.5"/>
          </body>
        </body>
      </body>"""


def _arm(side: str, y: float, joint: str) -> str:
    return f"""
      <body name="{side}arm_upper" pos="0 {y} 0.2">
        <joint name="{side}arm_shoulder_p" axis="0 1 0" {joint}/>
        <joint name="{side}arm_shoulder_r" axis="1 0 0" {joint}/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" mass="0.6"/>
        <body name="{side}arm_lower" pos="0 0 -0.2">
          <joint name="{side}arm_elbow_p" axis="0 1 0" {joint}/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.15" size="0.02" mass="0.3"/>
          <body name="{side}arm_hand" pos="0 0 -0.15">
            <joint name="{side}arm_wrist_p" axis="0 1 0" {joint}/>
            <geom type="box" size="0.02 0.02 0.04" pos="0 0 -0.04" mass="0.1"/>
            <site name="{side}arm_end" pos="0 0 -0.08"/>
          </body>
        </body>
      </body>"""


_BENT = "0 -0.3 0.6 -0.3 0"  # one leg: hip_r, hip_p, knee, ankle_p, ankle_r [rad]
_ARMS = "0 -0.2 -0.4 0  0 0.2 -0.4 0"  # rarm, larm: shoulder_p, shoulder_r, elbow, wrist


def humanoid(
    *,
    name: str = "little_humanoid",
    free: str = '<freejoint name="root"/>',
    torso: str = 'name="torso"',
    joint: str = 'range="-2.5 2.5"',
    soles: tuple[str, str] = ('name="rleg_sole"', 'name="lleg_sole"'),
    height: float = 0.9,
    keyframe: bool = True,
    before: str = "",
    before_qpos: str = "",
    after: str = "",
    extra: str = "",
) -> str:
    """A 16 kg humanoid, 8 + 10 + 8 hinges, box soles; with ``keyframe`` its start
    pose has the knees bent and the soles flat (hip + knee + ankle = 0).
    ``before``/``after``: MJCF of the world before/after the robot (``before_qpos``:
    the keyframe's qpos of the joints in ``before``)."""
    qpos = f"{before_qpos} 0 0 {height} 1 0 0 0 {_BENT} {_BENT} {_ARMS}"
    key = f'<keyframe><key name="stand" qpos="{qpos}"/></keyframe>'
    return f"""
<mujoco model="{name}">
  <compiler angle="radian" autolimits="true"/>
  <default><joint type="hinge" damping="0.5" armature="0.02"/></default>
  <worldbody>{before}
    <body {torso} pos="0 0 {height}">
      {free}
      <geom type="box" size="0.08 0.12 0.15" pos="0 0 0.1" mass="8"/>
      {_leg("r", -0.07, joint, soles[0])}{_leg("l", 0.07, joint, soles[1])}
      {_arm("r", -0.16, joint)}{_arm("l", 0.16, joint)}
    </body>{after}
  </worldbody>
  {key if keyframe else ""}
  {extra}
</mujoco>"""


def reach_and_hold(robot: Robot, scene: Scene, offset=(0.15, -0.05, 0.1), hold: float = 3.0):
    """The right hand ``offset`` [m] from where it is (position only), both feet
    fixed, the CoM over them; the final pose held ``hold`` s."""
    arm = robot.limb("rarm")
    target = robot.frame_pose(arm.end_frame, arm.end_frame_type).translation() + offset
    result = fullbody_inverse_kinematics(
        robot, [(target, IDENTITY)], limbs=["rarm"], rotation_axis=[None], stop=100
    )
    hand = robot.frame_pose(arm.end_frame, arm.end_frame_type).translation()
    report = scene.hold(robot.configuration.q.copy(), hold, criteria=HoldCriteria())
    return result, float(np.linalg.norm(hand - target)), report


def _solid(result, error, report, drift: float = 2e-3) -> None:
    assert result.converged, result.summary()
    assert error <= 1e-3
    assert report.passed, report.failures
    assert report.drift < drift and report.slip < 1e-3 and not report.fell


# ------------------------------------------------------------------ unnamed
def test_unnamed_free_joint_and_geoms_and_other_top_level_bodies():
    """The free joint, the torso and every geom unnamed; a free crate comes before
    the robot in the MJCF (its joint is the model's first) and a post after it."""
    crate = """
    <body name="crate" pos="1 0.5 0.1"><freejoint/>
      <geom type="box" size="0.1 0.1 0.1" mass="2"/></body>"""
    post = """
    <body name="post" pos="-1 0 0.5"><geom type="cylinder" size="0.05 0.5"/></body>"""
    floor = '\n    <geom name="floor" type="plane" size="5 5 0.1"/>'
    mjcf = humanoid(
        free="<freejoint/>",
        torso="",
        soles=("", ""),
        before=floor + crate,
        before_qpos="1 0.5 0.1 1 0 0 0",
        after=post,
    )
    spec = mujoco.MjSpec.from_string(mjcf)
    assert sum(1 for g in spec.geoms if not g.name) == 15
    robot = Robot.from_model(spec)
    model = robot.model
    assert robot.root_body == "body2" and robot.has_floating_base  # the robot, not the crate
    assert model.joint(0).name == "crate_joint0" and model.joint(1).name == "body2_joint0"
    assert all(model.geom(g).name for g in range(model.ngeom))
    assert set(robot.limbs) == {"rarm", "larm", "rleg", "lleg"}
    assert robot.own_nq == model.nq == 7 + 7 + 18
    scene = Scene.from_robot(robot)
    # the soles, by their generated names; the crate and the post are the environment
    assert scene.allowed_contacts == ["rleg_foot_geom0", "lleg_foot_geom0"]
    assert scene.mass == pytest.approx(16.0)
    _solid(*reach_and_hold(robot, scene))
    crate_q = robot.configuration.q[:7]
    np.testing.assert_allclose(crate_q[:3], [1.0, 0.5, 0.1])  # frozen by the IK


# ---------------------------------------------------------- own actuators
def test_own_position_actuators_are_the_servos():
    """Position actuators (kp = 200 N·m/rad, critically damped) on every hinge: the
    scene adds no servo, sets their controls to the pose, and a joint held at
    0.5 rad stays there (left at zero control they pulled it to 0.428 rad on G1)."""
    joints = [
        f"{s}{j}"
        for s in ("rleg", "lleg")
        for j in ("_hip_r", "_hip_p", "_knee_p", "_ankle_p", "_ankle_r")
    ] + [
        f"{s}arm_{j}"
        for s in ("r", "l")
        for j in ("shoulder_p", "shoulder_r", "elbow_p", "wrist_p")
    ]
    actuators = "".join(
        f'<position name="{j}_motor" joint="{j}" kp="200" dampratio="1"/>' for j in joints
    )
    robot = Robot.from_model(
        mujoco.MjSpec.from_string(humanoid(extra=f"<actuator>{actuators}</actuator>"))
    )
    scene = Scene.from_robot(robot)
    assert scene.robot_servos == scene.servo_joints and len(joints) == 18
    assert scene.model.nu == 18  # no servo added
    assert scene.servo_gains["rleg_knee_p"][0] == pytest.approx(200.0)
    # the left elbow bent to 0.5 rad more than it stands
    q = robot.configuration.q.copy()
    elbow = robot.model.joint("larm_elbow_p").qposadr[0]
    q[elbow] += 0.5
    scene.set_pose(q)
    np.testing.assert_allclose(
        scene.data.ctrl[scene.model.actuator("larm_elbow_p_motor").id], q[elbow]
    )
    report = scene.hold(q, 3.0)
    assert report.passed, report.failures
    assert scene.data.qpos[elbow] == pytest.approx(q[elbow], abs=2e-3)
    robot.configuration.update(robot.start_q())
    _solid(*reach_and_hold(robot, scene))


# --------------------------------------------------------- no joint ranges
def test_hinges_without_ranges():
    robot = Robot.from_model(mujoco.MjSpec.from_string(humanoid(joint="")))
    assert not robot.model.jnt_limited.any()
    lower, upper = robot.joint_limits()
    assert np.all(np.isinf(lower)) and np.all(np.isinf(upper))
    _solid(*reach_and_hold(robot, Scene.from_robot(robot)))


# ------------------------------------------------------------- a coupling
def test_equality_joint_coupling_kept_by_the_ik_and_the_physics():
    """The right wrist follows the elbow, ``wrist = 0.5 elbow`` (MJCF
    ``<equality joint>``, polycoef 0 0.5): the IK keeps it at level 0 while the
    elbow moves, the physics keeps it in the hold."""
    coupling = (
        '<equality><joint joint1="rarm_wrist_p" joint2="rarm_elbow_p" polycoef="0 0.5 0 0 0"/>'
        "</equality>"
    )
    arms = "0 -0.2 -0.4 -0.2  0 0.2 -0.4 0"  # the right wrist on the coupling: -0.2 = 0.5 (-0.4)
    mjcf = humanoid(extra=coupling).replace(_ARMS, arms)
    robot = Robot.from_model(mujoco.MjSpec.from_string(mjcf))
    (coupling_,) = find_couplings(robot.model).couplings
    scene = Scene.from_robot(robot)
    q0 = robot.configuration.q.copy()
    elbow, wrist = (robot.model.joint(j).qposadr[0] for j in ("rarm_elbow_p", "rarm_wrist_p"))
    arm = robot.limb("rarm")
    X = robot.frame_pose(arm.end_frame, arm.end_frame_type)
    target = X.translation() + np.array([0.15, -0.05, 0.15])
    result = fullbody_inverse_kinematics(
        robot, [(target, IDENTITY)], limbs=["rarm"], rotation_axis=[None], stop=100
    )
    assert result.converged, result.summary()
    assert "mjcf_couplings" in {t.name for t in result.tasks}
    q = robot.configuration.q.copy()
    assert abs(q[elbow] - q0[elbow]) > 0.1  # the elbow moved, the wrist with it
    assert abs(q[wrist] - 0.5 * q[elbow]) < 1e-5
    assert abs(coupling_.error_and_jacobian(q, robot.model.nv)[0]) < 1e-5
    report = scene.hold(q, 3.0, criteria=HoldCriteria())
    assert report.passed, report.failures
    assert abs(scene.data.qpos[wrist] - 0.5 * scene.data.qpos[elbow]) < 1e-3


# -------------------------------------------------------- a floating zero pose
def test_zero_pose_floating_21_mm_is_put_down():
    """No keyframe, the zero pose (legs straight) 21 mm above the floor (Robotis
    OP3): the robot stands on it; held from 21 mm up it would drop."""
    # legs straight: the soles' bottom is 0.05 + 0.25 + 0.25 + 0.04 = 0.59 m below the torso
    spec = mujoco.MjSpec.from_string(humanoid(height=0.611, keyframe=False))
    raw = spec.compile()
    data = mujoco.MjData(raw)
    mujoco.mj_kinematics(raw, data)
    assert floor_gap(raw, data, "torso") == pytest.approx(0.021, abs=1e-9)
    robot = Robot.from_model(spec)
    assert robot.keyframe is None and robot.keyframe_rule == "zero pose"  # soles already flat
    assert robot.floor_gap() == pytest.approx(0.0, abs=1e-9)
    assert robot.root_pose()[0][2] == pytest.approx(0.59, abs=1e-9)
    scene = Scene.from_robot(robot)
    floating = robot.configuration.q.copy()
    floating[2] += 0.021
    dropped = scene.hold(floating, 1.0)
    assert not dropped.passed and dropped.drift > 0.015
    _solid(*reach_and_hold(robot, scene))


def test_tilted_soles_get_a_standing_keyframe():
    """Ankles pitched 8 mrad at the zero pose (dm_control's humanoid): the robot
    gets keyframe ``pik_mj_standing``, its soles flat, its base where it was."""
    mjcf = humanoid(height=0.59, keyframe=False).replace(
        'name="rleg_foot" pos="0 0 -0.25"', 'name="rleg_foot" pos="0 0 -0.25" euler="0 0.008 0"'
    )
    robot = Robot.from_model(mujoco.MjSpec.from_string(mjcf))
    assert robot.keyframe == STANDING_KEYFRAME
    assert robot.keyframe_rule == "zero pose, soles made flat"
    sole = robot.data.geom("rleg_sole")
    assert sole.xmat.reshape(3, 3)[:, 2] == pytest.approx([0.0, 0.0, 1.0], abs=1e-4)
    # the pitch axes are parallel: the foot's pitch is 0.008 + hip_p + knee_p + ankle_p
    pitch = robot.angle_vector(["rleg_hip_p", "rleg_knee_p", "rleg_ankle_p"]).sum()
    assert pitch == pytest.approx(-0.008, abs=1e-4)
    assert robot.floor_gap() == pytest.approx(0.0, abs=GROUND_TOLERANCE)


# ------------------------------------------------------------ contact pairs
def test_soles_touching_only_through_contact_pairs():
    """Soles with contype = conaffinity = 0 that touch the robot's own floor through
    ``<contact><pair>``\\ s (Menagerie's MJX models, Apptronik Apollo): the scene
    keeps the pairs; without them the robot sinks through the floor."""
    soles = (
        'name="rleg_sole" contype="0" conaffinity="0"',
        'name="lleg_sole" contype="0" conaffinity="0"',
    )
    pairs = (
        '<contact><pair geom1="rleg_sole" geom2="floor"/><pair geom1="lleg_sole" geom2="floor"/>'
        "</contact>"
    )
    floor = '\n    <geom name="floor" type="plane" size="5 5 0.1" contype="0" conaffinity="0"/>'
    spec = mujoco.MjSpec.from_string(humanoid(soles=soles, before=floor, extra=pairs))
    robot = Robot.from_model(spec)
    scene = Scene.from_robot(robot)
    assert scene.model.npair == 2 and scene.allowed_contacts == ["rleg_sole", "lleg_sole"]
    assert scene.model.pair_solref[0, 0] == pytest.approx(0.005)  # the scene's contact
    static = scene.static_check(robot.configuration.q)
    assert static.feasible and static.touching_geoms == ["lleg_sole", "rleg_sole"]
    _solid(*reach_and_hold(robot, scene))
    without = Robot.from_model(mujoco.MjSpec.from_string(humanoid(soles=soles, before=floor)))
    sinking = Scene.from_robot(without).hold(without.configuration.q, 0.5)
    assert sinking.fell or sinking.drift > 0.05


# -------------------------------------------------- limbs the tree does not give
def _one_armed(tmp_path):
    """The humanoid with one arm, on its middle line (``carm``): the tree gives its
    legs, no left or right arm."""
    mjcf = humanoid(name="one_armed").replace(_ARMS, "0 0 -0.4 0")
    start = mjcf.index('<body name="rarm_upper"')
    end = mjcf.index("</body>\n    </body>", mjcf.index('<body name="larm_upper"'))
    mjcf = mjcf[:start] + _arm("c", 0.0, 'range="-2.5 2.5"').strip() + mjcf[end + 7 :]
    path = tmp_path / "one_armed.xml"
    path.write_text(mjcf)
    return path


def test_limbs_not_found_is_said_before_any_work(tmp_path):
    path = _one_armed(tmp_path)
    robot = Robot.from_model(path)  # nothing required: the legs it has
    assert set(robot.limbs) == {"rleg", "lleg"}
    with pytest.raises(LimbsNotFound) as err:
        Robot.from_model(path, required_limbs=["rleg", "lleg", "larm"])
    message = str(err.value)
    assert "['larm']" in message  # what is missing
    assert "rleg (5 joints" in message and "lleg (5 joints" in message  # what was found
    assert "[limbs.rarm]" in message and "--description PATH" in message  # how to describe it
    with pytest.raises(UnknownName, match=r"limb 'larm' does not exist.*'lleg'.*description"):
        robot.limb("larm")


def test_description_gives_the_limbs_to_the_cli(tmp_path, capsys):
    """``pik-mj run fullbody_reach --description FILE``: the description names the
    model (relative to the file) and the left arm; the run passes with its hold."""
    from pik_mj import cli

    _one_armed(tmp_path)
    text = 'model = "one_armed.xml"\nkeyframe = "stand"\n\n[limbs.larm]\nend = "carm_end"\n'
    (tmp_path / "one_armed.toml").write_text(text)
    description = load_description(tmp_path / "one_armed.toml")
    robot = Robot.from_model(description=description)
    assert robot.limb("larm").joints == (
        "carm_shoulder_p",
        "carm_shoulder_r",
        "carm_elbow_p",
        "carm_wrist_p",
    )
    assert robot.source.to_dict()["description"]["limbs"] == {"larm": {"end": "carm_end"}}
    js = tmp_path / "run.json"
    args = ["run", "fullbody_reach", "--description", str(tmp_path / "one_armed.toml")]
    # --speed 0: this one-armed robot's IK path runs its forearm through its torso
    # between two iterates (the motion playback reports it; the final pose is fine)
    code = cli.main(
        [*args, "--headless", "--quiet", "--hold", "1", "--speed", "0", "--json", str(js)]
    )
    out = capsys.readouterr()
    assert code == 0, out.out + out.err
    assert "[ok] converged" in out.out and "hold 1.00 s" in out.out
    # the run's robot is rebuilt from its source, description file included
    assert cli.main(["validate", str(js), "--duration", "0.5"]) == 0
    capsys.readouterr()
    assert (
        cli.main(
            [
                "run",
                "fullbody_reach",
                "--model",
                str(tmp_path / "one_armed.xml"),
                "--headless",
                "--quiet",
            ]
        )
        == 2
    )  # a usage error, before any work: what is missing and how to describe it
    err = capsys.readouterr().err
    assert "has no limb larm" in err and "--description PATH" in err


# ------------------------------------------------------------- hand's axes
@pytest.mark.parametrize("quat", ["1 0 0 0", "0.5 0.5 0.5 0.5", "0 0.7071068 0 0.7071068"])
def test_grip_axis_from_the_forearm_not_the_wrist_or_the_hand_geom_frame(quat):
    """The right hand ends in a wrist of two joints whose last anchor sits 5 cm
    to the front and side of the hand's centre (an offset wrist yaw), the hand
    frame is a box geom whose axes are turned as a mesh's principal axes would be
    (``quat``), no site. The forearm hangs: the grip axis (a bar in the fist) is
    forward, the palm faces the body's middle, whatever the geom's axes, because the
    forearm is read from the elbow, not from the wrist's anchor next to the hand."""
    hand = f"""<body name="rarm_hand" pos="0 0 -0.15">
            <joint name="rarm_wrist_p" axis="0 1 0" range="-2.5 2.5"/>
            <geom type="box" size="0.01 0.01 0.01" pos="0 0 -0.01" mass="0.05"/>
            <body name="rarm_palm" pos="0 0 -0.02">
              <joint name="rarm_wrist_y" axis="0 0 1" pos="0.03 0.04 -0.035" range="-2.5 2.5"/>
              <geom type="box" size="0.02 0.03 0.04" pos="0 0 -0.04" quat="{quat}" mass="0.1"/>
            </body>
          </body>"""
    mjcf = humanoid(keyframe=False)
    start = mjcf.index('<body name="rarm_hand"')
    end = mjcf.index("</body>", mjcf.index('<site name="rarm_end"')) + len("</body>")
    mjcf = mjcf[:start] + hand + mjcf[end:]
    robot = Robot.from_model(mujoco.MjSpec.from_string(mjcf))
    assert robot.limb("rarm").joints[-1] == "rarm_wrist_y"
    stature = Stature.of(robot)
    right = stature.hands["rarm"]
    assert right.frame_type == "geom" and right.body == "rarm_palm"
    X = right.pose(robot)
    forward, left = stature.R_WR[:, 0], stature.R_WR[:, 1]
    assert right.axis(X, right.grip) @ forward > 0.99
    assert right.axis(X, right.palm) @ left > 0.99  # the right palm faces left, inwards
