"""What a walk played in physics shows: its :class:`PlaybackReport`, the figures
and checks of the walking scenarios (:func:`evaluate_walk`), and the walk as a
scenario's ``motion`` section (:func:`walk_motion`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pik_mj.sim import Fall
from pik_mj.walking.support import support_margin
from pik_mj.walking.wholebody import WalkPattern

__all__ = [
    "SENSOR_VS_CONTACTS_RMS",
    "SENSOR_ZMP_RMS",
    "PlaybackReport",
    "evaluate_walk",
    "walk_motion",
]

SENSOR_ZMP_RMS = 0.05
"""[m] RMS distance allowed between the ZMP from the feet's force sensors and the
planned ZMP over a walk's pattern (the servos track the pattern without balance
feedback, and a foot lands a few ticks early or late)."""

SENSOR_VS_CONTACTS_RMS = 2e-3
"""[m] RMS distance allowed between the ZMP from the feet's force sensors and the
ZMP of MuJoCo's contact forces (the sensors leave out the feet's own inertia)."""


@dataclass(frozen=True)
class PlaybackReport:
    """What happened when a walk pattern was played in physics.

    Samples are taken at the pattern's ticks and on during the settling time.

    Attributes:
        t: Sample times (N,) [s] from the start of the pattern.
        root_p: Root body position (N, 3) [m].
        com: Robot CoM (N, 3) [m].
        feet_p: Sole frame position per limb (N, 3) [m].
        zmp: ZMP of the floor contact forces (N, 2) [m] (NaN without contact).
        zmp_margin: Its signed distance [m] to the support polygon of the soles
            touching the floor, at their actual poses, positive inside (N,).
        zmp_force_sensors: ZMP from the feet's force sensors (N, 2) [m] (NaN
            when no foot sensor carries 1 N; empty when the feet have none).
        zmp_force_sensors_margin: Its signed distance [m] to the support polygon
            of the feet carrying it (the hull of their soles at their actual
            poses, positive inside) (N,).
        standing_height: Root height at t = 0 [m].
        root_height_min: Lowest root height [m].
        fell: The robot fell (``fall``), or a robot geom other than the soles
            touched the floor.
        fall: The first sign of the fall (:class:`pik_mj.sim.Fall`: trunk tilt,
            root drift or root height against the pattern's root pose), or None.
        tilt_max: The trunk's largest tilt from the pattern's [rad].
        drift_max: The root's largest horizontal distance to the pattern's [m].
        bad_contacts: Robot geoms other than the soles that touched the floor.
        final_midfeet_error: Horizontal distance of the final mid-feet point to
            the planned one [m].
        final_root_error: Horizontal distance of the final root position to the
            pattern's last one [m].
        final_yaw_error: Largest heading error of a sole at the end [rad].
        foot_slip: Largest horizontal drift of a foot within one of its stance
            intervals (planned support) [m].
        foot_error: Largest horizontal distance of a supporting foot to its
            planned position [m].
        joint_error_max: Largest servo tracking error during the pattern [rad].
        wall_time: Wall time of the simulation [s] (its callbacks included).
        planned_contacts: Robot geoms allowed to touch the floor (the soles).
    """

    t: np.ndarray
    root_p: np.ndarray
    com: np.ndarray
    feet_p: dict[str, np.ndarray]
    zmp: np.ndarray
    standing_height: float
    root_height_min: float
    fell: bool
    bad_contacts: list[str]
    final_midfeet_error: float
    final_root_error: float
    final_yaw_error: float
    foot_slip: float
    foot_error: float
    joint_error_max: float
    wall_time: float
    params: dict[str, Any] = field(default_factory=dict)
    fall: Fall | None = None
    tilt_max: float = 0.0
    drift_max: float = 0.0
    zmp_margin: np.ndarray = field(default_factory=lambda: np.zeros(0))
    zmp_force_sensors: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    zmp_force_sensors_margin: np.ndarray = field(default_factory=lambda: np.zeros(0))
    planned_contacts: list[str] = field(default_factory=list)

    @property
    def height_ratio_min(self) -> float:
        """Lowest root height over the standing height."""
        return self.root_height_min / self.standing_height

    def passed(self, height_ratio: float = 0.8, final_tolerance: float = 0.05) -> bool:
        """Did not fall, stayed above ``height_ratio`` and ended within ``final_tolerance`` [m]."""
        return (
            not self.fell
            and self.height_ratio_min >= height_ratio
            and self.final_midfeet_error <= final_tolerance
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no time series)."""
        return {
            "standing_height": self.standing_height,
            "root_height_min": self.root_height_min,
            "height_ratio_min": self.height_ratio_min,
            "fell": self.fell,
            "fall": None if self.fall is None else self.fall.describe(),
            "tilt_max": self.tilt_max,
            "drift_max": self.drift_max,
            "bad_contacts": self.bad_contacts,
            "final_midfeet_error": self.final_midfeet_error,
            "final_root_error": self.final_root_error,
            "final_yaw_error": self.final_yaw_error,
            "foot_slip": self.foot_slip,
            "foot_error": self.foot_error,
            "joint_error_max": self.joint_error_max,
            "wall_time": self.wall_time,
            **self.params,
        }


def _played_ticks(
    pattern: WalkPattern, report: PlaybackReport
) -> tuple[int, np.ndarray, np.ndarray]:
    """``K``, the pattern's ticks that were played, and over them the ticks
    where the ZMP of the contact forces exists, and those where the ZMP from
    the feet's force sensors exists too (empty when the feet have none)."""
    K = min(len(pattern.t), len(report.t))
    contacts = np.all(np.isfinite(report.zmp[:K]), axis=1)
    sensed = np.all(np.isfinite(report.zmp_force_sensors[:K]), axis=1)
    return K, contacts, (sensed & contacts) if len(sensed) else sensed


def walk_motion(
    pattern: WalkPattern,
    report: PlaybackReport,
    *,
    height_ratio: float = 0.8,
    final_tolerance: float = 0.05,
) -> dict[str, Any]:
    """A walk played in physics as the ``motion`` section of a scenario's JSON,
    with the keys of :meth:`pik_mj.scenario.ScenarioResult.motion`.

    ``passed``: :meth:`PlaybackReport.passed`; ``duration`` [s]: the pattern and
    the settling; ``max_tracking_error``: the servos' joint error [rad] and the
    supporting feet's distance to their planned positions [m]; ``max_slip``: a
    foot's drift within a stance [m]; ``max_drift``: the root's largest
    distance to the pattern's root position ``‖p_root − q_ref[:3]‖`` [m];
    ``min_com_margin``: None (a walk's CoM leaves the single-support polygon by
    design) and ``min_zmp_margin`` [m] instead, that of the ZMP from the feet's
    force sensors to the support polygon of the feet carrying it over the
    pattern's ticks (:func:`evaluate_walk`'s ``sim_zmp_force_sensors_margin_min_m``),
    or without force sensors that of the ZMP of MuJoCo's contact forces
    (``sim_zmp_contacts_margin_min_m``); ``contacts``: the soles planned, robot geoms on the floor
    unexpected; ``fell``; the playback's own summary under ``parts["walk"]``.
    """
    K, _, sensed = _played_ticks(pattern, report)
    drift = np.linalg.norm(report.root_p[:K] - pattern.q[:K, :3], axis=1)
    margins = report.zmp_force_sensors_margin[:K][sensed]
    if not margins.size:
        margins = report.zmp_margin[:K][np.isfinite(report.zmp_margin[:K])]
    return {
        "passed": report.passed(height_ratio, final_tolerance),
        "duration": float(report.t[-1] - report.t[0]) if len(report.t) else 0.0,
        "max_tracking_error": {
            "joints_rad": report.joint_error_max,
            "frames_m": report.foot_error,
        },
        "min_com_margin": None,
        "min_zmp_margin": float(margins.min()) if margins.size else None,
        "max_slip": report.foot_slip,
        "max_drift": float(np.nanmax(drift)) if K else 0.0,
        "contacts": {
            "planned": list(report.planned_contacts),
            "planned_pairs": [],
            "unexpected": [[g, "floor", None] for g in report.bad_contacts],
        },
        "fell": report.fell,
        "parts": {"walk": report.to_dict()},
    }


def evaluate_walk(
    pattern: WalkPattern,
    report: PlaybackReport,
    *,
    height_ratio: float = 0.8,
    final_tolerance: float = 0.05,
) -> tuple[dict[str, Any], list[tuple[str, bool, str]]]:
    """Figures of a walk and the checks of the walking scenarios.

    Checks: the inverse-dynamics ZMP inside the planned support polygon at every
    tick; in physics no fall, root height >= ``height_ratio`` of standing, final
    mid-feet point within ``final_tolerance`` [m] of the plan.

    Returns:
        ``(figures, [(label, ok, detail), ...])``.
    """
    margin = pattern.support_margin("computed")
    k_min = int(np.argmin(margin))
    K, ok_rows, ok = _played_ticks(pattern, report)
    measured = report.zmp[:K]
    sim_err = np.linalg.norm(measured[ok_rows] - pattern.zmp_ref[:K][ok_rows], axis=1)
    figures: dict[str, Any] = {
        "footsteps": len(pattern.plan.footsteps),
        "ticks": len(pattern.t),
        "dt_s": pattern.dt,
        "duration_s": pattern.duration,
        "ik_time_s": pattern.solve_time,
        "ik_ms_per_tick": 1e3 * pattern.solve_time / len(pattern.t),
        "ik_iterations_per_tick": float(np.mean(pattern.ik_iterations[1:])),
        "ik_feet_error_max_m": float(pattern.ik_feet_error.max()),
        "ik_com_error_max_m": float(pattern.ik_com_error[1:].max()),
        "zmp_margin_computed_min_m": float(margin[k_min]),
        "zmp_margin_computed_min_at_s": float(pattern.t[k_min]),
        "zmp_margin_cart_min_m": float(pattern.support_margin("cart").min()),
        **{f"zmp_{k}_m": v for k, v in pattern.zmp_tracking().items()},
        "sim_zmp_contacts_margin_min_m": _nanmin(report.zmp_margin[:K]),
        "sim_zmp_vs_ref_max_m": float(sim_err.max()) if sim_err.size else float("nan"),
        "sim_zmp_vs_ref_rms_m": float(np.sqrt(np.mean(sim_err**2)))
        if sim_err.size
        else float("nan"),
        **{f"sim_{k}": v for k, v in report.to_dict().items()},
    }
    sensed = report.zmp_force_sensors[:K]
    has_sensors = len(sensed) > 0 and bool(np.all(np.isfinite(sensed), axis=1).any())
    if has_sensors:
        e_ref = np.linalg.norm(sensed[ok] - pattern.zmp_ref[:K][ok], axis=1)
        e_contacts = np.linalg.norm(sensed[ok] - measured[ok], axis=1)
        sensed_or_ref = pattern.zmp_ref.copy()  # the ticks played, the rest planned
        sensed_or_ref[:K][ok] = sensed[ok]
        planned = support_margin(pattern.plan, sensed_or_ref, pattern.outlines)[:K][ok]
        figures |= {
            "sim_zmp_force_sensors_ticks": int(ok.sum()),
            "sim_zmp_force_sensors_vs_ref_rms_m": float(np.sqrt(np.mean(e_ref**2))),
            "sim_zmp_force_sensors_vs_ref_max_m": float(e_ref.max()),
            "sim_zmp_force_sensors_vs_contacts_rms_m": float(np.sqrt(np.mean(e_contacts**2))),
            "sim_zmp_force_sensors_margin_min_m": float(
                np.min(report.zmp_force_sensors_margin[:K][ok])
            ),
            "sim_zmp_force_sensors_planned_margin_min_m": float(planned.min()),
        }
    checks = [
        (
            "ZMP from inverse dynamics inside the support polygon at every tick",
            bool(margin.min() > 0.0),
            f"min margin {margin.min() * 1e3:.1f} mm at t = {pattern.t[k_min]:.2f} s",
        ),
        (
            "physics playback: no fall (trunk tilt, root drift, root height)",
            not report.fell,
            _fall_detail(report),
        ),
        (
            f"physics playback: root height >= {height_ratio:.0%} of standing",
            report.height_ratio_min >= height_ratio,
            f"min {report.height_ratio_min:.3f}",
        ),
        (
            f"physics playback: ends within {final_tolerance * 100:.0f} cm of the plan",
            report.final_midfeet_error <= final_tolerance,
            f"mid-feet error {report.final_midfeet_error * 1e3:.1f} mm",
        ),
    ]
    if has_sensors:
        f = figures
        checks += [
            (
                "ZMP from the feet's force sensors inside the support polygon of the feet "
                "carrying it, at every tick",
                f["sim_zmp_force_sensors_margin_min_m"] > 0.0,
                f"min margin {f['sim_zmp_force_sensors_margin_min_m'] * 1e3:.1f} mm",
            ),
            (
                f"ZMP from the feet's force sensors within {SENSOR_ZMP_RMS * 1e3:.0f} mm RMS "
                "of the planned ZMP",
                f["sim_zmp_force_sensors_vs_ref_rms_m"] <= SENSOR_ZMP_RMS,
                f"RMS {f['sim_zmp_force_sensors_vs_ref_rms_m'] * 1e3:.1f} mm, max "
                f"{f['sim_zmp_force_sensors_vs_ref_max_m'] * 1e3:.1f} mm",
            ),
            (
                f"ZMP from the feet's force sensors equals the ZMP of MuJoCo's contact "
                f"forces ({SENSOR_VS_CONTACTS_RMS * 1e3:.0f} mm RMS)",
                f["sim_zmp_force_sensors_vs_contacts_rms_m"] <= SENSOR_VS_CONTACTS_RMS,
                f"RMS {f['sim_zmp_force_sensors_vs_contacts_rms_m'] * 1e3:.2f} mm",
            ),
        ]
    return figures, checks


def _nanmin(values: np.ndarray) -> float:
    """The smallest finite value, NaN when there is none."""
    finite = values[np.isfinite(values)]
    return float(finite.min()) if finite.size else float("nan")


def _fall_detail(report: PlaybackReport) -> str:
    """How the robot fell (the first sign, robot geoms on the floor), or how far
    it came from falling."""
    signs = [] if report.fall is None else [report.fall.describe()]
    if report.bad_contacts:
        signs.append(f"robot geoms on the floor: {report.bad_contacts}")
    return "; ".join(signs) or (
        f"tilt at most {np.degrees(report.tilt_max):.1f}°, root at most "
        f"{report.drift_max * 1e3:.0f} mm from the pattern's"
    )
