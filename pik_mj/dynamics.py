"""Statics and inverse dynamics (irteus ``:torque-vector``, ``:calc-zmp``,
``:calc-static-balance-point``, ``:calc-force-from-joint-torque``).

MuJoCo does the mechanics: ``mj_inverse`` (recursive Newton–Euler, the mass
matrix with armature, passive forces), ``mj_jac*`` (Jacobians),
``mj_differentiatePos`` (finite differences on the configuration manifold).

Sign convention: every wrench passed in or returned here — an external wrench,
a contact wrench, the ground reaction — is the wrench ACTING ON the robot,
expressed in the world frame, ``w = (f, n)`` [N, N·m]. The joint torques that
hold a motion then are

.. math::

    \\tau = M(q)\\,\\ddot q + c(q, \\dot q) - \\tau_{passive}
          - \\sum_k J_k^T w_k

with ``J_k = [J_p; J_ω]`` (6, nv) the world Jacobian of the point where ``w_k``
acts (its moment ``n_k`` taken about that point). ``M q̈ + c − τ_passive`` is
MuJoCo's ``qfrc_inverse`` (computed with the constraint solver disabled, so
contacts of a scene play no part). For a static pose ``q̇ = q̈ = 0`` this is
``τ = g(q) − Σ Jᵀ w``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np
import qpsolvers

from pik_mj import inputs
from pik_mj.balance import ContactConstraint, wrench_constraints
from pik_mj.exceptions import InvalidInput, PikError, UnknownName
from pik_mj.frames import Frame, robot_root_body
from pik_mj.spatial import STANDARD_GRAVITY, skew

_ANGLE_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))

DEFAULT_MAX_TORQUE = 100.0
"""irteus' default joint torque limit [N·m] when the model gives none."""

ExternalSpec = tuple[str, Sequence[float] | np.ndarray, Sequence[float] | np.ndarray]
"""``(frame name, force (3,) [N], moment (3,) [N·m])``, world frame, acting on the robot
at the frame's origin."""


# ----------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------


def _vector(value: object, size: int, what: str) -> np.ndarray:
    """``value`` flattened, as :func:`pik_mj.inputs.vector` of ``size``."""
    try:
        flat: object = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        flat = value  # refused by inputs.vector, which names it
    return inputs.vector(flat, size, what)


def _state(model: mujoco.MjModel, q: object, qvel: object, qacc: object):
    q = _vector(q, model.nq, "q (length nq)")
    v = np.zeros(model.nv) if np.isscalar(qvel) and qvel == 0 else _vector(qvel, model.nv, "qvel")
    a = np.zeros(model.nv) if np.isscalar(qacc) and qacc == 0 else _vector(qacc, model.nv, "qacc")
    return q, v, a


def _inverse(
    model: mujoco.MjModel, data: mujoco.MjData, q: np.ndarray, v: np.ndarray, a: np.ndarray
) -> np.ndarray:
    """``qfrc_inverse = M a + c(q, v) − τ_passive`` with constraints disabled (nv,)."""
    data.qpos[:] = q
    data.qvel[:] = v
    data.qacc[:] = a
    saved = model.opt.disableflags
    model.opt.disableflags = saved | int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    try:
        mujoco.mj_inverse(model, data)
    finally:
        model.opt.disableflags = saved
    return data.qfrc_inverse.copy()


def frame_jacobian(model: mujoco.MjModel, data: mujoco.MjData, frame: Frame) -> np.ndarray:
    """``[J_p; J_ω]`` (6, nv) of a frame origin, world frame (kinematics must be current)."""
    J_p, J_w = frame.jacobians(data)
    return np.vstack([J_p, J_w])


def _external_wrenches(
    model: mujoco.MjModel, external: Sequence[ExternalSpec]
) -> list[tuple[Frame, np.ndarray]]:
    if isinstance(external, (str, bytes)) or not isinstance(external, Sequence):
        raise InvalidInput("external must be a list of (frame, force (3,), moment (3,)) tuples")
    out = []
    for i, item in enumerate(external):
        if not isinstance(item, (tuple, list)) or len(item) not in (2, 3):
            raise InvalidInput(
                f"external[{i}] must be (frame name, force (3,)[, moment (3,)]), got {item!r}"
            )
        name = item[0]
        frame = name if isinstance(name, Frame) else Frame.find(model, name)
        f = _vector(item[1], 3, f"external[{i}] force")
        n = _vector(item[2], 3, f"external[{i}] moment") if len(item) == 3 else np.zeros(3)
        out.append((frame, np.concatenate([f, n])))
    return out


def _generalized_external(
    model: mujoco.MjModel, data: mujoco.MjData, external: Sequence[ExternalSpec]
) -> np.ndarray:
    """``Σ J_kᵀ w_k`` (nv,) of the external wrenches at the current kinematics."""
    total = np.zeros(model.nv)
    for frame, w in _external_wrenches(model, external):
        total += frame_jacobian(model, data, frame).T @ w
    return total


def joint_torques(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q: Sequence[float] | np.ndarray,
    qvel: Sequence[float] | np.ndarray | float = 0.0,
    qacc: Sequence[float] | np.ndarray | float = 0.0,
    external: Sequence[ExternalSpec] = (),
) -> np.ndarray:
    """Generalized forces that produce ``qacc`` at ``(q, qvel)`` under external wrenches.

    .. math::

        \\tau = \\underbrace{M(q)\\ddot q + c(q,\\dot q) - \\tau_{passive}}_{
        \\texttt{mj\\_inverse}} - \\sum_k J_k^T w_k

    For a floating base the free joint's rows are the wrench the base would need
    (zero only when the external wrenches balance the motion); see
    :func:`static_torques` for a robot standing on its feet.

    Args:
        model: The model.
        data: Workspace; its ``qpos``, ``qvel``, ``qacc`` and kinematics are overwritten.
        q: Configuration (nq,).
        qvel: Velocity (nv,) [rad/s, m/s], or 0.
        qacc: Acceleration (nv,) [rad/s², m/s²], or 0.
        external: ``[(frame name, force (3,) [N], moment (3,) [N·m]), ...]``: wrenches
            ACTING ON the robot at each frame's origin (site, body or geom), world frame.

    Returns:
        ``τ`` (nv,) [N·m for hinges, N for slides; free-joint rows as MuJoCo's dofs].
    """
    q, v, a = _state(model, q, qvel, qacc)
    tau = _inverse(model, data, q, v, a)
    return tau - _generalized_external(model, data, external)


# ----------------------------------------------------------------------------
# floating base
# ----------------------------------------------------------------------------


def free_root_body(model: mujoco.MjModel, root_body: str | None = None) -> int:
    """Id of the floating-base body: the robot's root body
    (:func:`pik_mj.robot.robot_root_body`), which must have a free joint."""
    b = robot_root_body(model, root_body)
    j = int(model.body_jntadr[b])
    if j < 0 or int(model.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_FREE):
        raise InvalidInput(
            f"body {model.body(b).name!r} has no free joint: a floating base is needed here"
        )
    return b


def _root_dofs(model: mujoco.MjModel, body: int) -> np.ndarray:
    j = int(model.body_jntadr[body])
    return np.arange(model.jnt_dofadr[j], model.jnt_dofadr[j] + 6)


def root_wrench(
    model: mujoco.MjModel, data: mujoco.MjData, tau: np.ndarray, root_body: str | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The world wrench on the floating base that the free-joint rows of ``tau`` stand for.

    With ``J_B`` the 6x6 block of the root body's world Jacobian on its own free
    joint (kinematics must be current),

    .. math::

        \\tau_{root} = J_B^T w_B \\;\\Rightarrow\\; w_B = J_B^{-T} \\tau_{root}

    Returns:
        ``(w_B (6,) = (f, n about p_WB), p_WB (3,))`` [N, N·m, m].
    """
    b = free_root_body(model, root_body)
    dofs = _root_dofs(model, b)
    J_B = frame_jacobian(model, data, Frame(model, model.body(b).name, "body", b))[:, dofs]
    return np.linalg.solve(J_B.T, tau[dofs]), data.xpos[b].copy()


def zmp_from_wrench(f: np.ndarray, n_W0: np.ndarray, z: float) -> np.ndarray:
    """Point on the plane ``z`` where the horizontal moment of ``(f, n_W0)`` vanishes.

    .. math::

        n_s = n_0 - s \\times f = 0_{xy} \\Rightarrow
        s_x = \\frac{z f_x - n_{0,y}}{f_z},\\; s_y = \\frac{z f_y + n_{0,x}}{f_z}
    """
    if f[2] <= 1e-9:
        raise PikError(
            f"the ground reaction has no upward force (f_z = {f[2]:.3g} N): the ZMP is undefined"
        )
    return np.array([(z * f[0] - n_W0[1]) / f[2], (z * f[1] + n_W0[0]) / f[2]])


def zmp_from_inverse_dynamics(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q: Sequence[float] | np.ndarray,
    qvel: Sequence[float] | np.ndarray | float = 0.0,
    qacc: Sequence[float] | np.ndarray | float = 0.0,
    z: float = 0.0,
    *,
    external: Sequence[ExternalSpec] = (),
    root_body: str | None = None,
) -> np.ndarray:
    """ZMP of a floating-base motion from ``mj_inverse`` (irteus ``:calc-zmp``).

    The free-joint rows of the inverse dynamics (minus the external wrenches)
    are the total wrench the ground must apply, ``(f, n_B)`` about the base
    origin ``p_WB`` (:func:`root_wrench`). Its moment about the world origin is
    ``n_0 = n_B + p_WB × f``, and the ZMP is the point ``s = (s_x, s_y, z)`` of
    the ground plane about which the horizontal moment vanishes:

    .. math::

        s_x = \\frac{z f_x - n_{0,y}}{f_z}, \\qquad
        s_y = \\frac{z f_y + n_{0,x}}{f_z}

    Args:
        model: Model with a free joint.
        data: Workspace (overwritten).
        q: Configuration (nq,).
        qvel: Velocity (nv,) or 0.
        qacc: Acceleration (nv,) or 0.
        z: Height of the ground plane [m].
        external: Other wrenches acting on the robot (see :func:`joint_torques`).
        root_body: The floating-base body (default: see :func:`free_root_body`).

    Returns:
        ``(s_x, s_y)`` [m].

    Raises:
        PikError: The ground would have to pull (``f_z <= 0``).
    """
    tau = joint_torques(model, data, q, qvel, qacc, external)
    w_B, p_WB = root_wrench(model, data, tau, root_body)
    f = w_B[:3]
    return zmp_from_wrench(f, w_B[3:] + np.cross(p_WB, f), float(z))


def zmp_of_motion(
    model: mujoco.MjModel,
    qs: np.ndarray,
    dt: float,
    z: float = 0.0,
    *,
    root_body: str | None = None,
) -> np.ndarray:
    """ZMP along a sampled motion, velocities and accelerations by finite differences.

    With ``q_{k+1} ⊖ q_k`` the tangent difference (``mj_differentiatePos``),

    .. math::

        \\dot q_k = \\frac{q_{k+1} \\ominus q_{k-1}}{2\\,dt}, \\qquad
        \\ddot q_k = \\frac{(q_{k+1} \\ominus q_k) - (q_k \\ominus q_{k-1})}{dt^2}

    (exact for motions quadratic in time). The first and last samples use the
    one-sided velocity and their neighbour's acceleration.

    Args:
        model: Model with a free joint.
        qs: Configurations (T, nq), T >= 3, sampled every ``dt``.
        dt: Sample period [s].
        z: Ground height [m].
        root_body: The floating-base body.

    Returns:
        ZMP per sample (T, 2) [m].
    """
    qs = np.asarray(qs, dtype=float)
    if qs.ndim != 2 or qs.shape[1] != model.nq or qs.shape[0] < 3:
        raise InvalidInput(f"qs must have shape (T >= 3, nq = {model.nq}), got {qs.shape}")
    if not np.all(np.isfinite(qs)):
        raise InvalidInput("qs holds NaN or inf")
    if not (np.isfinite(dt) and dt > 0):
        raise InvalidInput(f"dt must be a positive number of seconds, got {dt}")
    T = qs.shape[0]
    diff = np.zeros((T - 1, model.nv))  # (q_{k+1} ⊖ q_k) / dt
    for k in range(T - 1):
        mujoco.mj_differentiatePos(model, diff[k], dt, qs[k], qs[k + 1])
    vel = np.vstack([diff[:1], 0.5 * (diff[:-1] + diff[1:]), diff[-1:]])
    acc = (diff[1:] - diff[:-1]) / dt
    acc = np.vstack([acc[:1], acc, acc[-1:]])
    data = mujoco.MjData(model)
    return np.array(
        [
            zmp_from_inverse_dynamics(model, data, qs[k], vel[k], acc[k], z, root_body=root_body)
            for k in range(T)
        ]
    )


# ----------------------------------------------------------------------------
# contact wrench distribution (irteus :distribute-total-wrench-to-torque-method-default)
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class SoleContact:
    """A flat rectangular contact attached to a robot frame.

    Attributes:
        frame: Site (or body/geom) at the sole centre; its z-axis is the contact
            normal pointing into the robot, its x-axis the sole's length.
        half_x: Half length of the sole [m].
        half_y: Half width of the sole [m].
        mu: Friction coefficient.
        frame_type: ``"site"``, ``"body"``, ``"geom"`` or None (search).
    """

    frame: str
    half_x: float
    half_y: float
    mu: float = 0.5
    frame_type: str | None = None

    def constraint(self, model: mujoco.MjModel, data: mujoco.MjData) -> ContactConstraint:
        """The :class:`ContactConstraint` at the frame's current pose."""
        f = Frame.find(model, self.frame, self.frame_type)
        return ContactConstraint(
            p_WC=f.position(data),
            R_WC=f.rotation(data),
            half_x=self.half_x,
            half_y=self.half_y,
            mu=self.mu,
        )


class StaticTorques(NamedTuple):
    """Result of :func:`static_torques` (all wrenches act on the robot, world frame).

    Attributes:
        tau: Joint torques with the contacts, ``g(q) − J_extᵀ w_ext − J_cᵀ w_c`` (nv,);
            the free-joint rows are the residual (≈ 0).
        gravity: ``g(q) − J_extᵀ w_ext`` (nv,), no contacts.
        wrenches: Contact wrenches ``(f, n about the contact origin)`` (n_c, 6) [N, N·m].
        cops: Centre of pressure of each contact (n_c, 3) [m].
        contact_jacobians: ``J_c`` (6 n_c, nv) at the contact origins.
    """

    tau: np.ndarray
    gravity: np.ndarray
    wrenches: np.ndarray
    cops: np.ndarray
    contact_jacobians: np.ndarray


def static_torques(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    q: Sequence[float] | np.ndarray,
    contacts: Sequence[SoleContact],
    external: Sequence[ExternalSpec] = (),
    *,
    moment_weight: float = 100.0,
    root_body: str | None = None,
) -> StaticTorques:
    """Joint torques of a static pose standing on ``contacts`` (irteus ``:torque-vector``).

    The contact wrenches ``w = (w_1, ..., w_n)`` are the least-norm split
    (:func:`contact_wrenches`, each centre of pressure inside its sole and each
    force inside its inscribed friction pyramid) of the wrench the floating base
    needs: with ``g = qfrc_inverse`` at zero velocity and acceleration minus the
    external wrenches' ``J_extᵀ w_ext``, and ``root`` the free joint's rows,

    .. math::

        J_{c,root}^T w = g_{root}
        \\;\\Leftrightarrow\\; \\sum_i w_i = J_B^{-T} g_{root}
        \\quad (\\text{about one point, :func:`root_wrench`})

    Then ``τ = g − J_cᵀ w``, whose free-joint rows vanish.

    Args:
        model: Model with a free joint.
        data: Workspace (overwritten).
        q: Configuration (nq,).
        contacts: The soles in contact.
        external: Other wrenches acting on the robot (see :func:`joint_torques`).
        moment_weight: ``ρ`` [1/m²]: the larger, the closer each CoP to its sole centre.
        root_body: The floating-base body.

    Returns:
        :class:`StaticTorques`.

    Raises:
        PikError: No contact wrenches within the limits hold the pose.
    """
    if not contacts:
        raise InvalidInput("contacts is empty: give at least one SoleContact")
    for i, c in enumerate(contacts):
        if not isinstance(c, SoleContact):
            raise InvalidInput(f"contacts[{i}] must be a SoleContact, got {type(c).__name__}")
    gravity = joint_torques(model, data, q, 0.0, 0.0, external)
    # the wrench (about the world origin) the contacts must apply: what the free
    # joint's rows of g - J_ext^T w_ext stand for
    w_B, p_WB = root_wrench(model, data, gravity, root_body)
    total = np.concatenate([w_B[:3], w_B[3:] + np.cross(p_WB, w_B[:3])])
    constraints = [c.constraint(model, data) for c in contacts]
    wrenches = contact_wrenches(constraints, total, moment_weight=moment_weight)
    if wrenches is None:
        raise PikError(
            f"no contact wrenches on {[c.frame for c in contacts]} within the sole and "
            "friction limits hold this pose (the centre of mass or the external wrenches "
            "are outside what the contacts can balance)"
        )
    J_c = np.vstack(
        [frame_jacobian(model, data, Frame.find(model, c.frame, c.frame_type)) for c in contacts]
    )
    tau = gravity - J_c.T @ wrenches.reshape(-1)
    cops = np.array([_cop(c, w) for c, w in zip(constraints, wrenches, strict=True)])
    return StaticTorques(tau, gravity, wrenches, cops, J_c)


def contact_wrenches(
    contacts: Sequence[ContactConstraint],
    total: Sequence[float] | np.ndarray,
    *,
    moment_weight: float = 100.0,
) -> np.ndarray | None:
    """Least-norm contact wrenches inside their limits that sum to ``total``.

    Each contact ``i`` applies ``w_i = (f_i, n_i)`` at ``p_i`` (moment about
    ``p_i``), inside its limits ``C_i w_i + d_i >= 0``
    (:func:`pik_mj.balance.wrench_constraints`: friction pyramid, centre of
    pressure inside the rectangle, torsion); a point contact (zero half sizes)
    carries no moment, so only its force is unknown. The QP (DAQP)

    .. math::

        \\min_w \\sum_i \\|f_i\\|^2 + \\rho \\|n_i\\|^2
        \\quad\\text{s.t.}\\quad
        \\sum_i \\begin{bmatrix} f_i \\\\ n_i + p_i \\times f_i \\end{bmatrix} = w_{total},
        \\quad C_i w_i + d_i \\ge 0

    is solved in units of ``|f_total|`` (an O(1) problem whatever the robot's weight).
    The least-norm split keeps forces away from the edges of the cones, where a
    feed-forward would push a foot to slip (an LP's solution sits on an edge).

    Args:
        contacts: The contacts.
        total: The wrench ``(f, n about the world origin)`` (6,) [N, N·m] the
            contacts must apply together (e.g. minus gravity and the external wrenches).
        moment_weight: ``ρ`` [1/m²]: the larger, the closer each CoP to its centre.

    Returns:
        Wrenches ``(n, 6)`` [N, N·m], or None when no wrenches within the limits exist.
    """
    total = _vector(total, 6, "total")
    if not (np.isfinite(moment_weight) and moment_weight > 0):
        raise InvalidInput(f"moment_weight must be > 0 [1/m²], got {moment_weight}")
    cols, weights, A, G, h = [], [], [], [], []
    n = 0
    for c in contacts:
        C, d = wrench_constraints(c)
        point = c.half_x == 0.0 and c.half_y == 0.0
        if point:  # rows on the force alone; the moment rows pin n = 0
            keep = ~np.any(C[:, 3:] != 0.0, axis=1)
            C, d = C[keep, :3], d[keep]
        k = 3 if point else 6
        cols.append((n, k))
        weights += [1.0] * 3 + ([] if point else [moment_weight] * 3)
        block = np.zeros((6, k))
        block[:3, :3] = np.eye(3)
        block[3:, :3] = skew(c.p_WC)
        if not point:
            block[3:, 3:] = np.eye(3)
        A.append(block)
        G.append((n, C))
        h.append(d)
        n += k
    A_eq = np.hstack(A) if A else np.zeros((6, 0))
    G_in = np.zeros((sum(len(d) for d in h), n))
    r = 0
    for start, C in G:
        G_in[r : r + len(C), start : start + C.shape[1]] = C
        r += len(C)
    scale = float(np.linalg.norm(total[:3])) or 1.0
    x = qpsolvers.solve_qp(
        np.diag(weights),
        np.zeros(n),
        G=-G_in,
        h=np.concatenate(h) / scale if h else np.zeros(0),
        A=A_eq,
        b=total / scale,
        solver="daqp",
    )
    if x is None:
        return None
    out = np.zeros((len(contacts), 6))
    for i, (start, k) in enumerate(cols):
        out[i, :k] = scale * x[start : start + k]
    return out


def _cop(contact: ContactConstraint, w: np.ndarray) -> np.ndarray:
    """Centre of pressure on the contact plane of a wrench about ``p_WC``.

    In the contact frame, ``p = (-n_y / f_z, n_x / f_z, 0)``.
    """
    R = contact.R_WC
    f_C, n_C = R.T @ w[:3], R.T @ w[3:]
    if f_C[2] <= 1e-9:
        return np.full(3, np.nan)
    return contact.p_WC + R @ np.array([-n_C[1] / f_C[2], n_C[0] / f_C[2], 0.0])


# ----------------------------------------------------------------------------
# seed formulas
# ----------------------------------------------------------------------------


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
        z: Height of the balance point [m] (seed ``static-balance-point-height``).
        gravity: Gravitational acceleration [m/s²] (``|model.opt.gravity|``).

    Returns:
        ``(s_x, s_y, z)`` [m].
    """
    c = _vector(com, 3, "com")
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
    EXERTS on the environment satisfy ``τ = Jᵀ w`` (gravity excluded); the seed
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
    tau = _vector(tau, J.shape[1], "tau")
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
    tau = _vector(tau, model.nv, "tau (length nv)")
    return tau / torque_limits(model, max_torque)
