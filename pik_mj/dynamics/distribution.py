"""Contact wrench distribution (irteus manual:
``:distribute-total-wrench-to-torque-method-default``): the least-norm contact
wrenches within their limits that hold a static pose, and its joint torques."""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, NamedTuple

import daqp
import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.balance.contacts import ContactConstraint, contact_from_normal, wrench_constraints
from pik_mj.dynamics.floating_base import root_wrench
from pik_mj.dynamics.inverse import ExternalSpec, frame_jacobian, joint_torques
from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.frames import Frame


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
    solver: Literal["auto", "qp"] = "auto",
) -> np.ndarray | None:
    """Least-norm contact wrenches inside their limits that sum to ``total``.

    Each contact ``i`` applies ``w_i = (f_i, n_i)`` at ``p_i`` (moment about
    ``p_i``), inside its limits ``C_i w_i + d_i >= 0``
    (:func:`pik_mj.balance.wrench_constraints`: friction pyramid, centre of
    pressure inside the rectangle, torsion); a point contact (zero half sizes)
    carries no moment, so only its force is unknown. The QP

    .. math::

        \\min_w \\sum_i \\|f_i\\|^2 + \\rho \\|n_i\\|^2
        \\quad\\text{s.t.}\\quad
        \\underbrace{\\sum_i \\begin{bmatrix} f_i \\\\ n_i + p_i \\times f_i \\end{bmatrix}}_{A w}
        = w_{total},
        \\quad C_i w_i + d_i \\ge 0

    is solved in units of ``|f_total|`` (an O(1) problem whatever the robot's weight).
    Its equality-constrained minimum, the weighted least-norm split
    (``W = diag(1, ρ)``)

    .. math::

        w^* = W^{-1} A^T (A W^{-1} A^T)^{-1} w_{total},

    is the QP's solution whenever it is within every limit (the objective is
    strictly convex): it is taken then (``solver="auto"``), and DAQP solves the
    QP only where a limit is active, or where ``A`` has not full row rank
    (contacts on one line: :attr:`ContactDistribution.least_norm_map`).
    The least-norm split keeps forces away from the edges of the cones, where a
    feed-forward would push a foot to slip (an LP's solution sits on an edge).

    Args:
        contacts: The contacts.
        total: The wrench ``(f, n about the world origin)`` (6,) [N, N·m] the
            contacts must apply together (e.g. minus gravity and the external wrenches).
        moment_weight: ``ρ`` [1/m²]: the larger, the closer each CoP to its centre.
        solver: ``"auto"`` (the closed form where it is within the limits, else
            the QP) or ``"qp"`` (always the QP).

    Returns:
        Wrenches ``(n, 6)`` [N, N·m], or None when no wrenches within the limits exist.
    """
    total = inputs.flat_vector(total, 6, "total")
    return ContactDistribution(contacts, moment_weight).solve(total, solver)


class ContactDistribution:
    """The problem of :func:`contact_wrenches` for fixed contacts, solved for
    any number of totals: the unknowns ``x`` (a force per point contact, a
    force and a moment per flat one), the map ``A`` of ``x`` to the wrench about
    the world origin, the weights ``W`` and the limits ``G x <= h``
    (``G = -C``).

    Args:
        contacts: The contacts.
        moment_weight: ``ρ`` [1/m²] (:func:`contact_wrenches`).
        points: The contacts' points ``p_i`` (n, 3) [m] in place of their
            ``p_WC`` (see :meth:`of_points`).
    """

    def __init__(
        self,
        contacts: Sequence[ContactConstraint],
        moment_weight: float = 100.0,
        *,
        points: np.ndarray | None = None,
    ):
        _check_moment_weight(moment_weight)
        for i, c in enumerate(contacts):
            if not isinstance(c, ContactConstraint):
                raise InvalidInput(
                    f"contacts[{i}] must be a ContactConstraint, got {type(c).__name__}"
                )
        points = [c.p_WC for c in contacts] if points is None else points
        self._assemble([_limits(c) for c in contacts], points, moment_weight)

    def _assemble(
        self, limits: list[tuple[np.ndarray, np.ndarray]], points, moment_weight: float
    ) -> None:
        """``A``, ``W``, ``G``, ``h`` (class docstring) of contacts with the limits
        ``C, d`` (:func:`_limits`) at ``points``."""
        rows = [len(d) for _, d in limits]
        if limits and len(set(rows)) == 1 and all(C.shape[1] == 3 for C, _ in limits):
            self._assemble_points(limits, points)
            return
        widths = [C.shape[1] for C, _ in limits]
        n = sum(widths)
        starts = np.cumsum([0, *widths[:-1]]).astype(int) if widths else np.zeros(0, int)
        cols = list(zip(starts.tolist(), widths, strict=True))
        weights = [w for k in widths for w in [1.0] * 3 + [moment_weight] * (k - 3)]
        A = np.zeros((6, n))
        if n:
            forces = (starts[:, None] + np.arange(3)).reshape(-1)
            A[:, forces] = wrench_map(points)
        for start, k in cols:
            if k == 6:
                A[3:, start + 3 : start + 6] = np.eye(3)
        self.A, self.n, self.cols, self.weights = A, n, cols, np.array(weights)
        self._points_only = n == 3 * len(cols)  # every contact a point: a force alone
        self.h = np.concatenate([d for _, d in limits]) if limits else np.zeros(0)
        self.G = np.zeros((sum(rows), n))
        r = 0
        for (start, k), (C, _) in zip(cols, limits, strict=True):
            self.G[r : r + len(C), start : start + k] = -C
            r += len(C)
        self._clear_solvers()

    def _assemble_points(self, limits: list[tuple[np.ndarray, np.ndarray]], points) -> None:
        """:meth:`_assemble` of point contacts whose limits have the same rows:
        ``A`` the points' :func:`wrench_map`, unit weights, ``G`` block-diagonal."""
        K, r = len(limits), len(limits[0][1])
        self.A, self.n = wrench_map(points), 3 * K
        self.cols, self.weights = [(3 * i, 3) for i in range(K)], np.ones(3 * K)
        self._points_only = True  # a force alone each
        self.h = np.concatenate([d for _, d in limits])
        G = np.zeros((K, r, K, 3))
        G[np.arange(K), :, np.arange(K), :] = -np.array([C for C, _ in limits])
        self.G = G.reshape(K * r, 3 * K)
        self._clear_solvers()

    def _clear_solvers(self) -> None:
        """No least-norm map (:attr:`least_norm_map`) nor DAQP problem (:meth:`_qp`)
        formed yet."""
        self._map: np.ndarray | bool | None = False
        self._daqp: tuple[np.ndarray, ...] | None = None

    @classmethod
    def of_points(
        cls, points: np.ndarray, normals: np.ndarray, mu: np.ndarray, moment_weight: float = 100.0
    ) -> ContactDistribution:
        """Point contacts at ``points`` (n, 3) [m] pushed along ``normals`` (n, 3),
        with friction ``mu`` (n,), inside their inscribed pyramids
        (:func:`pik_mj.balance.contact_from_normal`). A contact's limits depend
        on its normal and friction only: the constraints are shared by every
        contact with the same ones, wherever it is."""
        _check_moment_weight(moment_weight)
        normals = np.asarray(normals, float).reshape(-1, 3).tolist()
        keys = tuple(
            (*normal, friction)
            for normal, friction in zip(normals, np.asarray(mu, float).tolist(), strict=True)
        )
        points = np.asarray(points, float).reshape(-1, 3)
        distribution = cls.__new__(cls)
        shared = _POINT_LIMITS.get((moment_weight, keys))
        if shared is not None:  # A alone depends on the points
            distribution.A = wrench_map(points)
            distribution.n, distribution.cols, distribution.weights = shared[:3]
            distribution._points_only, distribution.h, distribution.G = shared[3:]
            distribution._clear_solvers()
            return distribution
        found = {key: _limits(_at_origin(*key)) for key in dict.fromkeys(keys)}
        distribution._assemble([found[key] for key in keys], points, moment_weight)
        if len(_POINT_LIMITS) >= 1024:
            _POINT_LIMITS.clear()
        d = distribution
        for x in (d.weights, d.h, d.G):
            x.flags.writeable = False
        _POINT_LIMITS[moment_weight, keys] = (d.n, d.cols, d.weights, d._points_only, d.h, d.G)
        return distribution

    @property
    def least_norm_map(self) -> np.ndarray | None:
        """``L = W⁻¹ Aᵀ (A W⁻¹ Aᵀ)⁻¹`` (n, 6): the weighted least-norm ``x = L w``
        with ``A x = w`` for every wrench ``w``; None where ``A`` has not full row
        rank (``A L`` misses the identity by more than 1e-9: contacts on one line)."""
        if self._map is False:
            AW = self.A / self.weights if self.n else self.A
            try:
                L = AW.T @ np.linalg.inv(AW @ self.A.T)
            except np.linalg.LinAlgError:
                L = None
            # a non-finite L leaves A L non-finite (A has the identity on each force)
            ok = L is not None and np.max(np.abs(self.A @ L - _EYE6)) <= 1e-9
            self._map = L if ok else None
        return self._map

    def solve(self, total: np.ndarray, solver: Literal["auto", "qp"] = "auto") -> np.ndarray | None:
        """:func:`contact_wrenches` of the wrench ``total`` (6,) [N, N·m]: the
        wrenches (contacts, 6), or None."""
        if solver not in ("auto", "qp"):
            raise InvalidInput(f"solver must be 'auto' or 'qp', got {solver!r}")
        found = self.solve_unknowns(total, solver)
        if found is None:
            return None
        scale, x = found
        out = np.zeros((len(self.cols), 6))
        if self._points_only:  # forces alone, three columns each
            out[:, :3] = (scale * x).reshape(-1, 3)
            return out
        for i, (start, k) in enumerate(self.cols):
            out[i, :k] = scale * x[start : start + k]
        return out

    def solve_unknowns(
        self, total: np.ndarray, solver: Literal["auto", "qp"] = "auto"
    ) -> tuple[float, np.ndarray] | None:
        """:meth:`solve` as the unknowns ``x`` (n,) in units of ``s = |f_total|``
        (1 for a pure moment) and ``s``: the wrenches are ``s x`` (a force per
        point contact, a force and a moment per flat one, :attr:`cols`); None
        without a solution (``solver`` unchecked)."""
        force = total[:3].ravel(order="K")
        scale = math.sqrt(force.dot(force)) or 1.0  # |f| as np.linalg.norm
        b = total / scale
        h = self.h / scale
        L = self.least_norm_map if solver == "auto" else None
        x = None if L is None else L @ b
        if x is not None and not (self.G @ x <= h).all():
            x = None
        if x is None:
            x = self._qp(h, b)
        return None if x is None else (scale, x)

    def _qp(self, h: np.ndarray, b: np.ndarray) -> np.ndarray | None:
        """DAQP on ``min ½ xᵀ W x`` s.t. ``G x ≤ h``, ``A x = b`` (the rows of
        ``G`` then of ``A``, the latter equalities: ``sense`` 5, lower bounds
        ``-1e30``, as qpsolvers' ``solve_qp(..., solver="daqp")`` poses it); the
        solution, or None (``exitflag ≤ 0``)."""
        if self._daqp is None:
            rows = len(self.G) + len(self.A)
            sense = np.zeros(rows, dtype=np.intc)
            sense[len(self.G) :] = 5
            self._daqp = (
                np.diag(self.weights),
                np.zeros(self.n),
                np.vstack([self.G, self.A]),
                np.full(rows, -1e30),
                sense,
            )
        H, f, C, lower, sense = self._daqp
        x, _, exitflag, _ = daqp.solve(H, f, C, np.concatenate([h, b]), lower, sense)
        return x if exitflag > 0 else None


def _check_moment_weight(moment_weight: float) -> None:
    """``ρ`` > 0, finite.

    Raises:
        InvalidInput: It is not.
    """
    if not (np.isfinite(moment_weight) and moment_weight > 0):
        raise InvalidInput(f"moment_weight must be > 0 [1/m²], got {moment_weight}")


def wrench_map(points: Sequence[np.ndarray] | np.ndarray) -> np.ndarray:
    """``A`` (6, 3n): forces ``f_i`` at the points ``p_i`` (n, 3) [m] to the
    wrench they apply about the world origin, ``(Σ f_i, Σ p_i × f_i)``."""
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    x, y, z = P.T
    A = np.zeros((6, len(P), 3))
    A[:3] = _EYE3
    A[3, :, 1], A[3, :, 2] = -z, y
    A[4, :, 0], A[4, :, 2] = z, -x
    A[5, :, 0], A[5, :, 1] = -y, x
    return A.reshape(6, -1)


@functools.lru_cache(maxsize=1024)
def _at_origin(nx: float, ny: float, nz: float, mu: float) -> ContactConstraint:
    """A point contact at the origin with the normal ``(nx, ny, nz)`` and friction ``mu``."""
    return contact_from_normal(np.zeros(3), np.array([nx, ny, nz]), mu=mu)


_LIMITS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

_EYE6 = np.eye(6)
_EYE3 = np.eye(3)[:, None, :]  # (3, 1, 3): the forces' rows of A, broadcast over the points

_POINT_LIMITS: dict[tuple, tuple] = {}
"""What :meth:`ContactDistribution.of_points` builds of the contacts' normals
and friction alone (``n``, ``cols``, ``weights``, points only, ``h``, ``G``;
read-only), by ``moment_weight`` and their values."""


def _limits(contact: ContactConstraint) -> tuple[np.ndarray, np.ndarray]:
    """``C, d`` of :func:`pik_mj.balance.wrench_constraints` (read-only); a
    point contact's on its force alone (rows that involve the moment dropped:
    they pin ``n = 0``). They depend on the contact's frame, sizes, friction
    and force bounds, not on its position: cached by those values."""
    c = contact
    key = (c.R_WC.tobytes(), c.half_x, c.half_y, c.mu, c.fz_min, c.fz_max, c.torsion, c.pyramid)
    found = _LIMITS.get(key)
    if found is None:
        C, d = wrench_constraints(contact)
        if c.half_x == 0.0 and c.half_y == 0.0:
            keep = ~np.any(C[:, 3:] != 0.0, axis=1)
            C, d = C[keep, :3], d[keep]
        C.flags.writeable = False
        d.flags.writeable = False
        if len(_LIMITS) >= 4096:
            _LIMITS.clear()
        found = _LIMITS[key] = (C, d)
    return found


def _cop(contact: ContactConstraint, w: np.ndarray) -> np.ndarray:
    """Centre of pressure on the contact plane of a wrench about ``p_WC``.

    In the contact frame, ``p = (-n_y / f_z, n_x / f_z, 0)``.
    """
    R = contact.R_WC
    f_C, n_C = R.T @ w[:3], R.T @ w[3:]
    if f_C[2] <= 1e-9:
        return np.full(3, np.nan)
    return contact.p_WC + R @ np.array([-n_C[1] / f_C[2], n_C[0] / f_C[2], 0.0])
