"""The state guard around physics steps.

:class:`StateGuard` is dm_control's ``check_invalid_state``: MuJoCo's warning
  counters that mean the state is garbage are compared before and after each
  step, and a NaN or inf in ``qpos``/``qvel`` is caught, so a simulation fails
  loudly (:class:`~pik_mj.exceptions.SimulationUnstable`) instead of returning
  garbage. :meth:`pik_mj.sim.Scene.step` and :meth:`pik_mj.sim.Scene.hold` step
  through it.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, SimulationUnstable
from pik_mj.mujoco_warnings import mujoco_warnings

__all__ = ["UNSTABLE_WARNINGS", "StateGuard"]

#: Warnings after which the simulation state is garbage (as dm_control's
#: ``check_invalid_state``), plus full contact / constraint buffers.
UNSTABLE_WARNINGS: tuple[mujoco.mjtWarning, ...] = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADCTRL,
    mujoco.mjtWarning.mjWARN_CONTACTFULL,
    mujoco.mjtWarning.mjWARN_CNSTRFULL,
)


class StateGuard:
    """Steps ``(model, data)`` and raises when MuJoCo reports an invalid state.

    Args:
        model: The physics model.
        data: Its state (stepped in place).
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData):
        self.model = model
        self.data = data

    def _counts(self) -> np.ndarray:
        return np.array([self.data.warning[int(w)].number for w in UNSTABLE_WARNINGS])

    def _offender(self, warning: mujoco.mjtWarning, index: int) -> str:
        """Name of what a MuJoCo warning's ``lastinfo`` index points at."""
        m = self.model
        try:
            if warning == mujoco.mjtWarning.mjWARN_BADQPOS:
                j = int(np.searchsorted(m.jnt_qposadr, index, side="right") - 1)
                return f"qpos[{index}] (joint {m.joint(j).name!r})"
            if warning in (mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC):
                return f"dof {index} (joint {m.joint(int(m.dof_jntid[index])).name!r})"
            if warning == mujoco.mjtWarning.mjWARN_BADCTRL:
                return f"actuator {index} ({m.actuator(index).name!r})"
        except (IndexError, KeyError):
            pass
        return f"index {index}"

    def step(
        self, n: int = 1, *, before_step: Callable[[mujoco.MjData], None] | None = None
    ) -> None:
        """Advance ``n`` steps (``mj_step``), checking the state after each.

        Args:
            n: Number of steps (>= 0).
            before_step: Called with the data before each step (e.g. to write
                ``xfrc_applied``).

        Raises:
            SimulationUnstable: A warning of :data:`UNSTABLE_WARNINGS` fired or
                ``qpos``/``qvel`` is not finite; the message names the step's start
                time, the warning and the joint or actuator it points at, and what
                MuJoCo said.
        """
        if not isinstance(n, int) or n < 0:
            raise InvalidInput(f"n must be a non-negative integer, got {n!r}")
        m, d = self.model, self.data
        with mujoco_warnings([]) as messages:
            for _ in range(n):
                before, t = self._counts(), float(d.time)
                if before_step is not None:
                    before_step(d)
                mujoco.mj_step(m, d)
                after = self._counts()
                fired = [
                    w for w, b, a in zip(UNSTABLE_WARNINGS, before, after, strict=True) if a > b
                ]
                if fired or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
                    what = [
                        f"{w.name} at {self._offender(w, int(d.warning[int(w)].lastinfo))}"
                        for w in fired
                    ]
                    detail = f"; MuJoCo says: {' | '.join(messages)}" if messages else ""
                    raise SimulationUnstable(
                        f"simulation unstable in the step from t = {t:.4f} s: "
                        f"{', '.join(what) or 'non-finite qpos/qvel'}{detail}"
                    )
