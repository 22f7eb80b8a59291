r"""Can the servos keep the robot standing? The growth of the slowest-damped
mode of the physics linearized about a state (:func:`unstable_mode`).

MuJoCo's ``mjd_transitionFD`` gives the step's Jacobian ``A = ∂x_{k+1}/∂x_k``
(finite differences of ``mj_step``, contacts included) of the state
``x = (q, q̇, act)`` with the controls held, i.e. of the robot under its servos
at their current targets and feed-forward. An eigenvalue ``λ`` of ``A`` with
``|λ| > 1`` is a mode that grows by ``|λ|`` per step:

.. math::

    r = \ln|λ| / Δt \;[1/s], \qquad t_2 = \ln 2 / r

A robot whose ankles are less stiff than gravity's tipping stiffness ``m g h``
(Booster T1 under its own ``kp = 75`` actuators) has such a mode: started in
equilibrium it stays there for a while, and drifts away from any disturbance,
faster the stronger the disturbance. Its eigenvector names the joints that
move in it: those are the servos that cannot hold the stance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.sim.criteria import HoldCriteria
from pik_mj.sim.measures import Tracked
from pik_mj.sim.physics import Physics

__all__ = ["MIN_RATE", "Instability", "diagnose", "unstable_mode"]

MIN_RATE = 0.05
"""Growth rate [1/s] below which a mode counts as neutral (a stance drifts on its
soft contacts at rates around 0)."""


@dataclass(frozen=True)
class Instability:
    """A growing mode of the robot under its servos.

    Attributes:
        rate: Growth rate ``r`` [1/s].
        joints: The servo joints that move most in it, with their share of the
            largest servo joint motion [-] and their servo's stiffness
            ``kp`` [N·m/rad or N/m], largest first.
    """

    rate: float
    joints: list[tuple[str, float, float]]

    @property
    def doubling_time(self) -> float:
        """``ln 2 / r`` [s]."""
        return math.log(2.0) / self.rate

    def describe(self) -> str:
        """The mode in words: its doubling time and its joints."""
        names = ", ".join(f"{j} (kp {kp:g})" for j, _, kp in self.joints)
        return (
            f"the servos cannot keep the robot still: a mode of its stance grows x2 every "
            f"{self.doubling_time:.2f} s ({self.rate:.2f} /s; physics linearized by "
            f"mjd_transitionFD), mostly in {names}"
        )


def unstable_mode(
    scene: Physics, state: np.ndarray, share: float = 0.5, eps: float = 1e-6
) -> Instability | None:
    """The fastest growing mode of ``scene``'s physics about ``state`` (MuJoCo's
    ``mjtState.mjSTATE_INTEGRATION`` state: positions, velocities, activations,
    controls and applied forces), or None when none grows faster than
    :data:`MIN_RATE`.

    Args:
        scene: The scene.
        state: Its ``mj_getState`` with ``mjSTATE_INTEGRATION``.
        share: Joints moving at least this share of the largest servo joint
            motion of the mode are named [-].
        eps: Finite-difference step.
    """
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, np.asarray(state, float), mujoco.mjtState.mjSTATE_INTEGRATION)
    mujoco.mj_forward(m, d)
    nx = 2 * m.nv + m.na
    A = np.zeros((nx, nx))
    mujoco.mjd_transitionFD(m, d, eps, True, A, None, None, None)
    values, vectors = np.linalg.eig(A)
    k = int(np.argmax(np.abs(values)))
    rate = math.log(float(np.abs(values[k]))) / float(m.opt.timestep)
    if rate < MIN_RATE:
        return None
    motion = np.abs(vectors[: m.nv, k])[scene.servo_dofs]
    if not len(motion) or motion.max() == 0:
        return Instability(rate, [])
    motion = motion / motion.max()
    order = [int(i) for i in np.argsort(-motion) if motion[i] >= share]
    joints = [
        (scene.servo_joints[i], float(motion[i]), scene_kp(scene, scene.servo_joints[i]))
        for i in order
    ]
    return Instability(rate, joints)


def scene_kp(scene: Physics, joint: str) -> float:
    """The stiffness [N·m/rad or N/m] of ``joint``'s servo in joint space
    (``-γ² b_1`` of its position actuator)."""
    m = scene.model
    for a in scene.position_actuators:
        if (
            m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT
            and m.joint(int(m.actuator_trnid[a, 0])).name == joint
        ):
            return float(-(m.actuator_gear[a, 0] ** 2) * m.actuator_biasprm[a, 1])
    return 0.0


def diagnose(scene: Physics, run: Tracked, criteria: HoldCriteria) -> list[str]:
    """Why a run fell or drifted, when the servos are the cause: the
    :func:`unstable_mode` about its settled state, in words, if it grows by more
    than ``e`` over the run; else nothing."""
    moved = run.fell or run.drift >= criteria.max_drift
    if not moved or run.settled is None:
        return []
    mode = unstable_mode(scene, run.settled)
    if mode is None or mode.rate * run.simulated < 1.0:
        return []
    return [mode.describe()]
