"""Static formulas of irteus (irteus manual: ``:calc-static-balance-point``,
``:calc-force-from-joint-torque``, ``:torque-ratio-vector``): the static
balance point, the end-effector wrench of joint torques, joint torque limits."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.spatial import STANDARD_GRAVITY

_ANGLE_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))

DEFAULT_MAX_TORQUE = 100.0
"""irteus' default joint torque limit [N·m] when the model gives none."""


def static_balance_point(
    mass: float,
    com: Sequence[float] | np.ndarray,
    external_forces: Sequence[Sequence[float]] | np.ndarray = (),
    external_moments: Sequence[Sequence[float]] | np.ndarray = (),
    points: Sequence[Sequence[float]] | np.ndarray = (),
    z: float = 0.0,
    gravity: float = STANDARD_GRAVITY,
) -> np.ndarray:
    """Static balance point (irteus ``:calc-static-balance-point``, static extended ZMP).

    The point ``s = (s_x, s_y, z)`` where a ground reaction balancing gravity
    ``m g`` at the centroid ``c`` and the external forces ``f_i`` and moments
    ``n_i`` ACTING ON the robot at points ``p_i`` has no horizontal moment:

    .. math::

        s_x = \\frac{m g c_x + \\sum_i \\big((p_{i,z} - z) f_{i,x} - p_{i,x} f_{i,z}
              + n_{i,y}\\big)}{m g - \\sum_i f_{i,z}}, \\qquad
        s_y = \\frac{m g c_y + \\sum_i \\big((p_{i,z} - z) f_{i,y} - p_{i,y} f_{i,z}
              - n_{i,x}\\big)}{m g - \\sum_i f_{i,z}}

    Args:
        mass: Robot mass [kg].
        com: Centroid (3,) [m].
        external_forces: Forces (k, 3) [N].
        external_moments: Moments (k, 3) [N·m] (empty: zeros).
        points: Application points (k, 3) [m].
        z: Height of the balance point [m] (irteus manual:
            ``static-balance-point-height``).
        gravity: Gravitational acceleration [m/s²] (``|model.opt.gravity|``).

    Returns:
        ``(s_x, s_y, z)`` [m].
    """
    c = inputs.flat_vector(com, 3, "com")
    if not (np.isfinite(mass) and mass > 0):
        raise InvalidInput(f"mass must be > 0 [kg], got {mass}")
    F = np.asarray(external_forces, dtype=float).reshape(-1, 3)
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    M = np.asarray(external_moments, dtype=float).reshape(-1, 3)
    if M.size == 0:
        M = np.zeros_like(F)
    if not (F.shape == P.shape == M.shape):
        raise InvalidInput(
            f"external_forces {F.shape}, external_moments {M.shape} and points {P.shape} "
            "must all have shape (k, 3)"
        )
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(P)) and np.all(np.isfinite(M))):
        raise InvalidInput("external forces, moments and points must be finite")
    mg = mass * gravity
    denom = mg - F[:, 2].sum()
    if denom <= 1e-9:
        raise PikError(f"the ground would have to pull (m g − Σ f_z = {denom:.3g} N)")
    h = P[:, 2] - z
    sx = (mg * c[0] + np.sum(h * F[:, 0] - P[:, 0] * F[:, 2] + M[:, 1])) / denom
    sy = (mg * c[1] + np.sum(h * F[:, 1] - P[:, 1] * F[:, 2] - M[:, 0])) / denom
    return np.array([sx, sy, float(z)])


def force_from_joint_torque(J: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """End-effector wrench from joint torques (irteus ``:calc-force-from-joint-torque``).

    The joints holding torques ``τ`` against a wrench ``w`` that the end effector
    EXERTS on the environment satisfy ``τ = Jᵀ w`` (gravity excluded); irteus
    inverts it with the pseudo-inverse:

    .. math::

        w = (J^T)^{\\#} \\tau = (J J^T)^{-1} J \\tau \\quad (\\text{rank } J = 6)

    (the minimum-norm wrench when ``J`` has fewer than 6 independent columns).

    Args:
        J: End-effector Jacobian ``[J_p; J_ω]`` (6, n) over the limb's joints.
        tau: Joint torques (n,) [N·m].

    Returns:
        ``w = (f, n)`` (6,) [N, N·m].
    """
    J = np.asarray(J, dtype=float)
    if J.ndim != 2 or J.shape[0] != 6:
        raise InvalidInput(f"J must have shape (6, n), got {J.shape}")
    tau = inputs.flat_vector(tau, J.shape[1], "tau")
    return np.linalg.pinv(J.T) @ tau


def torque_limits(
    model: mujoco.MjModel, max_torque: float | Mapping[str, float] = DEFAULT_MAX_TORQUE
) -> np.ndarray:
    """Torque limit of each dof [N·m or N]; NaN for free and ball joints.

    Taken from, in order: the joint's ``actuatorfrcrange`` (``jnt_actfrcrange``),
    the ``forcerange`` × gear of a force-limited actuator driving the joint,
    ``max_torque`` (a float for every joint, or a mapping joint name → limit;
    joints it omits get :data:`DEFAULT_MAX_TORQUE`).
    """
    if isinstance(max_torque, Mapping):
        names = {model.joint(j).name for j in range(model.njnt)}
        for k, v in max_torque.items():
            if k not in names:
                raise UnknownName("joint", k, names)
            if not (np.isfinite(v) and v > 0):
                raise InvalidInput(f"max_torque[{k!r}] must be > 0, got {v}")
    elif not (np.isfinite(max_torque) and max_torque > 0):
        raise InvalidInput(f"max_torque must be > 0 [N·m], got {max_torque}")
    limits = np.full(model.nv, np.nan)
    for j in range(model.njnt):
        if int(model.jnt_type[j]) not in _ANGLE_JOINTS:
            continue
        name = model.joint(j).name
        if model.jnt_actfrclimited[j]:
            lim = float(np.max(np.abs(model.jnt_actfrcrange[j])))
        else:
            lim = np.nan
            for a in range(model.nu):
                if (
                    int(model.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)
                    and model.actuator_trnid[a, 0] == j
                    and model.actuator_forcelimited[a]
                ):
                    gear = abs(float(model.actuator_gear[a, 0]))
                    lim = float(np.max(np.abs(model.actuator_forcerange[a]))) * gear
                    break
            if np.isnan(lim):
                lim = float(
                    max_torque.get(name, DEFAULT_MAX_TORQUE)
                    if isinstance(max_torque, Mapping)
                    else max_torque
                )
        limits[model.jnt_dofadr[j]] = lim
    return limits


def torque_ratio(
    model: mujoco.MjModel,
    tau: Sequence[float] | np.ndarray,
    max_torque: float | Mapping[str, float] = DEFAULT_MAX_TORQUE,
) -> np.ndarray:
    """Signed ratio ``τ_i / τ_max,i`` per dof (irteus ``:torque-ratio-vector``).

    ``|ratio| > 1`` means a joint exceeds its limit (:func:`torque_limits`).
    Free- and ball-joint dofs are NaN.

    Args:
        model: The model.
        tau: Generalized forces (nv,).
        max_torque: Fallback limit(s), see :func:`torque_limits`.

    Returns:
        Ratios (nv,).
    """
    tau = inputs.flat_vector(tau, model.nv, "tau (length nv)")
    return tau / torque_limits(model, max_torque)
