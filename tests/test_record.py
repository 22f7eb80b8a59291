"""Tests of pik_mj.record: recordings are read back from the .rrd and checked.

Geometry is checked against MuJoCo's own world poses (``geom_xpos``,
``geom_xmat``) and against the MJCF inputs (``fromto`` end points, mesh vertices
before MuJoCo re-centres them), by composing the recorded transforms.
"""

from __future__ import annotations

import re
import subprocess
import sys
import uuid
from pathlib import Path

import mujoco
import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader
from scipy.spatial.transform import Rotation

from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.record import (
    PATHS,
    EntityData,
    Recorder,
    blueprint,
    read_blueprint,
    read_recording,
    style,
)
from pik_mj.record.geometry import right_mul_matrix

TET = np.array([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0], [0, 0, 0.2]], dtype=float)
TET_POS = np.array([0.0, 0.0, 0.1])
CAPSULE_FROMTO = np.array([[0.0, 0.0, 0.0], [0.3, 0.1, -0.2]])
CYLINDER_FROMTO = np.array([[0.0, 0.1, 0.0], [0.1, 0.3, 0.2]])
_UUID = re.compile(r"[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}")

MJCF = f"""
<mujoco>
  <compiler angle="radian"/>
  <asset>
    <material name="red" rgba="1 0 0 1"/>
    <mesh name="tet" vertex="{" ".join(map(str, TET.ravel()))}"/>
    <hfield name="hf" nrow="3" ncol="3" size="1 1 0.2 0.1"
            elevation="0 0 0 0 1 0 0 0 0"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 3 0.1" rgba="0.2 0.4 0.6 1"/>
    <geom name="terrain" type="hfield" hfield="hf" pos="5 0 0"/>
    <body name="table" pos="1 0 0.5" euler="0 0 0.4">
      <geom name="top" type="box" size="0.3 0.2 0.02"/>
    </body>
    <body name="crate" pos="-1 0 0.2">
      <freejoint/>
      <geom name="crate" type="box" size="0.1 0.1 0.1"/>
    </body>
    <body name="base" pos="0 0 1" euler="0.1 -0.2 0.3">
      <freejoint name="root"/>
      <geom name="box" type="box" size="0.1 0.2 0.3" pos="0.01 0.02 0.03"
            euler="0.2 0 0" material="red"/>
      <geom name="ball" type="sphere" size="0.05" pos="0 0 0.4" rgba="0 1 0 1"
            material="red"/>
      <geom name="collision" type="box" size="0.5 0.5 0.5" group="3"/>
      <body name="arm" pos="0.2 0 0" euler="0.3 0.2 0.1">
        <joint name="j1" type="hinge" axis="0 1 0"/>
        <geom name="capsule" type="capsule"
              fromto="{" ".join(map(str, CAPSULE_FROMTO.ravel()))}" size="0.04"/>
        <geom name="cylinder" type="cylinder"
              fromto="{" ".join(map(str, CYLINDER_FROMTO.ravel()))}" size="0.03"/>
        <geom name="egg" type="ellipsoid" size="0.05 0.06 0.07" pos="0.3 0 0"
              euler="0.5 0 0"/>
        <geom name="tet" type="mesh" mesh="tet" pos="{" ".join(map(str, TET_POS))}"/>
        <body name="left hand" pos="0.3 0 0">
          <joint name="j2" type="hinge" axis="1 0 0"/>
          <geom type="sphere" size="0.02"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def _rerun_cli() -> Path:
    return Path(sys.executable).parent / "rerun"


def _verify(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(_rerun_cli()), "rrd", "verify", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(MJCF)


def _posed_data(model: mujoco.MjModel, k: int) -> mujoco.MjData:
    """A configuration that moves every joint with ``k``."""
    data = mujoco.MjData(model)
    base = model.joint("root").qposadr[0]
    data.qpos[base : base + 3] = [0.01 * k, -0.02 * k, 1.0 + 0.005 * k]
    quat = Rotation.from_rotvec([0.05 * k, 0.1, -0.03 * k]).as_quat()  # xyzw
    data.qpos[base + 3 : base + 7] = np.roll(quat, 1)  # MuJoCo wxyz
    data.qpos[model.joint("j1").qposadr[0]] = 0.1 * k
    data.qpos[model.joint("j2").qposadr[0]] = -0.07 * k
    mujoco.mj_kinematics(model, data)
    return data


#: (translation, quaternion) components of each primitive's instance poses.
POSE_COMPONENTS = {
    "Boxes3D": ("Boxes3D:centers", "Boxes3D:quaternions"),
    "Capsules3D": ("Capsules3D:translations", "Capsules3D:quaternions"),
    "Cylinders3D": ("Cylinders3D:centers", "Cylinders3D:quaternions"),
    "Ellipsoids3D": ("Ellipsoids3D:centers", "Ellipsoids3D:quaternions"),
    "Mesh3D": ("InstancePoses3D:translations", "InstancePoses3D:quaternions"),
}


def _archetype(entity: EntityData) -> str:
    kinds = {c.split(":")[0] for c in entity.static} & set(POSE_COMPONENTS)
    assert len(kinds) == 1, sorted(entity.static)
    return kinds.pop()


def _find(rec: dict[str, EntityData], label: str, body: bool = False) -> tuple[str, int]:
    """(entity path, instance index) of the geom (or ``body``) labelled ``label``."""
    hits = []
    for path, entity in rec.items():
        if path.endswith("/bodies") != body:
            continue
        for component, value in entity.static.items():
            if component.endswith(":labels") and label in value:
                hits.append((path, value.index(label)))
    assert len(hits) == 1, (label, hits)
    return hits[0]


def _instance_pose(entity: EntityData, i: int, row: int | None = -1):
    """(p, R) of instance ``i``: temporal row ``row``, or static if ``row`` is None."""
    t_name, q_name = POSE_COMPONENTS[_archetype(entity)]
    if row is None:
        t, q = entity.static[t_name][i], entity.static[q_name][i]
    else:
        t, q = entity.temporal[t_name][row][1][i], entity.temporal[q_name][row][1][i]
    return np.array(t), Rotation.from_quat(q).as_matrix()  # scipy: xyzw


def _geom_pose(rec, label: str, row: int | None = -1):
    """(p, R, entity, i) of the primitive frame of geom ``label`` (a mesh has
    no labels: its entity is named after the mesh)."""
    path, i = ("world/robot/meshes/tet", 0) if label == "tet" else _find(rec, label)
    p, R = _instance_pose(rec[path], i, row)
    return p, R, rec[path], i


@pytest.fixture(scope="module")
def geometry_recording(model, tmp_path_factory):
    """One recording of the test model, with one posed iteration."""
    path = tmp_path_factory.mktemp("rec") / "geometry.rrd"
    data = _posed_data(model, 3)
    with Recorder.to_file(path) as rec:
        rec.log_model_geometry(model, robot_root_body="base")
        rec.log_body_poses(data, timeline="iteration", time=0)
    return path, data, read_recording(path)


# ---------------------------------------------------------------------------
# Entity paths


def test_paths_are_readable_and_nested():
    assert PATHS.geoms("capsules") == "world/robot/capsules"
    assert PATHS.geoms("boxes", robot=False, moving=False) == "world/scene/boxes"
    assert PATHS.geoms("boxes", robot=False) == "world/scene/moving/boxes"
    assert PATHS.bodies() == "world/robot/bodies"
    assert PATHS.bodies(robot=False) == "world/scene/moving/bodies"
    assert PATHS.task_target("rarm") == "world/tasks/rarm/target"
    # names rerun would escape become plain parts: the viewer shows them as written
    assert PATHS.task_target("left hand/x") == "world/tasks/left_hand_x/target"
    assert PATHS.task_error(0, "limits: 30 joints") == "errors/level_0/limits_30_joints"
    assert all(rr.escape_entity_path_part(p) == p for p in ("target_larm_end", "é.x-1"))
    assert PATHS.task_current("rarm") == "world/tasks/rarm/current"
    assert PATHS.task_error(2, "com") == "errors/level_2/com"
    assert PATHS.task_error(2, "com", log10=True) == "errors_log10/level_2/com"
    assert PATHS.task_error(2, "com", solve="reach again") == "errors/level_2/reach_again/com"
    assert PATHS.hold_metric("drift") == "hold/drift"
    assert PATHS.walk_series("x", "zmp_reference") == "walk/x/zmp_reference"


def test_right_mul_matrix_is_mujocos_quaternion_product():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(20, 4))
    b = rng.normal(size=(20, 4))
    M = right_mul_matrix(b)
    for i in range(20):
        ab = np.zeros(4)
        mujoco.mju_mulQuat(ab, a[i], b[i])
        np.testing.assert_allclose(M[i] @ a[i], ab, atol=1e-12)


# ---------------------------------------------------------------------------
# Static geometry


def test_geoms_are_grouped_by_kind(geometry_recording, model):
    _, _, rec = geometry_recording
    robot, scene = "world/robot", "world/scene"
    unnamed = f"geom_{model.body('left hand').geomadr[0]}"
    expected = {
        f"{scene}/boxes": ("Boxes3D:half_sizes", ["floor", "top"]),
        f"{scene}/hfields/hf": ("Mesh3D:vertex_positions", ["terrain"]),
        f"{scene}/moving/boxes": ("Boxes3D:half_sizes", ["crate"]),
        f"{robot}/boxes": ("Boxes3D:half_sizes", ["box"]),
        f"{robot}/ellipsoids": ("Ellipsoids3D:half_sizes", ["ball", "egg", unnamed]),
        f"{robot}/capsules": ("Capsules3D:lengths", ["capsule"]),
        f"{robot}/cylinders": ("Cylinders3D:lengths", ["cylinder"]),
        f"{robot}/meshes/tet": ("Mesh3D:vertex_positions", ["tet"]),
    }
    geometry = {p for p in rec if p.startswith("world/") and not p.endswith("/bodies")}
    assert geometry == set(expected)
    for path, (component, labels) in expected.items():
        entity = rec[path]
        assert component in entity.static, (path, sorted(entity.static))
        assert not entity.temporal.get(component), path
        if "Mesh3D" not in component:
            assert entity.static[f"{component.split(':')[0]}:labels"] == labels
    # one robot body marker per body, with its MJCF name
    bodies = rec[PATHS.bodies()].static["Ellipsoids3D:labels"]
    assert bodies == ["base", "arm", "left hand"]
    assert rec[PATHS.bodies(robot=False)].static["Ellipsoids3D:labels"] == ["crate"]
    # Group 3 (collision) is hidden by default.
    assert all("collision" not in e.static.get("Boxes3D:labels", []) for e in rec.values())


def test_geom_sizes_and_colors(geometry_recording, model):
    _, _, rec = geometry_recording

    def static(label, component):
        path, i = _find(rec, label)
        return rec[path].static[f"{_archetype(rec[path])}:{component}"][i]

    np.testing.assert_allclose(static("box", "half_sizes"), [0.1, 0.2, 0.3], rtol=1e-6)
    # Material colour when the geom's rgba is MuJoCo's default; rgba wins otherwise.
    assert static("box", "colors") == 0xFF0000FF
    assert static("ball", "colors") == 0x00FF00FF
    assert static("floor", "colors") == 0x336699FF
    np.testing.assert_allclose(static("egg", "half_sizes"), [0.05, 0.06, 0.07], rtol=1e-6)
    np.testing.assert_allclose(static("ball", "half_sizes"), [0.05] * 3, rtol=1e-6)
    np.testing.assert_allclose(static("floor", "half_sizes"), [2, 3, 1e-3], rtol=1e-6)
    assert static("capsule", "radii") == pytest.approx(0.04)
    assert static("cylinder", "radii") == pytest.approx(0.03)


def test_geom_world_poses_match_mujoco(geometry_recording, model):
    """Each recorded instance pose, moved to the primitive's centre, is MuJoCo's
    geom pose; the body frames are MuJoCo's body poses."""
    _, data, rec = geometry_recording
    checked = 0
    for g in range(model.ngeom):
        label = model.geom(g).name or f"geom_{g}"
        if label in ("collision", "terrain"):  # hidden / height field: below
            continue
        welded = label in ("floor", "top")
        p, R, entity, i = _geom_pose(rec, label, row=None if welded else -1)
        if _archetype(entity) == "Capsules3D":
            # rerun capsules start at their translation and run along +z
            centre = [0, 0, entity.static["Capsules3D:lengths"][i] / 2]
        elif label == "floor":  # the slab's top face is the plane z = 0
            centre = [0, 0, entity.static["Boxes3D:half_sizes"][i][2]]
        else:
            centre = [0, 0, 0]
        np.testing.assert_allclose(p + R @ centre, data.geom_xpos[g], atol=1e-6)
        np.testing.assert_allclose(R, data.geom_xmat[g].reshape(3, 3), atol=1e-6)
        checked += 1
    assert checked == 10
    for name in ("base", "arm", "left hand", "crate"):
        path, i = _find(rec, name, body=True)
        p, R = _instance_pose(rec[path], i)
        b = model.body(name).id
        np.testing.assert_allclose(p, data.xpos[b], atol=1e-6)
        np.testing.assert_allclose(R, data.xmat[b].reshape(3, 3), atol=1e-6)


def _arm_pose(data, model):
    b = model.body("arm").id
    return data.xpos[b], data.xmat[b].reshape(3, 3)


def test_capsule_and_cylinder_end_points_match_fromto(geometry_recording, model):
    """Axis convention: rerun's capsule/cylinder ends land on the MJCF fromto."""
    _, data, rec = geometry_recording
    p_WA, R_WA = _arm_pose(data, model)

    p, R, cap, i = _geom_pose(rec, "capsule")
    length = cap.static["Capsules3D:lengths"][i]
    ends = [p + R @ [0, 0, s] for s in (0.0, length)]
    want = [p_WA + R_WA @ e for e in CAPSULE_FROMTO]
    # Either direction is the same capsule.
    if np.linalg.norm(ends[0] - want[0]) > np.linalg.norm(ends[0] - want[1]):
        ends = ends[::-1]
    np.testing.assert_allclose(ends, want, atol=1e-6)

    p, R, cyl, i = _geom_pose(rec, "cylinder")
    half = cyl.static["Cylinders3D:lengths"][i] / 2
    ends = [p + R @ [0, 0, s] for s in (-half, half)]
    want = [p_WA + R_WA @ e for e in CYLINDER_FROMTO]
    if np.linalg.norm(ends[0] - want[0]) > np.linalg.norm(ends[0] - want[1]):
        ends = ends[::-1]
    np.testing.assert_allclose(ends, want, atol=1e-6)


def test_mesh_vertices_reproduce_the_mjcf_mesh(geometry_recording, model):
    """MuJoCo re-centres mesh vertices; the recorded instance pose must undo that."""
    _, data, rec = geometry_recording
    tet = rec["world/robot/meshes/tet"]
    p, R = _instance_pose(tet, 0)
    v = np.array(tet.static["Mesh3D:vertex_positions"])
    in_world = v @ R.T + p
    p_WA, R_WA = _arm_pose(data, model)
    want = (TET + TET_POS) @ R_WA.T + p_WA
    # Same vertex set (MuJoCo may reorder): match each to its nearest.
    d = np.linalg.norm(in_world[:, None, :] - want[None, :, :], axis=2)
    assert sorted(d.argmin(axis=1)) == [0, 1, 2, 3]
    np.testing.assert_allclose(d.min(axis=1), 0.0, atol=1e-6)
    faces = np.array(tet.static["Mesh3D:triangle_indices"])
    assert faces.shape == (4, 3)
    assert set(faces.ravel()) == {0, 1, 2, 3}
    normals = np.array(tet.static["Mesh3D:vertex_normals"])
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, rtol=1e-5)
    # Vertex normals point away from the centroid of a convex mesh.
    assert (np.sum((v - v.mean(axis=0)) * normals, axis=1) > 0).all()


def test_hfield_surface(geometry_recording):
    _, _, rec = geometry_recording
    terrain = rec["world/scene/hfields/hf"]
    v = np.array(terrain.static["Mesh3D:vertex_positions"])
    assert v.shape == (9, 3)
    assert len(terrain.static["Mesh3D:triangle_indices"]) == 8
    np.testing.assert_allclose(v[:, :2].min(axis=0), [-1, -1])
    np.testing.assert_allclose(v[:, :2].max(axis=0), [1, 1])
    # Only the middle sample is raised, to the full height 0.2 m.
    top = v[np.argmax(v[:, 2])]
    np.testing.assert_allclose(top, [0, 0, 0.2], atol=1e-6)
    assert np.sort(v[:, 2])[-2] == pytest.approx(0.0)
    # welded to the world at pos="5 0 0": one static instance pose
    p, R = _instance_pose(terrain, 0, row=None)
    np.testing.assert_allclose(p, [5, 0, 0], atol=1e-9)
    np.testing.assert_allclose(R, np.eye(3), atol=1e-9)


def test_scene_geoms_static_or_moving(geometry_recording):
    _, _, rec = geometry_recording
    welded = rec["world/scene/boxes"]
    assert welded.temporal == {}
    p, R = _instance_pose(welded, welded.static["Boxes3D:labels"].index("top"), row=None)
    np.testing.assert_allclose(p, [1, 0, 0.5], atol=1e-6)
    np.testing.assert_allclose(R, Rotation.from_euler("xyz", [0, 0, 0.4]).as_matrix(), atol=1e-6)
    # A free body outside the robot is scene, but moves.
    assert len(rec["world/scene/moving/boxes"].temporal["Boxes3D:centers"]) == 1
    assert len(rec[PATHS.bodies(robot=False)].temporal["Ellipsoids3D:centers"]) == 1


def test_default_classification_and_geom_groups(model, tmp_path):
    path = tmp_path / "default.rrd"
    with Recorder.to_file(path) as rec:
        rec.log_model_geometry(model, geom_groups=(0, 3))
        rec.log_body_poses(_posed_data(model, 1), timeline="iteration", time=0)
    out = read_recording(path)
    # everything but the world body moves, and is robot
    boxes = out["world/robot/boxes"]
    assert boxes.static["Boxes3D:labels"] == ["top", "crate", "box", "collision"]
    assert len(boxes.temporal["Boxes3D:centers"][0][1]) == 4
    assert out[PATHS.bodies()].static["Ellipsoids3D:labels"][:2] == ["table", "crate"]
    assert out["world/scene/boxes"].static["Boxes3D:labels"] == ["floor"]


# ---------------------------------------------------------------------------
# Per-iteration data


def test_body_poses_per_iteration(model, tmp_path):
    path = tmp_path / "poses.rrd"
    n = 70  # not a multiple of the buffer size
    datas = [_posed_data(model, k) for k in range(n)]
    with Recorder.to_file(path, flush_every=64) as rec:
        rec.log_model_geometry(model, robot_root_body="base")
        for k, data in enumerate(datas):
            rec.log_body_poses(data, timeline="iteration", time=k)
    out = read_recording(path)
    frames = out[PATHS.bodies()]
    times, t = frames.series("Ellipsoids3D:centers", "iteration")
    _, q = frames.series("Ellipsoids3D:quaternions", "iteration")
    assert times.tolist() == list(range(n))
    for i, name in enumerate(frames.static["Ellipsoids3D:labels"]):
        b = model.body(name).id
        p = np.array([x[i] for x in t])
        R = Rotation.from_quat(np.array([x[i] for x in q])).as_matrix()
        np.testing.assert_allclose(p, [d.xpos[b] for d in datas], atol=1e-6)
        np.testing.assert_allclose(R, [d.xmat[b].reshape(3, 3) for d in datas], atol=1e-6)
    # the geometry moves with the bodies, row by row
    g = model.geom("egg").id
    i = out["world/robot/ellipsoids"].static["Ellipsoids3D:labels"].index("egg")
    _, centers = out["world/robot/ellipsoids"].series("Ellipsoids3D:centers", "iteration")
    np.testing.assert_allclose([c[i] for c in centers], [d.geom_xpos[g] for d in datas], atol=1e-6)


def test_buffering_does_not_change_the_data(model, tmp_path):
    def run(path, flush_every):
        with Recorder.to_file(path, flush_every=flush_every) as rec:
            rec.log_model_geometry(model)
            for k in range(10):
                rec.log_body_poses(_posed_data(model, k), time=k)
                rec.log_scalar("errors/level_1/x", 0.5 * k)
                rec.log_com([k, 0, 1])
        return read_recording(path)

    a, b = run(tmp_path / "a.rrd", 1), run(tmp_path / "b.rrd", 4)
    # buffered columns are built as Arrow arrays by pik_mj: of the types rerun
    # gives the same components logged one by one
    assert _data_types(tmp_path / "a.rrd") == _data_types(tmp_path / "b.rrd")
    for entity, component in [
        (PATHS.bodies(), "Ellipsoids3D:quaternions"),
        ("world/robot/capsules", "Capsules3D:translations"),  # from the body poses
        ("world/robot/boxes", "Boxes3D:quaternions"),
        ("errors/level_1/x", "Scalars:scalars"),
        (PATHS.com, "Points3D:positions"),
        (PATHS.com, "Points3D:radii"),
        (PATHS.com, "Points3D:colors"),
    ]:
        ta, va = a[entity].series(component, "iteration")
        tb, vb = b[entity].series(component, "iteration")
        assert ta.tolist() == tb.tolist() == list(range(10))
        np.testing.assert_allclose(va, vb)


def test_com_scalars_frames_and_text(model, tmp_path):
    path = tmp_path / "values.rrd"
    coms = np.random.default_rng(0).normal(size=(5, 3))
    target = np.array([0.1, 0.2, 0.9])
    q = np.array([0.9, 0.1, -0.3, 0.2])  # wxyz, not normalized
    with Recorder.to_file(path) as rec:
        for k in range(5):
            rec.set_time("iteration", k)
            rec.log_com(coms[k], target=target)
            rec.log_task_errors({(1, "com"): 0.1 * k, (2, "posture"): k**2})
            rec.log_frame(PATHS.task_target("hand"), [k, 0, 0], q, axis_length=0.2)
        rec.log_text("level 2 not satisfied", level="WARN")
    out = read_recording(path)
    times, v = out[PATHS.com].series("Points3D:positions", "iteration")
    assert times.tolist() == [0, 1, 2, 3, 4]
    np.testing.assert_allclose([x[0] for x in v], coms, rtol=1e-6)
    _, v = out[PATHS.com_target].series("Points3D:positions", "iteration")
    np.testing.assert_allclose([x[0] for x in v], [target] * 5, rtol=1e-6)
    _, e = out[PATHS.task_error(1, "com")].series("Scalars:scalars", "iteration")
    np.testing.assert_allclose([x[0] for x in e], [0.0, 0.1, 0.2, 0.3, 0.4])
    _, e = out[PATHS.task_error(2, "posture")].series("Scalars:scalars", "iteration")
    np.testing.assert_allclose([x[0] for x in e], [0, 1, 4, 9, 16])
    # log10 of each error, 1e-16 for an error of 0 (the plots' log scale)
    _, e = out[PATHS.task_error(2, "posture", log10=True)].series("Scalars:scalars", "iteration")
    np.testing.assert_allclose([x[0] for x in e], [-16, 0, np.log10(4), np.log10(9), np.log10(16)])
    # the style goes with every row, in the chunk of the data (no static chunk)
    _, radii = out[PATHS.com].series("Points3D:radii", "iteration")
    _, colors = out[PATHS.com].series("Points3D:colors", "iteration")
    assert [x[0] for x in radii] == pytest.approx([style.COM_RADIUS] * 5)
    r, g, b = style.COM
    assert {x[0] for x in colors} == {(r << 24) | (g << 16) | (b << 8) | 0xFF}  # opaque
    # no geometry logged: no ground known, no projection of the CoM
    assert "Arrows3D:vectors" not in out[PATHS.com].temporal
    hand = out[PATHS.task_target("hand")]
    assert not hand.static
    _, lengths = hand.series("TransformAxes3D:axis_length", "iteration")
    assert [x[0] for x in lengths] == pytest.approx([0.2] * 5)
    _, quats = hand.series("Transform3D:quaternion", "iteration")
    R = Rotation.from_quat(quats[-1][0]).as_matrix()  # xyzw
    R_mj = np.zeros(9)
    mujoco.mju_quat2Mat(R_mj, q / np.linalg.norm(q))
    np.testing.assert_allclose(R, R_mj.reshape(3, 3), atol=1e-6)
    events = out[PATHS.events].temporal
    assert events["TextLog:text"][0][1] == ["level 2 not satisfied"]
    assert events["TextLog:level"][0][1] == ["WARN"]
    assert events["TextLog:text"][0][0]["iteration"] == 4


def test_polygon_and_contacts(tmp_path):
    path = tmp_path / "poly.rrd"
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    points = np.array([[0.1, 0.2, 0.0], [0.3, -0.1, 0.0]])
    forces = np.array([[0.0, 0.0, 100.0], [5.0, 0.0, 200.0]])
    with Recorder.to_file(path) as rec:
        rec.set_time("iteration", 0)
        rec.log_polygon(square, margin_vertices=0.5 + 0.8 * (square - 0.5))
        rec.log_contacts(points, forces, scale=2e-3)
    out = read_recording(path)
    # drawn LIFT above the ground, the loop closed
    strip = out[PATHS.support_polygon].temporal["LineStrips3D:strips"][0][1][0]
    up = np.array([0.0, 0.0, style.LIFT])
    np.testing.assert_allclose(strip, np.vstack([square, square[:1]]) + up)
    margin = out[f"{PATHS.support_polygon}/margin"].temporal["LineStrips3D:strips"]
    np.testing.assert_allclose(margin[0][1][0][0], [0.1, 0.1, 0.1 + style.LIFT], rtol=1e-6)
    c = out[PATHS.contact_forces].temporal
    np.testing.assert_allclose(c["Arrows3D:origins"][0][1], points)
    np.testing.assert_allclose(c["Arrows3D:vectors"][0][1], forces * 2e-3)
    np.testing.assert_allclose(
        out[PATHS.contact_points].temporal["Points3D:positions"][0][1], points
    )


def test_sim_time_is_seconds_and_timelines_can_be_dropped(model, tmp_path):
    path = tmp_path / "sim.rrd"
    with Recorder.to_file(path) as rec:
        rec.log_model_geometry(model)
        rec.log_body_poses(_posed_data(model, 0), timeline="iteration", time=7)
        rec.disable_timeline("iteration")
        for k in range(4):
            rec.log_body_poses(_posed_data(model, k), timeline="sim_time", time=0.002 * k)
            rec.log_scalar(PATHS.hold_metric("drift"), 0.01 * k)
    out = read_recording(path)
    times, drift = out["hold/drift"].series("Scalars:scalars", "sim_time")
    np.testing.assert_allclose(times, [0, 0.002, 0.004, 0.006], atol=1e-12)
    np.testing.assert_allclose([d[0] for d in drift], [0, 0.01, 0.02, 0.03])
    rows = out[PATHS.bodies()].temporal["Ellipsoids3D:centers"]
    # one row stamped with the iteration only, four with the physics time only
    assert sorted(sorted(t) for t, _ in rows) == [["iteration"]] + [["sim_time"]] * 4


# ---------------------------------------------------------------------------
# Files, streams, blueprint


def test_rrd_verify_and_blueprint(model, tmp_path):
    # the blueprint sent at close lays out what was logged
    path = tmp_path / "full.rrd"
    with Recorder.to_file(path) as rec:
        rec.log_model_geometry(model)
        rec.log_body_poses(_posed_data(model, 1), time=0)
        rec.log_task_errors({(k, "task"): 0.5 for k in (1, 2, 3)})
    result = _verify(path)
    assert result.returncode == 0, result.stderr
    bp = read_recording(path, blueprint=True)
    # Blueprint data lives on the "blueprint" timeline.
    views = {
        e.temporal["ViewBlueprint:space_origin"][-1][1][0]: e.temporal[
            "ViewBlueprint:class_identifier"
        ][-1][1][0]
        for e in bp.values()
        if "ViewBlueprint:space_origin" in e.temporal
    }
    assert views == {
        "world": "3D",
        "errors_log10/level_1": "TimeSeries",
        "errors_log10/level_2": "TimeSeries",
        "errors_log10/level_3": "TimeSeries",
    }
    assert isinstance(blueprint([]), rr.blueprint.Blueprint)


def test_blueprint_read_back_is_the_last_one_sent(tmp_path):
    # every send_blueprint makes its own store, listed in no set order
    path = tmp_path / "resent.rrd"
    rec = Recorder.to_file(path)
    for n in range(1, 6):
        rec.send_blueprint(levels=range(1, n + 1))
    rec.close(blueprint=False)
    bp = read_recording(path, blueprint=True)
    origins = {
        e.temporal["ViewBlueprint:space_origin"][-1][1][0]
        for e in bp.values()
        if "ViewBlueprint:space_origin" in e.temporal
    }
    assert origins == {"world"} | {f"errors/level_{k}" for k in range(1, 6)}


def _data_types(path: Path, blueprint: bool = False) -> dict[tuple[str, str], str]:
    """(entity, component) -> Arrow type of its data columns, in the recording
    or its blueprints (ids of views and containers left out)."""
    reader = RrdReader(path)
    out = {}
    for store in reader.blueprints() if blueprint else [None]:
        for chunk in reader.stream(store=store).to_chunks():
            entity = _UUID.sub("<id>", chunk.entity_path)
            for f in chunk.to_record_batch().schema:
                if (f.metadata or {}).get(b"rerun:kind") == b"data":
                    out[(entity, f.name)] = str(f.type)
    return out


def _blueprint_values(path: Path) -> dict[str, str]:
    """The active blueprint of ``path``, every entity's components and values,
    with the ids of views and containers named by their place in the layout."""
    bp = read_recording(path, blueprint=True)

    def last(entity: str, component: str) -> list:
        return bp[entity].temporal[component][-1][1]

    root_id = bytes(last("viewport", "ViewportBlueprint:root_container")[0])
    root = f"container/{uuid.UUID(bytes=root_id)}"
    order, todo = [], [root]
    while todo:
        key = todo.pop(0)
        order.append(key)
        if key.startswith("container/"):
            todo += list(last(key, "ContainerBlueprint:contents"))
    names = {key.split("/")[1]: f"<{i}>" for i, key in enumerate(order)}

    def named(x: object) -> str:
        text = repr(x)
        for id_, name in names.items():
            text = text.replace(id_, name)
        return text

    out = {}
    for entity, data in bp.items():
        rows = {c: [v for _, v in r] for c, r in data.temporal.items()}
        if entity == "viewport":
            rows["ViewportBlueprint:root_container"] = [names[root.split("/")[1]]]
        out[named(entity)] = named((sorted(data.static.items()), sorted(rows.items())))
    return out


def test_blueprint_is_sent_as_rerun_sends_it(model, tmp_path):
    # close() sends the blueprint's entities in one call, made once per layout:
    # read back, the same entities, components, values and Arrow types as
    # rerun's own send_blueprint of the same blueprint (the ids of views and
    # containers aside), each recording with its own camera
    def record(path: Path, k: int, rerun_sends: bool) -> Recorder:
        rec = Recorder.to_file(path)
        rec.log_model_geometry(model)
        rec.log_body_poses(_posed_data(model, k), time=0)
        rec.log_task_errors({(1, "task"): 0.5, (2, "other"): 0.1})
        rec.log_text("done")
        if rerun_sends:
            rec.stream.send_blueprint(rec.blueprint())
        rec.close(blueprint=not rerun_sends)
        return rec

    for k in (1, 2, 9):  # the first made anew, the others from what was made
        ours, theirs = tmp_path / f"ours{k}.rrd", tmp_path / f"rerun{k}.rrd"
        record(ours, k, rerun_sends=False)
        record(theirs, k, rerun_sends=True)
        assert _blueprint_values(ours) == _blueprint_values(theirs)
        assert _data_types(ours, blueprint=True) == _data_types(theirs, blueprint=True)
        eye = read_blueprint(ours).tabs[0][1][0].eye
        if k == 1:
            first = eye
    assert not np.allclose(eye["position"], first["position"])  # its own camera
    result = _verify(ours)
    assert result.returncode == 0, result.stderr


def test_recording_is_valid_after_an_exception(model, tmp_path):
    path = tmp_path / "failed.rrd"
    with pytest.raises(RuntimeError, match="solver exploded"):
        with Recorder.to_file(path, flush_every=64) as rec:
            rec.log_model_geometry(model)
            for k in range(10):
                rec.log_body_poses(_posed_data(model, k), time=k)
                rec.log_scalar(PATHS.task_error(1, "com"), float(k))
            raise RuntimeError("solver exploded")
    assert rec.closed
    result = _verify(path)
    assert result.returncode == 0, result.stderr
    out = read_recording(path)
    # Rows still buffered when the block raised were written on exit.
    times, _ = out[PATHS.bodies()].series("Ellipsoids3D:centers", "iteration")
    assert times.tolist() == list(range(10))
    _, e = out[PATHS.task_error(1, "com")].series("Scalars:scalars", "iteration")
    assert [x[0] for x in e] == [float(k) for k in range(10)]
    # the failure is in the text log, at the last time logged, and the layout was sent
    ((t, text),) = out[PATHS.events].temporal["TextLog:text"]
    assert text == ["run raised RuntimeError: solver exploded"] and t["iteration"] == 9
    bp = read_recording(path, blueprint=True)
    assert "errors/level_1" in {
        e.temporal["ViewBlueprint:space_origin"][-1][1][0]
        for e in bp.values()
        if "ViewBlueprint:space_origin" in e.temporal
    }
    with pytest.raises(PikError, match="closed"):
        rec.log_scalar("x", 1.0)


def test_rows_of_many_entities_sent_together_read_back_per_entity(model, tmp_path):
    # Rows sharing their time stamps go out as one record batch split per
    # entity; rows with other stamps, and static data, in the same send.
    path = tmp_path / "batched.rrd"
    with Recorder.to_file(path) as rec:
        rec.log_model_geometry(model)
        for k in range(5):
            rec.log_body_poses(_posed_data(model, k), time=k)
            rec.log_scalar(PATHS.task_error(1, "a"), float(k))
            rec.log_scalar(PATHS.task_error(2, "b"), 10.0 + k)
            if k % 2 == 0:
                rec.log_com([k, 0.0, 1.0])
        rec.send_buffered()  # sent without waiting; logging goes on
        rec.log_body_poses(_posed_data(model, 5), time=5)
        rec.log_scalar(PATHS.task_error(1, "a"), 5.0)
    assert _verify(path).returncode == 0
    out = read_recording(path)
    times, a = out[PATHS.task_error(1, "a")].series("Scalars:scalars", "iteration")
    assert times.tolist() == list(range(6)) and [x[0] for x in a] == [0, 1, 2, 3, 4, 5]
    times, b = out[PATHS.task_error(2, "b")].series("Scalars:scalars", "iteration")
    assert times.tolist() == list(range(5)) and [x[0] for x in b] == [10, 11, 12, 13, 14]
    times, c = out[PATHS.com].series("Points3D:positions", "iteration")
    assert times.tolist() == [0, 2, 4] and [x[0][0] for x in c] == [0, 2, 4]
    for k in (0, 3, 5):  # each body's slice of the shared pose columns
        data = _posed_data(model, k)
        for name in ("arm", "base"):
            path, i = _find(out, name, body=True)
            p, R = _instance_pose(out[path], i, row=k)
            b = model.body(name).id
            np.testing.assert_allclose(p, data.xpos[b], atol=1e-6)
            np.testing.assert_allclose(R, data.xmat[b].reshape(3, 3), atol=1e-6)
    # the point style went with its rows, the static geometry in the same sends
    times, radii = out[PATHS.com].series("Points3D:radii", "iteration")
    assert times.tolist() == [0, 2, 4] and not out[PATHS.com].static
    assert [r[0] for r in radii] == pytest.approx([style.COM_RADIUS] * 3)
    assert "Boxes3D:half_sizes" in out["world/robot/boxes"].static
    # a floating base: the CoM's plumb line to the floor plane (z = 0), lifted
    times, vectors = out[PATHS.com].series("Arrows3D:vectors", "iteration")
    _, origins = out[PATHS.com].series("Arrows3D:origins", "iteration")
    assert times.tolist() == [0, 2, 4]
    np.testing.assert_allclose([o[0] for o in origins], [[k, 0, 1] for k in (0, 2, 4)])
    np.testing.assert_allclose([v[0] for v in vectors], [[0, 0, style.LIFT - 1]] * 3, atol=1e-7)


def test_explicit_stream_is_not_the_global_one_and_stays_open(tmp_path):
    path = tmp_path / "explicit.rrd"
    stream = rr.RecordingStream("pik_mj_test", recording_id="explicit")
    stream.save(path)
    with Recorder(stream) as rec:
        rec.set_time("iteration", 3)
        rec.log_scalar("errors/level_1/a", 2.5)
    assert rr.get_global_data_recording() is None
    # The Recorder did not own the stream: it is still usable.
    stream.set_time("iteration", sequence=4)
    stream.log("errors/level_1/a", rr.Scalars(3.5))
    stream.disconnect()
    times, v = read_recording(path)["errors/level_1/a"].series("Scalars:scalars", "iteration")
    assert times.tolist() == [3, 4]
    assert [x[0] for x in v] == [2.5, 3.5]


# ---------------------------------------------------------------------------
# Bad input


def test_bad_input_is_rejected(model, tmp_path):
    with pytest.raises(InvalidInput, match="RecordingStream"):
        Recorder("not a stream")  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="flush_every"):
        Recorder.to_file(tmp_path / "x.rrd", flush_every=0)
    with pytest.raises(InvalidInput, match="does not exist"):
        Recorder.to_file(tmp_path / "no" / "dir.rrd")
    with Recorder.to_file(tmp_path / "bad.rrd") as rec:
        with pytest.raises(PikError, match="log_model_geometry"):
            rec.log_body_poses(mujoco.MjData(model), time=0)
        with pytest.raises(UnknownName, match="'base'"):
            rec.log_model_geometry(model, robot_root_body="nope")
        with pytest.raises(InvalidInput, match="geom_groups"):
            rec.log_model_geometry(model, geom_groups=(7,))
        with pytest.raises(PikError, match="no time is set"):
            rec.log_scalar("x", 1.0)
        with pytest.raises(UnknownName, match="sim_time"):
            rec.set_time("wall", 1)
        rec.set_time("wall", 1.5, kind="duration")
        with pytest.raises(InvalidInput, match="duration timeline"):
            rec.set_time("wall", 2, kind="sequence")
        with pytest.raises(InvalidInput, match="integer"):
            rec.set_time("iteration", 1.5)
        with pytest.raises(InvalidInput, match=r"shape \(3\)"):
            rec.log_com([1.0, 2.0])
        with pytest.raises(InvalidInput, match="finite"):
            rec.log_com([1.0, np.nan, 0.0])
        with pytest.raises(InvalidInput, match="finite"):
            rec.log_scalar("x", float("inf"))
        with pytest.raises(InvalidInput, match="contact forces"):
            rec.log_contacts(np.zeros((2, 3)), np.zeros((3, 3)))
        with pytest.raises(InvalidInput, match="zero"):
            rec.log_frame("f", [0, 0, 0], [0, 0, 0, 0])
        with pytest.raises(InvalidInput, match="axis_length"):
            rec.log_frame("f", [0, 0, 0], [1, 0, 0, 0], axis_length=-0.1)
        with pytest.raises(InvalidInput, match=r"frame positions must have shape \(2, 3\)"):
            rec.log_frames(["a", "b"], np.zeros((3, 3)), np.tile([1.0, 0, 0, 0], (2, 1)))
        with pytest.raises(InvalidInput, match="radius of point 'p'"):
            rec.log_point("p", [0, 0, 0], radius=0.0)
        with pytest.raises(InvalidInput, match="errors/level_1/x"):
            rec.log_task_errors({(1, "x"): float("nan")})
        with pytest.raises(InvalidInput, match="WARN"):
            rec.log_text("x", level="LOUD")
        rec.log_model_geometry(model)
        other = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
        with pytest.raises(InvalidInput, match="bodies"):
            rec.log_body_poses(mujoco.MjData(other), time=0)
