"""The seed's examples as scenarios: results, recording, simulation, and the registry.

A scenario is a script ``scenarios/<name>.py`` with a ``main(argv=None)`` and a
``run(out=None, *, progress=False, **params) -> ScenarioResult``. It solves with
:mod:`pik_mj.ik`, records its solves through a :class:`ScenarioRecorder` (a rerun
``.rrd`` when ``out`` is given, an iteration counter on stderr when ``progress``),
and ends with checks on its figures (:meth:`ScenarioResult.check`): a failed
check makes the scenario fail, it does not raise.

Simulation (DESIGN.md §5). For a robot with a floating base, the
:class:`ScenarioRecorder` puts the robot in a MuJoCo scene
(:class:`ScenarioScene`: the robot's model with the scenario's environment — the
room for the scenarios placed with :func:`robot_at_spot` — or a floor) and runs
:meth:`pik_mj.sim.Scene.static_check` on every IK iteration's configuration:
actual contacts, support polygon, CoM margin, static-equilibrium LP. With a hold
duration set (:func:`run_options`; ``pik-mj run`` does), the final pose is held in
physics when the recorder closes (:meth:`pik_mj.sim.Scene.hold`), into the same
recording on the ``sim_time`` timeline, and the verdict becomes a check.

The registry (:data:`REGISTRY`) maps names to :class:`Scenario` entries that load
the scripts from the ``scenarios/`` directory of the source tree.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import math
import sys
import time
import weakref
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import TracebackType
from typing import Any

import mujoco
import numpy as np

from . import balance
from .exceptions import InvalidInput, PikError, UnknownName
from .frames import Frame
from .record import Recorder
from .robot import Robot
from .sim import Grasp, Scene, StaticReport
from .solve import IterationInfo, SolveResult
from .tasks.com import CentroidTask
from .tasks.frame import FrameTask
from .tasks.scfr import ScfrTask

SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"
"""Where the scenario scripts live (the source tree's ``scenarios/``)."""

DEFAULT_SCENARIO = "fullbody_reach"
"""What ``pik-mj run`` runs without a name."""

DEFAULT_HOLD = 3.0
"""Physics hold of the final pose at the end of ``pik-mj run`` [s]."""


def jsonable(value: Any) -> Any:
    """``value`` with numpy scalars/arrays turned into Python numbers/lists; non-finite
    floats become None (JSON has no NaN)."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else None
    return value


@dataclass
class ScenarioResult:
    """Outcome of a scenario.

    Attributes:
        name: Scenario name.
        passed: Every check held (and no solve raised).
        solves: The scenario's solves by label, in order.
        figures: Measured numbers (JSON-ready after :meth:`to_dict`).
        messages: One line per check (``ok``/``FAILED``) and notes.
        main: Label of the solve whose state is reported at the top level of
            :meth:`to_dict` (default: the last one).
        recording: Path of the ``.rrd`` written, or None.
        balance: Simulation validation of the final pose (static check + physics
            hold, see :meth:`ScenarioScene.validate`), or None when no hold ran.
        static_reports: Per solve label, the :class:`pik_mj.sim.StaticReport` of
            every IK iteration's configuration (floating-base robots).
        static_check_times: Wall time of each per-iteration static check [s].
        robot_state: The final robot configuration and its scene (``model``,
            ``environment``, ``robot_pos``, ``allowed_contacts``, ``q``), what
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
    robot_state: dict[str, Any] | None = None
    robot: Robot | None = field(default=None, repr=False, compare=False)

    def check(self, label: str, ok: bool, detail: str = "") -> bool:
        """Record a check: ``ok`` False makes the scenario fail."""
        ok = bool(ok)
        self.messages.append(
            f"[{'ok' if ok else 'FAILED'}] {label}" + (f": {detail}" if detail else "")
        )
        if not ok:
            self.passed = False
        return ok

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
        (:meth:`simulation`), ``balance``, ``robot`` (:attr:`robot_state`)."""
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
            "balance": self.balance,
            "robot": self.robot_state,
        }
        return jsonable(out)

    def to_json(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2))

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
    return (
        f"balance: {'PASSED' if balance['passed'] else 'FAILED'} — static equilibrium "
        f"{'feasible' if static['feasible'] else 'INFEASIBLE'}, CoM margin "
        f"{_mm(static['margin'])}; hold {hold['simulated']:.2f} s: drift "
        f"{hold['drift'] * 1e3:.1f} mm, slip {hold['slip'] * 1e3:.2f} mm, min margin "
        f"{_mm(hold['min_margin'])}"
        + (f"; {'; '.join(hold['failures'])}" if hold["failures"] else "")
    )


def _short(value: Any) -> str:
    v = jsonable(value)
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list) and v and all(isinstance(x, float) for x in v):
        return "[" + ", ".join(f"{x:.4g}" for x in v) + "]"
    return str(v)


# ---------------------------------------------------------------------------
# Run options


@dataclass(frozen=True)
class RunOptions:
    """How the :class:`ScenarioRecorder` of a scenario run simulates.

    Scenario scripts do not pass these: :func:`run_scenario` and ``pik-mj run``
    set them with :func:`run_options` around the script's ``run``.

    Attributes:
        static_check: Run :meth:`pik_mj.sim.Scene.static_check` on every IK
            iteration (floating-base robots).
        hold: Duration [s] of the physics hold of the final pose when the
            recorder closes, or None for no hold.
        model: Model name or MJCF path the scenario was asked to load (helps to
            find the MJCF of a robot loaded from a path).
    """

    static_check: bool = True
    hold: float | None = None
    model: str | None = None


_OPTIONS: ContextVar[RunOptions | None] = ContextVar("pik_mj_run_options", default=None)


def current_run_options() -> RunOptions:
    """The :class:`RunOptions` in effect (defaults outside :func:`run_options`)."""
    return _OPTIONS.get() or RunOptions()


@contextmanager
def run_options(**changes: Any) -> Iterator[RunOptions]:
    """Set :class:`RunOptions` fields for the scenarios run inside the block."""
    unknown = set(changes) - set(RunOptions.__dataclass_fields__)
    if unknown:
        raise InvalidInput(
            f"unknown run options {sorted(unknown)}; valid: {list(RunOptions.__dataclass_fields__)}"
        )
    hold = changes.get("hold")
    if hold is not None and not (math.isfinite(hold) and hold > 0):
        raise InvalidInput(f"hold must be a duration > 0 [s] or None, got {hold}")
    options = replace(current_run_options(), **changes)
    token = _OPTIONS.set(options)
    try:
        yield options
    finally:
        _OPTIONS.reset(token)


# ---------------------------------------------------------------------------
# The scenario's robot in a simulated scene

#: Robots placed in an environment by :func:`robot_at_spot`: robot -> (model, environment).
_PLACED: weakref.WeakKeyDictionary[Robot, tuple[str, str]] = weakref.WeakKeyDictionary()

_QPOS_WIDTH = {mujoco.mjtJoint.mjJNT_FREE: 7, mujoco.mjtJoint.mjJNT_BALL: 4}


def _model_name(model: mujoco.MjModel) -> str:
    return model.names[: model.names.index(b"\0")].decode()


@functools.lru_cache(maxsize=32)
def _spec_signature(source: str) -> tuple[str, int]:
    """(model name, number of joints) of the MJCF ``source``."""
    from .models import load_spec

    spec = load_spec(source)
    return spec.modelname, len(spec.joints)


def model_source(model: mujoco.MjModel, hint: str | None = None) -> str:
    """The model name (or MJCF path) that ``model`` was loaded from.

    Candidates are ``hint`` and :func:`pik_mj.models.available_models`; one
    matches when its MJCF has the same model name and number of joints.

    Raises:
        PikError: No candidate matches.
    """
    from .models import available_models

    name = _model_name(model)
    candidates = ([str(hint)] if hint else []) + [n for n in available_models() if n != hint]
    for c in candidates:
        try:
            if _spec_signature(c) == (name, model.njnt):
                return c
        except PikError:
            continue
    raise PikError(
        f"cannot tell which MJCF model {name!r} ({model.njnt} joints) was loaded from; "
        f"tried {candidates}"
    )


def robot_contact_forces(
    model: mujoco.MjModel, data: mujoco.MjData, robot_geom: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Points ``p_WC`` (n, 3) [m] and forces (n, 3) [N] on the robot of the active
    contacts between robot geoms and other geoms (MuJoCo's ``mj_contactForce``).

    MuJoCo's contact frame has its normal (first row of ``frame``) from geom1 to
    geom2 and gives the force of geom1 on geom2 in that frame:

    .. math::
        f_W = R_{WC} f_C, \\quad R_{WC} = \\text{frame}^T, \\qquad
        f_{robot} = \\pm f_W \\;(+ \\text{ if the robot geom is geom2})
    """
    points, forces = [], []
    f6 = np.zeros(6)
    for i in range(data.ncon):
        c = data.contact[i]
        r1, r2 = bool(robot_geom[c.geom1]), bool(robot_geom[c.geom2])
        if r1 == r2 or c.efc_address < 0:  # not robot-environment, or inactive
            continue
        mujoco.mj_contactForce(model, data, i, f6)
        f_W = np.asarray(c.frame).reshape(3, 3).T @ f6[:3]
        points.append(np.array(c.pos))
        forces.append(f_W if r2 else -f_W)
    return np.array(points).reshape(-1, 3), np.array(forces).reshape(-1, 3)


class _HoldRecorder:
    """The recorder :meth:`Scene.hold` sees: every logged sample of body poses
    also logs the contact forces on the robot and their total vertical force."""

    def __init__(self, recorder: Recorder, scene: Scene):
        self._recorder = recorder
        self._scene = scene
        m = scene.model
        root = m.body(scene.root_body).id
        self._robot_geom = np.asarray(m.body_rootid)[m.geom_bodyid] == root

    def __getattr__(self, name: str) -> Any:
        return getattr(self._recorder, name)

    def log_body_poses(
        self, data: mujoco.MjData, *, timeline: str = "sim_time", time: float
    ) -> None:
        rec = self._recorder
        rec.log_body_poses(data, timeline=timeline, time=time)
        p, f = robot_contact_forces(self._scene.model, data, self._robot_geom)
        rec.log_contacts(p, f)
        rec.log_scalar(rec.paths.hold_metric("contact_force_z"), float(f[:, 2].sum()))


class ScenarioScene:
    """A scenario's robot in a simulated :class:`pik_mj.sim.Scene`.

    The scene holds the robot's own MJCF (``model``) and ``environment``; the
    robot configuration of the scenario (``robot.configuration.q``, possibly of a
    model composed with the environment) is mapped to the scene's robot-only
    ``q`` by joint names. A robot placed with :func:`robot_at_spot` has its free
    joint in world coordinates already, so the scene puts the robot model's
    origin at the world origin. A robot alone gets a floor at z = 0; when its
    start pose floats above it (dm_control's humanoids stand 0.2 m up), the
    robot is lowered by that gap (``robot_pos``) so its feet touch the floor — the
    IK keeps the feet where they are and takes them to be on the ground.

    Args:
        robot: The scenario's robot (read, never changed).
        model: Name or MJCF path of the robot's model.
        environment: Environment name, or None for a floor.
        ground: Lower a robot alone onto the floor (see above).

    Attributes:
        scene: The :class:`pik_mj.sim.Scene`.
        robot_pos: Where the robot model's origin is in the scene [m].
    """

    def __init__(
        self, robot: Robot, model: str, environment: str | None = None, *, ground: bool = True
    ):
        self.robot = robot
        self.model = str(model)
        self.environment = environment
        self.robot_pos = np.zeros(3)
        self.allowed_contacts: list[str] | None = None
        self.grasps: list[Grasp] = []  # objects held by robot frames (see grasp)
        # Wrenches the pose was solved for: (frame, force [N], moment [N·m]),
        # applied during the static check and the hold.
        self.external: list[tuple[str, Any, Any]] = []
        self.scene = Scene(self.model, environment)
        self._map_joints()
        if ground and environment is None:
            gap = self.ground_gap()
            if gap > self.scene.contact_tolerance:
                self.robot_pos = np.array([0.0, 0.0, -gap])
                self.scene = Scene(self.model, None, robot_pos=self.robot_pos)

    @classmethod
    def for_robot(cls, robot: Robot, model_hint: str | None = None) -> ScenarioScene:
        """The scene of ``robot``: its placement by :func:`robot_at_spot`, or its
        MJCF found by :func:`model_source` with a floor.

        Raises:
            PikError: The robot has no floating base, or its model is a composed
                scene that was not made by :func:`robot_at_spot`, or its MJCF
                cannot be found.
        """
        if not robot.has_floating_base:
            raise PikError(f"robot {robot.root_body!r} has no floating base: no balance to check")
        placed = _PLACED.get(robot)
        if placed is not None:
            return cls(robot, placed[0], placed[1])
        m = robot.model
        if np.any(np.asarray(m.body_rootid)[1:] != robot.root_body_id):
            raise PikError(
                "the robot's model holds other bodies than the robot; place it with "
                "pik_mj.scenarios.robot_at_spot so its environment is known"
            )
        return cls(robot, model_source(m, model_hint), None)

    def grasp(self, pairs: Sequence[tuple[str, str]]) -> None:
        r"""Hold objects in the robot's frames from now on (static check and hold).

        Each ``(frame, body)`` pair names a robot frame F (site or body) and a free
        body O of the environment; O's pose relative to F is read from the
        robot's configuration now (the scenario has carried the object with the
        hand), and the scene is rebuilt with a :class:`pik_mj.sim.Grasp`
        (weld equality, O's mass in the system):

        .. math::

            X_{FO} = X_{WF}^{-1} X_{WO}, \quad
            p_{FO} = R_{WF}^T (p_{WO} - p_{WF}), \quad R_{FO} = R_{WF}^T R_{WO}

        Raises:
            UnknownName: A frame or body unknown to the robot's model or the scene.
        """
        grasps = []
        for frame, body in pairs:
            X_WF = self.robot.frame_pose(frame, _frame_type(self.robot.model, frame))
            X_WO = self.robot.frame_pose(body, "body")
            X_FO = X_WF.inverse() @ X_WO
            grasps.append(Grasp(frame, body, X_FO.translation(), X_FO.rotation().as_matrix()))
        self.scene = Scene(self.model, self.environment, robot_pos=self.robot_pos, grasps=grasps)
        self.grasps = grasps

    def _map_joints(self) -> None:
        rm, m = self.scene.robot_model, self.robot.model
        src: list[int] = []
        dst: list[int] = []
        for j in range(rm.njnt):
            name = rm.joint(j).name
            k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            if k < 0 or m.jnt_type[k] != rm.jnt_type[j]:
                raise PikError(
                    f"joint {name!r} of model {self.model!r} is missing from the robot's "
                    "model or has another type"
                )
            n = _QPOS_WIDTH.get(int(rm.jnt_type[j]), 1)
            src += range(int(m.jnt_qposadr[k]), int(m.jnt_qposadr[k]) + n)
            dst += range(int(rm.jnt_qposadr[j]), int(rm.jnt_qposadr[j]) + n)
        self._src, self._dst = np.array(src, dtype=int), np.array(dst, dtype=int)
        self._nq = rm.nq

    def q_robot(self) -> np.ndarray:
        """The scene's robot configuration (``scene.robot_model.nq``) now."""
        q = np.zeros(self._nq)
        q[self._dst] = self.robot.configuration.q[self._src]
        return q

    def ground_gap(self) -> float:
        """Smallest distance [m] of the allowed contact geoms (soles) to a floor
        plane of the scene, at the robot's current pose (``mj_geomDistance``)."""
        sc = self.scene
        sc.set_pose(self.q_robot())
        m = sc.model
        root = m.body(sc.root_body).id
        robot_geom = np.asarray(m.body_rootid)[m.geom_bodyid] == root
        planes = [
            g
            for g in range(m.ngeom)
            if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE and not robot_geom[g]
        ]
        feet = [m.geom(n).id for n in sc.allowed_contacts]
        if not planes or not feet:
            return 0.0
        return min(
            mujoco.mj_geomDistance(m, sc.data, a, p, 10.0, None) for a in feet for p in planes
        )

    def static_check(self) -> StaticReport:
        """:meth:`pik_mj.sim.Scene.static_check` of the robot's configuration now."""
        return self.scene.static_check(self.q_robot())

    def validate(self, duration: float, recorder: Recorder | None = None) -> dict[str, Any]:
        """Static check and physics hold of the robot's configuration now.

        The geoms allowed to touch the environment during the hold are the
        scene's default (the soles) plus those touching it in this pose (e.g. a
        palm on a wall): the contacts the solve made are intended, new ones are not.

        Returns:
            ``{"model", "environment", "robot_pos", "static", "hold", "passed"}``
            as :func:`pik_mj.sim.validate_pose`; on a simulation failure
            ``{"passed": False, "error": message, ...}``.
        """
        from .exceptions import SimulationUnstable

        q = self.q_robot()
        self.scene.set_pose(q)
        wrenches = [
            balance.ExternalWrench(Frame.find(self.scene.model, f).position(self.scene.data), F, M)
            for f, F, M in self.external
        ]
        static = self.scene.static_check(q, external=wrenches)
        self.allowed_contacts = sorted(
            set(self.scene.allowed_contacts) | set(static.touching_geoms)
        )
        out: dict[str, Any] = {
            "model": self.model,
            "environment": self.environment,
            "robot_pos": self.robot_pos,
            "static": static.to_dict(),
        }
        hold_rec = None if recorder is None else _HoldRecorder(recorder, self.scene)
        try:
            hold = self.scene.hold(
                q,
                duration,
                recorder=hold_rec,
                allowed=self.allowed_contacts,
                external=self.external,
            )
        except SimulationUnstable as exc:
            return {**out, "hold": None, "passed": False, "error": str(exc)}
        return {**out, "hold": hold.to_dict(), "passed": bool(static.feasible and hold.passed)}

    def state(self) -> dict[str, Any]:
        """What ``pik-mj validate`` needs to rebuild this scene and pose: the
        robot-only ``q``, its placement, allowed contacts and held objects
        (``grasps``: ``{"frame", "body", "p_FO" [m], "R_FO"}`` each)."""
        return {
            "model": self.model,
            "environment": self.environment,
            "robot_pos": self.robot_pos,
            "allowed_contacts": self.allowed_contacts,
            "grasps": [
                {"frame": g.frame, "body": g.body, "p_FO": g.p_FO, "R_FO": g.R_FO}
                for g in self.grasps
            ],
            "q": self.q_robot(),
        }


def _frame_type(model: mujoco.MjModel, name: str) -> str:
    """``"site"`` or ``"body"``: the kind of frame ``name`` is in ``model``."""
    return Frame.find(model, name, None).frame_type


def _shrunk_polygon(vertices: np.ndarray, d: float) -> np.ndarray:
    """The convex polygon ``vertices`` (m, 3) (horizontal, counter-clockwise)
    with every edge moved inward by ``d`` [m]; (0, 3) when it vanishes.

    Vertex ``i`` is where the moved edges ``i-1`` and ``i`` meet:
    ``a_{i-1}^T v + b_{i-1} - d = 0 = a_i^T v + b_i - d``.
    """
    from .balance import halfplanes_from_polygon, shrink

    try:
        A, b = shrink(halfplanes_from_polygon(vertices[:, :2]), d)
    except InvalidInput:  # near-degenerate hull
        return np.zeros((0, 3))
    out = []
    for i in range(len(A)):
        M = np.array([A[i - 1], A[i]])
        if abs(np.linalg.det(M)) < 1e-12:
            return np.zeros((0, 3))
        out.append(np.linalg.solve(M, -np.array([b[i - 1], b[i]])))
    xy = np.array(out)
    if np.any(xy @ A.T + b < -1e-9):  # shrunk past a vertex: not the true offset
        return np.zeros((0, 3))
    return np.column_stack([xy, np.full(len(xy), float(np.mean(vertices[:, 2])))])


def _quat_wxyz(R: np.ndarray) -> np.ndarray:
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).ravel())
    return q


# ---------------------------------------------------------------------------
# Recording and progress


@dataclass
class _LogPlan:
    """The tasks of one solve's stack that :class:`ScenarioRecorder` logs."""

    levels: list[list[Any]]  # the stack it was made for (compared by identity)
    centroid: CentroidTask | None  # the first one: its target is the CoM target
    frames: list[tuple[FrameTask, str, str]]  # (task, target path, current path)
    current_paths: tuple[str, ...]
    scfr: list[ScfrTask]


class ScenarioRecorder:
    """Records a scenario's solves: a rerun file (if ``out``), progress on stderr,
    and, for a floating-base robot, a static check in simulation every iteration.

    Usage in a scenario::

        with ScenarioRecorder(out, robot, progress=progress) as rec:
            res = fullbody_inverse_kinematics(robot, ..., callback=rec.callback("reach"))
            rec.record("reach", res)
        rec.fill(result, main="reach")

    The ``iteration`` timeline counts iterations over all solves of the scenario.
    Each solve logs its start pose (at the current count); every iteration
    (count + 1) logs the body poses, the CoM and the target of a
    :class:`~pik_mj.tasks.com.CentroidTask`, the target and current frame of every
    :class:`~pik_mj.tasks.frame.FrameTask` (``world/tasks/<task>/target|current``),
    each task's error norm at ``errors/level_<k>/<task>``, and — from the
    :class:`ScenarioScene`'s static check — the support polygon of the actual
    ground contacts with the CoM's iso-margin outline (the polygon shrunk by the
    CoM margin, through the CoM's projection; ``<polygon>/margin``), the contact
    points with the LP's contact forces, and the scalars ``balance/margin`` [m],
    ``balance/feasible`` (1/0) and ``balance/contacts``; an SCFR task's region at
    ``world/scfr``. :meth:`record` logs the solve's final pose one tick later (the
    start pose again when it reverted) and a text line on a level failure or a
    revert. The blueprint, sent once when the recording is closed, opens on the
    3D view beside the per-level error plots.

    When the block ends without an exception and a hold duration is set
    (:func:`run_options`), the final pose is held in physics
    (:meth:`ScenarioScene.validate`) and logged on ``sim_time`` (body poses, CoM,
    support polygon, contact forces, ``hold/drift``, ``hold/slip``,
    ``hold/margin``, ``hold/contact_force_z``) before the file is closed. The
    file is flushed and closed also when the block raises.

    Args:
        out: ``.rrd`` path, or None for no recording.
        robot: The robot solved on (its model is logged once, statically).
        progress: Print ``\\r<solve> iteration <k>`` on stderr while solving.
        name: Application name in the recording.
        simulate: Run the per-iteration static check (default: the run option
            ``static_check``; only for robots with a floating base).
        hold: Hold duration [s] at the end (default: the run option ``hold``).

    Attributes:
        scene: The :class:`ScenarioScene`, or None (no floating base, or
            ``simulate`` off).
        static_reports: Per solve label, one static report per iteration.
        balance: The hold's report after :meth:`close`, or None.
    """

    def __init__(
        self,
        out: str | Path | None,
        robot: Robot,
        *,
        progress: bool = False,
        name: str = "pik_mj",
        simulate: bool | None = None,
        hold: float | None = None,
    ):
        options = current_run_options()
        self.robot = robot
        self.progress = progress
        self.results: dict[str, SolveResult] = {}
        self.iteration = 0
        self.static_reports: dict[str, list[StaticReport]] = {}
        self.static_check_times: list[float] = []
        self.balance: dict[str, Any] | None = None
        self.notes: list[str] = []
        self.hold_duration = options.hold if hold is None else hold
        self.scene: ScenarioScene | None = None
        simulate = options.static_check if simulate is None else simulate
        if (simulate or self.hold_duration) and robot.has_floating_base:
            try:
                self.scene = ScenarioScene.for_robot(robot, options.model)
            except PikError as exc:
                self.notes.append(f"no simulation: {exc}")
        self._simulate = bool(simulate) and self.scene is not None
        self.path = None if out is None else Path(out)
        self.recorder: Recorder | None = None
        if self.path is not None:
            self.recorder = Recorder.to_file(self.path, application_id=name)
            self.recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
            for note in self.notes:
                self.recorder.log_text(note, level="WARN")
            # the static geometry is on disk before the first solve: a run that
            # dies later still leaves a file that shows the robot
            self.recorder.flush()
        self._label = ""
        self._n_levels = 0  # most levels (level 0 included) of any solve so far
        self._task_frame_paths: dict[str, tuple[str, str]] = {}
        self._log_plan: _LogPlan | None = None
        self._logged_targets: dict[str, object] = {}
        self._feasible: bool | None = None
        self._closed = False

    def __enter__(self) -> ScenarioRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close(exc)

    def close(self, exc: BaseException | None = None) -> None:
        """Hold the final pose (when configured and ``exc`` is None), then flush
        and close the recording. Idempotent.

        Args:
            exc: The exception that ended the scenario, if any: it is written to
                the text log and no hold runs.
        """
        if self._closed:
            return
        self._closed = True
        try:
            if exc is not None:
                if self.recorder is not None:
                    self.recorder.log_text(
                        f"scenario raised {type(exc).__name__}: {exc}", level="ERROR"
                    )
            elif self.hold_duration and self.scene is not None:
                self._hold(float(self.hold_duration))
        finally:
            if self.recorder is not None:
                try:
                    # rows first: the stream writes them while the blueprint is built
                    self.recorder.send_buffered()
                    self._send_blueprint()
                finally:
                    self.recorder.close()
                    self.recorder = None

    def hold_external(self, wrenches: Sequence[tuple[str, Any, Any]]) -> None:
        """Wrenches ``(frame, force, moment)`` the final pose is balanced against:
        the static check and the hold apply them (e.g. forces at the hands)."""
        if self.scene is not None:
            self.scene.external = [(str(f), F, M) for f, F, M in wrenches]

    def _hold(self, duration: float) -> None:
        rec = self.recorder
        if self.progress:
            sys.stderr.write(f"  physics hold of the final pose: {duration:g} s ...")
            sys.stderr.flush()
        if rec is not None:
            rec.disable_timeline("iteration")
            rec.set_time("sim_time", 0.0)
            rec.log_text(f"physics hold of the final pose for {duration:g} s")
        self.balance = self.scene.validate(duration, rec) if self.scene is not None else None
        text = balance_summary(self.balance) if self.balance is not None else "no hold"
        if self.progress:
            sys.stderr.write(
                f" {'passed' if self.balance and self.balance['passed'] else 'FAILED'}\n"
            )
            sys.stderr.flush()
        if rec is not None:
            rec.log_text(text, level="INFO" if self.balance and self.balance["passed"] else "ERROR")

    # -- per-iteration logging --------------------------------------------------

    def _log_pose(self, com_target: Any = None) -> None:
        if self.recorder is None:
            return
        self.recorder.log_body_poses(self.robot.data, time=self.iteration)
        if com_target is not None:  # logged when it changes, like fixed frame targets
            com_target = np.asarray(com_target, dtype=float)
            last = self._logged_targets.get(self.recorder.paths.com_target)
            if isinstance(last, np.ndarray) and np.array_equal(last, com_target):
                com_target = None
            else:
                self._logged_targets[self.recorder.paths.com_target] = com_target.copy()
        self.recorder.log_com(self.robot.com(), target=com_target)

    def _frame_paths(self, task: str) -> tuple[str, str]:
        """Entity paths of a frame task's target and current frame (cached)."""
        paths = self._task_frame_paths.get(task)
        if paths is None:
            assert self.recorder is not None
            p = self.recorder.paths
            paths = self._task_frame_paths[task] = (p.task_target(task), p.task_current(task))
        return paths

    def _plan(self, levels: list[list[Any]]) -> _LogPlan:
        """What ``levels`` log each iteration (made once per solve: the solve
        loop passes the same stack every iteration)."""
        plan = self._log_plan
        if plan is not None and plan.levels is levels:
            return plan
        tasks = [task for level in levels for task in level]
        centroids = [t for t in tasks if isinstance(t, CentroidTask)]
        frames = [(t, *self._frame_paths(t.name)) for t in tasks if isinstance(t, FrameTask)]
        plan = self._log_plan = _LogPlan(
            levels=levels,
            centroid=centroids[0] if centroids else None,
            frames=frames,
            current_paths=tuple(current for _, _, current in frames),
            scfr=[t for t in tasks if isinstance(t, ScfrTask)],
        )
        return plan

    def _log_tasks(self, info: IterationInfo) -> None:
        """CoM (+ target), task frames, task errors and SCFR regions."""
        rec = self.recorder
        assert rec is not None
        cfg, data = info.configuration, info.configuration.data
        plan = self._plan(info.levels)
        com_target = None if plan.centroid is None else plan.centroid.target_now(cfg)
        for task, target_path, _ in plan.frames:
            # a fixed target is logged when it changes: the viewer holds the
            # latest value (callable and robot-frame targets move)
            fixed = task.target_pose
            if fixed is None or self._logged_targets.get(target_path) is not fixed:
                p_T, R_T = task.target_pose_now(cfg)
                rec.log_frame(target_path, p_T, _quat_wxyz(R_T))
                self._logged_targets[target_path] = fixed
        if plan.frames:  # all current frames in one call (one buffer)
            rec.log_frames(
                plan.current_paths,
                [task.move_target.position(data) for task, _, _ in plan.frames],
                [_quat_wxyz(task.move_target.rotation(data)) for task, _, _ in plan.frames],
            )
        for task in plan.scfr:
            region = task.region(cfg)
            if not region.empty:
                z = float(np.mean([c.p_WC[2] for c in task.contacts_now(cfg)]))
                v = np.column_stack([region.vertices, np.full(len(region.vertices), z)])
                rec.log_polygon(v, path=rec.paths.scfr, color=(40, 200, 120))
        self._log_pose(com_target)
        # the solve loop's own evaluation at this configuration: no recomputation
        rec.log_task_errors({(r.level, r.name): r.error for r in info.tasks})
        self._n_levels = max(self._n_levels, len(info.levels))

    def _send_blueprint(self) -> None:
        """One blueprint, sent at the end: a plot per level of every solve
        (a later solve with fewer levels must not hide an earlier one's), the
        simulation's series when they were logged."""
        rec = self.recorder
        assert rec is not None
        extra = [(rec.paths.balance, "balance (simulation)")] if self._simulate else []
        if self.balance is not None:
            extra.append((rec.paths.hold, "physics hold"))
        rec.send_blueprint(range(1, self._n_levels), extra=extra)

    def _log_static(self, report: StaticReport) -> None:
        rec = self.recorder
        assert rec is not None and self.scene is not None
        # scene frame -> the IK model's frame (they differ by a lowered robot's gap)
        shift = -self.scene.robot_pos
        poly = report.support_polygon + shift
        if len(poly) >= 3:
            shrunk = _shrunk_polygon(poly, report.margin) if report.margin > 0 else np.zeros((0, 3))
            rec.log_polygon(poly, shrunk)
        else:
            rec.log_polygon(np.zeros((0, 3)), np.zeros((0, 3)))
        env = report.environment_contacts
        forces = np.zeros((len(env), 3)) if report.forces is None else report.forces
        rec.log_contacts(np.array([c.position for c in env]).reshape(-1, 3) + shift, forces)
        paths = rec.paths
        if math.isfinite(report.margin):
            rec.log_scalar(paths.balance_metric("margin"), report.margin)
        rec.log_scalar(paths.balance_metric("feasible"), float(report.feasible))
        rec.log_scalar(paths.balance_metric("contacts"), float(len(env)))
        if report.feasible != self._feasible:
            if self._feasible is not None or not report.feasible:
                rec.log_text(
                    f"{self._label}: static equilibrium "
                    + ("regained" if report.feasible else f"infeasible ({report.message})"),
                    level="INFO" if report.feasible else "WARN",
                )
            self._feasible = report.feasible

    def callback(self, label: str) -> Callable[[IterationInfo], None]:
        """Start solve ``label`` (its start pose is logged) and return its callback."""
        self._label = label
        reports = self.static_reports.setdefault(label, [])
        if self.recorder is not None:
            self.recorder.set_time("iteration", self.iteration)
            self.recorder.log_text(f"solve {label!r} starts")
        self._log_pose()

        def on_iteration(info: IterationInfo) -> None:
            self.iteration += 1
            if self.progress:
                sys.stderr.write(f"\r  {label}: iteration {info.iteration:4d}")
                sys.stderr.flush()
            report = None
            if self._simulate:
                assert self.scene is not None
                t0 = time.perf_counter()
                report = self.scene.static_check()
                self.static_check_times.append(time.perf_counter() - t0)
                reports.append(report)
            if self.recorder is None:
                return
            self.recorder.set_time("iteration", self.iteration)
            self._log_tasks(info)
            if report is not None:
                self._log_static(report)

        return on_iteration

    def fill(self, result: ScenarioResult, main: str | None = None) -> None:
        """Hand the solves, static checks, balance report, robot state and the
        recording path to ``result``; a hold that ran becomes a check."""
        result.solves = dict(self.results)
        result.main = main
        result.robot = self.robot
        result.recording = None if self.path is None else str(self.path)
        result.static_reports = {k: list(v) for k, v in self.static_reports.items() if v}
        result.static_check_times = list(self.static_check_times)
        result.robot_state = None if self.scene is None else self.scene.state()
        for note in self.notes:
            if f"note: {note}" not in result.messages:
                result.messages.append(f"note: {note}")
        result.balance = self.balance
        if self.balance is not None:
            result.check(
                f"simulation: final pose in static equilibrium and held "
                f"{self.hold_duration:g} s in physics",
                self.balance["passed"],
                balance_summary(self.balance).removeprefix("balance: "),
            )

    def record(self, label: str, result: SolveResult) -> SolveResult:
        """Keep ``result`` under ``label``, log the solve's final pose and, in the
        text log, its outcome (level failure, revert)."""
        self.results[label] = result
        if self.progress:
            sys.stderr.write(
                f"\r  {label}: {result.iterations} iterations, "
                f"{'converged' if result.converged else 'NOT converged'}\n"
            )
            sys.stderr.flush()
        self.iteration += 1
        self._log_pose()
        if self.recorder is not None:
            rec = self.recorder
            if result.failure:
                rec.log_text(f"solve {label!r}: level failure: {result.failure}", level="ERROR")
            rec.log_text(
                f"solve {label!r}: {'converged' if result.converged else 'not converged'}"
                f" after {result.iterations} iterations"
                + (", reverted to its start pose" if result.reverted else ""),
                level="INFO" if result.converged else "WARN",
            )
        return result


# ---------------------------------------------------------------------------
# Geometry helpers shared by the scenarios


def com_margin(robot: Robot, point: np.ndarray | None = None) -> float:
    """Signed distance [m] of the CoM's (or ``point``'s) ground projection to the edges
    of the support polygon of both soles, positive inside."""
    from .balance import support_polygon
    from .ik import sole_polygons

    region = support_polygon(sole_polygons(robot))
    return float(region.signed_distance(robot.com() if point is None else np.asarray(point)))


def robot_at_spot(robot: str, spot: str, environment: str = "room") -> Robot:
    """The robot standing in ``environment`` with its root over the site ``spot``.

    The spot's position (x, y) and yaw are read from the environment model; the
    robot is attached there with :func:`pik_mj.models.compose_scene`, so the robot
    and the room's objects (e.g. the kettle's ``kettle_handle`` site) share one
    world frame, and the robot's ``reset_pose`` keyframe is moved with it. The
    robot's :class:`ScenarioScene` is then ``robot`` in ``environment``.
    """
    from .models import compose_scene, load_model

    env = load_model(environment)
    data = mujoco.MjData(env)
    mujoco.mj_kinematics(env, data)
    site = Frame.find(env, spot, "site")
    p, R = site.position(data), site.rotation(data)
    spec = compose_scene(
        robot, environment, robot_pos=(p[0], p[1], 0.0), robot_yaw=math.atan2(R[1, 0], R[0, 0])
    )
    placed = Robot(spec.compile())
    _PLACED[placed] = (robot, environment)
    return placed


# ---------------------------------------------------------------------------
# Registry


@dataclass(frozen=True)
class Scenario:
    """A registry entry.

    Attributes:
        name: Scenario name.
        description: One line for ``pik-mj list``.
        script: File name in :data:`SCENARIO_DIR`, or None when ``fn`` is given.
        fn: The ``run`` function itself (for entries defined in code, e.g. tests).
        requires: Modules the scenario needs; while one is missing the scenario
            is *waiting* and does not run.
        accepts_model: Whether ``run`` takes a ``model`` argument.
        walking: A walking scenario: its motion is already played in physics
            (no IK iterations through a :class:`ScenarioRecorder`, no hold).
    """

    name: str
    description: str
    script: str | None = None
    fn: Callable[..., ScenarioResult] | None = None
    requires: tuple[str, ...] = ()
    accepts_model: bool = False
    walking: bool = False

    def missing(self) -> list[str]:
        """Required modules that cannot be found."""
        out = []
        for mod in self.requires:
            try:
                found = importlib.util.find_spec(mod) is not None
            except ModuleNotFoundError:
                found = False
            if not found:
                out.append(mod)
        return out

    def load(self) -> Callable[..., ScenarioResult]:
        """The scenario's ``run`` function."""
        if self.fn is not None:
            return self.fn
        path = SCENARIO_DIR / str(self.script)
        if not path.is_file():
            raise PikError(f"scenario script {str(path)!r} is missing")
        spec = importlib.util.spec_from_file_location(f"pik_mj_scenario_{self.name}", path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module.run


REGISTRY: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario(
            "three_dof_reach",
            "3-DoF arm: reach sweep; the seed's failing case reverts; an unreachable one stretches",
            "three_dof_reach.py",
        ),
        Scenario(
            "cocktail_shaker",
            "dual arm: left hand on a path, right hand target a callable of the left hand",
            "cocktail_shaker.py",
        ),
        Scenario(
            "fullbody_reach",
            "fullbody IK: feet fixed, CoM over the feet, left hand reaching low (default)",
            "fullbody_reach.py",
            accepts_model=True,
        ),
        Scenario(
            "fullbody_external_force",
            "fullbody IK with forces on both hands: static balance point between the feet",
            "fullbody_external_force.py",
        ),
        Scenario(
            "kettle",
            "room: robot at spot_counter_front looks at the kettle, grasps the handle, lifts 0.1 m",
            "kettle.py",
        ),
        Scenario(
            "wall_contact",
            "room: a hand on the wall at spot_wall, CoM in the SCFR of feet + hand",
            "wall_contact.py",
            requires=("pik_mj.tasks.scfr",),
        ),
        Scenario(
            "walk_forward",
            "walking: 4 steps of 0.12 m by preview control + whole-body IK, played in physics",
            "walk_forward.py",
            walking=True,
        ),
        Scenario(
            "walk_go_pos",
            "walking: go_pos(0.5 m, 0.15 m, 45°) footsteps, pattern played in physics",
            "walk_go_pos.py",
            walking=True,
        ),
    )
}


def scenario(name: str) -> Scenario:
    """The registry entry ``name``."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise UnknownName("scenario", name, REGISTRY) from None


def check_runnable(name: str, model: str | None = None) -> Scenario:
    """The entry ``name`` if it can run (with ``model``), else a usage error.

    Raises:
        UnknownName: No such scenario.
        InvalidInput: ``model`` given to a scenario that does not take one.
        PikError: The scenario is waiting for a module that does not exist yet.
    """
    entry = scenario(name)
    missing = entry.missing()
    if missing:
        raise PikError(f"scenario {name!r} is waiting for {missing} (not available yet)")
    if model is not None and not entry.accepts_model:
        takes = [s.name for s in REGISTRY.values() if s.accepts_model]
        raise InvalidInput(f"scenario {name!r} takes no model; scenarios that do: {takes}")
    return entry


def run_scenario(
    name: str,
    out: str | Path | None = None,
    *,
    progress: bool = False,
    model: str | None = None,
    hold: float | None = None,
    static_check: bool = True,
    params: Mapping[str, Any] | None = None,
) -> ScenarioResult:
    """Run scenario ``name`` (see :data:`REGISTRY`).

    Args:
        name: Scenario name.
        out: ``.rrd`` file to write, or None.
        progress: Iteration counter on stderr.
        model: Robot model for scenarios that take one.
        hold: Physics hold of the final pose [s] (floating-base robots), or None.
        static_check: Static check in simulation at every IK iteration.
        params: More keyword arguments of the scenario's ``run`` (e.g. a shorter
            walk: ``{"n_steps": 2}``).

    Raises:
        UnknownName: No such scenario.
        InvalidInput: ``model`` given to a scenario that does not take one, or
            ``params`` the scenario does not take.
        PikError: The scenario is waiting for a module that does not exist yet.
    """
    import inspect

    entry = check_runnable(name, model)
    run = entry.load()
    kwargs: dict[str, Any] = {"progress": progress, **(params or {})}
    if model is not None:
        kwargs["model"] = model
    accepted = inspect.signature(run).parameters
    takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in accepted.values())
    unknown = [k for k in kwargs if k not in accepted and k != "progress"]
    if unknown and not takes_any:
        valid = [p for p in accepted if p not in ("out", "progress")]
        raise InvalidInput(f"scenario {name!r} takes no parameter {unknown}; it takes {valid}")
    with run_options(hold=hold, static_check=static_check, model=model):
        return run(out, **kwargs)


def main_for(run: Callable[..., ScenarioResult], argv: list[str] | None, doc: str | None) -> int:
    """The ``main`` of a scenario script: ``--out FILE.rrd``, ``--json FILE``,
    ``--model NAME`` (if ``run`` takes one), ``--hold SECONDS`` (physics hold of
    the final pose, default 3; 0: none); prints the summary; 0 iff passed."""
    import argparse
    import inspect

    parser = argparse.ArgumentParser(description=(doc or "").strip().splitlines()[0])
    parser.add_argument("--out", help="rerun recording to write (.rrd)")
    parser.add_argument("--json", help="JSON summary to write")
    parser.add_argument(
        "--hold", type=float, default=DEFAULT_HOLD, help="physics hold of the final pose [s]"
    )
    takes_model = "model" in inspect.signature(run).parameters
    if takes_model:
        parser.add_argument("--model", help="robot model name or MJCF path")
    args = parser.parse_args(argv)
    kwargs: dict[str, Any] = {"progress": True}
    model = args.model if takes_model and args.model else None
    if model:
        kwargs["model"] = model
    with run_options(hold=args.hold if args.hold > 0 else None, model=model):
        result = run(args.out, **kwargs)
    print(result.summary())
    if args.json:
        result.to_json(args.json)
    return 0 if result.passed else 1
