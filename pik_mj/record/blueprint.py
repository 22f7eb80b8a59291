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

The layout is plain data first (:func:`layout_of` -> :class:`Layout`), then
rerun's blueprint classes (:func:`blueprint_for`). :func:`send_blueprint_for`
(what :meth:`Recorder.close <pik_mj.record.recorder.Recorder.close>` calls)
makes what rerun logs for a layout once, and sends it again for every
recording of that layout with that recording's cameras.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from pik_mj.record.paths import PATHS, EntityPaths

__all__ = [
    "Framing",
    "Layout",
    "Plot",
    "Tab",
    "blueprint",
    "blueprint_for",
    "eye",
    "layout_of",
    "send_blueprint_for",
]

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


@dataclass(frozen=True)
class Plot:
    """A time-series view: its name, origin and contents (``()``: ``$origin/**``)."""

    name: str
    origin: str
    contents: tuple[str, ...] = ()


@dataclass(frozen=True)
class Tab:
    """One tab of a layout: a 3D view (with the image views of ``cameras``
    below it), the text log when ``events``, and ``plots`` beside them.

    Attributes:
        name: The tab's name.
        view: The 3D view's name.
        timeline: The timeline whose :class:`Framing` its camera frames (None:
            any framed timeline).
        direction: Where its camera looks from (:func:`eye`).
        plots: Its time-series views.
        cameras: Entity paths of camera images shown below the 3D view.
        events: Whether the text log of events is shown below the 3D view.
        hidden: Entity paths its 3D view leaves out: cameras with no rows on
            its timeline (rerun marks the view with an error for a pinhole
            that has no value at the time shown).
    """

    name: str
    view: str
    timeline: str | None
    direction: tuple[float, float] = POSE_VIEW
    plots: tuple[Plot, ...] = ()
    cameras: tuple[str, ...] = ()
    events: bool = False
    hidden: tuple[str, ...] = ()


@dataclass(frozen=True)
class Layout:
    """What :func:`blueprint_for` lays out, as plain data (hashable): its
    tabs, the first one active, and the timeline the time panel opens on."""

    tabs: tuple[Tab, ...]
    timeline: str | None


def _framing_of(tab: Tab, framing: Mapping[str, Framing]) -> Framing | None:
    if tab.timeline is None:
        return next(iter(framing.values()), None)
    return framing.get(tab.timeline)


def _plot(plot: Plot) -> rrb.TimeSeriesView:
    return rrb.TimeSeriesView(
        origin=plot.origin,
        name=plot.name,
        contents=list(plot.contents) if plot.contents else "$origin/**",
    )


def _under(logged: Mapping[str, set[str]], parent: str, timeline: str | None = None) -> list[str]:
    """Paths logged under ``parent`` (on ``timeline``), sorted."""
    return sorted(
        p
        for p, timelines in logged.items()
        if p.startswith(f"{parent}/") and (timeline is None or timeline in timelines)
    )


def layout_of(logged: Mapping[str, set[str]], paths: EntityPaths = PATHS) -> Layout:
    """The layout of everything ``logged`` (entity path -> the timelines of its
    rows, what a :class:`~pik_mj.record.recorder.Recorder` logged); see the
    module docstring."""
    makers = (_solve_tab, _motion_tab, _sensors_tab, _hold_tab, _walk_tab)
    tabs = [tab for tab in (make(logged, paths) for make in makers) if tab is not None]
    timeline = tabs[0].timeline if tabs else None
    if not tabs:
        tabs.append(Tab("world", "world", None))
    if paths.events in logged:  # the text log in the first tab
        tabs[0] = dataclasses.replace(tabs[0], events=True)
    return Layout(tuple(tabs), timeline)


def _solve_tab(logged: Mapping[str, set[str]], paths: EntityPaths) -> Tab | None:
    """The solves' tab (``iteration``): one plot per level's errors, the static
    check's margin and counts."""
    prefix = f"{paths.errors}/level_"
    levels = sorted(
        {int(p[len(prefix) :].split("/")[0]) for p in _under(logged, paths.errors, "iteration")}
    )
    if not levels:
        return None
    plots = []
    for k in levels:
        if k == 0 and len(levels) > 1:
            continue  # hard rows: what the levels above keep
        log10 = bool(_under(logged, paths.level_errors(k, log10=True)))
        plots.append(
            Plot(
                f"level {k}: " + ("log10 of each task's error" if log10 else "task errors"),
                paths.level_errors(k, log10=log10),
            )
        )
    if paths.balance_metric("margin") in logged:
        plots.append(
            Plot(
                "static check: CoM margin to the support polygon [m]",
                paths.balance,
                (paths.balance_metric("margin"),),
            )
        )
    counts = [p for p in ("contacts", "feasible") if paths.balance_metric(p) in logged]
    if counts:
        plots.append(
            Plot(
                "static check: contacts [count], equilibrium (1 = yes)",
                paths.balance,
                tuple(paths.balance_metric(p) for p in counts),
            )
        )
    on_iterations = set(_under(logged, paths.cameras, "iteration"))
    return Tab(
        "solve (timeline: iteration)",
        "solve: robot, targets, balance",
        "iteration",
        plots=tuple(plots),
        hidden=tuple(p for p in _under(logged, paths.cameras) if p not in on_iterations),
    )


def _motion_tab(logged: Mapping[str, set[str]], paths: EntityPaths) -> Tab | None:
    """The motions' tab (``sim_time``): tracking, drift and slip, waypoints,
    and the cameras' images."""
    motion = _under(logged, paths.motion, "sim_time")
    if not motion:
        return None
    metres = [
        p
        for p in motion
        if p.rsplit("/", 1)[1] in _HOLD_METRES or p.startswith(f"{paths.motion}/frame_error/")
    ]
    plots = [
        Plot(title, paths.motion, tuple(series))
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
    return Tab(
        "motion (timeline: sim_time)",
        "motion: physical robot, IK reference (translucent)",
        "sim_time",
        plots=tuple(plots),
        cameras=tuple(images),
    )


def _sensors_tab(logged: Mapping[str, set[str]], paths: EntityPaths) -> Tab | None:
    """The sensors' tab (``sim_time``): forces, bumpers, IMUs."""
    if not _under(logged, paths.sensors, "sim_time"):
        return None
    plots = [
        Plot(
            title,
            f"{paths.sensors}/{groups[0]}",
            tuple(p for g in groups for p in _under(logged, f"{paths.sensors}/{g}", "sim_time")),
        )
        for groups, title in (
            (("force", "touch"), "sensors: contact force at force sensors and bumpers [N]"),
            (("bumper",), "sensors: bumpers (1 = on)"),
            (("imu_acceleration",), "sensors: IMU acceleration a - g, sensor frame [m/s²]"),
            (("imu_angular_velocity",), "sensors: IMU angular velocity, sensor frame [rad/s]"),
        )
        if any(_under(logged, f"{paths.sensors}/{g}", "sim_time") for g in groups)
    ]
    return Tab(
        "sensors (timeline: sim_time)",
        "sensors: the physical robot",
        "sim_time",
        plots=tuple(plots),
    )


def _hold_tab(logged: Mapping[str, set[str]], paths: EntityPaths) -> Tab | None:
    """The physics holds' tab (``sim_time``): metres and newtons apart."""
    hold = _under(logged, paths.hold, "sim_time")
    if not hold:
        return None
    metres = [p for p in hold if p.rsplit("/", 1)[1] in _HOLD_METRES]
    newtons = [p for p in hold if p not in metres]
    plots = [
        Plot(
            "hold: "
            + ", ".join(_HOLD_NAMES.get(p.rsplit("/", 1)[1], p.rsplit("/", 1)[1]) for p in series)
            + f" [{unit}]",
            paths.hold,
            tuple(series),
        )
        for series, unit in ((metres, "m"), (newtons, "N"))
        if series
    ]
    return Tab("physics hold (timeline: sim_time)", "physics hold", "sim_time", plots=tuple(plots))


def _walk_tab(logged: Mapping[str, set[str]], paths: EntityPaths) -> Tab | None:
    """The walks' tab (``sim_time``): ZMP and CoM along x and y, ZMP margin."""
    if not _under(logged, paths.walk, "sim_time"):
        return None
    plots = [
        Plot(title, f"{paths.walk}/{group}")
        for group, title in (
            ("x", "walk: ZMP and CoM, x [m]"),
            ("y", "walk: ZMP and CoM, y [m]"),
            ("margin", "walk: ZMP margin to the support polygon [m]"),
        )
        if _under(logged, f"{paths.walk}/{group}")
    ]
    return Tab("walking (timeline: sim_time)", "walking", "sim_time", WALK_VIEW, plots=tuple(plots))


def _build(
    layout: Layout, paths: EntityPaths, framing: Mapping[str, Framing]
) -> tuple[rrb.Blueprint, list[tuple[rrb.Spatial3DView, Tab]]]:
    """The rerun blueprint of ``layout``, and its 3D views with their tabs."""
    tabs: list[rrb.Container] = []
    views = []
    for tab in layout.tabs:
        frame = _framing_of(tab, framing)
        view3d = rrb.Spatial3DView(
            origin=paths.world,
            name=tab.view,
            contents=["$origin/**", *(f"- {p}" for p in tab.hidden)],
            eye_controls=None if frame is None else eye(frame, tab.direction),
        )
        views.append((view3d, tab))
        view: Any = view3d
        if tab.cameras:
            cams = [
                rrb.Spatial2DView(origin=p, name=f"camera {p.split('/')[-2]}") for p in tab.cameras
            ]
            view = rrb.Vertical(view, rrb.Horizontal(*cams), row_shares=[3, 1])
        if tab.events:
            events = rrb.TextLogView(origin=paths.events, name="events and failures")
            view = rrb.Vertical(view, events, row_shares=[4, 1])
        if tab.plots:
            plots = rrb.Vertical(*[_plot(p) for p in tab.plots])
            tabs.append(rrb.Horizontal(view, plots, column_shares=[3, 2], name=tab.name))
        else:
            tabs.append(rrb.Horizontal(view, name=tab.name))
    root = tabs[0] if len(tabs) == 1 else rrb.Tabs(*tabs, active_tab=0)
    panel = [] if layout.timeline is None else [rrb.TimePanel(timeline=layout.timeline)]
    return rrb.Blueprint(root, *panel), views


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
    return _build(layout_of(logged, paths), paths, framing or {})[0]


def send_blueprint_for(
    stream: rr.RecordingStream,
    logged: Mapping[str, set[str]],
    paths: EntityPaths = PATHS,
    *,
    framing: Mapping[str, Framing] | None = None,
) -> None:
    """Send :func:`blueprint_for` on ``stream``, made active and default
    (``RecordingStream.send_blueprint``)."""
    stream.send_blueprint(
        blueprint_for(logged, paths, framing=framing), make_active=True, make_default=True
    )


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
