"""pik_mj.robot.ground: lowest points, floor gap and sole polygons of collision geometry,
checked against MuJoCo's own distances (mj_geomDistance) and contacts on a floor."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
import pytest
from local_menagerie import menagerie_model
from mesh_sole_humanoid import mesh_sole_humanoid
from scipy.spatial import ConvexHull

from pik_mj.balance import convex_hull_2d, polygon_area, support_polygon
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.frames import Frame
from pik_mj.robot import Limb, Robot, ground
from pik_mj.robot.keyframes import standing_pose
from pik_mj.robot.limbs import find_limbs
from pik_mj.robot.loading import load_model, load_spec
from pik_mj.sim import Scene

# A free body carrying one geom of each kind (and a mesh box), visual geoms
# larger than the collision ones, plus a plane: the floor z = 0.
_SHAPES = """
<mujoco><compiler angle="radian"/>
<asset><mesh name="box" vertex="-.05 -.03 -.02  .05 -.03 -.02  -.05 .03 -.02  .05 .03 -.02
                               -.05 -.03  .02  .05 -.03  .02  -.05 .03  .02  .05 .03  .02"/></asset>
<worldbody>
  <geom name="floor" type="plane" size="5 5 .1"/>
  <body name="thing" pos="0 0 1"><freejoint/>
    <geom name="sphere" type="sphere" size=".04" pos=".3 0 0"/>
    <geom name="capsule" type="capsule" size=".02 .1" pos="0 .3 0" euler=".3 .5 .1"/>
    <geom name="cylinder" type="cylinder" size=".05 .08" pos="-.3 0 0" euler=".4 -.2 0"/>
    <geom name="box" type="box" size=".1 .05 .02" pos="0 -.3 0" euler=".2 .3 .4"/>
    <geom name="ellipsoid" type="ellipsoid" size=".03 .06 .09" pos=".3 .3 0" euler="-.5 .2 .7"/>
    <geom name="mesh" type="mesh" mesh="box" pos="-.3 .3 0" euler=".1 .6 -.3"/>
    <geom name="visual" type="box" size=".5 .5 .5" contype="0" conaffinity="0"/>
  </body>
</worldbody></mujoco>
"""

# A foot of each contact kind: flat box, three capsules (H1-like), four spheres
# (G1-like), an upright cylinder, a mesh block; each foot also carries a large
# visual box that must never count.
_FEET = """
<mujoco><compiler angle="radian"/>
<asset><mesh name="block" vertex="-.08 -.04 0  .12 -.04 0  -.08 .04 0  .12 .04 0
                                  -.06 -.03 .03  .1 -.03 .03  -.06 .03 .03  .1 .03 .03"/></asset>
<worldbody>
  <body name="robot" pos="0 0 .5"><freejoint/>
    <geom type="box" size=".1 .1 .1" contype="0" conaffinity="0"/>
    <body name="box_foot" pos="0 0 -.3"><joint type="hinge" axis="0 1 0"/>
      <geom type="box" size=".11 .05 .015"/>
      <geom type="box" size=".15 .08 .05" pos="0 0 -.02" contype="0" conaffinity="0"/>
    </body>
    <body name="capsule_foot" pos=".5 0 -.3">
      <geom type="capsule" size=".014" fromto="-.035 0 -.056 .02 0 -.045"/>
      <geom type="capsule" size=".014" fromto=".02 0 -.045 .115 0 -.056"/>
      <geom type="capsule" size=".014" fromto=".14 -.03 -.056 .14 .03 -.056"/>
    </body>
    <body name="sphere_foot" pos="1 0 -.3">
      <geom name="heel" type="sphere" size=".005" pos="-.05 .025 -.03"/>
      <geom type="sphere" size=".005" pos="-.05 -.025 -.03"/>
      <geom type="sphere" size=".005" pos=".12 .03 -.03"/>
      <geom type="sphere" size=".005" pos=".12 -.03 -.03"/>
    </body>
    <body name="cylinder_foot" pos="1.5 0 -.3"><geom type="cylinder" size=".04 .02"/></body>
    <body name="mesh_foot" pos="2 0 -.3"><geom type="mesh" mesh="block"/></body>
  </body>
</worldbody></mujoco>
"""


def _data(model: mujoco.MjModel, qpos: np.ndarray | None = None) -> mujoco.MjData:
    data = mujoco.MjData(model)
    if qpos is not None:
        data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    return data


def _distance_to_polygon(p: np.ndarray, poly: np.ndarray) -> float:
    """Distance [m] from a point to a convex ccw polygon (0 inside), brute force."""
    n = len(poly)
    edges = [(poly[i], poly[(i + 1) % n]) for i in range(n)]
    cross = [(b - a)[0] * (p - a)[1] - (b - a)[1] * (p - a)[0] for a, b in edges]
    inside = min(cross) >= -1e-12
    if inside:
        return 0.0
    best = np.inf
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        best = min(best, float(np.linalg.norm(p - (a + t * (b - a)))))
    return best


def _outside(points: np.ndarray, poly: np.ndarray) -> float:
    """Largest distance of ``points`` (k, 2) outside ``poly`` [m]."""
    return max(_distance_to_polygon(p, poly) for p in points)


def _floor_contacts(spec: mujoco.MjSpec, qpos: np.ndarray, foot: str) -> np.ndarray:
    """MuJoCo's contact points (k, 3) between a floor plane z = 0 and the geoms of
    ``foot`` and its children, at ``qpos``."""
    spec = spec.copy()
    spec.worldbody.add_geom(name="test_floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[9, 9, 1])
    model = spec.compile()
    data = _data(model, qpos)
    floor = model.geom("test_floor").id
    feet = ground.subtree_bodies(model, model.body(foot).id)
    points = []
    for c in data.contact[: data.ncon]:
        other = c.geom2 if c.geom1 == floor else c.geom1 if c.geom2 == floor else -1
        if other >= 0 and model.geom_bodyid[other] in feet:
            points.append(c.pos.copy())
    return np.array(points)


# ----------------------------------------------------------------- lowest points
@pytest.mark.parametrize("kind", ["sphere", "capsule", "cylinder", "box", "ellipsoid", "mesh"])
def test_lowest_height_is_mujocos_distance_to_the_floor(kind):
    """Random orientations of the body: the formula's height equals MuJoCo's
    signed distance of the geom to the plane z = 0."""
    model = mujoco.MjModel.from_xml_string(_SHAPES)
    rng = np.random.default_rng(3)
    g, floor = model.geom(kind).id, model.geom("floor").id
    for _ in range(20):
        q = model.qpos0.copy()
        q[:3] = [0.0, 0.0, 1.0]
        quat = rng.normal(size=4)
        q[3:] = quat / np.linalg.norm(quat)
        data = _data(model, q)
        expected = mujoco.mj_geomDistance(model, data, g, floor, 10.0, None)
        assert ground.lowest_height(model, data, g) == pytest.approx(expected, abs=1e-6)
        bottom = ground.bottom_points(model, data, g)
        assert np.all(np.abs(bottom[:, 2] - expected) <= ground.DEFAULT_TOLERANCE + 1e-9)


def test_lowest_height_refuses_a_plane():
    model = mujoco.MjModel.from_xml_string(_SHAPES)
    with pytest.raises(InvalidInput, match="PLANE"):
        ground.lowest_height(model, _data(model), model.geom("floor").id)


def test_floor_gap_of_a_floating_robot():
    """The lowest collision geom (the capsule foot's), not the larger visual
    boxes; against MuJoCo's distance of each collision geom to a floor."""
    model = mujoco.MjModel.from_xml_string(_FEET)
    data = _data(model)
    gap = ground.floor_gap(model, data, "robot")
    spec = mujoco.MjSpec.from_string(_FEET)
    spec.worldbody.add_geom(name="f", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[9, 9, 1])
    m2 = spec.compile()
    d2 = _data(m2)
    robot_geoms = ground.collision_geoms(m2, ground.subtree_bodies(m2, m2.body("robot").id))
    floor = m2.geom("f").id
    expected = min(mujoco.mj_geomDistance(m2, d2, g, floor, 10.0, None) for g in robot_geoms)
    assert gap == pytest.approx(expected, abs=1e-9)
    assert gap == pytest.approx(0.5 - 0.3 - 0.056 - 0.014, abs=1e-9)  # the capsule foot
    # lowering the root by the gap puts the robot on the floor
    q = model.qpos0.copy()
    q[2] -= gap
    assert ground.floor_gap(model, _data(model, q), "robot") == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------------ sole polygons
@pytest.mark.parametrize(
    ("foot", "area", "n"),
    [
        ("box_foot", 0.22 * 0.10, 4),
        # heel point and the cross capsule's two ends (the toe point lies inside)
        ("capsule_foot", 0.5 * 0.06 * 0.175, 3),
        ("sphere_foot", 0.5 * (0.05 + 0.06) * 0.17, 4),
        ("cylinder_foot", ground.CYLINDER_RIM_POINTS / 2 * 0.04**2 * np.sin(2 * np.pi / 16), 16),
        ("mesh_foot", 0.20 * 0.08, 4),
    ],
)
def test_sole_polygon_matches_mujoco_contacts(foot, area, n):
    """Each foot, put 2 mm into a floor: the polygon has the expected area, and
    MuJoCo's contact points of the same pose lie on it (within 1 mm); for all but
    the cylinder (MuJoCo makes at most 4 contacts on a disc) the two hulls agree
    both ways within 1 mm."""
    model = mujoco.MjModel.from_xml_string(_FEET)
    q = model.qpos0.copy()
    body = model.body(foot).id
    heights = ground.geom_heights(model, _data(model), ground.subtree_bodies(model, body))
    q[2] -= min(heights.values()) + 0.002
    data = _data(model, q)
    poly = ground.sole_polygon(model, data, foot)
    assert len(poly) == n
    assert polygon_area(poly[:, :2]) == pytest.approx(area, rel=1e-6)
    contacts = _floor_contacts(mujoco.MjSpec.from_string(_FEET), q, foot)
    assert len(contacts) >= 3
    assert _outside(contacts[:, :2], poly[:, :2]) <= 1e-3
    if foot != "cylinder_foot":
        hull = convex_hull_2d(contacts[:, :2])
        assert _outside(poly[:, :2], hull) <= 1e-3


def test_sole_polygon_ignores_visual_geoms():
    """The box foot's collision box is 0.22 x 0.10 m; its visual box (0.30 x 0.16 m,
    what bounding boxes of every geom gave) is left out."""
    model = mujoco.MjModel.from_xml_string(_FEET)
    robot = Robot(model, limbs={"leg": Limb("leg", (), "box_foot", "body", "box_foot")})
    new = ground.sole_polygons(robot, ["leg"])[0]
    assert np.ptp(new[:, :2], axis=0) == pytest.approx([0.22, 0.10], abs=1e-9)
    foot = model.body("box_foot").id
    visual = [
        g for g in range(model.ngeom) if model.geom_bodyid[g] == foot and not model.geom_contype[g]
    ]
    assert 2 * model.geom_size[visual[0], :2] == pytest.approx([0.30, 0.16], abs=1e-9)


def test_sole_geoms_given_by_name_and_bad_names():
    model = mujoco.MjModel.from_xml_string(_FEET)
    data = _data(model)
    only_heel = ground.sole_polygon(model, data, "sphere_foot", geoms=["heel"])
    assert only_heel.shape == (1, 3)
    with pytest.raises(UnknownName, match="heel"):
        ground.sole_polygon(model, data, "sphere_foot", geoms=["toe"])
    robot = Robot(model, limbs={"leg": Limb("leg", (), "sphere_foot", "body", "sphere_foot")})
    with pytest.raises(InvalidInput, match="no area to stand on"):
        ground.sole_polygons(robot, ["leg"], soles={"leg": ["heel"]})


def test_a_foot_tilted_in_the_start_pose_has_no_area():
    """The sole comes from the start pose: a box foot pitched 0.2 rad there
    touches a floor along one edge."""
    spec = mujoco.MjSpec.from_string(_FEET)
    qpos = spec.compile().qpos0.copy()
    qpos[7] = 0.2  # the box foot's hinge
    spec.add_key(name="tilted", qpos=qpos.tolist())
    model = spec.compile()
    robot = Robot(model, limbs={"leg": Limb("leg", (), "box_foot", "body", "box_foot")})
    with pytest.raises(InvalidInput, match="tilted"):
        ground.sole_polygons(robot, ["leg"])


def test_the_sole_goes_with_its_foot():
    """A foot pitched 0.2 rad after the start pose carries its sole polygon along:
    the start pose's polygon moved by the foot's motion ``X_WB' X_WB^-1``."""
    model = mujoco.MjModel.from_xml_string(_FEET)
    robot = Robot(model, limbs={"leg": Limb("leg", (), "box_foot", "body", "box_foot")})
    before = ground.sole_polygons(robot, ["leg"])[0]
    foot = model.body("box_foot").id
    X0 = (robot.data.xpos[foot].copy(), robot.data.xmat[foot].reshape(3, 3).copy())
    q = robot.configuration.q.copy()
    q[model.jnt_qposadr[1]] = 0.2
    robot.configuration.update(q)
    after = ground.sole_polygons(robot, ["leg"])[0]
    R = robot.data.xmat[foot].reshape(3, 3) @ X0[1].T
    expected = robot.data.xpos[foot] + (before - X0[0]) @ R.T
    np.testing.assert_allclose(after, expected, atol=1e-12)
    assert np.ptp(after[:, 2]) > 0.02  # tilted with the foot


def test_sample_humanoid_soles_are_its_box_soles():
    """Box feet without visual geoms: each sole is its box's bottom face; its frame
    (from MuJoCo's 4 corner contacts) is the leg's end site, the sole's centre."""
    robot = Robot(load_model("sample_humanoid"))
    for leg, poly in zip(("rleg", "lleg"), ground.sole_polygons(robot), strict=True):
        box = robot.model.geom(f"{leg}_sole")
        assert np.ptp(poly[:, :2], axis=0) == pytest.approx(2 * box.size[:2], abs=1e-9)
        centre = robot.frame_pose(f"{leg}_end").translation()
        assert poly.mean(axis=0) == pytest.approx(centre, abs=1e-9)
    assert ground.sole_size(robot) == pytest.approx((0.22, 0.12), abs=1e-9)
    for leg, sole in ground.robot_soles(robot).items():
        p_WS, R_WS = sole.pose(robot.model, robot.data)
        X = robot.frame_pose(f"{leg}_end")
        np.testing.assert_allclose(p_WS, X.translation(), atol=1e-9)
        np.testing.assert_allclose(R_WS, X.rotation().as_matrix(), atol=1e-9)
        assert sole.geoms == (f"{leg}_sole",) and sole.size == pytest.approx((0.22, 0.12))


def test_with_and_without_the_robots_spec():
    """``Robot(model)`` has no spec: its probe copies the geoms; on primitive soles
    the polygons are the ones of the spec's probe."""
    with_spec = ground.sole_polygons(Robot.from_model("sample_humanoid"))
    without = ground.sole_polygons(Robot(load_model("sample_humanoid")))
    for a, b in zip(with_spec, without, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-9)


# ------------------------------------------------------------- mesh soles
def _mesh_sole_robot() -> Robot:
    return Robot.from_model(mujoco.MjSpec.from_string(mesh_sole_humanoid()))


def test_mesh_soles_are_mujocos_contacts_not_the_mesh_vertices():
    """A humanoid without sites whose mesh soles sit off the ankle: each sole is the
    hull of MuJoCo's contacts with a floor in the start pose (the scene's
    collision detection, an independent call), 4 of the 9 bottom vertices of the
    mesh; its frame is their centroid, off the ankle."""
    robot = _mesh_sole_robot()
    assert robot.model.nsite == 0
    scene = Scene.from_robot(robot)
    probe = scene.probe(robot.start_q())
    touching = _contacts_by_geom(scene.model, probe, scene.contact_tolerance)
    soles = ground.robot_soles(robot)
    for leg, side in (("rleg", -1.0), ("lleg", 1.0)):
        sole = soles[leg]
        poly = sole.polygon(robot.model, robot.data)
        contacts = touching[f"{'right' if side < 0 else 'left'}_sole"]
        assert len(poly) == 4 == len(contacts)
        assert _outside(contacts[:, :2], poly[:, :2]) <= 1e-6
        assert _outside(poly[:, :2], convex_hull_2d(contacts[:, :2])) <= 1e-6
        bottom = ground.bottom_points(robot.model, robot.data, robot.model.geom(sole.geoms[0]).id)
        assert len(bottom) == 9 and _outside(bottom[:, :2], poly[:, :2]) > 0.01
        p_WS, _ = sole.pose(robot.model, robot.data)
        ankle = robot.data.xpos[robot.model.body(sole.body).id]
        assert np.hypot(*(p_WS - ankle)[:2]) > 0.03  # off-centre
        assert p_WS[:2] == pytest.approx(_centroid(poly[:, :2]), abs=1e-9)


def test_mesh_sole_com_margin_against_brute_force():
    """The margin of the CoM (and of it leaning 7 cm forward, or sideways) in the
    support polygon of both soles equals the brute-force distance to the hull of
    MuJoCo's contacts (scipy's Qhull facets); leaning forward, the hull of every
    bottom vertex of the meshes claims more than 1 cm too much."""
    robot = _mesh_sole_robot()
    region = support_polygon(ground.sole_polygons(robot))
    scene = Scene.from_robot(robot)
    touching = _contacts_by_geom(scene.model, scene.probe(robot.start_q()), 2e-3)
    points = np.vstack([touching["right_sole"], touching["left_sole"]])[:, :2]
    facets = ConvexHull(points).equations  # outward unit normals: n . p + d <= 0 inside
    vertices = support_polygon(
        [
            ground.sole_polygon(robot.model, robot.data, robot.model.body(b).id)
            for b in ("right_foot", "left_foot")
        ]
    )
    for offset in ([0.0, 0.0], [0.07, 0.0], [-0.03, 0.05], [0.02, -0.2]):
        c = robot.com() + np.array([*offset, 0.0])
        brute = -np.max(facets[:, :2] @ c[:2] + facets[:, 2])
        assert region.signed_distance(c) == pytest.approx(brute, abs=1e-9)
    lean = robot.com() + np.array([0.07, 0.0, 0.0])
    true, claimed = region.signed_distance(lean), vertices.signed_distance(lean)
    assert claimed > true + 0.01
    print(f"\nleaning CoM margin {true * 1e3:.1f} mm; the mesh vertices claim {claimed * 1e3:.1f}")


def _contacts_by_geom(
    model: mujoco.MjModel, data: mujoco.MjData, max_dist: float
) -> dict[str, np.ndarray]:
    """Contact points (k, 3) of each geom touching the scene's floor in ``data``."""
    out: dict[str, list[np.ndarray]] = {}
    floor = model.geom("floor").id
    for c in data.contact[: data.ncon]:
        if c.dist <= max_dist and floor in (c.geom1, c.geom2):
            other = c.geom2 if c.geom1 == floor else c.geom1
            out.setdefault(model.geom(other).name, []).append(c.pos.copy())
    return {k: np.array(v) for k, v in out.items()}


def _centroid(poly: np.ndarray) -> np.ndarray:
    """Area centroid of a polygon (k, 2), by triangles from its first vertex."""
    a, total = poly[0], 0.0
    c = np.zeros(2)
    for b, d in itertools.pairwise(poly[1:]):
        area = 0.5 * abs((b - a)[0] * (d - a)[1] - (b - a)[1] * (d - a)[0])
        c += area * (a + b + d) / 3.0
        total += area
    return c / total


# ---------------------------------------------------------------- real robots
# (foot length x width of the sole polygon [m], of the bounding boxes of every geom
# on the foot, visual meshes included, which pik_mj used before [m], area [m²])
_MENAGERIE_SOLES = {
    "unitree_g1": ((0.170, 0.060), (0.213, 0.076), 0.0094),
    "unitree_h1": ((0.175, 0.060), (0.248, 0.088), 0.0053),
    "booster_t1": ((0.223, 0.100), (0.229, 0.100), 0.0223),
}


@pytest.mark.parametrize("name", list(_MENAGERIE_SOLES))
def test_menagerie_soles_against_mujoco_contacts(name):
    """In the standing pose put 3 mm into a floor: each sole polygon and the hull
    of MuJoCo's contact points on that foot agree within 1 mm both ways; the
    bounding boxes of all the foot's geoms (visual meshes included) are larger by
    the measured amounts."""
    model = menagerie_model(name)
    pose = standing_pose(model)
    q = pose.qpos.copy()
    q[2] -= pose.floor_gap + ground.DEFAULT_TOLERANCE
    robot = Robot(model, limbs=find_limbs(model, pose.qpos))
    robot.configuration.update(q)
    size, old_size, area = _MENAGERIE_SOLES[name]
    spec = load_spec(name)
    for leg, poly in zip(("rleg", "lleg"), ground.sole_polygons(robot), strict=True):
        assert np.ptp(poly[:, :2], axis=0) == pytest.approx(size, abs=1e-3)
        old = _bounding_box_sole(robot, leg)
        assert np.ptp(old[:, :2], axis=0) == pytest.approx(old_size, abs=1e-3)
        assert polygon_area(poly[:, :2]) == pytest.approx(area, abs=1e-4)
        foot = Frame.find(model, robot.limb(leg).end_frame).body_id
        contacts = _floor_contacts(spec, q, model.body(foot).name)
        assert _outside(contacts[:, :2], poly[:, :2]) <= 1e-3
        assert _outside(poly[:, :2], convex_hull_2d(contacts[:, :2])) <= 1e-3


def _bounding_box_sole(robot: Robot, leg: str) -> np.ndarray:
    """The bottom corners of the world boxes bounding every geom of the leg's end
    body (MuJoCo's ``geom_aabb`` placed by ``geom_xpos``, ``geom_xmat``), visual
    meshes included: the sole pik_mj took before it used the collision geometry."""
    model, data = robot.model, robot.data
    limb = robot.limb(leg)
    body = Frame.find(model, limb.end_frame, limb.end_frame_type).body_id
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    pts = np.vstack(
        [
            (model.geom_aabb[g, :3] + signs * model.geom_aabb[g, 3:])
            @ data.geom_xmat[g].reshape(3, 3).T
            + data.geom_xpos[g]
            for g in np.flatnonzero(model.geom_bodyid == body)
        ]
    )
    bottom = pts[pts[:, 2] <= pts[:, 2].min() + 1e-6]
    return bottom if len(bottom) >= 3 else pts
