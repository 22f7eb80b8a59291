"""A scenario's result: its solves, motions, balance, figures and checks, as JSON and as
text (:class:`ScenarioResult`); the one-line summary of a balance report."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.outputs import write_atomic
from pik_mj.robot import Robot
from pik_mj.sim import (
    HoldCriteria,
    HoldReport,
    MotionReport,
    Scene,
    StaticChecks,
    StaticReport,
    balance_report,
)
from pik_mj.sim.validate import describe_violation
from pik_mj.solve import SolveResult


def jsonable(value: Any, where: str = "value") -> Any:
    """``value`` with numpy scalars/arrays turned into Python numbers/lists; non-finite
    floats become None (JSON has no NaN); paths become strings.

    Raises:
        InvalidInput: A value JSON cannot hold (an object, a function, ...), named by
            its place in ``value`` (``where``), before anything is written.
    """
    if isinstance(value, Mapping):
        return {str(k): jsonable(v, f"{where}[{k!r}]") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist(), where)
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, Path):
        return str(value)
    if value is None or isinstance(value, str):
        return value
    raise InvalidInput(
        f"{where} is a {type(value).__name__}, which JSON cannot hold; use numbers, "
        "strings, booleans, None, lists, dicts or numpy arrays"
    )


@dataclass
class ScenarioResult:
    """Outcome of a scenario.

    Attributes:
        name: Scenario name.
        passed: Every check held.
        solves: The scenario's solves by label, in order.
        figures: Measured numbers (JSON-ready after :meth:`to_dict`).
        messages: One line per check (``ok``/``FAILED``) and notes.
        main: Label of the solve whose state is reported at the top level of
            :meth:`to_dict` (default: the last one).
        recording: Path of the ``.rrd`` written, or None.
        balance: The final pose's static check and physics hold
            (:func:`pik_mj.sim.balance_report`), or None when no hold ran.
        static_reports: Per solve label, the :class:`pik_mj.sim.StaticReport` of
            every IK iteration's configuration.
        static_check_times: Wall time of each per-iteration static check [s].
        motions: The solves' iterates played in physics
            (:class:`pik_mj.sim.MotionReport`), by label, in order (a motion in
            parts, e.g. before and after a grasp, has one per part).
        walk: A walking pattern played in physics, as the ``motion`` section
            (:func:`pik_mj.walking.playback.walk_motion`), or None.
        robot_state: The final pose and what rebuilds its scene (the robot's
            source, ``q``, ``allowed_contacts``, ``grasps``, ``external``), what
            ``pik-mj validate`` reads back; None without a scene.
        robot: The robot in its final configuration (not serialized).
    """

    name: str
    passed: bool = True
    solves: dict[str, SolveResult] = field(default_factory=dict)
    figures: dict[str, Any] = field(default_factory=dict)
    messages: list[str] = field(default_factory=list)
    main: str | None = None
    recording: str | None = None
    balance: dict[str, Any] | None = None
    static_reports: dict[str, list[StaticReport]] = field(default_factory=dict)
    static_check_times: list[float] = field(default_factory=list)
    motions: dict[str, MotionReport] = field(default_factory=dict)
    walk: dict[str, Any] | None = None
    robot_state: dict[str, Any] | None = None
    robot: Robot | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidInput(f"a scenario's name must be a non-empty string, got {self.name!r}")

    def check(self, label: str, ok: bool, detail: str = "") -> bool:
        """Record a check: ``ok`` False makes the scenario fail.

        Raises:
            InvalidInput: ``label`` or ``detail`` not a string, ``ok`` not a truth
                value (an array of them is ambiguous).
        """
        if not isinstance(label, str) or not isinstance(detail, str):
            raise InvalidInput(f"a check's label and detail must be strings, got {label!r}")
        if not isinstance(ok, (bool, np.bool_)):
            raise InvalidInput(f"check {label!r}: ok must be True or False, got {ok!r}")
        ok = bool(ok)
        self.messages.append(
            f"[{'ok' if ok else 'FAILED'}] {label}" + (f": {detail}" if detail else "")
        )
        if not ok:
            self.passed = False
        return ok

    def add_solve(
        self,
        label: str,
        result: SolveResult,
        checks: StaticChecks | None = None,
        *,
        finish: Sequence[Any] = (),
    ) -> SolveResult:
        """Keep solve ``label`` and, with ``checks``, its per-iteration static
        reports; hand ``result`` to the ``finish`` method of each of ``finish``
        (the solve's logger and progress display)."""
        for callback in finish:
            callback.finish(result)
        self.solves[label] = result
        if checks is not None:
            self.static_reports[label] = list(checks.reports)
            self.static_check_times += checks.times
        return result

    def add_motion(
        self, label: str, motion: MotionReport, *, finish: Sequence[Any] = ()
    ) -> MotionReport:
        """Keep the motion ``label`` (a check on its verdict); hand it to the
        ``finish`` method of each of ``finish`` (its recorder's motion logger)."""
        for callback in finish:
            callback.finish(motion)
        self.motions[label] = motion
        self.check(
            f"motion {label!r}: the iterates played in physics (no fall, no foot slip, "
            "no unexpected contact)",
            motion.passed,
            motion.summary().removeprefix("motion: "),
        )
        return motion

    def motion(self) -> dict[str, Any] | None:
        """The ``motion`` section of :meth:`to_dict`, or None when nothing was
        played: over all parts ``passed``, ``duration`` [s], ``max_tracking_error``
        (``joints_rad``, ``frames_m``), ``min_com_margin`` [m] (None: contact
        lost), ``max_slip`` [m], ``max_drift`` [m], ``contacts`` (``planned``,
        ``unexpected``), ``fell``, and each part's
        :meth:`~pik_mj.sim.MotionReport.to_dict` under ``parts``. A walk
        (:attr:`walk`) has the same keys, and ``min_zmp_margin`` [m]."""
        if not self.motions:
            return self.walk
        parts = list(self.motions.values())
        margin = min(m.min_margin for m in parts)
        return {
            "passed": all(m.passed for m in parts),
            "duration": sum(m.duration + m.settle for m in parts),
            "max_tracking_error": {
                "joints_rad": max(m.tracking_error for m in parts),
                "frames_m": max(m.max_frame_error for m in parts),
            },
            "min_com_margin": margin if math.isfinite(margin) else None,
            "max_slip": max(m.slip for m in parts),
            "max_drift": max(m.drift for m in parts),
            "contacts": {
                "planned": list(dict.fromkeys(g for m in parts for g in m.planned_contacts)),
                "planned_pairs": [
                    list(p) for p in dict.fromkeys(p for m in parts for p in m.planned_pairs)
                ],
                "unexpected": [list(c) for m in parts for c in m.unexpected_contacts],
            },
            "fell": any(m.fell for m in parts),
            "parts": {label: m.to_dict() for label, m in self.motions.items()},
        }

    def add_balance(
        self,
        scene: Scene,
        static: StaticReport,
        hold: HoldReport | None,
        criteria: HoldCriteria,
        *,
        external: Sequence[tuple[str, Any, Any]] = (),
    ) -> None:
        """Keep the final pose's static check and hold (a check on the hold's
        verdict), and what ``pik-mj validate`` needs to redo them."""
        allowed = scene.allowed_contacts if criteria.allowed is None else criteria.allowed
        robot = scene.robot
        self.robot = robot
        source = robot.source.to_dict() if robot.source is not None else {}
        self.robot_state = {
            **source,
            "q": static.q,
            "allowed_contacts": list(allowed),
            "grasps": [g.to_dict() for g in scene.grasps],
            "external": [[f, np.asarray(F), np.asarray(M)] for f, F, M in external],
        }
        if hold is None:
            return
        self.balance = balance_report(static, hold, source or None)
        self.check(
            f"simulation: final pose in static equilibrium and held {hold.duration:g} s in physics",
            self.balance["passed"],
            balance_summary(self.balance).removeprefix("balance: "),
        )

    def main_solve(self) -> SolveResult | None:
        if not self.solves:
            return None
        return (
            self.solves[self.main] if self.main in self.solves else list(self.solves.values())[-1]
        )

    def simulation(self) -> dict[str, Any] | None:
        """Summary of the per-iteration static checks, or None if none ran.

        ``iterations_checked``, ``equilibrium_iterations`` (LP feasible),
        ``min_margin_m`` (smallest CoM margin to the support polygon of the actual
        ground contacts over all iterations; None = an iteration had no ground
        contact), ``final_margin_m``, ``final_feasible``, check timing, and per
        solve the ``margin_m`` and ``feasible`` series.
        """
        reports = [r for rs in self.static_reports.values() for r in rs]
        if not reports:
            return None
        ms = [1e3 * t for t in self.static_check_times]
        margins = [r.margin for r in reports]
        return {
            "iterations_checked": len(reports),
            "equilibrium_iterations": sum(r.feasible for r in reports),
            "min_margin_m": min(margins),
            "final_margin_m": margins[-1],
            "final_feasible": reports[-1].feasible,
            "final_touching_geoms": reports[-1].touching_geoms,
            "median_check_ms": float(np.median(ms)) if ms else 0.0,
            "max_check_ms": max(ms, default=0.0),
            "solves": {
                label: {
                    "iterations": len(rs),
                    "equilibrium_iterations": sum(r.feasible for r in rs),
                    "min_margin_m": min((r.margin for r in rs), default=None),
                    "margin_m": [r.margin for r in rs],
                    "feasible": [r.feasible for r in rs],
                }
                for label, rs in self.static_reports.items()
            },
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: ``converged``, ``iterations``, ``tasks`` (name, level,
        error, satisfied, checked), ``timing`` of the main solve at the top level,
        every solve under ``solves``, ``figures``, ``messages``, ``simulation``
        (:meth:`simulation`), ``motion`` (:meth:`motion`), ``balance``, ``robot``
        (:attr:`robot_state`)."""
        main = self.main_solve()
        main_dict = main.to_dict() if main is not None else {}
        all_ms = [1e3 * t for s in self.solves.values() for t in s.iteration_times]
        out: dict[str, Any] = {
            "name": self.name,
            "passed": self.passed,
            "main_solve": self.main or (list(self.solves)[-1] if self.solves else None),
            "converged": main_dict.get("converged", False),
            "iterations": main_dict.get("iterations", 0),
            "tasks": main_dict.get("tasks", []),
            "timing": {
                **main_dict.get("timing", {}),
                "total_iterations": sum(s.iterations for s in self.solves.values()),
                "all_median_iteration_ms": float(np.median(all_ms)) if all_ms else 0.0,
            },
            "solves": {k: v.to_dict() for k, v in self.solves.items()},
            "figures": self.figures,
            "messages": self.messages,
            "recording": self.recording,
            "simulation": self.simulation(),
            "motion": self.motion(),
            "balance": self.balance,
            "robot": self.robot_state,
        }
        return jsonable(out, "ScenarioResult")

    def to_json(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` to ``path`` (directories created).

        Raises:
            InvalidInput: ``path`` cannot be written (a directory, no permission),
                or a figure JSON cannot hold; nothing is written then.
            OutputError: The write failed (a full disk); nothing is left of it.
        """
        p = inputs.output_path(path, "JSON summary")
        text = json.dumps(self.to_dict(), indent=2)
        p.parent.mkdir(parents=True, exist_ok=True)
        return write_atomic(p, text, "JSON summary")

    def summary(self, *, recording: bool = True) -> str:
        """Readable summary; ``recording`` False leaves out the recording's path."""
        lines = [f"scenario {self.name}: {'PASSED' if self.passed else 'FAILED'}"]
        main = self.main_solve()
        for label, res in self.solves.items():
            text = res.summary() if res is main else res.summary().splitlines()[0]
            lines.append(f"- solve {label!r}: " + text.replace("\n", "\n  "))
        if self.figures:
            lines.append("figures:")
            for k, v in self.figures.items():
                lines.append(f"  {k} = {_short(v)}")
        sim = self.simulation()
        if sim is not None:
            lines.append(
                f"simulation, every iteration: {sim['equilibrium_iterations']}/"
                f"{sim['iterations_checked']} iterations in static equilibrium, min CoM "
                f"margin {_mm(sim['min_margin_m'])}, {sim['median_check_ms']:.2f} ms per check"
            )
        for label, m in self.motions.items():
            lines.append(f"{m.summary()} [{label}]")
        if self.balance is not None:
            lines.append(balance_summary(self.balance))
        lines += self.messages
        if recording and self.recording:
            lines.append(f"recording: {self.recording}  (view with: rerun {self.recording})")
        return "\n".join(lines)


def _mm(x: float | None) -> str:
    return "none (no ground contact)" if x is None or not math.isfinite(x) else f"{x * 1e3:.1f} mm"


def balance_summary(balance: Mapping[str, Any]) -> str:
    """One line: the static check and the physics hold of a balance report."""
    if "error" in balance:
        return f"balance: FAILED ({balance['error']})"
    static, hold = balance["static"], balance["hold"]
    limits = balance.get("joint_limits") or []
    return (
        f"balance: {'PASSED' if balance['passed'] else 'FAILED'} — static equilibrium "
        f"{'feasible' if static['feasible'] else 'INFEASIBLE'}, CoM margin "
        f"{_mm(static['margin'])}; hold {hold['simulated']:.2f} s: drift "
        f"{hold['drift'] * 1e3:.1f} mm, slip {hold['slip'] * 1e3:.2f} mm, min margin "
        f"{_mm(hold['min_margin'])}"
        + ("; balance feedback on" if (hold.get("balance_feedback") or {}).get("on") else "")
        + (f"; {'; '.join(hold['failures'])}" if hold["failures"] else "")
        + "".join(f"; {describe_violation(v)}" for v in limits)
    )


def _short(value: Any) -> str:
    v = jsonable(value)
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list) and v and all(isinstance(x, float) for x in v):
        return "[" + ", ".join(f"{x:.4g}" for x in v) + "]"
    return str(v)
