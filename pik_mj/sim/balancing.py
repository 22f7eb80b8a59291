r"""Balance feedback through the robot's own servos in a hold and a motion: the
stance ankles' targets turned against the trunk's inclination error
(:mod:`pik_mj.sim.stabilizer`), where the robot cannot stand on its servos alone.

**When.** With the feet on the floor and every other joint held, the body above
the ankles is an inverted pendulum about the ankles' pitch axes: gravity tips it
with the stiffness :math:`m g h` [N·m/rad] (``m`` the robot's mass and what it holds, ``h`` its
CoM's height above the ankle axes), the ankle servos hold it with
:math:`k_{ankle} = \sum_{legs} k_{p,j} (a_j^T \hat y)^2`, the stiffness ``k_p``
of each leg's ankle joint ``j`` whose axis ``a_j`` is nearest the lateral
direction :math:`\hat y` (horizontal, across the feet). When
:math:`k_{ankle} < m g h` the upright pose is an unstable equilibrium of the
servos: any disturbance grows, and the robot falls unless something measures
its inclination and acts, as a real robot's balance controller does. The
feedback is then on (:func:`balance_feedback`; a hold or a motion can turn
it off); otherwise the servos alone
play the run, as the robot's position servos would.

**How.** Every :data:`FEEDBACK_PERIOD` [s] (the physics runs in C between, so
the feedback acts as a sampled controller with that period), the measured trunk
rotation ``R`` (its IMU) and angular velocity are compared with the
reference's root rotation :math:`R^{ref}`, and each stance ankle's servo target
moves by the stabilizer's :math:`\Delta q_j = k_\theta a_j^T e + k_\omega a_j^T
\omega_h` through its actuator's control: for MuJoCo's affine position actuator
(:mod:`pik_mj.sim.servos`) the control that moves the target by
:math:`\Delta q` is :math:`\Delta u = -b_1 \gamma \Delta q / g_0`. With
:math:`k_\theta = 1` the ankles resist a tilt of the trunk with twice their own
stiffness.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from pik_mj.sim.physics import Physics
from pik_mj.sim.servos import position_actuators
from pik_mj.sim.stabilizer import TiltStabilizer, ankle_joints, tilt_stabilizer
from pik_mj.spatial import cross_rows

__all__ = [
    "FEEDBACK_PERIOD",
    "LEGS",
    "SERVOS_ALONE",
    "BalanceFeedback",
    "BalanceLoop",
    "Stance",
    "balance_feedback",
    "stance",
]

FEEDBACK_PERIOD = 0.01
"""Period [s] of the balance feedback: the physics steps in C between its updates."""

SERVOS_ALONE = " (linearized with the servos alone: the balance feedback left out)"
"""What a diagnosis of a run with the feedback on adds (:mod:`pik_mj.sim.stability`
linearizes the robot under its servos' controls held)."""

LEGS = ("rleg", "lleg")
"""The limbs whose ankles carry the robot."""


@dataclass(frozen=True)
class Stance:
    """What decides whether a robot stands on its ankle servos (module docstring).

    Attributes:
        ankle_stiffness: ``k_ankle`` [N·m/rad]: the legs' ankle servos about the
            lateral axis.
        tipping_stiffness: ``m g h`` [N·m/rad].
    """

    ankle_stiffness: float
    tipping_stiffness: float

    @property
    def needs_feedback(self) -> bool:
        """``k_ankle < m g h``: the servos alone cannot keep the robot upright."""
        return self.ankle_stiffness < self.tipping_stiffness

    def describe(self, on: bool) -> str:
        """One line: the feedback ``on`` or off, and the figures."""
        k, mgh = self.ankle_stiffness, self.tipping_stiffness
        return (
            f"balance feedback {'on' if on else 'off'}: ankle servos {k:.0f} N·m/rad "
            f"{'<' if self.needs_feedback else '>='} m g h {mgh:.0f} N·m/rad"
        )

    def to_dict(self, on: bool) -> dict[str, Any]:
        """JSON-ready figures, the feedback ``on`` or off."""
        return {
            "on": bool(on),
            "ankle_stiffness": self.ankle_stiffness,
            "tipping_stiffness": self.tipping_stiffness,
        }


@dataclass(frozen=True)
class BalanceFeedback:
    """The stabilizer acting on the controls of the ankles' actuators.

    Attributes:
        stabilizer: The tilt stabilizer over the ankle joints.
        actuators: The ankle joints' actuators (ids), in the stabilizer's order.
        scale: Control per target offset of each [control units / rad].
        legs: The stance legs.
        period: Steps between updates.
        stance: The figures that call for it.
    """

    stabilizer: TiltStabilizer
    actuators: np.ndarray
    scale: np.ndarray
    legs: tuple[str, ...]
    period: int
    stance: Stance

    def offsets(self, data: mujoco.MjData, reference: mujoco.MjData) -> np.ndarray:
        """Control offsets (len(actuators),) for the state in ``data`` and the
        root rotation of ``reference`` (kinematics current)."""
        R_ref = reference.xmat[self.stabilizer.root_id].reshape(3, 3)
        dq = self.stabilizer.correction(data, R_ref, self.legs, len(self.actuators))
        return self.scale * dq

    def apply(self, controls: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """``controls`` (k, ncontrol) with ``offsets`` added to the ankle
        actuators' columns (a new array)."""
        out = np.array(controls, dtype=float)
        out[:, self.actuators] += offsets
        return out


class BalanceLoop:
    """One run's :class:`BalanceFeedback`: its control offsets, computed at every
    ``period``-th step from the state then and held in between (the physics
    between two updates runs in C, whatever the chunks it is stepped in).

    Args:
        feedback: The feedback.
        model: The scene's model.
    """

    def __init__(self, feedback: BalanceFeedback, model: mujoco.MjModel):
        self.feedback = feedback
        self.model = model
        self._data = mujoco.MjData(model)
        self._offsets = np.zeros(len(feedback.actuators))

    def chunk(self, step: int, n: int) -> int:
        """``n`` steps from ``step`` cut at the next update."""
        p = self.feedback.period
        return min(n, p - step % p)

    def controls(
        self, controls: np.ndarray, step: int, state: np.ndarray, reference: mujoco.MjData
    ) -> np.ndarray:
        """``controls`` (k, ncontrol) of the steps from ``step`` with the offsets
        added, updated first when ``step`` is an update's, from ``state`` (the
        full physics state, ``mjSTATE_FULLPHYSICS``) and ``reference`` (its
        kinematics current)."""
        if step % self.feedback.period == 0:
            m, d = self.model, self._data
            mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
            mujoco.mj_kinematics(m, d)
            self._offsets = self.feedback.offsets(d, reference)
        return self.feedback.apply(controls, self._offsets)


@dataclass(frozen=True)
class _Ankles:
    """A scene's driven ankle joints, found once (:func:`_ankles`).

    Attributes:
        legs: Each leg's ankle joints (ids) that a position actuator drives.
        driven: ``{joint id: (actuator id, kp, kv)}`` of those joints.
        data: Scratch data of the scene's model (the kinematics of a pose).
    """

    legs: dict[str, list[int]]
    driven: dict[int, tuple[int, float, float]]
    data: mujoco.MjData


_FOUND: weakref.WeakKeyDictionary[Physics, _Ankles] = weakref.WeakKeyDictionary()


def _ankles(scene: Physics, q: np.ndarray) -> _Ankles:
    """The scene's :class:`_Ankles`: each leg's ankle joints
    (:func:`~pik_mj.sim.stabilizer.ankle_joints`, in the first configuration
    ``q`` asked about) that a position actuator drives; the data left at the
    kinematics of ``q``."""
    found = _FOUND.get(scene)
    if found is None:
        m, robot = scene.model, scene.robot
        data = scene.kinematics(q)
        legs = {leg: robot.limbs[leg].joints for leg in LEGS if leg in robot.limbs}
        driven = position_actuators(m, range(m.njnt))
        ankles = {
            leg: [j for j in ids if j in driven] for leg, ids in ankle_joints(m, data, legs).items()
        }
        ids = [j for joints in ankles.values() for j in joints]
        found = _FOUND[scene] = _Ankles(ankles, {j: driven[j] for j in ids}, data)
    else:
        scene.kinematics(q, found.data)
    return found


def stance(scene: Physics, q: np.ndarray) -> Stance | None:
    """The robot's :class:`Stance` in the configuration ``q`` (module docstring);
    None for a robot without a floating base or without two driven ankles."""
    if scene.robot.free_qposadr is None:
        return None
    found = _ankles(scene, q)
    ankles, data = found.legs, found.data
    if len(ankles) < 2 or not all(ankles.values()):
        return None
    up = scene.up()
    a, b = (np.mean([data.xanchor[j] for j in ids], axis=0) for ids in ankles.values())
    across = cross_rows(up, cross_rows(a - b, up))
    if np.linalg.norm(across) < 1e-9:
        return None
    across /= np.linalg.norm(across)
    k = sum(
        found.driven[j][1] * float(data.xaxis[j] @ across) ** 2
        for ids in ankles.values()
        for j in ids
    )
    pivot = np.mean([data.xanchor[j] for ids in ankles.values() for j in ids], axis=0)
    h = float((scene.com(data) - pivot) @ up)
    mgh = (scene.mass + scene.carried_mass) * float(np.linalg.norm(scene.model.opt.gravity)) * h
    return Stance(ankle_stiffness=float(k), tipping_stiffness=mgh)


def balance_feedback(
    scene: Physics, q: np.ndarray, figures: Stance | None = None
) -> BalanceFeedback | None:
    """The :class:`BalanceFeedback` of the robot standing in configuration ``q``
    when it needs one (its :class:`Stance`, given or computed,
    ``needs_feedback``), else None."""
    figures = stance(scene, q) if figures is None else figures
    if figures is None or not figures.needs_feedback:
        return None
    m = scene.model
    found = _ankles(scene, q)
    joints = [j for ids in found.legs.values() for j in ids]
    names = [m.joint(j).name for j in joints]
    legs = {leg: [m.joint(j).name for j in ids] for leg, ids in found.legs.items()}
    actuators = np.array([found.driven[j][0] for j in joints], dtype=int)
    gear = m.actuator_gear[actuators, 0]
    scale = -m.actuator_biasprm[actuators, 1] * gear / m.actuator_gainprm[actuators, 0]
    stabilizer = tilt_stabilizer(m, found.data.qpos, scene.root_body, names, legs)
    period = max(1, round(FEEDBACK_PERIOD / float(m.opt.timestep)))
    return BalanceFeedback(stabilizer, actuators, scale, tuple(legs), period, figures)
