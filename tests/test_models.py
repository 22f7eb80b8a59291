"""Models in models/, dm_control's humanoids, and a robot's world (Robot.from_model)."""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot, RobotSource
from pik_mj.robot.loading import MODELS_DIR, available_models, load_model, load_spec, model_path

HUMANOID_JOINTS = [
    *(
        f"{s}leg_{j}"
        for s in "rl"
        for j in ("hip_y", "hip_r", "hip_p", "knee_p", "ankle_p", "ankle_r")
    ),
    *(
        f"{s}arm_{j}"
        for s in "rl"
        for j in (
            "shoulder_p",
            "shoulder_r",
            "shoulder_y",
            "elbow_p",
            "wrist_y",
            "wrist_r",
            "wrist_p",
        )
    ),
    "torso_waist_p",
    "torso_waist_y",
    "head_neck_y",
    "head_neck_p",
]
HUMANOID_SITES = ["rarm_end", "larm_end", "rleg_end", "lleg_end", "head_end"]


def _names(model: mujoco.MjModel, obj: mujoco.mjtObj, n: int) -> list[str]:
    return [mujoco.mj_id2name(model, obj, i) for i in range(n)]


def _box_bottom_z(data: mujoco.MjData, model: mujoco.MjModel, geom: str) -> float:
    """Lowest z of a box geom, from its 8 corners."""
    g = model.geom(geom)
    R = data.geom(geom).xmat.reshape(3, 3)
    corners = [
        data.geom(geom).xpos + R @ (np.array(s) * g.size)
        for s in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
    ]
    return float(min(c[2] for c in corners))


def _reset(model: mujoco.MjModel) -> mujoco.MjData:
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("reset_pose").id)
    mujoco.mj_forward(model, data)
    return data


# ------------------------------------------------------------------- loading
def test_available_models():
    assert available_models() == [
        "three_dof_arm",
        "sample_humanoid",
        "room",
        "dm_humanoid",
        "dm_humanoid_cmu",
    ]
    assert available_models("humanoid") == ["sample_humanoid", "dm_humanoid", "dm_humanoid_cmu"]
    assert available_models("arm") == ["three_dof_arm"]
    assert available_models("scene") == ["room"]
    assert available_models("quadruped") == []


@pytest.mark.parametrize(
    ("name", "nq", "nv"),
    [
        ("three_dof_arm", 3, 3),
        ("sample_humanoid", 37, 36),
        ("room", 7, 6),
        ("dm_humanoid", 28, 27),
        ("dm_humanoid_cmu", 63, 62),
    ],
)
def test_models_load_and_compile(name, nq, nv):
    model = load_model(name)
    assert (model.nq, model.nv) == (nq, nv)
    assert load_spec(name).compile().nv == nv


def test_shipped_models_declare_radians():
    for name in ("three_dof_arm", "sample_humanoid", "room"):
        root = ET.parse(model_path(name)).getroot()
        assert root.find("compiler").get("angle") == "radian", name


def test_dm_humanoids_come_from_installed_package():
    import dm_control

    for name, file in (
        ("dm_humanoid", "humanoid.xml"),
        ("dm_humanoid_cmu", "humanoid_CMU.xml"),
    ):
        path = model_path(name)
        assert path.name == file
        assert path.is_relative_to(dm_control.__path__[0])
        assert not path.is_relative_to(MODELS_DIR)


def test_path_accepted(tmp_path):
    assert model_path(str(MODELS_DIR / "room.xml")) == MODELS_DIR / "room.xml"
    assert load_model(MODELS_DIR / "three_dof_arm.xml").nv == 3


def test_unknown_name_lists_models():
    with pytest.raises(UnknownName) as err:
        load_model("no_such_robot")
    assert err.value.kind == "model"
    for name in available_models():
        assert name in str(err.value)


def test_missing_path_says_path_and_names(tmp_path):
    missing = tmp_path / "nope.xml"
    with pytest.raises(InvalidInput) as err:
        load_spec(str(missing))
    assert str(missing) in str(err.value)
    assert "sample_humanoid" in str(err.value)


# ----------------------------------------------------------- three-DoF arm
def test_three_dof_arm_forward_kinematics_matches_planar_formula():
    model = load_model("three_dof_arm")
    assert _names(model, mujoco.mjtObj.mjOBJ_JOINT, 3) == ["joint0", "joint1", "joint2"]
    np.testing.assert_allclose(model.jnt_range, [[-1.74533, 1.74533]] * 3)
    np.testing.assert_allclose(model.jnt_axis, [[0, 1, 0]] * 3)
    assert model.nbody == 5 and model.body_jntnum[1] == 0  # l1 fixed to the world
    data = mujoco.MjData(model)
    q = np.array([0.3, -0.7, 1.1])
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    # Rotations about +y take z towards +x.
    a = np.cumsum(q)
    x = 0.1 * math.sin(a[0]) + 0.1 * math.sin(a[1]) + 0.02 * math.sin(a[2])
    z = 0.02 + 0.1 * math.cos(a[0]) + 0.1 * math.cos(a[1]) + 0.02 * math.cos(a[2])
    np.testing.assert_allclose(data.site("end").xpos, [x, 0, z], atol=1e-12)
    assert data.ncon == 0


# --------------------------------------------------------- sample humanoid
def test_sample_humanoid_names_ranges_masses():
    model = load_model("sample_humanoid")
    joints = _names(model, mujoco.mjtObj.mjOBJ_JOINT, model.njnt)
    assert joints[0] == "root"
    assert model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert model.body(model.jnt_bodyid[0]).name == "pelvis"
    assert sorted(joints[1:]) == sorted(HUMANOID_JOINTS)
    for site in HUMANOID_SITES:
        assert model.site(site).id >= 0
    for geom in ("rleg_sole", "lleg_sole"):
        np.testing.assert_allclose(2 * model.geom(geom).size[:2], [0.22, 0.12])
    for body in ("rleg_thigh", "rarm_upper", "torso_chest", "head_link"):
        assert model.body(body).id >= 0
    assert model.nu == 0
    hinge = model.jnt_type == mujoco.mjtJoint.mjJNT_HINGE
    assert hinge.sum() == 30 and model.jnt_limited[hinge].all()
    # Radians: no range beyond a full half turn, and knees bend one way.
    assert np.abs(model.jnt_range[hinge]).max() <= math.pi
    for s in "rl":
        lo, hi = model.joint(f"{s}leg_knee_p").range
        assert lo == 0.0 and hi > 2.0
        lo, hi = model.joint(f"{s}arm_elbow_p").range
        assert hi == 0.0 and lo < -2.0
    # Mass: the compiled total equals the geom masses written in the file.
    written = 0.0
    root = ET.parse(model_path("sample_humanoid")).getroot()
    sole_mass = float(root.find(".//default[@class='sole']/geom").get("mass"))
    for geom in root.find("worldbody").iter("geom"):
        if geom.get("mass") is not None:
            written += float(geom.get("mass"))
        elif geom.get("class") == "sole":
            written += sole_mass
    assert model.body_subtreemass[1] == pytest.approx(written, abs=1e-9)
    assert 55.0 <= written <= 65.0
    assert np.all(model.body_mass[1:] > 0.4)
    assert np.all(model.body_inertia[1:] > 0)


def test_reset_pose_soles_flat_on_the_floor():
    model = load_model("sample_humanoid")
    data = _reset(model)
    for leg in ("rleg", "lleg"):
        assert abs(_box_bottom_z(data, model, f"{leg}_sole")) < 1e-6
        site = data.site(f"{leg}_end")
        assert abs(site.xpos[2]) < 1e-6
        np.testing.assert_allclose(site.xmat.reshape(3, 3), np.eye(3), atol=1e-12)
    knees = [data.joint(f"{s}leg_knee_p").qpos[0] for s in "rl"]
    assert all(0.3 <= k <= 0.5 for k in knees)
    # The arms hang away from the body: the hands are outside the thighs.
    assert data.site("rarm_end").xpos[1] < data.geom("rleg_thigh").xpos[1] - 0.15
    assert data.site("larm_end").xpos[1] > data.geom("lleg_thigh").xpos[1] + 0.15
    height = data.geom("head").xpos[2] + model.geom("head").size[0]
    assert 1.45 < height < 1.65
    # The centroid is above the soles.
    com = data.subtree_com[1]
    for leg in ("rleg", "lleg"):
        sole = data.geom(f"{leg}_sole")
        assert abs(com[0] - sole.xpos[0]) < model.geom(f"{leg}_sole").size[0]


def test_reset_pose_touches_floor_with_soles_only():
    for environment, pos, yaw in (
        (None, (0, 0, 0), 0.0),
        ("room", (0, 0, 0), 0.0),
        ("room", (0.4, 0, 0), 0.0),
        ("room", (0, 1.05, 0), math.pi / 2),
    ):
        at = None if environment is None else (pos[0], pos[1], yaw)
        model = Robot.from_model("sample_humanoid", environment=environment, at=at).model
        if environment is None:  # the robot alone has no floor: the scene adds one
            from pik_mj.sim import Scene

            model = Scene.from_robot(Robot.from_model("sample_humanoid")).model
        data = _reset(model)
        pairs = {
            frozenset((model.geom(c.geom1).name, model.geom(c.geom2).name))
            for c in data.contact[: data.ncon]
        }
        assert pairs == {
            frozenset(("floor", "rleg_sole")),
            frozenset(("floor", "lleg_sole")),
        }
        dist = data.contact.dist[: data.ncon]
        assert np.all((dist < 0) & (dist > -1e-6))


# -------------------------------------------------------------------- room
def test_room_contents():
    model = load_model("room")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.geom("floor").type == mujoco.mjtGeom.mjGEOM_PLANE
    for geom in ("counter", "wall"):
        assert model.geom(geom).type == mujoco.mjtGeom.mjGEOM_BOX
    kettle = model.body("kettle")
    assert model.joint("kettle_free").type == mujoco.mjtJoint.mjJNT_FREE
    assert model.body_subtreemass[kettle.id] == pytest.approx(1.0, abs=0.05)
    # The kettle's bottom rests on the counter top.
    top = data.geom("counter").xpos[2] + model.geom("counter").size[2]
    pot = data.geom("kettle_pot")
    bottom = pot.xpos[2] - model.geom("kettle_pot").size[1]
    assert bottom == pytest.approx(top, abs=1e-9)
    assert 0.8 <= top <= 0.95
    for site in (
        "kettle_handle",
        "kettle_center",
        "spot_counter_front",
        "spot_wall",
        "spot_origin",
    ):
        assert model.site(site).id >= 0
    # kettle_handle sits on the handle bar; its x points from the handle into
    # the pot.
    handle = data.site("kettle_handle")
    bar = data.geom("kettle_handle")
    assert np.linalg.norm(handle.xpos - bar.xpos) < 1e-9
    x_axis = handle.xmat.reshape(3, 3)[:, 0]
    to_pot = data.site("kettle_center").xpos - handle.xpos
    assert x_axis @ to_pot > 0.95 * np.linalg.norm(to_pot[:2])
    assert data.ncon == 0  # nothing overlaps at the start
    # The kettle stays on the counter under gravity.
    for _ in range(500):
        mujoco.mj_step(model, data)
    assert np.linalg.norm(data.qvel) < 1e-2
    assert abs(data.body("kettle").xpos[2] - top) < 2e-3


def test_spots_in_reach_of_the_sample_humanoid():
    room = load_model("room")
    room_data = mujoco.MjData(room)
    mujoco.mj_forward(room, room_data)
    robot = load_model("sample_humanoid")
    data = _reset(robot)
    shoulder = data.body("rarm_upper").xpos
    arm_length = np.linalg.norm(shoulder - data.body("rarm_lower").xpos)
    arm_length += np.linalg.norm(data.body("rarm_lower").xpos - data.site("rarm_end").xpos)
    # Standing at spot_counter_front (facing +x), the right hand reaches the handle.
    spot = room_data.site("spot_counter_front")
    handle = room_data.site("kettle_handle").xpos
    R = spot.xmat.reshape(3, 3)
    shoulder_W = spot.xpos + R @ shoulder
    assert 0.6 * arm_length < np.linalg.norm(handle - shoulder_W) < 0.9 * arm_length
    # Its toes stay clear of the counter.
    toe = spot.xpos + R @ (data.geom("rleg_sole").xpos + np.array([0.11, 0, 0]))
    counter_front = room_data.geom("counter").xpos[0] - room.geom("counter").size[0]
    assert toe[0] < counter_front - 0.05
    # At spot_wall (x towards the wall) a straight arm reaches the wall face.
    spot = room_data.site("spot_wall")
    R = spot.xmat.reshape(3, 3)
    wall_face = room_data.geom("wall").xpos[1] - room.geom("wall").size[1]
    reach = (spot.xpos + R @ shoulder)[1] + arm_length
    assert R[:, 0] @ [0, 1, 0] == pytest.approx(1.0)
    assert wall_face < reach < wall_face + 0.3


# ------------------------------------------------- the robot's world
def _yaw(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@pytest.mark.parametrize("environment", ["room", None])
def test_world_keeps_names_free_joint_and_poses(environment, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo would write MUJOCO_LOG.TXT here
    robot = load_model("sample_humanoid")
    p_WR, yaw = np.array([0.4, -0.3, 0.0]), 0.8
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        placed = Robot.from_model(
            "sample_humanoid", environment=environment, at=(p_WR[0], p_WR[1], yaw)
        )
        spec, model = placed.spec, placed.spec.compile()
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    if environment is not None:
        assert model.geom("floor").type == mujoco.mjtGeom.mjGEOM_PLANE
    for obj, count in (
        (mujoco.mjtObj.mjOBJ_JOINT, "njnt"),
        (mujoco.mjtObj.mjOBJ_SITE, "nsite"),
        (mujoco.mjtObj.mjOBJ_BODY, "nbody"),
        (mujoco.mjtObj.mjOBJ_GEOM, "ngeom"),
    ):
        scene_names = set(_names(model, obj, getattr(model, count)))
        robot_names = _names(robot, obj, getattr(robot, count))
        assert {n for n in robot_names if n and n != "world"} <= scene_names
    # The robot's joints come first, at the robot's own addresses: its qpos is a
    # prefix of the world's.
    np.testing.assert_array_equal(model.jnt_qposadr[: robot.njnt], robot.jnt_qposadr)
    np.testing.assert_array_equal(model.jnt_type[: robot.njnt], robot.jnt_type)
    root = model.joint("root")
    assert root.type == mujoco.mjtJoint.mjJNT_FREE
    assert model.body_parentid[root.bodyid[0]] == 0
    assert model.opt.timestep == pytest.approx(0.002)
    # Same joints, ranges and masses as the robot alone.
    ids = [model.joint(robot.joint(j).name).id for j in range(robot.njnt)]
    np.testing.assert_array_equal(model.jnt_range[ids], robot.jnt_range)
    pelvis = model.body("pelvis").id
    assert model.body_subtreemass[pelvis] == pytest.approx(robot.body_subtreemass[1])
    # reset_pose in the world = reset_pose of the robot, moved by (p_WR, yaw).
    scene_data, robot_data = _reset(model), _reset(robot)
    R = _yaw(yaw)
    for site in HUMANOID_SITES:
        np.testing.assert_allclose(
            scene_data.site(site).xpos, p_WR + R @ robot_data.site(site).xpos, atol=1e-9
        )
        np.testing.assert_allclose(
            scene_data.site(site).xmat.reshape(3, 3),
            R @ robot_data.site(site).xmat.reshape(3, 3),
            atol=1e-9,
        )
    # ... and qpos0 too (the placement moved the body, not only the keyframe).
    d0 = mujoco.MjData(model)
    mujoco.mj_kinematics(model, d0)
    d0_robot = mujoco.MjData(robot)
    mujoco.mj_kinematics(robot, d0_robot)
    np.testing.assert_allclose(
        d0.body("pelvis").xpos, p_WR + R @ d0_robot.body("pelvis").xpos, atol=1e-12
    )
    # The world can be written and read back.
    again = mujoco.MjSpec.from_string(spec.to_xml()).compile()
    assert (again.nq, again.nbody, again.nkey) == (model.nq, model.nbody, model.nkey)


def test_placed_at_a_site_of_the_environment():
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_wall")
    room = load_model("room")
    data = mujoco.MjData(room)
    mujoco.mj_kinematics(room, data)
    spot = data.site("spot_wall")
    # the robot model's origin is the spot (its heading +y: the spot's x axis)
    R = spot.xmat.reshape(3, 3)
    assert R[:, 0] @ [0, 1, 0] == pytest.approx(1.0)
    alone = Robot.from_model("sample_humanoid")
    for site in HUMANOID_SITES:
        np.testing.assert_allclose(
            robot.data.site(site).xpos, spot.xpos + R @ alone.data.site(site).xpos, atol=1e-9
        )
    assert robot.placement == pytest.approx((0.0, 1.05, 0.0, math.pi / 2))
    assert robot.source == RobotSource("sample_humanoid", "room", "spot_wall")
    # the kettle waits on the counter in the start pose (the room's qpos0)
    k = robot.model.joint("kettle_free").qposadr[0]
    np.testing.assert_allclose(robot.configuration.q[k : k + 3], [0.9, -0.2, 0.85])
    with pytest.raises(UnknownName, match="spot_counter_front"):
        Robot.from_model("sample_humanoid", environment="room", at="spot_nope")
    with pytest.raises(InvalidInput, match="no environment"):
        Robot.from_model("sample_humanoid", at="spot_wall")


def test_dm_humanoid_into_room_renames_clashing_assets_and_stands_on_the_floor():
    robot = load_model("dm_humanoid")
    placed = Robot.from_model("dm_humanoid", environment="room", at=(0.5, 0, 0))
    model = placed.model
    assert model.nv == 27 + 6  # robot + kettle
    assert model.nu == robot.nu == 21
    assert model.nsensor == robot.nsensor
    for j in range(robot.njnt):
        joint = model.joint(robot.joint(j).name)
        np.testing.assert_allclose(joint.range, robot.joint(j).range)
    materials = _names(model, mujoco.mjtObj.mjOBJ_MATERIAL, model.nmat)
    assert "grid" in materials and "room_grid" in materials
    # One floor, the room's (dm_control's own floor plane is left out).
    planes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    assert len(planes) == 1 and model.mat(model.geom_matid[planes[0]]).name == "room_grid"
    # dm_control's humanoid starts 0.2 m up; in its world it stands on z = 0:
    # independent of mj_geomDistance, the lowest point of its foot capsules.
    d = placed.data
    bottoms = []
    for g in range(model.ngeom):
        if model.body_rootid[model.geom_bodyid[g]] != placed.root_body_id:
            continue
        if "foot" in model.body(model.geom_bodyid[g]).name:
            r, h = model.geom_size[g][0], model.geom_size[g][1]
            axis = d.geom_xmat[g].reshape(3, 3)[:, 2]
            bottoms.append(min(d.geom_xpos[g][2] + s * h * axis[2] for s in (-1, 1)) - r)
    assert min(bottoms) == pytest.approx(0.0, abs=1e-9)
    lowered = d.body("torso").xpos
    np.testing.assert_allclose(lowered[:2], [0.5, 0.0], atol=1e-12)
    data = mujoco.MjData(robot)
    mujoco.mj_kinematics(robot, data)
    assert lowered[2] < data.body("torso").xpos[2] - 0.1


def test_fixed_base_arm_and_cmu():
    arm = Robot.from_model("three_dof_arm", at=(1, 2, 0.5, 0.0))
    np.testing.assert_allclose(arm.data.site("end").xpos, [1, 2, 0.74], atol=1e-12)
    assert not arm.has_floating_base
    cmu = Robot.from_model("dm_humanoid_cmu", environment="room")
    assert cmu.model.nv == 62 + 6


def test_world_does_not_modify_given_specs():
    robot = load_spec("sample_humanoid")
    environment = load_spec("room")
    placed = Robot.from_model(robot, environment=environment, at=(0.1, 0.2, 0.3))
    assert robot.default.name == "main"
    assert environment.compile().nbody == load_model("room").nbody
    assert robot.compile().nbody == load_model("sample_humanoid").nbody
    assert robot.compile().body_pos[1] == pytest.approx([0.0, 0.0, 0.85])
    # a spec is not JSON: the source says so
    assert not placed.source.serializable
    with pytest.raises(InvalidInput, match="MjSpec"):
        placed.source.to_dict()


def test_source_round_trip_rebuilds_the_same_world(tmp_path):
    import json

    path = tmp_path / "arm.xml"
    path.write_text(model_path("three_dof_arm").read_text())
    for robot in (
        Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front"),
        Robot.from_model(str(path), at=(0.2, -0.1, 0.3, 1.0)),
    ):
        d = json.loads(json.dumps(robot.source.to_dict()))
        again = Robot.from_source(d)
        assert again.source == robot.source
        np.testing.assert_array_equal(again.configuration.q, robot.configuration.q)
        assert again.model.nbody == robot.model.nbody
    assert Robot.from_source({"model": "three_dof_arm"}).source.model == "three_dof_arm"
    assert RobotSource.from_dict({"model": str(path)}).model == str(path)
    with pytest.raises(InvalidInput, match="model"):
        RobotSource.from_dict({"q": [0.0]})
    with pytest.raises(InvalidInput, match="at"):
        RobotSource.from_dict({"model": "room", "at": {"x": 1}})


def test_world_rejects_bad_placement_and_keyframe():
    with pytest.raises(InvalidInput, match="at must be"):
        Robot.from_model("three_dof_arm", at=(0, 0))
    with pytest.raises(InvalidInput, match="at must be"):
        Robot.from_model("three_dof_arm", at=(0.0, 0.0, float("nan")))
    with pytest.raises(UnknownName, match="reset_pose"):
        Robot.from_model("sample_humanoid", keyframe="nope")
    with pytest.raises(InvalidInput, match=r"compiled mujoco\.MjModel"):
        Robot("sample_humanoid")
