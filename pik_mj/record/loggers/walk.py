"""The logger of a walk played in physics (a ``play_walk_pattern`` callback),
and the walk's series: footsteps, ZMPs, CoM, support polygon, margins.

    log = recorder.walk_logger()
    report = log.finish(play_walk_pattern(pattern, scene, callback=log))

The walk is on ``sim_time`` [s] from the start of its pattern.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from pik_mj.balance import convex_hull_2d
from pik_mj.exceptions import PikError
from pik_mj.record import style
from pik_mj.record.loggers.physics import check_every
from pik_mj.record.loggers.surface import RecorderSurface
from pik_mj.walking.gait import DOUBLE_SUPPORT
from pik_mj.walking.playback import PlaybackReport, WalkSample
from pik_mj.walking.support import outline_at, support_margin
from pik_mj.walking.wholebody import WalkPattern

__all__ = ["WalkLogger", "log_walk"]


class WalkLogger:
    """Logs a walk played in physics on ``sim_time`` (a
    :func:`~pik_mj.walking.playback.play_walk_pattern` callback).

    Made by :meth:`Recorder.walk_logger
    <pik_mj.record.recorder.Recorder.walk_logger>`. The first call logs the
    scene's geometry (the robot's root body from the
    :class:`~pik_mj.walking.playback.WalkSample`); every ``every``-th sample (the
    first one included) the body poses at the sample's time. :meth:`finish`
    logs the walk's series (:func:`log_walk`).
    """

    def __init__(self, recorder: RecorderSurface, every: int = 2) -> None:
        self.every = check_every(every)
        self.recorder = recorder
        self.calls = 0
        self.pattern: WalkPattern | None = None

    def __call__(self, sample: WalkSample) -> None:
        rec = self.recorder
        if self.calls == 0:
            rec.log_model_geometry(sample.model, sample.data, robot_root_body=sample.root_body)
            self.pattern = sample.pattern
        self.calls += 1
        if sample.k % self.every == 0:
            rec.log_body_poses(sample.data, timeline="sim_time", time=sample.time)

    def finish(self, report: PlaybackReport) -> PlaybackReport:
        """Log the walk's pattern and its playback ``report`` (:func:`log_walk`);
        returns ``report``."""
        if self.pattern is None:
            raise PikError(
                "the walk logger has seen no sample: pass it to "
                "play_walk_pattern(..., callback=logger) before finish(report)"
            )
        log_walk(self.recorder, self.pattern, report)
        return report


#: The walking series: (plot group, name, colour, legend), the colours those of
#: the 3D overlays.
_WALK_SERIES = [
    (axis, name, color, f"{label} {axis} [m]")
    for axis in "xy"
    for name, color, label in (
        ("zmp_reference", style.ZMP_REFERENCE, "ZMP reference"),
        ("zmp_inverse_dynamics", style.ZMP_INVERSE_DYNAMICS, "ZMP of the inverse dynamics"),
        ("zmp_measured", style.ZMP, "ZMP measured in physics"),
        ("zmp_force_sensors", style.ZMP_FORCE_SENSORS, "ZMP from the feet's force sensors"),
        ("com", style.COM, "CoM"),
    )
] + [
    ("margin", "zmp_inverse_dynamics", style.ZMP_INVERSE_DYNAMICS, "ZMP of the inverse dynamics"),
    ("margin", "zmp_measured", style.ZMP, "ZMP measured in physics"),
    (
        "margin",
        "zmp_force_sensors",
        style.ZMP_FORCE_SENSORS,
        "ZMP from the force sensors, to the feet carrying it",
    ),
]


def log_walk(recorder: RecorderSurface, pattern: WalkPattern, report: PlaybackReport) -> None:
    """Log a walking pattern and its playback in physics on ``sim_time``.

    ``pattern`` is a :class:`~pik_mj.walking.wholebody.WalkPattern`, ``report``
    the :class:`~pik_mj.walking.playback.PlaybackReport` of playing it (its
    samples are at ``report.t``, the pattern's ticks ``pattern.t`` first). Logged:

    * the footstep plan, static: each sole's outline at its planned pose, the
      initial stance first (:attr:`EntityPaths.footsteps`);
    * per tick of the pattern: the ZMP reference and the ZMP of its inverse
      dynamics as points (``world/zmp/reference|inverse_dynamics``), the
      planned support polygon when it changes, the planned CoM (the CoM
      target), and the series ``walk/x|y/zmp_reference``,
      ``walk/x|y/zmp_inverse_dynamics``, ``walk/margin/zmp_inverse_dynamics``
      (signed distance to the support polygon, positive inside [m]);
    * per sample of the playback: the ZMP of the floor contact forces
      (``world/zmp``, series ``walk/x|y/zmp_measured`` and, during the
      pattern, ``walk/margin/zmp_measured``) and the CoM (``world/com`` with
      its ground projection, series ``walk/x|y/com``);
    * a line of text with the outcome.

    Ground overlays are drawn :attr:`Recorder.lift` above the plan's ground
    plane.
    """
    plan = pattern.plan
    z = float(plan.ground_z) + recorder.lift
    _log_footsteps(recorder, pattern, z)
    K, N = len(pattern.t), len(report.t)
    measured = np.asarray(report.zmp, dtype=float)
    seen = np.all(np.isfinite(measured), axis=1)
    during = np.where(seen[:K, None], measured[:K], 0.0)
    if len(during) < K:  # the playback stopped early (a fall)
        during = np.vstack([during, np.zeros((K - len(during), 2))])
    margin_measured = support_margin(plan, during, pattern.outlines)
    margin_id = support_margin(plan, pattern.zmp_computed, pattern.outlines)
    sensed = np.asarray(report.zmp_force_sensors, dtype=float)
    paths = recorder.paths
    recorder.disable_timeline("iteration")
    last_polygon = None
    for k in range(N):
        recorder.set_time("sim_time", float(report.t[k]))
        if k < K:
            last_polygon = _log_plan_tick(recorder, pattern, k, z, last_polygon)
            recorder.log_scalar(paths.walk_series("margin", "zmp_inverse_dynamics"), margin_id[k])
            if seen[k]:
                recorder.log_scalar(paths.walk_series("margin", "zmp_measured"), margin_measured[k])
            recorder.log_com(report.com[k], target=pattern.com_ref[k])
        else:
            recorder.log_com(report.com[k])
        for axis, v in zip("xy", report.com[k][:2], strict=True):
            recorder.log_scalar(paths.walk_series(axis, "com"), v)
        if seen[k]:
            _log_zmp(recorder, paths.zmp, "zmp_measured", measured[k], z, 1.0, style.ZMP)
        if k < len(sensed) and np.all(np.isfinite(sensed[k])):
            path = f"{paths.zmp}/force_sensors"
            color = style.ZMP_FORCE_SENSORS
            _log_zmp(recorder, path, "zmp_force_sensors", sensed[k], z, 0.6, color)
            recorder.log_scalar(
                paths.walk_series("margin", "zmp_force_sensors"),
                float(report.zmp_force_sensors_margin[k]),
            )
    recorder.log_text(
        f"walk: {len(plan.footsteps)} footsteps over {pattern.duration:.2f} s; ZMP of the "
        f"inverse dynamics at least {margin_id.min() * 1e3:.1f} mm inside the support polygon; "
        f"in physics: {'FELL' if report.fell else 'no fall'}, ends "
        f"{report.final_midfeet_error * 1e3:.1f} mm from the plan",
        level="WARN" if report.fell else "INFO",
    )


def _log_footsteps(recorder: RecorderSurface, pattern: WalkPattern, z: float) -> None:
    """The footstep plan at height ``z`` [m], static: each sole's outline at its
    planned pose, the initial stance first; and the walking series' legends."""
    plan = pattern.plan
    steps = [*plan.initial_feet.values(), *plan.footsteps]
    outlines = [outline_at(f.p_W, f.yaw, pattern.soles[f.limb].outline) for f in steps]
    recorder.log_static(
        recorder.paths.footsteps,
        rr.LineStrips3D(
            [np.column_stack([np.vstack([c, c[:1]]), np.full(len(c) + 1, z)]) for c in outlines],
            colors=[style.FOOTSTEP],
            radii=[style.OUTLINE_RADIUS / 2],
        ),
    )
    for group, name, color, label in _WALK_SERIES:
        recorder.log_series_style(recorder.paths.walk_series(group, name), color, label)


def _log_plan_tick(
    recorder: RecorderSurface, pattern: WalkPattern, k: int, z: float, last_polygon: object
) -> object:
    """Tick ``k`` of the pattern at height ``z`` [m]: the support polygon when
    it changed from ``last_polygon`` (the key returned for the tick before), the
    ZMP reference and the ZMP of the inverse dynamics; returns the polygon's key."""
    plan = pattern.plan
    limbs = plan.params.all_limbs
    support = limbs if plan.support[k] == DOUBLE_SUPPORT else (plan.support[k],)
    key = tuple((lb, *plan.feet_p[lb][k][:2], plan.feet_yaw[lb][k]) for lb in support)
    if key != last_polygon:
        corners = np.vstack(
            [
                outline_at(plan.feet_p[lb][k], plan.feet_yaw[lb][k], pattern.soles[lb].outline)
                for lb in support
            ]
        )
        hull = convex_hull_2d(corners)
        recorder.log_polygon(np.column_stack([hull, np.full(len(hull), z)]), lift=0.0)
    zmp = recorder.paths.zmp
    for name, p_xy, color in (
        ("reference", pattern.zmp_ref[k], style.ZMP_REFERENCE),
        ("inverse_dynamics", pattern.zmp_computed[k], style.ZMP_INVERSE_DYNAMICS),
    ):
        _log_zmp(recorder, f"{zmp}/{name}", f"zmp_{name}", p_xy, z, 0.8, color)
    return key


def _log_zmp(
    recorder: RecorderSurface,
    path: str,
    series: str,
    p_xy: np.ndarray,
    z: float,
    size: float,
    color: tuple[int, int, int],
) -> None:
    """A ZMP ``p_xy`` [m]: a point at ``path``, at height ``z`` [m], of ``size``
    times :data:`~pik_mj.record.style.ZMP_RADIUS`, and its x and y series
    ``walk/x|y/<series>``."""
    recorder.log_point(path, [p_xy[0], p_xy[1], z], radius=style.ZMP_RADIUS * size, color=color)
    for axis, v in zip("xy", p_xy, strict=True):
        recorder.log_scalar(recorder.paths.walk_series(axis, series), v)
