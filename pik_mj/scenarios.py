"""The seed's examples as scenarios: results, recording, and the registry the CLI uses.

A scenario is a script ``scenarios/<name>.py`` with a ``main(argv=None)`` and a
``run(out=None, *, progress=False, **params) -> ScenarioResult``. It solves with
:mod:`pik_mj.ik`, records its solves through a :class:`ScenarioRecorder` (a rerun
``.rrd`` when ``out`` is given, an iteration counter on stderr when ``progress``),
and ends with checks on its figures (:meth:`ScenarioResult.check`): a failed
check makes the scenario fail, it does not raise.

The registry (:data:`REGISTRY`) maps names to :class:`Scenario` entries that load
the scripts from the ``scenarios/`` directory of the source tree.
"""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from .exceptions import InvalidInput, PikError, UnknownName
from .frames import Frame
from .record import Recorder
from .robot import Robot
from .solve import IterationInfo, SolveResult

SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"
"""Where the scenario scripts live (the source tree's ``scenarios/``)."""

DEFAULT_SCENARIO = "fullbody_reach"
"""What ``pik-mj run`` runs without a name."""


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
        balance: Simulation validation of the final pose (filled by the CLI when
            :mod:`pik_mj.sim` provides it), or None.
        robot: The robot in its final configuration (not serialized), for
            post-processing such as the balance hook.
    """

    name: str
    passed: bool = True
    solves: dict[str, SolveResult] = field(default_factory=dict)
    figures: dict[str, Any] = field(default_factory=dict)
    messages: list[str] = field(default_factory=list)
    main: str | None = None
    recording: str | None = None
    balance: dict[str, Any] | None = None
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

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: ``converged``, ``iterations``, ``tasks`` (name, level,
        error, satisfied, checked), ``timing`` of the main solve at the top level,
        every solve under ``solves``, ``figures``, ``messages``, ``balance``."""
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
            # Hook: `balance` (simulation validation from pik_mj.sim) is added by the CLI.
            "balance": self.balance,
        }
        return jsonable(out)

    def to_json(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_dict(), indent=2))

    def summary(self) -> str:
        lines = [f"scenario {self.name}: {'PASSED' if self.passed else 'FAILED'}"]
        main = self.main_solve()
        for label, res in self.solves.items():
            text = res.summary() if res is main else res.summary().splitlines()[0]
            lines.append(f"- solve {label!r}: " + text.replace("\n", "\n  "))
        if self.figures:
            lines.append("figures:")
            for k, v in self.figures.items():
                lines.append(f"  {k} = {_short(v)}")
        lines += self.messages
        if self.recording:
            lines.append(f"recording: {self.recording}  (view with: rerun {self.recording})")
        return "\n".join(lines)


def _short(value: Any) -> str:
    v = jsonable(value)
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list) and v and all(isinstance(x, float) for x in v):
        return "[" + ", ".join(f"{x:.4g}" for x in v) + "]"
    return str(v)


# ---------------------------------------------------------------------------
# Recording and progress


class ScenarioRecorder:
    """Records a scenario's solves: a rerun file (if ``out``) and progress on stderr.

    Usage in a scenario::

        with ScenarioRecorder(out, robot, progress=progress) as rec:
            res = fullbody_inverse_kinematics(robot, ..., callback=rec.callback("reach"))
            rec.record("reach", res)

    The ``iteration`` timeline counts iterations over all solves of the scenario;
    each solve logs its start pose, every iteration's body poses, each task's error
    norm at ``errors/level_<k>/<task>``, the robot's CoM, and its final pose (the
    start pose again when the solve reverted).

    Args:
        out: ``.rrd`` path, or None for no recording.
        robot: The robot solved on (its model is logged once, statically).
        progress: Print ``\\r<solve> iteration <k>`` on stderr while solving.
        name: Application name in the recording.
    """

    def __init__(
        self,
        out: str | Path | None,
        robot: Robot,
        *,
        progress: bool = False,
        name: str = "pik_mj",
    ):
        self.robot = robot
        self.progress = progress
        self.results: dict[str, SolveResult] = {}
        self.iteration = 0
        self.path = None if out is None else Path(out)
        self.recorder: Recorder | None = None
        if self.path is not None:
            self.recorder = Recorder.to_file(self.path, application_id=name)
            self.recorder.log_model_geometry(robot.model, robot_root_body=robot.root_body)
        self._label = ""

    def __enter__(self) -> ScenarioRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        if self.recorder is not None:
            self.recorder.close()
            self.recorder = None

    def _log_pose(self, com_target: Any = None) -> None:
        if self.recorder is None:
            return
        self.recorder.log_body_poses(self.robot.data, time=self.iteration)
        self.recorder.log_com(self.robot.com(), target=com_target)

    def callback(self, label: str) -> Callable[[IterationInfo], None]:
        """Start solve ``label`` (its start pose is logged) and return its callback."""
        self._label = label
        if self.recorder is not None:
            self.recorder.set_time("iteration", self.iteration)
            self.recorder.log_text(f"solve {label!r} starts")
        self._log_pose()

        def on_iteration(info: IterationInfo) -> None:
            self.iteration += 1
            if self.progress:
                sys.stderr.write(f"\r  {label}: iteration {info.iteration:4d}")
                sys.stderr.flush()
            if self.recorder is None:
                return
            self._log_pose()
            errors = {}
            for k, level in enumerate(info.levels):
                for task in level:
                    e = float(np.linalg.norm(task.compute_error(info.configuration)))
                    errors[(k, task.name)] = e
            self.recorder.log_task_errors(errors)

        return on_iteration

    def fill(self, result: ScenarioResult, main: str | None = None) -> None:
        """Hand the solves, the robot and the recording path to ``result``."""
        result.solves = dict(self.results)
        result.main = main
        result.robot = self.robot
        result.recording = None if self.path is None else str(self.path)

    def record(self, label: str, result: SolveResult) -> SolveResult:
        """Keep ``result`` under ``label`` and log the solve's final pose."""
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
            self.recorder.log_text(
                f"solve {label!r}: {'converged' if result.converged else 'not converged'}"
                f" after {result.iterations} iterations"
                + (", reverted" if result.reverted else ""),
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
    world frame, and the robot's ``reset_pose`` keyframe is moved with it.
    """
    import mujoco

    from .models import compose_scene, load_model

    env = load_model(environment)
    data = mujoco.MjData(env)
    mujoco.mj_kinematics(env, data)
    site = Frame.find(env, spot, "site")
    p, R = site.position(data), site.rotation(data)
    spec = compose_scene(
        robot, environment, robot_pos=(p[0], p[1], 0.0), robot_yaw=math.atan2(R[1, 0], R[0, 0])
    )
    return Robot(spec.compile())


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
    """

    name: str
    description: str
    script: str | None = None
    fn: Callable[..., ScenarioResult] | None = None
    requires: tuple[str, ...] = ()
    accepts_model: bool = False

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
    )
}


def scenario(name: str) -> Scenario:
    """The registry entry ``name``."""
    try:
        return REGISTRY[name]
    except KeyError:
        raise UnknownName("scenario", name, REGISTRY) from None


def run_scenario(
    name: str,
    out: str | Path | None = None,
    *,
    progress: bool = False,
    model: str | None = None,
) -> ScenarioResult:
    """Run scenario ``name`` (see :data:`REGISTRY`).

    Raises:
        UnknownName: No such scenario.
        InvalidInput: ``model`` given to a scenario that does not take one.
        PikError: The scenario is waiting for a module that does not exist yet.
    """
    entry = scenario(name)
    missing = entry.missing()
    if missing:
        raise PikError(f"scenario {name!r} is waiting for {missing} (not available yet)")
    kwargs: dict[str, Any] = {"progress": progress}
    if model is not None:
        if not entry.accepts_model:
            takes = [s.name for s in REGISTRY.values() if s.accepts_model]
            raise InvalidInput(f"scenario {name!r} takes no model; scenarios that do: {takes}")
        kwargs["model"] = model
    return entry.load()(out, **kwargs)


def main_for(run: Callable[..., ScenarioResult], argv: list[str] | None, doc: str | None) -> int:
    """The ``main`` of a scenario script: ``--out FILE.rrd``, ``--json FILE``,
    ``--model NAME`` (if ``run`` takes one); prints the summary; 0 iff passed."""
    import argparse
    import inspect

    parser = argparse.ArgumentParser(description=(doc or "").strip().splitlines()[0])
    parser.add_argument("--out", help="rerun recording to write (.rrd)")
    parser.add_argument("--json", help="JSON summary to write")
    takes_model = "model" in inspect.signature(run).parameters
    if takes_model:
        parser.add_argument("--model", help="robot model name or MJCF path")
    args = parser.parse_args(argv)
    kwargs: dict[str, Any] = {"progress": True}
    if takes_model and args.model:
        kwargs["model"] = args.model
    result = run(args.out, **kwargs)
    print(result.summary())
    if args.json:
        result.to_json(args.json)
    return 0 if result.passed else 1
