"""Physics stepped in C: :class:`Stepper` advances one or many states of a
scene's model ``k`` steps per Python call with ``mujoco.rollout`` (one
``MjData`` per thread), the controls of every step given.

The controls are MuJoCo's ``mjSTATE_CTRL`` (the actuators' controls) and,
with external wrenches, ``mjSTATE_XFRC_APPLIED``; everything else a step reads
(``qfrc_applied``, equality activations, mocap) is at its reset value. A
rollout ends a trajectory at the first MuJoCo warning (the remaining states
repeat the last one): the stepper then replays that chunk step by step through
the state guard (:class:`~pik_mj.sim.guard.StateGuard`), which raises
:class:`~pik_mj.exceptions.SimulationUnstable` with the warning, its time and
the joint or actuator it points at (a warning that is not one of
:data:`~pik_mj.sim.guard.UNSTABLE_WARNINGS` is stepped through).
"""

from __future__ import annotations

import mujoco
import numpy as np
from mujoco import rollout

from pik_mj.sim.guard import StateGuard

__all__ = ["FULL", "Stepper"]

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS
"""The state a rollout starts from and returns: time, ``qpos``, ``qvel``, ``act``."""


class Stepper:
    """Steps states of ``model`` in C.

    Args:
        model: The model.
        xfrc: The controls include ``xfrc_applied`` (external wrenches).
        nthread: Threads of the rollout pool (0: the calling thread).

    Attributes:
        spec: MuJoCo's state bits of a control row.
        ncontrol: Length of a control row: ``nu`` (+ ``6 nbody`` with ``xfrc``).
        nstate: Length of a state.
    """

    def __init__(self, model: mujoco.MjModel, *, xfrc: bool = False, nthread: int = 0):
        self.model = model
        spec = mujoco.mjtState.mjSTATE_CTRL
        if xfrc:
            spec = spec | mujoco.mjtState.mjSTATE_XFRC_APPLIED
        self.spec = int(spec)
        self.ncontrol = mujoco.mj_stateSize(model, self.spec)
        self.nstate = mujoco.mj_stateSize(model, FULL)
        self.nthread = int(nthread)
        self._pool = rollout.Rollout(nthread=self.nthread)
        self._datas: list[mujoco.MjData] = []
        self._out: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def close(self) -> None:
        """Shut the thread pool down."""
        self._pool.close()

    def state(self, data: mujoco.MjData) -> np.ndarray:
        """The full physics state (:data:`FULL`) of ``data``."""
        s = np.empty(self.nstate)
        mujoco.mj_getState(self.model, data, s, FULL)
        return s

    def step(self, data: mujoco.MjData, controls: np.ndarray) -> np.ndarray:
        """Advance ``data`` by ``len(controls)`` steps, row ``k`` of ``controls``
        (``ncontrol``) the controls of step ``k``; ``data`` ends in the last
        step's state (its contacts, forces), warm-started from its own
        ``qacc_warmstart``. Returns the trajectory (``len(controls)``,
        :data:`FULL`): the state after each step, the last one ``data``'s.

        Raises:
            SimulationUnstable: A step went unstable (the chunk replayed, see the
                module docstring).
        """
        controls = np.ascontiguousarray(controls, dtype=float).reshape(1, -1, self.ncontrol)
        n = controls.shape[1]
        start = self.state(data)[None]
        if n not in self._out:
            self._out[n] = (np.empty((1, n, self.nstate)), np.empty((1, n, self.model.nsensordata)))
        out, sensors = self._out[n]
        warm = data.qacc_warmstart.copy()[None]
        self._pool.rollout(
            [self.model], [data], start, controls, control_spec=self.spec, skip_checks=True,
            nstep=n, initial_warmstart=warm, state=out, sensordata=sensors,
        )  # fmt: skip
        if not self._finished(out[0], start[0, 0], n):
            trajectory, replayed = self.replay(start[0], warm[0], controls[0])
            mujoco.mj_copyData(data, self.model, replayed)
            return trajectory
        return out[0].copy()

    def step_many(self, states: np.ndarray, controls: np.ndarray) -> np.ndarray:
        """The trajectories (n, k, nstate) of the states (n, nstate) under the
        controls (n, k, ncontrol), on the pool's threads (each chunk of steps
        starts cold: no warm start).

        Raises:
            SimulationUnstable: A trajectory went unstable (its chunk replayed).
        """
        states = np.ascontiguousarray(states, dtype=float)
        controls = np.ascontiguousarray(controls, dtype=float)
        n, k = controls.shape[:2]
        if not self._datas:
            self._datas = [mujoco.MjData(self.model) for _ in range(max(1, self.nthread))]
        out = np.empty((n, k, self.nstate))
        sensors = np.empty((n, k, self.model.nsensordata))
        self._pool.rollout(
            [self.model] * n, self._datas, states, controls, control_spec=self.spec,
            skip_checks=True, nstep=k, initial_warmstart=None, state=out, sensordata=sensors,
        )  # fmt: skip
        for i in range(n):
            if not self._finished(out[i], states[i, 0], k):
                out[i], _ = self.replay(states[i], None, controls[i])
        return out

    def _finished(self, trajectory: np.ndarray, t0: float, n: int) -> bool:
        """The rollout ran its ``n`` steps from ``t0`` to finite states."""
        end = t0 + n * self.model.opt.timestep
        return bool(
            abs(trajectory[-1, 0] - end) < 0.5 * self.model.opt.timestep
            and np.isfinite(trajectory[-1]).all()
        )

    def replay(
        self, state: np.ndarray, warm: np.ndarray | None, controls: np.ndarray
    ) -> tuple[np.ndarray, mujoco.MjData]:
        """Step ``state`` under ``controls`` one step at a time through the state
        guard, on a new ``MjData`` (raises where the rollout stopped); the
        trajectory (k, nstate) and the final data."""
        m = self.model
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, state, FULL)
        if warm is not None:
            d.qacc_warmstart[:] = warm
        guard = StateGuard(m, d)
        out = np.empty((len(controls), self.nstate))
        for k, row in enumerate(controls):
            mujoco.mj_setState(m, d, row, self.spec)
            guard.step(1)
            out[k] = self.state(d)
        return out, d
