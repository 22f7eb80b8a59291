"""The geom pairs MuJoCo collides (:func:`pik_mj.tasks.collision_pairs.collidable_pairs`),
checked against ``mj_collision`` itself.

The reference: every geom that is not a plane is made a 5 cm sphere and every body
and geom is put within 2 mm of the origin, so every two geoms overlap; then the
pairs in ``data.contact`` after ``mj_forward`` are exactly the pairs MuJoCo tests.
Only geometry changes: the filters (``<contact><pair>``, ``<exclude>``,
contype/conaffinity, weld and parent–child filtering, the option flags, the
missing plane–plane collider) are MuJoCo's, on the model as compiled. The
midphase is switched off because its bounding-volume trees were built for the
geoms' real places (it changes how MuJoCo finds the pairs, not which).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from local_menagerie import requires_menagerie

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.world import floor_environment
from pik_mj.tasks.collision_pairs import (
    collidable_pairs,
    collision_pairs,
    contacts_disabled,
    geoms_named,
)

FILTERS = Path(__file__).parent / "mjcf" / "collision_filters.xml"


def _tested_by_mujoco(model: mujoco.MjModel) -> set[tuple[int, int]]:
    """Geom pairs ``(g1 < g2)`` in ``data.contact`` once every geom overlaps every
    other (module docstring); modifies ``model``."""
    rng = np.random.default_rng(0)
    solid = model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE
    model.geom_type[solid] = mujoco.mjtGeom.mjGEOM_SPHERE
    model.geom_size[solid] = 0.05
    model.geom_rbound[solid] = 0.05
    model.geom_aabb[solid] = [0.0, 0.0, 0.0, 0.05, 0.05, 0.05]
    model.geom_pos[solid] = rng.uniform(-0.002, 0.002, size=(int(solid.sum()), 3))
    model.body_pos[:] = 0.0
    model.jnt_pos[:] = 0.0
    model.geom_sameframe[:] = 0  # geom_xpos from geom_pos, not from a body frame
    model.body_sameframe[:] = 0
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MIDPHASE
    data = mujoco.MjData(model)
    data.qpos[:] = 0.0
    mujoco.mj_forward(model, data)
    return {tuple(sorted(int(g) for g in c.geom)) for c in data.contact[: data.ncon]}


def _names(model: mujoco.MjModel, pairs) -> set[tuple[str, str]]:
    return {(model.geom(int(a)).name, model.geom(int(b)).name) for a, b in pairs}


def _compare(model: mujoco.MjModel) -> np.ndarray:
    ours = collidable_pairs(model)
    theirs = _tested_by_mujoco(model)
    assert {tuple(p) for p in ours.tolist()} == theirs
    return ours


def test_filters_as_mujoco_applies_them():
    model = mujoco.MjModel.from_xml_path(str(FILTERS))
    pairs = _names(model, _compare(model))
    assert len(pairs) == 13
    # explicit pairs: geoms that collide with nothing else (contype = conaffinity = 0),
    # a parent and its child (link3's box and the base: different welds, no bitmask)
    assert {("base_ghost", "link3_pad"), ("link1", "side_tip"), ("base", "link3")} <= pairs
    assert ("floor", "side_tip") in pairs  # an explicit pair with the world
    assert ("post", "link1") in pairs  # both explicit and dynamic: once
    # filtered: parent and child (base-link1), the welded gear and its parent link
    # (one weld body), excluded bodies (base-side), bits matching neither way
    # (link2: type 2, affinity 4 against 1/1), static against static (floor-post),
    # plane against plane (floor-ramp)
    for pair in [("base", "link1"), ("link1", "gear1"), ("base", "side"), ("base", "link2")]:
        assert pair not in pairs and pair[::-1] not in pairs
    for pair in [("floor", "post"), ("floor", "ramp"), ("ball", "link2")]:
        assert pair not in pairs and pair[::-1] not in pairs
    # the gear welded to link1 is link1 for the parent filter: base-gear1 filtered too
    assert ("base", "gear1") not in pairs


def test_filterparent_disabled():
    model = mujoco.MjModel.from_xml_path(str(FILTERS))
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
    pairs = _names(model, _compare(model))
    assert {("base", "link1"), ("base", "gear1"), ("link2", "link3")} <= pairs  # now kept
    assert ("link1", "link2") not in pairs  # type 1 / affinity 1 against 2 / 4: the bits
    assert ("link1", "gear1") not in pairs  # one weld body
    assert len(pairs) == 16


@pytest.mark.parametrize("flag", ["mjDSBL_CONTACT", "mjDSBL_CONSTRAINT"])
def test_contacts_disabled_collide_nothing(flag):
    model = mujoco.MjModel.from_xml_path(str(FILTERS))
    model.opt.disableflags |= getattr(mujoco.mjtDisableBit, flag)
    assert contacts_disabled(model)
    assert len(_compare(model)) == 0


def test_selection_of_geoms():
    model = mujoco.MjModel.from_xml_path(str(FILTERS))
    every = {tuple(p) for p in collidable_pairs(model).tolist()}
    arm = geoms_named(model, ["link1", "gear1", "link2", "link3"], "arm")
    world = geoms_named(model, ["floor", "ramp", "post"], "world")
    among = {tuple(p) for p in collidable_pairs(model, arm).tolist()}
    across = {tuple(p) for p in collidable_pairs(model, arm, world).tolist()}
    assert among == {p for p in every if set(p) <= set(arm.tolist())}
    assert across == {
        p for p in every if (p[0] in arm and p[1] in world) or (p[1] in arm and p[0] in world)
    }
    assert _names(model, across) == {
        ("floor", "link1"), ("floor", "gear1"), ("ramp", "link1"), ("ramp", "gear1"),
        ("post", "link1"), ("post", "gear1"),
    }  # fmt: skip
    with pytest.raises(UnknownName, match="geom or body"):
        geoms_named(model, ["nope"], "arm")
    with pytest.raises(InvalidInput, match="not a string"):
        geoms_named(model, "link1", "arm")


def test_link_pairs_include_explicit_pairs_and_drop_touching_ones():
    """The irteus link-pair list of the base, the arm and the side arm: MuJoCo's pairs
    among them (link order kept) and with the obstacles (link first), minus those
    within ``touching`` at the reference pose."""
    model = mujoco.MjModel.from_xml_path(str(FILTERS))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    links = ["base", "link1", "gear1", "link2", "link3", "side", "side_tip"]
    got = [(p.name1, p.name2) for p in collision_pairs(model, data, links, ["post", "floor"])]
    assert got == [
        ("base", "link3"), ("base_ghost", "link3_pad"), ("link1", "side_tip"),
        ("base", "post"), ("base", "floor"), ("link1", "post"), ("link1", "floor"),
        ("gear1", "post"), ("gear1", "floor"), ("side_tip", "floor"),
    ]  # fmt: skip
    # link1-side_tip 0.35 m, base-floor 0.40 m, base-link3 0.42 m apart: "touching"
    # at 0.43 m; side_tip-floor, 0.45 m, is not
    near = collision_pairs(model, data, links, ["post", "floor"], touching=0.43)
    assert set(got) - {(p.name1, p.name2) for p in near} == {
        ("link1", "side_tip"),
        ("base", "floor"),
        ("base", "link3"),
    }


@pytest.mark.parametrize(
    "name", ["sample_humanoid", "dm_humanoid", "unitree_g1", "unitree_h1", "booster_t1"]
)
def test_robots_on_a_floor_as_mujoco_collides_them(name):
    if name.startswith(("unitree", "booster")):
        requires_menagerie(name)
    robot = Robot.from_model(name, environment=floor_environment())
    spec = robot.spec.copy()
    spec.memory = 50 * 2**20  # every pair in contact at once
    _compare(spec.compile())


def test_room_as_mujoco_collides_it():
    robot = Robot.from_model("sample_humanoid", environment="room", at="spot_counter_front")
    spec = robot.spec.copy()
    spec.memory = 50 * 2**20
    assert len(_compare(spec.compile())) > 200
