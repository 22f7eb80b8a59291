"""Viewer layouts (rerun blueprints) of pik_mj's recordings.

:func:`blueprint_for` lays out what a recording holds, one tab per kind of run,
each opening on what matters:

* **solve** (timeline ``iteration``, the one the recording opens on): the 3D
  view with its camera framed on the robot, one plot per priority level of
  ``log10`` of each task's error (a log scale: convergence to 1e-8 shows), the
  static check's CoM margin [m] and its counts apart, and the text log of
  events and failures;
* **motion** (timeline ``sim_time``): the 3D view of the physical robot and
  its IK reference beside it, the joint tracking error [rad], the drift from
  the reference, foot slip, CoM margin and task-frame errors [m], the index of
  the waypoint (IK iterate) the reference passed, and each camera's view;
* **sensors** (timeline ``sim_time``), when a motion logged them: contact
  forces at the force sensors and bumpers [N], the bumpers' state, the IMUs'
  acceleration [m/s²] and angular velocity [rad/s];
* **physics hold** (timeline ``sim_time``): the 3D view, drift / slip / CoM
  margin [m], and the vertical contact force [N];
* **walking** (timeline ``sim_time``): the 3D view over the walk, the ZMP
  (reference, inverse dynamics, measured) and CoM along x and y [m], and the
  ZMP's margin to the support polygon [m].

Each plot names its unit, each tab its timeline; the time panel opens on the
first tab's timeline (rerun 0.41 has one timeline for all views: the other
tabs' plots fill when it is switched to theirs).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import rerun.blueprint as rrb

from .paths import PATHS, EntityPaths

__all__ = ["Framing", "blueprint", "blueprint_for", "eye"]

#: Where a 3D view's camera looks at the robot from: (azimuth from the robot's
#: heading, elevation) [rad]. A solve or a hold from the front left, which
#: shows a reaching arm; a walk more from the front, which shows the ground
#: between the feet (the ZMP in double support).
POSE_VIEW = (0.75, 0.5)
WALK_VIEW = (0.35, 0.6)
#: Distance of the camera from the framed centre, in units of the framed size.
EYE_DISTANCE = 1.25


#: Physics-hold series in metres, and the words of every hold series.
_HOLD_METRES = ("drift", "slip", "margin")
_HOLD_NAMES = {
    "drift": "root drift",
    "slip": "foot slip",
    "margin": "CoM margin",
    "contact_force_z": "vertical contact force",
}


@dataclass(frozen=True)
class Framing:
    """What a 3D view's camera frames.

    Attributes:
        low: Lower corner of the box of the robot's body positions [m].
        high: Upper corner of that box [m].
        heading: Yaw of the robot's root at the start [rad]: the camera looks
            at its front.
        height: The robot's height [m] (its geoms).
        ground: Height of the ground it stands on [m], or None (a robot fixed to
            the world: the box of its bodies is framed).
    """

    low: np.ndarray
    high: np.ndarray
    heading: float
    height: float
    ground: float | None = None


def eye(framing: Framing, direction: tuple[float, float] = POSE_VIEW) -> rrb.EyeControls3D:
    """An orbiting camera on the centre of the framed box, from the robot's
    ``direction`` (azimuth from its heading, elevation), at
    :data:`EYE_DISTANCE` times the framed size
    ``s = max(h, extent_x, extent_y)`` (``h`` the robot's height).

    .. math::
        p_{eye} = c + D s \\, (\\cos\\epsilon \\cos\\psi,\\;
                                \\cos\\epsilon \\sin\\psi,\\; \\sin\\epsilon),
        \\qquad \\psi = \\text{heading} + \\text{azimuth}
    """
    low, high = np.asarray(framing.low, float), np.asarray(framing.high, float)
    size = max(float(framing.height), float(high[0] - low[0]), float(high[1] - low[1]), 0.2)
    center = 0.5 * (low + high)
    if framing.ground is not None:  # a standing robot: half its height
        center[2] = framing.ground + 0.5 * float(framing.height)
    psi, el = framing.heading + direction[0], direction[1]
    u = np.array([math.cos(el) * math.cos(psi), math.cos(el) * math.sin(psi), math.sin(el)])
    return rrb.EyeControls3D(
        kind=rrb.Eye3DKind.Orbital,
        position=center + EYE_DISTANCE * size * u,
        look_target=center,
        eye_up=(0.0, 0.0, 1.0),
    )


def _view3d(
    paths: EntityPaths,
    framing: Framing | None,
    name: str,
    direction: tuple[float, float] = POSE_VIEW,
) -> rrb.Spatial3DView:
    return rrb.Spatial3DView(
        origin=paths.world,
        name=name,
        eye_controls=None if framing is None else eye(framing, direction),
    )


def _plot(name: str, origin: str, contents: Sequence[str] | None = None) -> rrb.TimeSeriesView:
    """A plot of the series under ``origin`` (or of ``contents``)."""
    return rrb.TimeSeriesView(
        origin=origin, name=name, contents=list(contents) if contents else "$origin/**"
    )


def _under(logged: Mapping[str, set[str]], parent: str, timeline: str | None = None) -> list[str]:
    """Paths logged under ``parent`` (on ``timeline``), sorted."""
    return sorted(
        p
        for p, timelines in logged.items()
        if p.startswith(f"{parent}/") and (timeline is None or timeline in timelines)
    )


def _tab(
    view3d: rrb.Spatial3DView,
    plots: list[rrb.TimeSeriesView],
    name: str,
    events: rrb.TextLogView | None = None,
) -> rrb.Container:
    left = view3d if events is None else rrb.Vertical(view3d, events, row_shares=[4, 1])
    if not plots:
        return rrb.Horizontal(left, name=name)
    return rrb.Horizontal(left, rrb.Vertical(*plots), column_shares=[3, 2], name=name)


def blueprint_for(
    logged: Mapping[str, set[str]],
    paths: EntityPaths = PATHS,
    *,
    framing: Mapping[str, Framing] | None = None,
) -> rrb.Blueprint:
    """The layout of everything ``logged`` (see the module docstring).

    Args:
        logged: What a :class:`~pik_mj.record.recorder.Recorder` logged: entity
            path -> the timelines of its rows.
        paths: Entity-path table.
        framing: Per timeline, what the 3D view's camera frames (the robot's
            body positions seen on it); no camera is set without it.
    """
    framing = framing or {}
    tabs: list[rrb.Container] = []
    timelines: list[str] = []
    events = rrb.TextLogView(origin=paths.events, name="events and failures")
    text = paths.events in logged

    def first_events() -> rrb.TextLogView | None:
        return events if text and not tabs else None

    prefix = f"{paths.errors}/level_"
    levels = sorted(
        {int(p[len(prefix) :].split("/")[0]) for p in _under(logged, paths.errors, "iteration")}
    )
    if levels:
        plots = []
        for k in levels:
            if k == 0 and len(levels) > 1:
                continue  # hard rows: what the levels above keep
            log10 = bool(_under(logged, paths.level_errors(k, log10=True)))
            plots.append(
                _plot(
                    f"level {k}: " + ("log10 of each task's error" if log10 else "task errors"),
                    paths.level_errors(k, log10=log10),
                )
            )
        if paths.balance_metric("margin") in logged:
            plots.append(
                _plot(
                    "static check: CoM margin to the support polygon [m]",
                    paths.balance,
                    [paths.balance_metric("margin")],
                )
            )
        counts = [p for p in ("contacts", "feasible") if paths.balance_metric(p) in logged]
        if counts:
            plots.append(
                _plot(
                    "static check: contacts [count], equilibrium (1 = yes)",
                    paths.balance,
                    [paths.balance_metric(p) for p in counts],
                )
            )
        view = _view3d(paths, framing.get("iteration"), "solve: robot, targets, balance")
        tabs.append(_tab(view, plots, "solve (timeline: iteration)", first_events()))
        timelines.append("iteration")
    motion = _under(logged, paths.motion, "sim_time")
    if motion:
        metres = [
            p
            for p in motion
            if p.rsplit("/", 1)[1] in _HOLD_METRES or p.startswith(f"{paths.motion}/frame_error/")
        ]
        plots = [
            _plot(title, paths.motion, series)
            for title, series in (
                ("motion: joint tracking error [rad]", [paths.motion_metric("tracking_error")]),
                (
                    "motion: root drift from the reference, foot slip, CoM margin, "
                    "task-frame errors [m]",
                    metres,
                ),
                (
                    "motion: waypoint (IK iterate) the reference passed [index]",
                    [paths.motion_metric("waypoint")],
                ),
            )
            if set(series) & set(motion)
        ]
        images = [p for p in _under(logged, paths.cameras, "sim_time") if p.endswith("/image")]
        view = _view3d(
            paths, framing.get("sim_time"), "motion: physical robot, IK reference (translucent)"
        )
        if images:
            cams = [rrb.Spatial2DView(origin=p, name=f"camera {p.split('/')[-2]}") for p in images]
            view = rrb.Vertical(view, rrb.Horizontal(*cams), row_shares=[3, 1])
        tabs.append(_tab(view, plots, "motion (timeline: sim_time)", first_events()))
        timelines.append("sim_time")
    sensors = _under(logged, paths.sensors, "sim_time")
    if sensors:
        plots = [
            _plot(
                title,
                f"{paths.sensors}/{groups[0]}",
                [p for g in groups for p in _under(logged, f"{paths.sensors}/{g}", "sim_time")],
            )
            for groups, title in (
                (("force", "touch"), "sensors: contact force at force sensors and bumpers [N]"),
                (("bumper",), "sensors: bumpers (1 = on)"),
                (("imu_acceleration",), "sensors: IMU acceleration a - g, sensor frame [m/s²]"),
                (("imu_angular_velocity",), "sensors: IMU angular velocity, sensor frame [rad/s]"),
            )
            if any(_under(logged, f"{paths.sensors}/{g}", "sim_time") for g in groups)
        ]
        view = _view3d(paths, framing.get("sim_time"), "sensors: the physical robot")
        tabs.append(_tab(view, plots, "sensors (timeline: sim_time)", first_events()))
        timelines.append("sim_time")
    hold = _under(logged, paths.hold, "sim_time")
    if hold:
        metres = [p for p in hold if p.rsplit("/", 1)[1] in _HOLD_METRES]
        newtons = [p for p in hold if p not in metres]
        plots = [
            _plot(
                "hold: "
                + ", ".join(
                    _HOLD_NAMES.get(p.rsplit("/", 1)[1], p.rsplit("/", 1)[1]) for p in series
                )
                + f" [{unit}]",
                paths.hold,
                series,
            )
            for series, unit in ((metres, "m"), (newtons, "N"))
            if series
        ]
        view = _view3d(paths, framing.get("sim_time"), "physics hold")
        tabs.append(_tab(view, plots, "physics hold (timeline: sim_time)", first_events()))
        timelines.append("sim_time")
    walk = _under(logged, paths.walk, "sim_time")
    if walk:
        plots = [
            _plot(title, f"{paths.walk}/{group}")
            for group, title in (
                ("x", "walk: ZMP and CoM, x [m]"),
                ("y", "walk: ZMP and CoM, y [m]"),
                ("margin", "walk: ZMP margin to the support polygon [m]"),
            )
            if _under(logged, f"{paths.walk}/{group}")
        ]
        view = _view3d(paths, framing.get("sim_time"), "walking", WALK_VIEW)
        tabs.append(_tab(view, plots, "walking (timeline: sim_time)", first_events()))
        timelines.append("sim_time")
    if not tabs:
        view = _view3d(paths, next(iter(framing.values()), None), "world")
        tabs.append(_tab(view, [], "world", first_events()))
    root = tabs[0] if len(tabs) == 1 else rrb.Tabs(*tabs, active_tab=0)
    panel = rrb.TimePanel(timeline=timelines[0]) if timelines else None
    return rrb.Blueprint(root, *([panel] if panel is not None else []))


def blueprint(
    levels: Sequence[int],
    paths: EntityPaths = PATHS,
    *,
    extra: Sequence[tuple[str, str]] = (),
) -> rrb.Blueprint:
    """A fixed layout: the 3D ``world`` view beside one time series per level.

    Args:
        levels: Priority levels whose error series get a view.
        paths: Entity-path table.
        extra: More time-series views ``(origin, name)`` below the level views
            (e.g. ``(paths.balance, "balance")``).
    """
    view3d = rrb.Spatial3DView(origin=paths.world, name="world")
    series = [
        rrb.TimeSeriesView(origin=paths.level_errors(k), name=f"level {int(k)} errors")
        for k in levels
    ] + [rrb.TimeSeriesView(origin=origin, name=name) for origin, name in extra]
    if not series:
        return rrb.Blueprint(view3d)
    return rrb.Blueprint(rrb.Horizontal(view3d, rrb.Vertical(*series), column_shares=[2, 1]))
