"""Body inclination feedback through the stance ankles: what a robot's balance
controller adds to its servo targets so that open-loop errors do not add up (a
walking pattern's cart-table pendulum diverges from any error; a robot whose
ankle servos are softer than its weight's tipping stiffness falls from any).

With the root body's measured rotation :math:`R` (its IMU), the pattern's
:math:`R^{ref}` and the measured angular velocity :math:`\\omega` (world frame),
the inclination error is the horizontal part of
:math:`e = \\log(R\\, R^{ref\\,T})`, to first order the vector of the
skew-symmetric part :math:`\\tfrac12 (E - E^T)^\\vee`, :math:`E = R R^{ref\\,T}`.
Turning a stance ankle joint of world axis :math:`a` by :math:`\\Delta q` turns
everything above the (fixed) foot by :math:`-\\Delta q` about :math:`a`, so each
stance ankle joint's target moves by

.. math::

    \\Delta q_j = k_\\theta\\, a_j^T e + k_\\omega\\, a_j^T \\omega_h

(:math:`\\omega_h` the horizontal part of :math:`\\omega`), which turns the body
back towards the pattern. The ankle joints of a leg are its last pitch and roll
joints (axes horizontal, nearest the foot); the stance legs are the pattern's
(both in double support).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

__all__ = ["ANKLE_DAMPING", "ANKLE_GAIN", "TiltStabilizer", "ankle_joints", "tilt_stabilizer"]

ANKLE_GAIN = 1.0
"""k_θ [rad/rad]: the ankle targets turn by the body's inclination error."""
ANKLE_DAMPING = 0.05
"""k_ω [rad/(rad/s)] = [s]: and by its inclination rate times 50 ms."""

_HORIZONTAL = 0.5
"""|axis_z| below which a joint axis is horizontal."""


def ankle_joints(
    model: mujoco.MjModel, data: mujoco.MjData, legs: Mapping[str, Sequence[str]]
) -> dict[str, list[int]]:
    """Each leg's ankle joints (ids): of its joints (``legs``: names, hip first),
    the last one whose axis is nearest each horizontal direction (x and y), among
    those with a horizontal axis, in the pose of ``data``."""
    out = {}
    for leg, joints in legs.items():
        ids = [model.joint(j).id for j in joints]
        horizontal = [j for j in ids if abs(data.xaxis[j][2]) < _HORIZONTAL]
        chosen = []
        for axis in (0, 1):
            along = [j for j in horizontal if abs(data.xaxis[j][axis]) >= np.sqrt(0.5)]
            if along:
                chosen.append(along[-1])
        out[leg] = chosen
    return out


@dataclass(frozen=True)
class TiltStabilizer:
    """Body inclination feedback (module docstring) over a drive's joints.

    Attributes:
        root_id: The root body's id in the scene.
        root_qadr: The root's free joint qpos address (its quaternion at +3).
        root_dofadr: Its dof address (angular velocity, body frame, at +3).
        ankles: Each leg's ankle joints, as indices into the drive's joints.
        ankle_ids: The same joints' ids in the scene.
        gain: k_θ [rad/rad].
        damping: k_ω [s].
    """

    root_id: int
    root_qadr: int
    root_dofadr: int
    ankles: dict[str, list[int]]
    ankle_ids: dict[str, list[int]]
    gain: float = ANKLE_GAIN
    damping: float = ANKLE_DAMPING

    def correction(
        self, data: mujoco.MjData, R_ref: np.ndarray, stance: Sequence[str], n: int
    ) -> np.ndarray:
        """Target offsets (n,) [rad] over the drive's ``n`` joints for the state in
        ``data``, the root's reference rotation ``R_ref`` (3, 3) and the ``stance``
        legs."""
        out = np.zeros(n)
        R = data.xmat[self.root_id].reshape(3, 3)
        E = R @ R_ref.T
        e = 0.5 * np.array([E[2, 1] - E[1, 2], E[0, 2] - E[2, 0], 0.0])
        w = R @ data.qvel[self.root_dofadr + 3 : self.root_dofadr + 6]
        w[2] = 0.0
        for leg in stance:
            for i, j in zip(self.ankles[leg], self.ankle_ids[leg], strict=True):
                a = data.xaxis[j]
                out[i] += self.gain * (a @ e) + self.damping * (a @ w)
        return out


def tilt_stabilizer(
    model: mujoco.MjModel,
    q0: np.ndarray,
    root_body: str,
    joints: Sequence[str],
    legs: Mapping[str, Sequence[str]],
    *,
    gain: float = ANKLE_GAIN,
    damping: float = ANKLE_DAMPING,
) -> TiltStabilizer:
    """The :class:`TiltStabilizer` of a drive over ``joints`` (names) for the robot
    of ``model`` whose legs are ``legs`` (``{leg: joint names, hip first}``), its
    ankles found in the configuration ``q0`` (:func:`ankle_joints`)."""
    data = mujoco.MjData(model)
    data.qpos[: len(q0)] = q0
    mujoco.mj_kinematics(model, data)
    ankles = ankle_joints(model, data, legs)
    index = {name: i for i, name in enumerate(joints)}
    root = model.body(root_body).id
    joint = model.body_jntadr[root]
    return TiltStabilizer(
        root_id=root,
        root_qadr=int(model.jnt_qposadr[joint]),
        root_dofadr=int(model.jnt_dofadr[joint]),
        ankles={leg: [index[model.joint(j).name] for j in ids] for leg, ids in ankles.items()},
        ankle_ids=ankles,
        gain=gain,
        damping=damping,
    )
