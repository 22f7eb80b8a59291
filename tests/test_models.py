"""Models in models/, dm_control's humanoids, and compose_scene."""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.models import (
    MODELS_DIR,
    available_models,
    compose_scene,
    load_model,
    load_spec,
    model_path,
)

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
        model = compose_scene(
            "sample_humanoid", environment, robot_pos=pos, robot_yaw=yaw
        ).compile()
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


# ----------------------------------------------------------- compose_scene
def _yaw(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@pytest.mark.parametrize("environment", ["room", None])
def test_compose_keeps_names_free_joint_and_poses(environment, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo would write MUJOCO_LOG.TXT here
    robot = load_model("sample_humanoid")
    p_WR, yaw = np.array([0.4, -0.3, 0.0]), 0.8
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spec = compose_scene("sample_humanoid", environment, robot_pos=p_WR, robot_yaw=yaw)
        model = spec.compile()
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
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
    root = model.joint("root")
    assert root.type == mujoco.mjtJoint.mjJNT_FREE
    assert model.body_parentid[root.bodyid[0]] == 0
    assert model.opt.timestep == pytest.approx(0.002)
    # Same joints, ranges and masses as the robot alone.
    ids = [model.joint(robot.joint(j).name).id for j in range(robot.njnt)]
    np.testing.assert_array_equal(model.jnt_range[ids], robot.jnt_range)
    pelvis = model.body("pelvis").id
    assert model.body_subtreemass[pelvis] == pytest.approx(robot.body_subtreemass[1])
    # reset_pose in the scene = reset_pose of the robot, moved by (p_WR, yaw).
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
    # The scene can be written and read back.
    again = mujoco.MjSpec.from_string(spec.to_xml()).compile()
    assert (again.nq, again.nbody, again.nkey) == (model.nq, model.nbody, model.nkey)


def test_compose_dm_humanoid_into_room_renames_clashing_assets():
    robot = load_model("dm_humanoid")
    model = compose_scene("dm_humanoid", "room", robot_pos=(0.5, 0, 0)).compile()
    assert model.nv == 27 + 6  # robot + kettle
    assert model.nu == robot.nu == 21
    assert model.nsensor == robot.nsensor
    for j in range(robot.njnt):
        joint = model.joint(robot.joint(j).name)
        np.testing.assert_allclose(joint.range, robot.joint(j).range)
    materials = _names(model, mujoco.mjtObj.mjOBJ_MATERIAL, model.nmat)
    assert "grid" in materials and "humanoid_grid" in materials
    # The room keeps its own floor material.
    assert model.mat(model.geom("floor").matid[0]).name == "grid"
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.body("torso").xpos, [0.5, 0, 1.5], atol=1e-12)


def test_compose_fixed_base_arm_and_cmu():
    arm = compose_scene("three_dof_arm", None, robot_pos=(1, 2, 0.5)).compile()
    data = mujoco.MjData(arm)
    mujoco.mj_forward(arm, data)
    np.testing.assert_allclose(data.site("end").xpos, [1, 2, 0.74], atol=1e-12)
    cmu = compose_scene("dm_humanoid_cmu", "room").compile()
    assert cmu.nv == 62 + 6


def test_compose_does_not_modify_given_specs():
    robot = load_spec("sample_humanoid")
    environment = load_spec("room")
    compose_scene(robot, environment)
    assert robot.default.name == "main"
    assert environment.compile().nbody == load_model("room").nbody
    assert robot.compile().nbody == load_model("sample_humanoid").nbody


def test_compose_rejects_bad_pose():
    with pytest.raises(InvalidInput, match="robot_pos"):
        compose_scene("three_dof_arm", None, robot_pos=(0, 0))
    with pytest.raises(InvalidInput, match="robot_yaw"):
        compose_scene("three_dof_arm", None, robot_yaw=float("nan"))
