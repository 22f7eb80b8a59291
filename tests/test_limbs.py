"""Limbs from the kinematic tree (pik_mj.robot.limbs), the keyframe rule
(pik_mj.robot.keyframes) and robot description files (pik_mj.robot.description)."""

from __future__ import annotations

import json
from itertools import pairwise

import mujoco
import numpy as np
import pytest
from local_menagerie import menagerie_model

from pik_mj.exceptions import InvalidInput, LimbsNotFound, UnknownName
from pik_mj.robot import Limb, Robot
from pik_mj.robot.description import (
    LimbDescription,
    RobotDescription,
    load_description,
    robot_limbs,
)
from pik_mj.robot.keyframes import standing_pose
from pik_mj.robot.limbs import find_limbs, limb_from_end
from pik_mj.robot.loading import load_model, load_spec


# ------------------------------------------------------- the project's own robots
def _sides(limb, joints, end, kind, left, right):
    """The right and left copies of a limb written with ``{s}`` (limb) / ``{n}`` (names)."""
    return {
        limb.format(s=s): (tuple(j.format(n=n) for j in joints), end.format(n=n), kind)
        for s, n in (("r", right), ("l", left))
    }


# The limbs of dm_control's humanoids before find_limbs: their limb tables,
# written out: {limb: (joints, end frame, its type)}.
_DM_HUMANOID = {
    "torso": (("abdomen_z", "abdomen_y", "abdomen_x"), "pelvis", "body"),
    **_sides(
        "{s}leg",
        [f"{{n}}_{j}" for j in ("hip_x", "hip_z", "hip_y", "knee", "ankle_y", "ankle_x")],
        "{n}_foot",
        "body",
        "left",
        "right",
    ),
    **_sides(
        "{s}arm",
        [f"{{n}}_{j}" for j in ("shoulder1", "shoulder2", "elbow")],
        "{n}_hand",
        "site",
        "left",
        "right",
    ),
}
_DM_HUMANOID_CMU = {
    "torso": (
        tuple(f"{b}r{a}" for b in ("lowerback", "upperback", "thorax") for a in "zyx"),
        "thorax",
        "body",
    ),
    "head": (
        tuple(f"{b}r{a}" for b in ("lowerneck", "upperneck", "head") for a in "zyx"),
        "head",
        "body",
    ),
    **_sides(
        "{s}leg",
        ["{n}" + j for j in ("femurrz", "femurry", "femurrx", "tibiarx", "footrz", "footrx")],
        "{n}foot",
        "body",
        "l",
        "r",
    ),
    **_sides(
        "{s}arm",
        [
            "{n}" + j
            for j in (
                "claviclerz",
                "claviclery",
                "humerusrz",
                "humerusry",
                "humerusrx",
                "radiusrx",
                "wristry",
                "handrz",
                "handrx",
            )
        ],
        "{n}hand",
        "body",
        "l",
        "r",
    ),
}


def _sample_naming(model) -> dict:
    """sample_humanoid's naming rule: limb ``x`` holds the joints ``x_*`` and ends at
    the site ``x_end``, or, without one, at the body of its last joint."""
    names = [model.joint(j).name for j in range(1, model.njnt)]
    out = {}
    for limb in ("rarm", "larm", "rleg", "lleg", "torso", "head"):
        joints = tuple(n for n in names if n.startswith(limb + "_"))
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, f"{limb}_end") >= 0:
            out[limb] = (joints, f"{limb}_end", "site")
        else:
            out[limb] = (joints, model.body(model.joint(joints[-1]).bodyid[0]).name, "body")
    return out


@pytest.mark.parametrize("name", ["sample_humanoid", "dm_humanoid", "dm_humanoid_cmu"])
def test_same_limbs_as_the_naming_and_the_tables(name):
    """sample_humanoid's rleg_*/..._end naming and dm_control's limb tables, limb
    for limb (joints, end frame and its type, first body: the body of the first
    joint); Robot finds the same ones."""
    model = load_model(name)
    tables = {"dm_humanoid": _DM_HUMANOID, "dm_humanoid_cmu": _DM_HUMANOID_CMU}
    expected = tables[name] if name in tables else _sample_naming(model)
    found = find_limbs(model)
    assert set(found) == set(expected)
    for limb, (joints, end, kind) in expected.items():
        first = model.body(model.joint(joints[0]).bodyid[0]).name
        assert found[limb] == Limb(limb, joints, end, kind, first)
    assert Robot.from_model(name).limbs == found


def test_turned_root_keeps_left_and_right():
    """The sample humanoid turned 90° and 180° about z: the same limbs (left is
    the robot's left, not the world's)."""
    expected = find_limbs(load_model("sample_humanoid"))
    for quat in ([np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], [0, 0, 0, 1]):
        spec = load_spec("sample_humanoid")
        spec.body("pelvis").quat = quat
        model = spec.compile()
        assert find_limbs(model, model.qpos0) == expected


# ------------------------------------------------------------ Menagerie robots
_EXPECTED = {
    # limb: (number of joints, end frame, end frame type, first body)
    "unitree_g1": {
        "rleg": (6, "right_foot", "site", "right_hip_pitch_link"),
        "lleg": (6, "left_foot", "site", "left_hip_pitch_link"),
        "rarm": (7, "right_wrist_yaw_link", "body", "right_shoulder_pitch_link"),
        "larm": (7, "left_wrist_yaw_link", "body", "left_shoulder_pitch_link"),
        "torso": (3, "imu_in_torso", "site", "waist_yaw_link"),
    },
    "unitree_g1:g1_with_hands": {  # the fingers are left out: the arm ends at the wrist
        "rarm": (7, "right_wrist_yaw_link", "body", "right_shoulder_pitch_link"),
        "larm": (7, "left_wrist_yaw_link", "body", "left_shoulder_pitch_link"),
    },
    "unitree_h1": {
        "rleg": (5, "right_ankle_link", "body", "right_hip_yaw_link"),
        "lleg": (5, "left_ankle_link", "body", "left_hip_yaw_link"),
        "rarm": (4, "right_elbow_link", "body", "right_shoulder_pitch_link"),
        "larm": (4, "left_elbow_link", "body", "left_shoulder_pitch_link"),
        "torso": (1, "imu", "site", "torso_link"),
    },
    "booster_t1": {
        "rleg": (6, "right_foot_link", "body", "Hip_Pitch_Right"),
        "lleg": (6, "left_foot_link", "body", "Hip_Pitch_Left"),
        "rarm": (4, "right_hand_link", "body", "AR1"),
        "larm": (4, "left_hand_link", "body", "AL1"),
        "torso": (1, "Waist", "body", "Waist"),
        "head": (2, "H2", "body", "H1"),
    },
}


@pytest.mark.parametrize("name", list(_EXPECTED))
def test_menagerie_limbs(name):
    model = menagerie_model(name)
    limbs = find_limbs(model)
    expected = _EXPECTED[name]
    got = {
        k: (len(x.joints), x.end_frame, x.end_frame_type, x.root_body)
        for k, x in limbs.items()
        if k in expected
    }
    assert got == expected
    if ":" not in name:
        assert set(limbs) == set(expected)  # no head on G1 and H1
    # joints run from the first body down: each joint's body is below the previous one's
    for limb in limbs.values():
        bodies = [model.jnt_bodyid[model.joint(j).id] for j in limb.joints]
        assert all(model.body_parentid[b] == a or b == a for a, b in pairwise(bodies))


# --------------------------------------------------------------- failures
_ONE_LEG = """
<mujoco><compiler angle="radian"/><worldbody>
<body name="base" pos="0 0 1"><freejoint/><geom type="box" size=".1 .1 .1"/>
  <body name="thigh" pos="0 0 -.2"><joint name="hip" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0 0 -.4" size=".03"/>
    <body name="foot" pos="0 0 -.45"><joint name="ankle" axis="0 1 0"/>
      <geom type="box" size=".1 .05 .02"/></body></body>
  <body name="arm" pos="0 .2 0"><joint name="shoulder" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0 .3 0" size=".03"/>
    <site name="hand" pos="0 .3 0"/></body>
</body></worldbody></mujoco>
"""


def test_no_limbs_is_a_clear_error_naming_what_was_found():
    model = mujoco.MjModel.from_xml_string(_ONE_LEG)
    with pytest.raises(LimbsNotFound) as err:
        find_limbs(model)
    message = str(err.value)
    assert "['foot']" in message  # the body touching the floor
    assert "touched by 1 leg(s), not 2" in message
    assert "[limbs.rarm]" in message and "description=PATH" in message
    assert err.value.found == {}
    assert isinstance(err.value, InvalidInput)


def test_description_overrides_what_the_tree_cannot_give(tmp_path):
    """The one-legged robot described in TOML: its described limbs, with the
    joints found from the chain above the end frame, or given."""
    model = mujoco.MjModel.from_xml_string(_ONE_LEG)
    path = tmp_path / "robot.toml"
    path.write_text(
        'model = "one_leg.xml"\n'
        "[limbs.rleg]\n"
        'end = "foot"\n'
        "[limbs.rarm]\n"
        'end = "hand"\n'
        'joints = ["shoulder"]\n'
    )
    description = load_description(path)
    assert description.model == str(tmp_path / "one_leg.xml")
    limbs = robot_limbs(model, description, required=("rleg", "rarm"))
    assert limbs["rleg"].joints == ("hip", "ankle")
    assert (limbs["rleg"].end_frame, limbs["rleg"].end_frame_type) == ("foot", "body")
    assert (limbs["rarm"].end_frame, limbs["rarm"].end_frame_type) == ("hand", "site")
    with pytest.raises(LimbsNotFound, match="lleg"):
        robot_limbs(model, description, required=("rleg", "lleg"))


def test_description_in_toml_and_json_is_the_same(tmp_path):
    data = {
        "model": "sample_humanoid",
        "root_body": "pelvis",
        "keyframe": "reset_pose",
        "limbs": {
            "rarm": {"end": "rarm_end"},
            "larm": {"end": "larm_end", "start": "larm_lower"},
            "rleg": {"end": "rleg_end", "joints": ["rleg_hip_y", "rleg_knee_p"]},
        },
        "soles": {"rleg": ["rleg_sole"]},
    }
    (tmp_path / "d.json").write_text(json.dumps(data))
    (tmp_path / "d.toml").write_text(
        'model = "sample_humanoid"\nroot_body = "pelvis"\nkeyframe = "reset_pose"\n'
        '[limbs.rarm]\nend = "rarm_end"\n'
        '[limbs.larm]\nend = "larm_end"\nstart = "larm_lower"\n'
        '[limbs.rleg]\nend = "rleg_end"\njoints = ["rleg_hip_y", "rleg_knee_p"]\n'
        '[soles]\nrleg = ["rleg_sole"]\n'
    )
    from_json = load_description(tmp_path / "d.json")
    assert load_description(tmp_path / "d.toml") == from_json
    assert from_json.to_dict() == data
    assert RobotDescription.from_dict(from_json.to_dict()) == from_json
    assert from_json.limbs["larm"] == LimbDescription("larm_end", (), "larm_lower")

    model = load_model("sample_humanoid")
    limbs = robot_limbs(model, from_json)
    found = find_limbs(model)
    assert limbs["rarm"] == found["rarm"] and limbs["lleg"] == found["lleg"]
    assert limbs["larm"].joints == found["larm"].joints[3:]  # from the lower arm on
    assert limbs["rleg"].joints == ("rleg_hip_y", "rleg_knee_p")


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"limb": {}}, r"unknown keys \['limb'\]; valid keys are"),
        ({"limbs": {"rarm": {"joints": ["a"]}}}, "needs 'end'"),
        ({"limbs": {"rarm": {"end": "x", "frame": "y"}}}, "limbs.rarm: unknown keys"),
        ({"limbs": {"rarm": {"end": "x", "joints": "j"}}}, "list of names"),
        ({"keyframe": 1.5}, "keyframe must be a name or an index"),
        ({"soles": ["a"]}, "soles must be a table"),
    ],
)
def test_bad_descriptions(data, match):
    with pytest.raises(InvalidInput, match=match):
        RobotDescription.from_dict(data)


def test_bad_description_files_and_names(tmp_path):
    with pytest.raises(InvalidInput, match="does not exist"):
        load_description(tmp_path / "none.toml")
    (tmp_path / "d.yaml").write_text("a: 1")
    with pytest.raises(InvalidInput, match=r"\.toml or \.json"):
        load_description(tmp_path / "d.yaml")
    (tmp_path / "d.toml").write_text("limbs = [")
    with pytest.raises(InvalidInput, match="cannot be parsed"):
        load_description(tmp_path / "d.toml")
    model = load_model("sample_humanoid")
    with pytest.raises(UnknownName, match="rarm_end"):
        limb_from_end(model, "rarm", "rarm_tip")
    with pytest.raises(UnknownName):
        limb_from_end(model, "rarm", "rarm_end", joints=["rarm_elbow"])
    with pytest.raises(InvalidInput, match="not above"):
        limb_from_end(model, "rarm", "rarm_end", start="larm_upper")


# ------------------------------------------------------------------ keyframes
def _keyframed(keys: str) -> mujoco.MjModel:
    """A one-body robot whose sphere foot floats 21 mm in qpos0, with keyframes."""
    return mujoco.MjModel.from_xml_string(
        f"""<mujoco><worldbody><body name="b" pos="0 0 .071"><freejoint/>
        <geom type="sphere" size=".05"/></body></worldbody>
        <keyframe>{keys}</keyframe></mujoco>"""
    )


def test_keyframe_rule():
    q = "0 0 {z} 1 0 0 0"
    three = _keyframed(
        f'<key qpos="{q.format(z=0.05)}"/><key name="crouch" qpos="{q.format(z=0.04)}"/>'
        f'<key name="Home" qpos="{q.format(z=0.06)}"/>'
    )
    home = standing_pose(three)
    assert (home.keyframe, home.index, home.rule) == ("Home", 2, "standing name")
    assert home.floor_gap == pytest.approx(0.01)
    first = standing_pose(_keyframed(f'<key qpos="{q.format(z=0.05)}"/><key name="crouch"/>'))
    assert (first.keyframe, first.index, first.rule) == ("", 0, "first keyframe")
    assert first.describe() == "keyframe #0 (first keyframe), 0.0 mm above the floor"
    zero = standing_pose(_keyframed(""))
    assert (zero.index, zero.rule) == (None, "zero pose")
    assert zero.floor_gap == pytest.approx(0.021)  # the floating zero pose, like OP3's
    assert "21.0 mm above the floor" in zero.describe()
    assert standing_pose(three, "crouch").floor_gap == pytest.approx(-0.01)
    assert standing_pose(three, "#0").index == 0 == standing_pose(three, 0).index
    with pytest.raises(UnknownName, match=r"\['#0', 'Home', 'crouch'\]"):
        standing_pose(three, "stand")
    with pytest.raises(InvalidInput, match="out of range"):
        standing_pose(three, 3)


@pytest.mark.parametrize(
    ("name", "keyframe", "gap_mm"),
    [("unitree_g1", "stand", -1.9), ("unitree_h1", None, 15.8), ("booster_t1", "home", -0.9)],
)
def test_menagerie_standing_poses(name, keyframe, gap_mm):
    pose = standing_pose(menagerie_model(name))
    assert pose.keyframe == keyframe
    assert 1e3 * pose.floor_gap == pytest.approx(gap_mm, abs=0.05)
