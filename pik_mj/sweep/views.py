"""Views of a sweep's rows: a summary table, a PNG of map slices, a rerun recording.

Each case is drawn at its hand target, coloured by its ``verdict``
(:data:`pik_mj.sweep.dataset.VERDICTS`): green validated (reached, static check,
motion and hold passed), orange held (the hold alone passed: the motion failed),
red reached but failing the static check or the hold, grey not reached, purple
raised. The PNG (matplotlib, the ``sweep`` extra) cuts the
targets into slices across one axis (default ``y``: side views, x forward and z
up), one row of panels per stack, with the robot's start pose in grey.
The recording holds the robot's geometry at its start pose and one point cloud
per stack and verdict (``world/sweep/<stack>/<verdict>``), with a blueprint of
one 3D view per stack.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pyarrow as pa
import rerun as rr
import rerun.blueprint as rrb

from pik_mj.exceptions import InvalidInput
from pik_mj.record import Recorder
from pik_mj.sweep.case import REQUIRED, standing_robot
from pik_mj.sweep.dataset import VERDICTS
from pik_mj.sweep.spec import Grid, Sweep

COLORS = {
    "validated": (44, 160, 44),
    "held": (255, 160, 40),
    "fails": (214, 39, 40),
    "unreached": (170, 170, 170),
    "error": (148, 103, 189),
}
LEGEND = {
    "validated": "reached, moves there and stands (validated)",
    "held": "reached and stands, but the motion fails (a hold alone)",
    "fails": "reached, fails static check or hold",
    "unreached": "not reached",
    "error": "raised",
}
SWEEP_PATH = "world/sweep"  # rerun entities: world/sweep/<stack>/<verdict>
AXIS_LABEL = {"x": "x [m] (forward)", "y": "y [m] (left)", "z": "z [m] (height)"}


def _median(values: list[Any]) -> float:
    vals = [v for v in values if v is not None]
    return float(np.median(vals)) if vals else float("nan")


def summary_table(table: pa.Table) -> str:
    """One line per (robot, stack): cases, verdict counts, median times of a case."""
    rows = table.to_pylist()
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["robot"], r["stack"]), []).append(r)
    w = max([len(k[0]) for k in groups] + [5])
    head = (
        f"{'robot':<{w}}  {'stack':<10} {'cases':>6} {'validated':>14} {'held':>5} {'fails':>6} "
        f"{'unreached':>9} {'error':>6} {'solve [s]':>10} {'static [ms]':>12} {'hold [s]':>9}"
    )
    lines = [head]
    for (robot, stack), rs in groups.items():
        n = len(rs)
        count = {v: sum(r["verdict"] == v for r in rs) for v in VERDICTS}
        valid = f"{count['validated']} ({count['validated'] / n:.0%})"
        lines.append(
            f"{robot:<{w}}  {stack:<10} {n:>6} {valid:>14} {count['held']:>5} {count['fails']:>6} "
            f"{count['unreached']:>9} {count['error']:>6} "
            f"{_median([r['solve_time'] for r in rs]):>10.3f} "
            f"{1e3 * _median([r['static_time'] for r in rs]):>12.1f} "
            f"{_median([r['hold_time'] for r in rs]):>9.3f}"
        )
    return "\n".join(lines)


def _robot_rows(table: pa.Table, sweep: Sweep, robot: str | None) -> tuple[str, list[dict]]:
    robot = sweep.robots[0] if robot is None else robot
    if robot not in sweep.robots:
        raise InvalidInput(f"robot {robot!r} is not in the sweep; its robots: {sweep.robots}")
    return robot, [r for r in table.to_pylist() if r["robot"] == robot]


# unit directions sampling a round geom's surface: the axes and the cube diagonals
_DIRS = np.vstack([np.eye(3), -np.eye(3), np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T])
_DIRS /= np.linalg.norm(_DIRS, axis=1, keepdims=True)


def _geom_points(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> np.ndarray:
    """Points (n, 3) [m] on (or around) geom ``g``'s surface, world frame."""
    kind, size = model.geom_type[g], model.geom_size[g]
    t = mujoco.mjtGeom
    if kind == t.mjGEOM_SPHERE:
        local = size[0] * _DIRS
    elif kind == t.mjGEOM_ELLIPSOID:
        local = size * _DIRS
    elif kind in (t.mjGEOM_CAPSULE, t.mjGEOM_CYLINDER):
        ends = np.array([[0.0, 0.0, -size[1]], [0.0, 0.0, size[1]]])
        local = (ends[:, None, :] + size[0] * _DIRS[None]).reshape(-1, 3)
    else:  # boxes, meshes, ...: the corners of the geom's bounding box
        center, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        local = center + half * np.array(np.meshgrid(*[[-1, 1]] * 3)).reshape(3, -1).T
    return data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T


def _silhouette(robot: str, hand: str, axes: tuple[int, int]) -> list[np.ndarray]:
    """The robot's start pose projected on the plane of ``axes``: one polygon (n, 2)
    [m] per visible robot geom (the convex hull of its projected surface points)."""
    from scipy.spatial import ConvexHull, QhullError

    r = standing_robot(robot, hand)
    model, data, root_id = r.model, r.data, r.root_body_id
    polygons = []
    for g in range(model.ngeom):
        if model.body_rootid[model.geom_bodyid[g]] != root_id or model.geom_group[g] > 2:
            continue
        pts = _geom_points(model, data, g)[:, list(axes)]
        try:
            polygons.append(pts[ConvexHull(pts).vertices])
        except QhullError:  # seen edge-on (no area): nothing to fill
            continue
    return polygons


def _slices(values: np.ndarray, grid: bool, count: int) -> list[tuple[float, float, str]]:
    """(low, high, title) of each slice: one per grid value, else ``count`` bins."""
    if grid:
        return [(v, v, f"= {v:+.2f} m") for v in np.unique(values)]
    if values.min() == values.max():
        count = 1
    edges = np.linspace(values.min(), values.max(), count + 1)
    return [(lo, hi, f"in [{lo:+.2f}, {hi:+.2f}] m") for lo, hi in itertools.pairwise(edges)]


def plot_map(
    table: pa.Table,
    sweep: Sweep,
    path: str | os.PathLike[str],
    *,
    robot: str | None = None,
    across: str = "y",
    bins: int = 4,
) -> Path:
    """Write a PNG of the map: slices across ``across``, one row per stack.

    Args:
        table: The sweep's rows.
        sweep: The sweep.
        path: The PNG to write.
        robot: Robot whose cases are drawn (default: the sweep's first).
        across: Target axis cut into slices (``x``, ``y`` or ``z``).
        bins: Slices of a random sweep (a grid has one per value of ``across``).

    Raises:
        InvalidInput: Bad axis, or two cases of one stack at one target (a
            sweep varying more than the target: plot a subset of the rows).
    """
    from matplotlib.collections import PatchCollection, PolyCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch, Rectangle

    if across not in REQUIRED:
        raise InvalidInput(f"across must be one of {REQUIRED}, got {across!r}")
    robot, rows = _robot_rows(table, sweep, robot)
    if not rows:
        raise InvalidInput(f"no rows of robot {robot!r} to plot")
    u, v = (a for a in REQUIRED if a != across)
    grid = isinstance(sweep.space, Grid)
    cut = np.array([r[across] for r in rows])
    slices = _slices(cut, grid, bins)
    seen = {(r["stack"], r["x"], r["y"], r["z"]) for r in rows}
    if len(seen) != len(rows):
        raise InvalidInput("two cases of one stack share a target: plot a subset of the rows")
    # cell size of a grid (its spacing), else a dot
    step = {}
    for a in (u, v):
        vals = np.unique([r[a] for r in rows])
        step[a] = float(np.min(np.diff(vals))) if grid and len(vals) > 1 else 0.05
    stacks = [s for s in sweep.stacks if any(r["stack"] == s for r in rows)]
    fig = Figure(figsize=(max(2.9 * len(slices) + 0.6, 7.0), 3.3 * len(stacks) + 1.0), dpi=110)
    axes = fig.subplots(len(stacks), len(slices), squeeze=False, sharex=True, sharey=True)
    robot_shape = _silhouette(robot, sweep.hand, (REQUIRED.index(u), REQUIRED.index(v)))
    for i, stack in enumerate(stacks):
        for j, (lo, hi, title) in enumerate(slices):
            ax = axes[i][j]
            last = j == len(slices) - 1
            inside = [
                r
                for r in rows
                if r["stack"] == stack
                and (r[across] == lo if grid else lo <= r[across] and (r[across] < hi or last))
            ]
            colors = [np.array(COLORS[r["verdict"]]) / 255 for r in inside]
            if grid:
                cells = [
                    Rectangle((r[u] - step[u] / 2, r[v] - step[v] / 2), step[u], step[v])
                    for r in inside
                ]
                ax.add_collection(
                    PatchCollection(cells, facecolors=colors, edgecolors="white", linewidths=0.5)
                )
            else:
                ax.scatter([r[u] for r in inside], [r[v] for r in inside], s=16, c=colors)
            ax.add_collection(
                PolyCollection(robot_shape, facecolors="0.6", edgecolors="0.35", linewidths=0.4)
            )
            if "z" in (u, v):
                ax.axhline(0.0, color="0.5", linewidth=0.8)  # the floor
            ax.set_aspect("equal")
            ax.set_title(f"{stack}, {across} {title}", fontsize=9)
            if i == len(stacks) - 1:
                ax.set_xlabel(AXIS_LABEL[u], fontsize=8)
            if j == 0:
                ax.set_ylabel(AXIS_LABEL[v], fontsize=8)
            ax.tick_params(labelsize=7)
    pts = np.vstack([[[r[u], r[v]] for r in rows], *robot_shape])
    pad = max(step.values())
    axes[0][0].set_xlim(pts[:, 0].min() - pad, pts[:, 0].max() + pad)
    axes[0][0].set_ylim(min(pts[:, 1].min(), 0.0) - pad, pts[:, 1].max() + pad)
    count = {k: sum(r["verdict"] == k for r in rows) for k in VERDICTS}
    handles = [
        Patch(color=np.array(COLORS[k]) / 255, label=f"{LEGEND[k]}: {count[k]}")
        for k in VERDICTS
        if count[k]
    ]
    fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(
        f"{robot}: {sweep.hand} hand targets, {len(rows)} cases, "
        f"{count['validated']} validated (hold {sweep.hold:g} s)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0.07, 1, 0.97))
    path = Path(path)
    fig.savefig(path)
    return path


def log_map(
    table: pa.Table, sweep: Sweep, stream: Any, *, robot: str | None = None, radius: float = 0.0
) -> None:
    """Log the map to the rerun ``stream``: the robot at its start pose and one
    point cloud per stack and verdict, static; a blueprint with one 3D view per
    stack.

    Args:
        table: The sweep's rows.
        sweep: The sweep.
        stream: A ``rerun.RecordingStream``.
        robot: Robot whose cases are drawn (default: the sweep's first).
        radius: Point radius [m] (0: a quarter of the grid spacing, else 1.5 cm).
    """
    robot, rows = _robot_rows(table, sweep, robot)
    if radius <= 0:
        steps = [
            np.min(np.diff(v)) for v in getattr(sweep.space, "axes", {}).values() if len(v) > 1
        ]
        radius = float(min(steps)) / 4 if steps else 0.015
    r = standing_robot(robot, sweep.hand)
    recorder = Recorder(stream)
    recorder.log_model_geometry(r.model, r.data, robot_root_body=r.root_body)
    recorder.log_body_poses(r.data, timeline="iteration", time=0)
    recorder.close(blueprint=False)  # sends the rows; the stream stays the caller's
    stacks = [s for s in sweep.stacks if any(r["stack"] == s for r in rows)]
    for stack in stacks:
        for k in VERDICTS:
            mine = [r for r in rows if r["stack"] == stack and r["verdict"] == k]
            p = [[r["x"], r["y"], r["z"]] for r in mine]
            if p:
                stream.log(
                    f"{SWEEP_PATH}/{stack}/{k}",
                    rr.Points3D(p, colors=[COLORS[k]] * len(p), radii=radius),
                    static=True,
                )
    views = [
        rrb.Spatial3DView(
            origin="world",
            name=stack,
            contents=["+ world/**", f"- {SWEEP_PATH}/**", f"+ {SWEEP_PATH}/{stack}/**"],
        )
        for stack in stacks
    ]
    stream.send_blueprint(rrb.Blueprint(rrb.Horizontal(*views)))


def write_views(
    table: pa.Table,
    sweep: Sweep,
    *,
    png: str | os.PathLike[str] | None = None,
    rrd: str | os.PathLike[str] | None = None,
    across: str = "y",
    robots: Sequence[str] | None = None,
) -> list[Path]:
    """Write the PNG and/or the recording of each robot (``<stem>-<robot>`` when
    the sweep has several); returns the files written."""
    robots = list(sweep.robots if robots is None else robots)
    written = []
    for robot in robots:
        for target, kind in ((png, "png"), (rrd, "rrd")):
            if target is None:
                continue
            p = Path(target)
            if len(robots) > 1:
                p = p.with_name(f"{p.stem}-{Path(robot).stem}{p.suffix}")
            p.parent.mkdir(parents=True, exist_ok=True)
            if kind == "png":
                plot_map(table, sweep, p, robot=robot, across=across)
            else:
                stream = rr.RecordingStream("pik_mj sweep")
                stream.save(p)
                try:
                    log_map(table, sweep, stream, robot=robot)
                finally:
                    stream.disconnect()
            written.append(p)
    return written
