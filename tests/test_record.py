"""Tests of pik_mj.record: recordings are read back from the .rrd and checked.

Geometry is checked against MuJoCo's own world poses (``geom_xpos``,
``geom_xmat``) and against the MJCF inputs (``fromto`` end points, mesh vertices
before MuJoCo re-centres them), by composing the recorded transforms.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
import rerun as rr
from scipy.spatial.transform import Rotation

from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.record import PATHS, EntityData, Recorder, blueprint, read_recording

TET = np.array([[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0], [0, 0, 0.2]], dtype=float)
TET_POS = np.array([0.0, 0.0, 0.1])
CAPSULE_FROMTO = np.array([[0.0, 0.0, 0.0], [0.3, 0.1, -0.2]])
CYLINDER_FROMTO = np.array([[0.0, 0.1, 0.0], [0.1, 0.3, 0.2]])

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


def _pose(entity: EntityData, static: bool = True, row: int = -1):
    """(p, R) of a recorded Transform3D (static, or temporal row ``row``)."""
    if static:
        t = entity.static["Transform3D:translation"][0]
        q = entity.static["Transform3D:quaternion"][0]
    else:
        t = entity.temporal["Transform3D:translation"][row][1][0]
        q = entity.temporal["Transform3D:quaternion"][row][1][0]
    return np.array(t), Rotation.from_quat(q).as_matrix()  # scipy: xyzw


def _geom_world(rec, body_path, geom_path, body_pose):
    """World pose of a geom frame from the recorded X_WB and X_BG."""
    p_WB, R_WB = body_pose
    p_BG, R_BG = _pose(rec[geom_path])
    return p_WB + R_WB @ p_BG, R_WB @ R_BG


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


def test_paths_are_escaped_and_nested():
    assert PATHS.body("torso") == "world/robot/torso"
    assert PATHS.body("floor", robot=False) == "world/scene/floor"
    assert PATHS.body("left hand") == "world/robot/left\\ hand"
    assert PATHS.body("walker/torso") == "world/robot/walker\\/torso"
    assert PATHS.geom("world/robot/torso", "head") == "world/robot/torso/head"
    assert PATHS.task_target("rarm") == "world/tasks/rarm/target"
    assert PATHS.task_current("rarm") == "world/tasks/rarm/current"
    assert PATHS.task_error(2, "com") == "errors/level_2/com"
    assert PATHS.hold_metric("drift") == "hold/drift"


# ---------------------------------------------------------------------------
# Static geometry


def test_every_geom_type_is_logged_static(geometry_recording, model):
    _, _, rec = geometry_recording
    robot, scene = "world/robot", "world/scene"
    expected = {
        f"{scene}/world/floor": "Boxes3D:half_sizes",
        f"{scene}/world/terrain": "Mesh3D:vertex_positions",
        f"{scene}/table/top": "Boxes3D:half_sizes",
        f"{scene}/crate/crate": "Boxes3D:half_sizes",
        f"{robot}/base/box": "Boxes3D:half_sizes",
        f"{robot}/base/ball": "Ellipsoids3D:half_sizes",
        f"{robot}/arm/capsule": "Capsules3D:lengths",
        f"{robot}/arm/cylinder": "Cylinders3D:lengths",
        f"{robot}/arm/egg": "Ellipsoids3D:half_sizes",
        f"{robot}/arm/tet": "Mesh3D:vertex_positions",
    }
    unnamed = model.body("left hand").geomadr[0]
    expected[f"{PATHS.body('left hand')}/geom_{unnamed}"] = "Ellipsoids3D:half_sizes"
    for path, component in expected.items():
        assert path in rec, path
        assert component in rec[path].static, (path, sorted(rec[path].static))
        assert not rec[path].temporal.get(component), path
    # Group 3 (collision) is hidden by default.
    assert not any(p.endswith("/collision") for p in rec)


def test_geom_sizes_and_colors(geometry_recording, model):
    _, _, rec = geometry_recording
    box = rec["world/robot/base/box"].static
    np.testing.assert_allclose(box["Boxes3D:half_sizes"][0], [0.1, 0.2, 0.3], rtol=1e-6)
    # Material colour when the geom's rgba is MuJoCo's default; rgba wins otherwise.
    assert box["Boxes3D:colors"][0] == 0xFF0000FF
    assert rec["world/robot/base/ball"].static["Ellipsoids3D:colors"][0] == 0x00FF00FF
    assert rec["world/scene/world/floor"].static["Boxes3D:colors"][0] == 0x336699FF
    np.testing.assert_allclose(
        rec["world/robot/arm/egg"].static["Ellipsoids3D:half_sizes"][0],
        [0.05, 0.06, 0.07],
        rtol=1e-6,
    )
    np.testing.assert_allclose(
        rec["world/robot/base/ball"].static["Ellipsoids3D:half_sizes"][0],
        [0.05] * 3,
        rtol=1e-6,
    )
    floor = rec["world/scene/world/floor"].static
    np.testing.assert_allclose(floor["Boxes3D:half_sizes"][0], [2, 3, 1e-3], rtol=1e-6)
    # The slab's top face is the plane z = 0.
    assert floor["Boxes3D:centers"][0][2] + 1e-3 == pytest.approx(0.0, abs=1e-9)


def test_geom_world_poses_match_mujoco(geometry_recording, model):
    """Recorded X_WB ∘ X_BG ∘ (primitive centre) equals MuJoCo's geom pose."""
    _, data, rec = geometry_recording
    checked = 0
    for g in range(model.ngeom):
        name = model.geom(g).name
        b = model.geom_bodyid[g]
        if b == 0 or name == "collision":
            continue
        bname = model.body(b).name
        body_path = PATHS.body(bname, robot=bname in ("base", "arm", "left hand"))
        if bname == "table":
            body_pose = _pose(rec[body_path])  # welded: static pose
        else:
            body_pose = _pose(rec[body_path], static=False)
        path = PATHS.geom(body_path, name or f"geom_{g}")
        p_WG, R_WG = _geom_world(rec, body_path, path, body_pose)
        static = rec[path].static
        if "Capsules3D:lengths" in static:
            # rerun capsules start at their translation and run along +z.
            t = np.array(static["Capsules3D:translations"][0])
            centre = t + np.array([0, 0, static["Capsules3D:lengths"][0] / 2])
        elif "Boxes3D:centers" in static:
            centre = np.array(static["Boxes3D:centers"][0])
        else:
            centre = np.zeros(3)
        np.testing.assert_allclose(p_WG + R_WG @ centre, data.geom_xpos[g], atol=1e-6)
        np.testing.assert_allclose(R_WG, data.geom_xmat[g].reshape(3, 3), atol=1e-6)
        checked += 1
    assert checked == 9


def _arm_pose(data, model):
    b = model.body("arm").id
    return data.xpos[b], data.xmat[b].reshape(3, 3)


def test_capsule_and_cylinder_end_points_match_fromto(geometry_recording, model):
    """Axis convention: rerun's capsule/cylinder ends land on the MJCF fromto."""
    _, data, rec = geometry_recording
    arm = "world/robot/arm"
    arm_pose = _pose(rec[arm], static=False)
    p_WA, R_WA = _arm_pose(data, model)

    cap = rec[f"{arm}/capsule"].static
    p_WG, R_WG = _geom_world(rec, arm, f"{arm}/capsule", arm_pose)
    t = np.array(cap["Capsules3D:translations"][0])
    length = cap["Capsules3D:lengths"][0]
    ends = [p_WG + R_WG @ (t + np.array([0, 0, s])) for s in (0.0, length)]
    want = [p_WA + R_WA @ e for e in CAPSULE_FROMTO]
    assert cap["Capsules3D:radii"][0] == pytest.approx(0.04)
    # Either direction is the same capsule.
    if np.linalg.norm(ends[0] - want[0]) > np.linalg.norm(ends[0] - want[1]):
        ends = ends[::-1]
    np.testing.assert_allclose(ends, want, atol=1e-6)

    cyl = rec[f"{arm}/cylinder"].static
    p_WG, R_WG = _geom_world(rec, arm, f"{arm}/cylinder", arm_pose)
    half = cyl["Cylinders3D:lengths"][0] / 2
    ends = [p_WG + R_WG @ [0, 0, s] for s in (-half, half)]
    want = [p_WA + R_WA @ e for e in CYLINDER_FROMTO]
    if np.linalg.norm(ends[0] - want[0]) > np.linalg.norm(ends[0] - want[1]):
        ends = ends[::-1]
    np.testing.assert_allclose(ends, want, atol=1e-6)
    assert cyl["Cylinders3D:radii"][0] == pytest.approx(0.03)


def test_mesh_vertices_reproduce_the_mjcf_mesh(geometry_recording, model):
    """MuJoCo re-centres mesh vertices; the recorded X_BG must undo that."""
    _, _, rec = geometry_recording
    tet = rec["world/robot/arm/tet"].static
    p_BG, R_BG = _pose(rec["world/robot/arm/tet"])
    v = np.array(tet["Mesh3D:vertex_positions"])
    in_body = v @ R_BG.T + p_BG
    want = TET + TET_POS
    # Same vertex set (MuJoCo may reorder): match each to its nearest.
    d = np.linalg.norm(in_body[:, None, :] - want[None, :, :], axis=2)
    assert sorted(d.argmin(axis=1)) == [0, 1, 2, 3]
    np.testing.assert_allclose(d.min(axis=1), 0.0, atol=1e-6)
    faces = np.array(tet["Mesh3D:triangle_indices"])
    assert faces.shape == (4, 3)
    assert set(faces.ravel()) == {0, 1, 2, 3}
    normals = np.array(tet["Mesh3D:vertex_normals"])
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, rtol=1e-5)
    # Vertex normals point away from the centroid of a convex mesh.
    assert (np.sum((v - v.mean(axis=0)) * normals, axis=1) > 0).all()


def test_hfield_surface(geometry_recording):
    _, _, rec = geometry_recording
    terrain = rec["world/scene/world/terrain"].static
    v = np.array(terrain["Mesh3D:vertex_positions"])
    assert v.shape == (9, 3)
    assert len(terrain["Mesh3D:triangle_indices"]) == 8
    np.testing.assert_allclose(v[:, :2].min(axis=0), [-1, -1])
    np.testing.assert_allclose(v[:, :2].max(axis=0), [1, 1])
    # Only the middle sample is raised, to the full height 0.2 m.
    top = v[np.argmax(v[:, 2])]
    np.testing.assert_allclose(top, [0, 0, 0.2], atol=1e-6)
    assert np.sort(v[:, 2])[-2] == pytest.approx(0.0)


def test_scene_bodies_static_or_dynamic(geometry_recording):
    _, _, rec = geometry_recording
    table = rec["world/scene/table"]
    assert table.temporal == {}
    p, R = _pose(table)
    np.testing.assert_allclose(p, [1, 0, 0.5], atol=1e-6)
    np.testing.assert_allclose(R, Rotation.from_euler("xyz", [0, 0, 0.4]).as_matrix(), atol=1e-6)
    # A free body outside the robot is scene, but moves.
    assert len(rec["world/scene/crate"].temporal["Transform3D:translation"]) == 1
    for body in ("base", "arm", "left hand"):
        assert PATHS.body(body) in rec


def test_default_classification_and_geom_groups(model, tmp_path):
    path = tmp_path / "default.rrd"
    with Recorder.to_file(path) as rec:
        rec.log_model_geometry(model, geom_groups=(0, 3))
        rec.log_body_poses(_posed_data(model, 1), timeline="iteration", time=0)
    out = read_recording(path)
    assert "world/robot/table/top" in out  # everything but the world body moves
    assert "Transform3D:translation" in out["world/robot/table"].temporal
    assert "world/robot/base/collision" in out
    assert "world/scene/world/floor" in out


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
    for name in ("base", "arm", "left hand"):
        b = model.body(name).id
        entity = out[PATHS.body(name)]
        times, t = entity.series("Transform3D:translation", "iteration")
        _, q = entity.series("Transform3D:quaternion", "iteration")
        assert times.tolist() == list(range(n))
        p = np.array([x[0] for x in t])
        R = Rotation.from_quat(np.array([x[0] for x in q])).as_matrix()
        np.testing.assert_allclose(p, [d.xpos[b] for d in datas], atol=1e-6)
        np.testing.assert_allclose(R, [d.xmat[b].reshape(3, 3) for d in datas], atol=1e-6)


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
    for entity, component in [
        (PATHS.body("arm"), "Transform3D:quaternion"),
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
    # the style goes with every row, in the chunk of the data (no static chunk)
    _, radii = out[PATHS.com].series("Points3D:radii", "iteration")
    _, colors = out[PATHS.com].series("Points3D:colors", "iteration")
    assert [x[0] for x in radii] == pytest.approx([0.03] * 5)
    assert {x[0] for x in colors} == {0xE62828FF}  # (230, 40, 40), opaque
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
    strip = out[PATHS.support_polygon].temporal["LineStrips3D:strips"][0][1][0]
    np.testing.assert_allclose(strip, np.vstack([square, square[:1]]))
    margin = out[f"{PATHS.support_polygon}/margin"].temporal["LineStrips3D:strips"]
    np.testing.assert_allclose(margin[0][1][0][0], [0.1, 0.1, 0.1], rtol=1e-6)
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
    rows = out[PATHS.body("arm")].temporal["Transform3D:translation"]
    # one row stamped with the iteration only, four with the physics time only
    assert sorted(sorted(t) for t, _ in rows) == [["iteration"]] + [["sim_time"]] * 4


# ---------------------------------------------------------------------------
# Files, streams, blueprint


def test_rrd_verify_and_blueprint(model, tmp_path):
    path = tmp_path / "full.rrd"
    with Recorder.to_file(path) as rec:
        rec.log_model_geometry(model)
        rec.send_blueprint(levels=[1, 2, 3])
        rec.log_body_poses(_posed_data(model, 1), time=0)
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
        "errors/level_1": "TimeSeries",
        "errors/level_2": "TimeSeries",
        "errors/level_3": "TimeSeries",
    }
    assert isinstance(blueprint([]), rr.blueprint.Blueprint)


def test_blueprint_read_back_is_the_last_one_sent(tmp_path):
    # every send_blueprint makes its own store, listed in no set order
    path = tmp_path / "resent.rrd"
    with Recorder.to_file(path) as rec:
        for n in range(1, 6):
            rec.send_blueprint(levels=range(1, n + 1))
    bp = read_recording(path, blueprint=True)
    origins = {
        e.temporal["ViewBlueprint:space_origin"][-1][1][0]
        for e in bp.values()
        if "ViewBlueprint:space_origin" in e.temporal
    }
    assert origins == {"world"} | {f"errors/level_{k}" for k in range(1, 6)}


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
    times, _ = out[PATHS.body("arm")].series("Transform3D:translation", "iteration")
    assert times.tolist() == list(range(10))
    _, e = out[PATHS.task_error(1, "com")].series("Scalars:scalars", "iteration")
    assert [x[0] for x in e] == [float(k) for k in range(10)]
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
            p, R = _pose(out[PATHS.body(name)], static=False, row=k)
            b = model.body(name).id
            np.testing.assert_allclose(p, data.xpos[b], atol=1e-6)
            np.testing.assert_allclose(R, data.xmat[b].reshape(3, 3), atol=1e-6)
    # the point style went with its rows, the static geometry in the same sends
    times, radii = out[PATHS.com].series("Points3D:radii", "iteration")
    assert times.tolist() == [0, 2, 4] and not out[PATHS.com].static
    assert "Transform3D:translation" in out["world/robot/table/top"].static


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
        with pytest.raises(InvalidInput, match="WARN"):
            rec.log_text("x", level="LOUD")
        rec.log_model_geometry(model)
        other = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
        with pytest.raises(InvalidInput, match="bodies"):
            rec.log_body_poses(mujoco.MjData(other), time=0)
