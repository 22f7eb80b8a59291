"""The stepping loop of a hold and a motion: :func:`track` steps a scene's physics
while its servos track a reference; :func:`track_many` steps many at once.

The physics runs in C, a chunk of steps per Python call (``mujoco.rollout``,
:class:`~pik_mj.sim.stepping.Stepper`), with the controls of every step from the
reference (:class:`~pik_mj.sim.measures.Reference`): the same physics, step for
step, as stepping one at a time. A chunk runs on to the next check for a fall
(:data:`FALL_CHECK_EVERY` rows; with external wrenches, one row: their lever
arms to the bodies' CoM are taken at each chunk's start). The rollout returns
the state after every step; the record keeps every ``record_every``-th
(:data:`RECORD_EVERY` by default: 40 ms at a 2 ms step), read by the
:class:`~pik_mj.sim.sampling.Sampler` (root pose, CoM, joints, watched geoms,
contacts; every ``margin_every`` steps the ground contacts; the contacts of
all rows classified at once, at the end or before a callback), the reference
moved to each row's time (:meth:`~pik_mj.sim.measures.Reference.updates` of
all the rows' times, its timing evaluated once per run). The figures are computed over
the whole record at the end (:func:`pik_mj.sim.figures.figures`). A fall ends
the run at the check after it (``stop_on_fall``).

**Callbacks** (e.g. a recorder's ``hold_logger()``) get a
:class:`~pik_mj.sim.measures.HoldSample` of the scene's data every ``every``
steps: the chunks then end at every ``every``-th step too, while the record
keeps its rows at every ``record_every``-th step, so a run with callbacks has
the figures of the same run without (the balance feedback, where a robot needs
it, :mod:`pik_mj.sim.balancing`, updates at every ``period``-th step whatever
the chunks). A hold or a motion calls its callbacks as far apart as they ask
(:func:`pik_mj.callbacks.call_stride`: a recorder's loggers at the viewer's
rate); ``every=1``, or a callback that does not say, is the slow path, a Python
call per step, for a callback that needs every step; ``record_every=1`` gives
the checks every step (what the benchmarks compare the sampled figures with).
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import mujoco
import numpy as np

from pik_mj.callbacks import Callback
from pik_mj.frames import Frame
from pik_mj.sim.balancing import BalanceFeedback, BalanceLoop
from pik_mj.sim.criteria import HoldCriteria, slip_verdict_geoms
from pik_mj.sim.falls import fall_measures, first_fall
from pik_mj.sim.figures import RunningFigures, figures
from pik_mj.sim.measures import HoldSample, Reference, Tracked
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.sampling import Record, Sampler
from pik_mj.sim.stepping import FULL, Stepper

__all__ = [
    "FALL_CHECK_EVERY",
    "MARGIN_EVERY",
    "RECORD_EVERY",
    "SETTLE",
    "Run",
    "track",
    "track_many",
]

RECORD_EVERY = 20
"""Steps between the record's rows (samples)."""

MARGIN_EVERY = 40
"""Steps between evaluations of the CoM margin (a hull of the ground contacts)."""

FALL_CHECK_EVERY = 10
"""Samples between the checks for a fall that ends a run early (the fall's time
and figures come from every sample, at the end)."""

SETTLE = 0.1
"""Time [s] after the start at which a run keeps its state (``Tracked.settled``):
the contacts have taken the robot's weight."""

_INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION


class Run:
    """One reference tracked in a scene: its sampler, record and counters.

    Args:
        scene: The scene.
        reference: What the servos track.
        duration: Simulated time [s].
        criteria: Pass/fail thresholds.
        allowed: Robot geoms allowed to touch the environment anywhere.
        planned_pairs: Geom pairs allowed to touch each other.
        external: Wrenches ``(frame, force, moment)`` acting on the robot.
        margin_every: Steps between CoM margin evaluations.
        record_every: Steps between the record's rows (and the last step).
        frames: Task frames whose distance to the reference is recorded.
        feedback: The balance feedback on the servos' controls
            (:mod:`pik_mj.sim.balancing`; the chunks end at its updates), or None.
    """

    def __init__(
        self,
        scene: Physics,
        reference: Reference,
        duration: float,
        *,
        criteria: HoldCriteria,
        allowed: Sequence[str],
        planned_pairs: Sequence[frozenset[str]] = (),
        external: Sequence[External] = (),
        margin_every: int = MARGIN_EVERY,
        frames: Sequence[Frame] = (),
        record_every: int = RECORD_EVERY,
        feedback: BalanceFeedback | None = None,
    ):
        self.scene, self.reference, self.criteria = scene, reference, criteria
        self.balance = None if feedback is None else BalanceLoop(feedback, scene.model)
        self.sampler = Sampler(
            scene,
            allowed=allowed,
            planned_pairs=planned_pairs,
            allow_self_contact=criteria.allow_self_contact,
            frames=frames,
            max_slope=criteria.max_ground_slope,
        )
        self.frames = [f.name for f in frames]
        self.feet = slip_verdict_geoms(scene, allowed, criteria)
        self.record = Record()
        self.steps = 0
        self.n_steps = max(1, round(duration / scene.model.opt.timestep))
        self.margin_every = int(margin_every)
        self.record_every = int(record_every)
        self._recorded = 0  # the steps at the last row
        self.wrenches = [_wrench(scene, *w) for w in external]
        self.settled: np.ndarray | None = None
        self.fell = False
        self.so_far: RunningFigures | None = None  # the figures a callback sees
        self._checked = 0
        self.settle_step = self.record_every  # the first row at or after SETTLE
        while self.settle_step * scene.model.opt.timestep < SETTLE:
            self.settle_step += self.record_every
        self._t_wall = time.perf_counter()
        reference.begin(scene.borrow_data())  # given back, with the sampler's, by finish()
        d = scene.data
        self.t0 = float(d.time)
        self.limits = criteria.fall_limits(scene, scene.com_height(d), scene.root_height(d))
        self.start = np.empty(mujoco.mj_stateSize(scene.model, _INTEGRATION))
        mujoco.mj_getState(scene.model, d, self.start, _INTEGRATION)
        self.state = np.empty(mujoco.mj_stateSize(scene.model, FULL))  # the last step's
        mujoco.mj_getState(scene.model, d, self.state, FULL)
        self._last = self.sampler.read(
            self.record, d.qpos, self.t0, reference.data, reference.waypoint, True
        )
        dt = scene.model.opt.timestep
        # every step's controls at once (a constant reference's rows are tiled per chunk)
        times = np.arange(self.n_steps) * dt
        self._controls = reference.controls(times) if reference.moving else None
        # the reference at every row's time, its timing evaluated once for the run
        rows = np.arange(self.record_every, self.n_steps + self.record_every, self.record_every)
        rows[-1] = self.n_steps
        self._rows = reference.updates(rows * dt)

    @property
    def done(self) -> bool:
        """Every step taken, or a fall seen with ``stop_on_fall``."""
        return self.steps >= self.n_steps or (self.fell and self.criteria.stop_on_fall)

    def controls(self, n: int, xfrc: bool) -> np.ndarray:
        """The control rows (``ctrl`` [+ ``xfrc_applied``]) of the next ``n`` steps
        (at most the steps left)."""
        dt = self.scene.model.opt.timestep
        t = (self.steps + np.arange(min(n, self.n_steps - self.steps))) * dt
        if self._controls is None:
            ctrl = self.reference.controls(t)
        else:
            ctrl = self._controls[self.steps : self.steps + len(t)]
        if self.balance is not None:
            ctrl = self.balance.controls(ctrl, self.steps, self.state, self.reference.data)
        if not xfrc:
            return ctrl
        m, d = self.scene.model, self._last
        xfrc_rows = np.zeros((len(t), m.nbody, 6))
        loads = self.reference.loads(t)
        for body, lever, force, moment in self.wrenches:
            w = np.concatenate([force, moment + np.cross(lever(d), force)])
            xfrc_rows[:, body] += loads[:, None] * w
        return np.hstack([ctrl, xfrc_rows.reshape(len(t), -1)])

    def chunk(self, every: int | None = None, long: bool = True) -> int:
        """Steps of the next chunk: to the next row (and the next ``every``-th
        step with callbacks); ``long`` (no ``every``): on to the row of the next
        fall check, ending at the settle row (``SETTLE``) on the way. The chunks
        end at the same rows and checks whatever their length."""
        r = self.record_every
        n = r - self.steps % r
        if every is not None:
            n = min(n, every - self.steps % every)
        elif long:
            n += max(FALL_CHECK_EVERY - (len(self.record) - self._checked) - 1, 0) * r
            if self.steps < self.settle_step:
                n = min(n, self.settle_step - self.steps)
        if self.balance is not None:
            n = self.balance.chunk(self.steps, n)
        return min(n, self.n_steps - self.steps)

    def take(self, trajectory: np.ndarray) -> None:
        """Record a chunk's trajectory (the states after each of its steps,
        ``mjSTATE_FULLPHYSICS``): its rows at every ``record_every``-th step and
        its last state."""
        r, n = self.record_every, len(trajectory)
        self.state = trajectory[-1]
        ends = list(range(r - self.steps % r, n + 1, r))
        if not ends or ends[-1] != n:
            ends.append(n)
        done = 0
        for k in ends:
            self.sample(k - done, trajectory[k - 1])
            done = k

    def sample(self, n: int, state: np.ndarray) -> None:
        """Record the state (``mjSTATE_FULLPHYSICS``) after ``n`` more steps, the
        reference moved to that time."""
        m = self.scene.model
        self.steps += n
        reference = self.reference
        if self.steps % self.record_every and self.steps < self.n_steps:
            reference.update(self.steps * m.opt.timestep)  # a callback's chunk, between rows
            return
        next(self._rows)
        before, self._recorded = self._recorded, self.steps
        margin = self.steps // self.margin_every > before // self.margin_every
        qpos = state[1 : 1 + m.nq]
        self._last = self.sampler.read(
            self.record, qpos, state[0], reference.data, reference.waypoint, margin,
            reference.moving,
        )  # fmt: skip
        if len(self.record) - self._checked >= FALL_CHECK_EVERY or self.steps >= self.n_steps:
            self.fell = self.fell or self._falling()

    def keep_settled(self, data: mujoco.MjData) -> None:
        """Keep ``data``'s state as the settled one once :data:`SETTLE` has passed."""
        if self.settled is None and self.steps * self.scene.model.opt.timestep >= SETTLE:
            self.settled = np.empty(mujoco.mj_stateSize(self.scene.model, _INTEGRATION))
            mujoco.mj_getState(self.scene.model, data, self.settled, _INTEGRATION)

    def _falling(self) -> bool:
        """A sample since the last check is past a fall threshold (:mod:`pik_mj.sim.falls`)."""
        r, k = self.record, self._checked
        self._checked = len(r)
        tilt, drift, height, ref_height = fall_measures(
            np.array(r.root_pos[k:]),
            np.array(r.root_mat[k:]),
            np.array(r.ref_root_pos[k:]),
            np.array(r.ref_root_mat[k:]),
            self.scene.up(),
        )
        times = np.array(r.time[k:])
        return first_fall(times, tilt, drift, height, ref_height, self.limits) is not None

    def finish(self) -> Tracked:
        """The figures of the run (:func:`pik_mj.sim.figures.figures`)."""
        self.sampler.flush(self.record)
        self.sampler.close()
        self.scene.give_back(self.reference.data)
        out = figures(
            self.scene,
            self.record,
            self.sampler.watched,
            self.feet,
            self.limits,
            self.steps,
            self.t0,
            time.perf_counter() - self._t_wall,
            self.frames,
        )
        out.settled = self.settled
        return out


def _wrench(scene: Physics, frame: str, force, moment) -> tuple:
    """``(body id, lever(data), force (3,), moment (3,))`` of an external wrench:
    applied at the frame's origin, as ``xfrc_applied`` (force, moment about the
    body's CoM ``n + (p_WF - p_WCoM) × f``)."""
    target = Frame.find(scene.model, frame)
    body = target.body_id

    def lever(d: mujoco.MjData) -> np.ndarray:
        return target.position(d) - d.xipos[body]

    return body, lever, np.asarray(force, float), np.asarray(moment, float)


def track(
    scene: Physics,
    reference: Reference,
    duration: float,
    *,
    criteria: HoldCriteria,
    allowed: Sequence[str],
    planned_pairs: Sequence[frozenset[str]] = (),
    external: Sequence[External] = (),
    callbacks: Sequence[Callback] = (),
    every: int = 1,
    record_every: int = RECORD_EVERY,
    margin_every: int = MARGIN_EVERY,
    frames: Sequence[Frame] = (),
    feedback: BalanceFeedback | None = None,
) -> Tracked:
    """Step the physics for ``duration`` [s] while the servos track ``reference``
    (module docstring), in chunks that end at a fall check (at every
    ``every``-th step with callbacks; at every row with external wrenches); the
    record's rows every ``record_every`` steps; the scene's data ends in the
    last state; with ``feedback``, the balance feedback acts on the servos'
    controls (:mod:`pik_mj.sim.balancing`).

    A contact is unexpected unless its robot geom is in ``allowed`` (touching
    the environment anywhere), or the pair is in ``planned_pairs`` (environment
    or self contact), or it is a self-contact and ``criteria.allow_self_contact``.

    Raises:
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    run = Run(
        scene, reference, duration, criteria=criteria, allowed=allowed,
        planned_pairs=planned_pairs, external=external, margin_every=margin_every, frames=frames,
        record_every=record_every, feedback=feedback,
    )  # fmt: skip
    xfrc = bool(external)
    stepper = Stepper(scene.model, xfrc=xfrc)
    d = scene.data
    try:
        if callbacks:
            _call(callbacks, run, criteria, frames)
        while not run.done:
            # With callbacks, the rows where they fall without: the same figures.
            # With external wrenches, a row per chunk: their lever arms are the
            # last row's.
            chunk = run.chunk(every if callbacks else None, long=not xfrc)
            run.take(stepper.step(d, run.controls(chunk, xfrc)))
            run.keep_settled(d)
            if callbacks and (run.steps % every == 0 or run.done):
                _call(callbacks, run, criteria, frames)
    finally:
        stepper.close()
    return run.finish()


def _call(callbacks: Sequence[Callback], run: Run, criteria: HoldCriteria, frames) -> None:
    """Each callback with a :class:`HoldSample` of the scene's data now."""
    scene, reference = run.scene, run.reference
    if run.so_far is None:
        run.so_far = RunningFigures(scene, len(run.sampler.watch))
    so_far = run.so_far
    run.sampler.flush(run.record)
    so_far.update(run.record)
    d = scene.data
    sample = HoldSample(
        time=float(d.time),
        step=run.steps,
        model=scene.model,
        data=d,
        com=scene.com(),
        drift=so_far.drift,
        slip=so_far.slip,
        _scene=scene,
        reference=reference.data if reference.moving else None,
        waypoint=reference.waypoint,
        tracking_error=float(np.max(np.abs(run.record.q[-1] - run.record.ref_q[-1]), initial=0.0)),
        _frames=frames,
        _max_slope=criteria.max_ground_slope,
    )
    for call in callbacks:
        call(sample)


def track_many(
    scene: Physics,
    references: Sequence[Reference],
    duration: float,
    *,
    criteria: HoldCriteria,
    allowed: Sequence[str],
    nthread: int = 0,
    record_every: int = RECORD_EVERY,
    margin_every: int = MARGIN_EVERY,
    feedback: Sequence[BalanceFeedback | None] | None = None,
) -> list[Tracked]:
    """:func:`track` of each reference (no external wrenches, no callbacks), all
    stepped together: each chunk is one rollout of every run still going, on
    ``nthread`` threads (one ``MjData`` each); a run that fell leaves the next
    chunks; ``feedback``: each reference's balance feedback (or None). The
    scene's data ends in the last reference's start.

    Raises:
        SimulationUnstable: MuJoCo reported an invalid state.
    """
    runs = [
        Run(
            scene,
            r,
            duration,
            criteria=criteria,
            allowed=allowed,
            margin_every=margin_every,
            record_every=record_every,
            feedback=f,
        )
        for r, f in zip(references, feedback or [None] * len(references), strict=True)
    ]
    stepper = Stepper(scene.model, nthread=nthread)
    states = [_start(scene, run) for run in runs]
    try:
        while active := [i for i, run in enumerate(runs) if not run.done]:
            n = min(runs[i].chunk() for i in active)
            controls = np.stack([runs[i].controls(n, False) for i in active])
            out = stepper.step_many(np.stack([states[i] for i in active]), controls)
            for k, i in enumerate(active):
                states[i] = out[k, -1]
                runs[i].take(out[k])
                if runs[i].settled is None and runs[i].steps * scene.model.opt.timestep >= SETTLE:
                    runs[i].settled = _integration(scene, states[i], controls[k, -1])
    finally:
        stepper.close()
    return [run.finish() for run in runs]


def _start(scene: Physics, run: Run) -> np.ndarray:
    """The full physics state of ``run``'s start (its reference began on the
    scene's data, :attr:`Run.start`)."""
    d = scene.borrow_data()
    mujoco.mj_setState(scene.model, d, run.start, _INTEGRATION)
    state = np.empty(mujoco.mj_stateSize(scene.model, FULL))
    mujoco.mj_getState(scene.model, d, state, FULL)
    scene.give_back(d)
    return state


def _integration(scene: Physics, state: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """The ``mjSTATE_INTEGRATION`` state of a full physics state and its controls."""
    m = scene.model
    d = scene.borrow_data()
    mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_setState(m, d, controls, mujoco.mjtState.mjSTATE_CTRL)
    out = np.empty(mujoco.mj_stateSize(m, _INTEGRATION))
    mujoco.mj_getState(m, d, out, _INTEGRATION)
    scene.give_back(d)
    return out
