"""Tests of pik_mj.robot.sensors: force/torque sensors, the ZMP from them, IMUs, bumpers.

The physics scenes are built here with MjSpec (sample humanoid + floor plane +
a position servo per hinge), independent of pik_mj.sim. References: the
robot's weight, its CoM (MuJoCo's ``subtree_com``), MuJoCo's contact forces
(``mj_contactForce``), hand computations of the ZMP formula, gravity rotated
into a site frame built from its MJCF, and a hinge's velocity times its axis.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.loading import load_model, load_spec
from pik_mj.robot.sensors import (
    FORCE_TORQUE,
    IMU,
    ContactWrench,
    RobotSensors,
    add_sensors,
    zmp_from_force_sensors,
    zmp_from_wrenches,
)

LIMBS = {
    "rleg": ["rleg_thigh", "rleg_shank", "rleg_foot"],
    "lleg": ["lleg_thigh", "lleg_shank", "lleg_foot"],
    "rarm": ["rarm_upper", "rarm_lower", "rarm_hand"],
    "larm": ["larm_upper", "larm_lower", "larm_hand"],
    "head": ["head_link"],
}
FEET = ("rleg_end", "lleg_end")
RAISED_ARM = -1.2  # rarm_shoulder_r [rad] of the standing pose


def standing_scene(
    spec: mujoco.MjSpec | None = None, duration: float = 1.0, box: tuple | None = None
) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The sample humanoid on a floor, its right arm raised sideways
    (``rarm_shoulder_r = -1.2``, so the right foot carries more), servos (kp 3000
    N·m/rad, kv 300 N·m·s/rad: damped enough to be still after 1 s) holding
    the pose for ``duration`` seconds, then ``mj_forward``. ``box``: (centre,
    half sizes) of a static box added to the world."""
    spec = load_spec("sample_humanoid") if spec is None else spec
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[5, 5, 0.1])
    if box is not None:
        spec.worldbody.add_geom(
            name="box", type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(box[0]), size=list(box[1])
        )
    hinges = [j.name for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_HINGE]
    for name in hinges:
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=3000.0, kv=300.0)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("reset_pose").id)
    data.joint("rarm_shoulder_r").qpos[0] = RAISED_ARM
    data.ctrl[:] = [data.joint(n).qpos[0] for n in hinges]
    for _ in range(round(duration / model.opt.timestep)):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    return model, data


def robot_contact_wrenches(
    model: mujoco.MjModel, data: mujoco.MjData, geoms: set[str] | None = None
) -> list[ContactWrench]:
    """MuJoCo's contact forces on the robot (``mj_contactForce``: the force of
    geom1 on geom2 in the contact frame, whose rows are the frame's axes), each
    at its contact point; only contacts of robot geoms in ``geoms`` when given."""
    robot = model.body("pelvis").id
    out = []
    for i in range(data.ncon):
        c = data.contact[i]
        ft = np.zeros(6)
        mujoco.mj_contactForce(model, data, i, ft)
        R = c.frame.reshape(3, 3)
        for g, sign in ((c.geom2, 1.0), (c.geom1, -1.0)):
            if model.body_rootid[model.geom_bodyid[g]] != robot:
                continue
            if geoms is not None and model.geom(g).name not in geoms:
                continue
            out.append(ContactWrench(sign * R.T @ ft[:3], sign * R.T @ ft[3:], c.pos.copy()))
    return out


@pytest.fixture(scope="module")
def standing() -> tuple[mujoco.MjModel, mujoco.MjData]:
    return standing_scene()


# ----------------------------------------------------------------- discovery
def test_sample_humanoid_sensors_found_and_grouped():
    model = load_model("sample_humanoid")
    sensors = RobotSensors.from_model(model)
    assert [s.name for s in sensors.force_sensors] == [
        "rleg_end",
        "lleg_end",
        "rarm_end",
        "larm_end",
    ]
    assert [s.name for s in sensors.imu_sensors] == ["imu"]
    assert [b.name for b in sensors.bumpers] == ["rarm_bumper", "larm_bumper"]
    rleg = sensors.force_sensor("rleg_end")
    assert (rleg.body, rleg.force.name, rleg.torque.name) == (
        "rleg_foot",
        "rleg_end_force",
        "rleg_end_torque",
    )
    assert (rleg.force.frame, rleg.force.unit, rleg.torque.unit) == ("site", "N", "N·m")
    imu = sensors.imu_sensor("imu")
    assert imu.body == "pelvis"
    assert [imu.accelerometer.unit, imu.gyro.unit, imu.framequat.frame] == [
        "m/s²",
        "rad/s",
        "world",
    ]
    readings = sensors.read(mujoco.MjData(model))
    assert {k: v.shape for k, v in readings.items()} == {
        **{
            f"{s}_{k}": (3,)
            for s in ("rleg_end", "lleg_end", "rarm_end", "larm_end")
            for k in FORCE_TORQUE
        },
        "imu_accelerometer": (3,),
        "imu_gyro": (3,),
        "imu_framequat": (4,),
        "rarm_bumper_touch": (1,),
        "larm_bumper_touch": (1,),
    }
    limbs = sensors.by_limb(LIMBS)
    assert [s.name for s in limbs["rleg"].force_sensors] == ["rleg_end"]
    assert [b.name for b in limbs["larm"].bumpers] == ["larm_bumper"]
    assert limbs["rarm"].imu_sensors == () and limbs["head"].force_sensors == ()
    assert all(c.body in LIMBS["rarm"] for c in limbs["rarm"].channels)
    # the pelvis IMU belongs to no limb; restricting to bodies drops it too
    only_legs = RobotSensors.from_model(model, bodies=LIMBS["rleg"] + LIMBS["lleg"])
    assert [s.name for s in only_legs.force_sensors] == ["rleg_end", "lleg_end"]
    assert only_legs.imu_sensors == ()
    with pytest.raises(UnknownName, match=r"force sensor 'rleg'.*'rleg_end'"):
        sensors.force_sensor("rleg")
    with pytest.raises(UnknownName, match=r"IMU 'gsensor'.*\['imu'\]"):
        sensors.imu_sensor("gsensor")
    with pytest.raises(UnknownName, match="body 'nope'"):
        RobotSensors.from_model(model, bodies=["nope"])


ENVIRONMENT_WITH_SENSORS = """
<mujoco>
  <worldbody>
    <body name="table" pos="1 0 0.4">
      <geom name="table_top" type="box" size="0.3 0.3 0.02"/>
      <site name="table_pad" type="box" size="0.3 0.3 0.03"/>
      <camera name="wall_camera" pos="0 0 1" xyaxes="1 0 0 0 1 0"/>
    </body>
  </worldbody>
  <sensor><touch name="table_touch" site="table_pad"/></sensor>
</mujoco>
"""


def test_sensors_and_cameras_found_through_the_robot(tmp_path):
    """``robot.force_sensors``, ``.imu_sensors``, ``.bumpers``, ``.cameras``
    (seed ``:force-sensors``, ``:imu-sensors``, ``:cameras``), and by limb as
    ``(send robot :rleg :force-sensors)``: the robot's own, not the
    environment's touch sensor and camera."""
    env = tmp_path / "table.xml"
    env.write_text(ENVIRONMENT_WITH_SENSORS)
    robot = Robot.from_model("sample_humanoid", environment=str(env))
    alone = RobotSensors.from_model(load_model("sample_humanoid"))
    assert [s.name for s in robot.force_sensors] == [s.name for s in alone.force_sensors]
    assert [s.name for s in robot.imu_sensors] == ["imu"]
    assert [b.name for b in robot.bumpers] == ["rarm_bumper", "larm_bumper"]
    assert [c.name for c in robot.cameras] == ["head_camera"]
    assert "wall_camera" in [robot.model.camera(c).name for c in range(robot.model.ncam)]
    assert robot.camera("head_camera").intrinsics.width == 320
    # by limb: the limb's own bodies (the torso without the arms and the head)
    assert robot.bodies("rleg") == LIMBS["rleg"]
    assert robot.bodies("rarm") == LIMBS["rarm"]
    assert set(robot.bodies("torso")).isdisjoint(LIMBS["rarm"] + LIMBS["head"])
    for limb in ("rleg", "lleg", "rarm", "larm"):
        assert [s.name for s in robot.sensors(limb).force_sensors] == [f"{limb}_end"]
    assert [b.name for b in robot.sensors("rarm").bumpers] == ["rarm_bumper"]
    assert robot.sensors("torso").imu_sensors == ()  # the IMU is on the pelvis, the root
    with pytest.raises(UnknownName, match=r"camera of the robot 'wall_camera'.*head_camera"):
        robot.camera("wall_camera")
    with pytest.raises(UnknownName, match=r"limb 'tail'.*rarm"):
        robot.sensors("tail")


# ------------------------------------------------------- force sensors, ZMP
def test_feet_forces_sum_to_the_weight(standing):
    """At rest the feet's compensated sensor forces carry the whole robot (1 %;
    measured: 1.3e-6); MuJoCo's raw readings carry it less the feet's weight."""
    model, data = standing
    sensors = RobotSensors.from_model(model)
    feet = [sensors.force_sensor(f) for f in FEET]
    weight = -model.body_subtreemass[model.body("pelvis").id] * model.opt.gravity[2]
    fz = sum(s.contact_wrench(model, data).force[2] for s in feet)
    assert fz == pytest.approx(weight, rel=0.01)
    assert fz == pytest.approx(weight, rel=1e-4)
    raw = sum(s.contact_wrench(model, data, compensate=False).force[2] for s in feet)
    feet_weight = -2 * model.body_subtreemass[model.body("rleg_foot").id] * model.opt.gravity[2]
    assert raw == pytest.approx(weight - feet_weight, rel=1e-4)
    # horizontal forces vanish at rest
    assert abs(sum(s.contact_wrench(model, data).force[0] for s in feet)) < 0.5


def test_zmp_from_force_sensors_at_rest(standing):
    """The ZMP from the feet's sensors is the CoM's ground projection at rest
    (measured 0.08 mm) and the ZMP of MuJoCo's contact forces (measured 1e-7 m);
    each foot's centre of pressure is that of its own contacts."""
    model, data = standing
    sensors = RobotSensors.from_model(model)
    feet = [sensors.force_sensor(f) for f in FEET]
    zmp = zmp_from_force_sensors(model, data, feet)
    com = data.subtree_com[model.body("pelvis").id]
    assert np.linalg.norm(zmp.point[:2] - com[:2]) < 3e-3
    assert zmp.point[2] == 0.0
    contacts = zmp_from_wrenches(robot_contact_wrenches(model, data))
    assert np.linalg.norm(zmp.point - contacts) < 1e-3
    for foot, sole in zip(FEET, ("rleg_sole", "lleg_sole"), strict=True):
        own = zmp_from_wrenches(robot_contact_wrenches(model, data, {sole}))
        assert np.linalg.norm(zmp.cops[foot] - own) < 1e-3
    # double support: the f_z-weighted mean of the feet's centres of pressure
    fz = np.array([zmp.normal_forces[f] for f in FEET])
    mean = (fz[0] * zmp.cops[FEET[0]] + fz[1] * zmp.cops[FEET[1]]) / fz.sum()
    np.testing.assert_allclose(zmp.point, mean, atol=1e-12)
    np.testing.assert_allclose(zmp.force[2], fz.sum())
    # a threshold above one foot's load leaves the other foot alone
    single = zmp_from_force_sensors(model, data, feet, fz_threshold=fz.min() + 1e-6)
    assert list(single.cops) == [FEET[int(np.argmax(fz))]]
    np.testing.assert_allclose(single.point, zmp.cops[FEET[int(np.argmax(fz))]], atol=1e-12)
    assert zmp_from_force_sensors(model, data, feet, fz_threshold=1e4) is None


def test_sensors_added_to_a_spec_at_the_ankles():
    """add_sensors gives any site a 6-axis sensor: sensors at the ankles (7 cm
    above the floor) give the same ZMP as the sole sensors, through the general
    formula (p_z != floor height), and the same weight."""
    spec = load_spec("sample_humanoid")
    for leg in ("rleg", "lleg"):
        spec.body(f"{leg}_foot").add_site(name=f"{leg}_ankle", quat=[0.9, 0.1, -0.2, 0.3])
    names = add_sensors(spec, ["rleg_ankle", "lleg_ankle"])
    assert names == [
        "rleg_ankle_force",
        "rleg_ankle_torque",
        "lleg_ankle_force",
        "lleg_ankle_torque",
    ]
    model, data = standing_scene(spec, duration=0.6)
    sensors = RobotSensors.from_model(model)
    soles = zmp_from_force_sensors(model, data, [sensors.force_sensor(f) for f in FEET])
    ankles = zmp_from_force_sensors(
        model, data, [sensors.force_sensor(f) for f in ("rleg_ankle", "lleg_ankle")]
    )
    assert data.site("rleg_ankle").xpos[2] == pytest.approx(0.07, abs=2e-3)
    np.testing.assert_allclose(ankles.point, soles.point, atol=1e-9)
    np.testing.assert_allclose(ankles.force, soles.force, atol=1e-6)
    with pytest.raises(InvalidInput, match="already has sensors named"):
        add_sensors(spec, ["rleg_ankle"])
    with pytest.raises(UnknownName, match=r"site 'nope'.*'rleg_ankle'"):
        add_sensors(spec, ["nope"])
    with pytest.raises(UnknownName, match="sensor kind 'lidar'"):
        add_sensors(spec, ["rleg_ankle"], ["lidar"])


def test_zmp_formula_by_hand():
    """Two vertical forces: the ZMP is their f_z-weighted mean. A force at
    height h pushing forward by f_x moves the centre of pressure back by
    h f_x / f_z. A moment n_y about the point shifts it by -n_y / f_z."""
    up = [
        ContactWrench(np.array([0, 0, 100.0]), np.zeros(3), np.array([0.1, 0, 0])),
        ContactWrench(np.array([0, 0, 300.0]), np.zeros(3), np.array([-0.1, 0.2, 0])),
    ]
    np.testing.assert_allclose(zmp_from_wrenches(up), [-0.05, 0.15, 0.0], atol=1e-15)
    high = ContactWrench(np.array([10.0, 0, 100.0]), np.zeros(3), np.array([0.3, 0.2, 0.1]))
    np.testing.assert_allclose(zmp_from_wrenches([high]), [0.3 - 0.01, 0.2, 0.0], atol=1e-15)
    np.testing.assert_allclose(zmp_from_wrenches([high], z=0.1), [0.3, 0.2, 0.1], atol=1e-15)
    moment = ContactWrench(np.array([0, 0, 200.0]), np.array([4.0, -6.0, 0]), np.zeros(3))
    np.testing.assert_allclose(zmp_from_wrenches([moment]), [0.03, 0.02, 0.0], atol=1e-15)
    with pytest.raises(InvalidInput, match="do not push up"):
        zmp_from_wrenches([ContactWrench(np.array([0, 0, -1.0]), np.zeros(3), np.zeros(3))])
    with pytest.raises(InvalidInput, match="at least one"):
        zmp_from_wrenches([])


# -------------------------------------------------------------------- bumper
def test_bumper_on_when_the_hand_presses_a_box():
    """A box 3 mm into the right hand's reach: after 0.5 s the right bumper reads
    the normal force of the hand's contacts (mj_contactForce; measured 29.3 N)
    and is on; the left one is off. With the box 2 cm lower, both are off and
    read 0."""
    spec = load_spec("sample_humanoid")
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("reset_pose").id)
    data.joint("rarm_shoulder_r").qpos[0] = RAISED_ARM
    mujoco.mj_forward(model, data)
    hand = model.geom("rarm_hand").id
    R = data.geom_xmat[hand].reshape(3, 3)
    lowest = data.geom_xpos[hand] - np.abs(R) @ model.geom_size[hand]  # bottom of the AABB
    centre = data.geom_xpos[hand].copy()
    for depth, on in ((0.003, True), (-0.02, False)):  # box top above the hand's bottom [m]
        top = lowest[2] + depth
        box = ((centre[0], centre[1], top - 0.05), (0.1, 0.1, 0.05))
        model, data = standing_scene(load_spec("sample_humanoid"), duration=0.5, box=box)
        sensors = RobotSensors.from_model(model)
        right, left = sensors.bumper("rarm_bumper"), sensors.bumper("larm_bumper")
        pressed = robot_contact_wrenches(model, data, {"rarm_hand"})
        normal = sum(float(w.force @ np.array([0, 0, 1.0])) for w in pressed)
        assert right.is_on(data) is on
        assert not left.is_on(data) and left.force(data) == 0.0
        if on:
            assert right.force(data) > 5.0
            assert right.force(data) == pytest.approx(normal, rel=1e-6)
        else:
            assert right.force(data) == 0.0 and not pressed


# ----------------------------------------------------------------------- IMU
IMU_MJCF = """
<mujoco>
  <compiler angle="radian"/>
  <option gravity="0.3 -0.2 -9.81"/>
  <worldbody>
    <body name="stand" pos="0 0 1">
      <!-- a hinge along gravity: at rest it stays at rest (MuJoCo computes no
           acceleration for bodies welded to the world: their accelerometer reads 0) -->
      <joint type="hinge" axis="0.3 -0.2 -9.81"/>
      <body name="fixed" euler="0.3 -0.5 1.1">
        <geom type="box" size="0.1 0.1 0.1"/>
        <site name="fixed_imu" euler="0.2 0.4 -0.7"/>
      </body>
    </body>
    <body name="spinner" pos="1 0 1" euler="0 0.4 0">
      <joint name="spin" type="hinge" axis="0.6 0 0.8"/>
      <geom type="cylinder" size="0.1 0.02" mass="1"/>
      <site name="spinner_imu" euler="0.5 0 0.3"/>
    </body>
    <body name="faller" pos="2 0 1">
      <freejoint/>
      <geom type="sphere" size="0.05" contype="0" conaffinity="0"/>
      <site name="faller_imu" euler="1 2 3"/>
    </body>
  </worldbody>
</mujoco>
"""


def rotation_of(euler_xyz) -> np.ndarray:
    """Rotation matrix of MJCF ``euler`` (MuJoCo's default sequence ``xyz``,
    intrinsic), built with MuJoCo's quaternion helpers."""
    q = np.array([1.0, 0, 0, 0])
    for axis, angle in zip(np.eye(3), euler_xyz, strict=True):
        step = np.zeros(4)
        mujoco.mju_axisAngle2Quat(step, axis, angle)
        out = np.zeros(4)
        mujoco.mju_mulQuat(out, q, step)
        q = out
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, q)
    return R.reshape(3, 3)


@pytest.fixture(scope="module")
def imu_model() -> mujoco.MjModel:
    spec = mujoco.MjSpec.from_string(IMU_MJCF)
    add_sensors(spec, ["fixed_imu", "spinner_imu", "faller_imu"], IMU)
    return spec.compile()


def test_accelerometer_at_rest_reads_minus_gravity_in_the_site_frame(imu_model):
    model = imu_model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    imu = RobotSensors.from_model(model).imu_sensor("fixed_imu")
    R_WS = rotation_of([0.3, -0.5, 1.1]) @ rotation_of([0.2, 0.4, -0.7])
    g = np.array([0.3, -0.2, -9.81])
    reading = imu.read(data)
    np.testing.assert_allclose(reading.acceleration, R_WS.T @ -g, atol=1e-9)
    np.testing.assert_allclose(reading.angular_velocity, 0.0, atol=1e-12)
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, R_WS.ravel())
    np.testing.assert_allclose(reading.orientation * np.sign(reading.orientation[0]), q, atol=1e-9)
    # in free fall the accelerometer reads nothing
    np.testing.assert_allclose(
        RobotSensors.from_model(model).imu_sensor("faller_imu").read(data).acceleration,
        0,
        atol=1e-9,
    )


def test_accelerometer_of_the_standing_humanoid(standing):
    """The pelvis IMU of the humanoid held still by its servos: -g in the site
    frame to 1e-3 m/s² (measured 5.8e-4: the servo-held robot is not perfectly
    still), orientation that of the pelvis."""
    model, data = standing
    imu = RobotSensors.from_model(model).imu_sensor("imu")
    R_WS = data.site_xmat[imu.site_id].reshape(3, 3)
    reading = imu.read(data)
    np.testing.assert_allclose(reading.acceleration, R_WS.T @ -model.opt.gravity, atol=1e-3)
    np.testing.assert_allclose(reading.orientation, data.xquat[model.body("pelvis").id], atol=1e-12)


def test_gyro_reads_the_spin_in_the_site_frame(imu_model):
    """A body spun about a hinge at 3 rad/s: the gyro reads 3 · axis_W in the
    site frame, with axis_W and R_WS from the MJCF's euler angles."""
    model = imu_model
    data = mujoco.MjData(model)
    data.qvel[model.joint("spin").dofadr[0]] = 3.0
    data.qpos[model.joint("spin").qposadr[0]] = 0.7
    mujoco.mj_forward(model, data)
    R_WB0 = rotation_of([0, 0.4, 0])
    axis_B = np.array([0.6, 0, 0.8])
    spin = np.zeros(4)
    mujoco.mju_axisAngle2Quat(spin, axis_B, 0.7)
    R_spin = np.zeros(9)
    mujoco.mju_quat2Mat(R_spin, spin)
    R_WS = R_WB0 @ R_spin.reshape(3, 3) @ rotation_of([0.5, 0, 0.3])
    gyro = RobotSensors.from_model(model).imu_sensor("spinner_imu").read(data).angular_velocity
    np.testing.assert_allclose(gyro, R_WS.T @ (R_WB0 @ axis_B) * 3.0, atol=1e-9)
    # the free body spun about its own axes: the gyro reads qvel's angular part
    dof = model.jnt_dofadr[model.body("faller").jntadr[0]]
    data.qvel[dof + 3 : dof + 6] = [0.5, -1.0, 2.0]
    mujoco.mj_forward(model, data)
    R_BS = rotation_of([1, 2, 3])
    gyro = RobotSensors.from_model(model).imu_sensor("faller_imu").read(data).angular_velocity
    np.testing.assert_allclose(gyro, R_BS.T @ [0.5, -1.0, 2.0], atol=1e-9)


def test_bad_input(standing):
    model, data = standing
    sensors = RobotSensors.from_model(model)
    with pytest.raises(InvalidInput, match="at least one force sensor"):
        zmp_from_force_sensors(model, data, [])
    with pytest.raises(InvalidInput, match="fz_threshold > 0"):
        zmp_from_force_sensors(model, data, sensors.force_sensors, fz_threshold=0.0)
    with pytest.raises(InvalidInput, match="bumper_threshold"):
        RobotSensors.from_model(model, bumper_threshold=float("nan"))
    spec = mujoco.MjSpec.from_string(IMU_MJCF)
    add_sensors(spec, ["fixed_imu"], ["force"])
    force_only = RobotSensors.from_model(spec.compile()).force_sensor("fixed_imu")
    with pytest.raises(InvalidInput, match="needs both a force and a torque"):
        zmp_from_force_sensors(model, data, [force_only])
