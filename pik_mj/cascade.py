"""One step of the priority cascade: one QP per level (seed 000,
``prioritized-inverse-kinematics``).

Level ``k >= 1`` solves, over ``x = Δq`` (length ``nv``) and slacks ``ω_k`` for its
own inequality rows:

.. math::

    \\min_{x, \\omega_k}\\; \\sum (A_k x - b_k)^T W_A (A_k x - b_k)
        + \\omega_k^T W_C \\omega_k + \\lambda_k \\|x\\|^2

subject to

* level 0's rows, hard: ``A_0 x = b_0``, ``d_l0 <= C_0 x <= d_u0``;
* every level ``j < k`` kept at what it achieved at its own solution ``x_j*``:
  equality rows ``A_j x = A_j x_j*`` and inequality rows
  ``min(d_lj, C_j x_j*) - τ <= C_j x <= max(d_uj, C_j x_j*) + τ``;
* ``d_lk <= C_k x + ω_k <= d_uk``;

with ``λ_k = min(w + w_r e_k, w_max) + μ_k``, ``e_k`` the level's squared error at
``x = 0`` and ``μ_k`` the tasks' own Levenberg–Marquardt damping.

:class:`NullSpaceCascade` solves the levels in order:

* when no inequality row is active, the level's optimum is in closed form:
  its equality part minimized over the null space of the kept equality rows
  (projector ``P``). This is the common case (joint limits far away): a few
  small dense products;
* when that optimum crosses a few hard or kept inequality rows (joint limits
  reached), those found active are held at their bounds as extra equality
  rows of this level alone and the level is solved again in closed form
  (:meth:`NullSpaceCascade.active_set`), accepted only with a KKT
  certificate (feasible, multipliers of the right sign): the level's exact
  optimum, like the closed form (no ``τ``, no feasibility error);
* otherwise (no certificate, the level's own inequality rows needing their
  slacks, ``λ_k = 0``) the level's QP goes to the QP backend (OSQP by
  default), with the kept equality rows as equalities and the inequality rows
  as bounds;
* a hierarchical backend (``"daqp-hqp"``, :class:`~pik_mj.qp.HierarchicalBackend`)
  solves all levels in one call instead, exactly (``λ_k → 0``, ``τ = 0``).

``τ`` (:data:`DEFAULT_RELAXATION`) absorbs the inexactness of a first-order
solver, so that a lower level can never be made infeasible by the rounding of a
higher one; it is also the bound by which a lower level may move a higher
level's inequality rows. Kept inequality rows are further widened by the
feasibility error ``v_k`` of every backend solution from their level on times
the row's 1-norm, since each ``x_k*`` met them only to within ``v_k``: a row
``a`` of level ``j`` ends within ``τ + ‖a‖₁ Σ_{k>=j} v_k`` of what level ``j``
achieved (the bound the tests check); an equality row ends within the
feasibility error of the backend solutions below it (0 in closed form).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import mujoco
import numpy as np

from pik_mj.exceptions import InfeasibleHardConstraints, InvalidInput, QPFailure
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.hierarchy import HierarchicalProblem
from pik_mj.qp.make import as_backend
from pik_mj.qp.problem import LevelProblem, QPSolution
from pik_mj.tasks.task import TaskRows

DEFAULT_RELAXATION = 1e-5
"""τ [row units: m, rad], ten times the absolute tolerance of the default OSQP
settings. A lower level may move a higher level's row by at most
``τ + ε_prim``, with ``ε_prim = eps_abs + eps_rel·max(|A z|, |z|)`` OSQP's
primal feasibility tolerance."""

FEASIBILITY_TOLERANCE = 1e-10
"""How far [row units] the closed-form step may cross an inequality before the
level goes to the active-set closed form or the QP backend."""

FACE_ROUNDS = 2
"""Most faces :meth:`NullSpaceCascade.active_set` tries by adding the rows
crossed on the face before (then the dual active-set method decides)."""

ACTIVE_SET_STEPS = 16
"""Most rows :meth:`NullSpaceCascade.dual_active_set` adds before the level
goes to the QP backend."""

KKT_TOLERANCE = 1e-9
"""Relative tolerance of the active-set certificate: a held row's multiplier
(per unit 1-norm of the row) may have the wrong sign, and the stationarity
residual may be, by this times the gradient's scale."""


@dataclass(frozen=True)
class Regularization:
    """Seed ``regular``, ``regular-rel``, ``regular-max`` for one level.

    ``λ = min(w + w_r · e, w_max)`` where ``e`` is the level's squared error.
    """

    w: float = 1e-6
    w_r: float = 5.0
    w_max: float = 0.1

    def weight(self, squared_error: float) -> float:
        return min(self.w + self.w_r * squared_error, self.w_max)


def per_level(value: float | Sequence[float], n_levels: int, name: str) -> list[float]:
    """Seed convention: a float is shared by every level, a list gives one per level."""
    if type(value) is float:  # the common case, without numpy calls
        values = [value] * n_levels
    else:
        try:
            if np.ndim(value) == 0:
                values = [float(value)] * n_levels  # type: ignore[arg-type]
            else:
                values = [float(v) for v in value]  # type: ignore[union-attr]
        except (TypeError, ValueError):
            raise InvalidInput(
                f"{name} must be a float or one float per solved level, got {value!r}"
            ) from None
        if isinstance(value, bool) or (
            np.ndim(value) > 0 and any(isinstance(v, bool) for v in value)  # type: ignore[union-attr]
        ):
            raise InvalidInput(f"{name} must be a float or one per solved level, got {value!r}")
        if len(values) != n_levels:
            raise InvalidInput(
                f"{name} has {len(values)} entries; give a float or one per solved level "
                f"({n_levels})"
            )
    if not all(math.isfinite(v) and v >= 0 for v in values):
        raise InvalidInput(f"{name} must be finite and >= 0, got {values}")
    return values


@dataclass
class CascadeStep:
    """Result of one cascade step.

    Attributes:
        x: The step of the last level, shape (nv,).
        level_x: ``x_k*`` for each solved level k = 1..K (empty for a
            hierarchical backend, which returns the last only).
        level_errors: Squared error ``e_k`` of each solved level at ``x = 0``.
        level_lambdas: Regularization ``λ_k`` used at each level (0 for a
            hierarchical backend: each level exact).
        problems: The QP of each level handed to the backend (levels solved in
            closed form have none; see :meth:`NullSpaceCascade.level_problem`),
            or the one :class:`HierarchicalProblem` (whose arrays the backend's
            next problem of the same shape rewrites: copy them to keep them).
        violations: Feasibility error ``v_k`` of each level's solution
            (largest constraint violation of its QP; 0 in closed form). A row
            ``a`` of level ``j`` ends within ``τ + ‖a‖₁ Σ_{k>=j} v_k`` of its
            value at ``x_j*``.
        closed_form: Number of levels solved in closed form.
    """

    x: np.ndarray
    level_x: list[np.ndarray]
    level_errors: list[float]
    level_lambdas: list[float]
    problems: list[LevelProblem | HierarchicalProblem] = field(default_factory=list)
    violations: list[float] = field(default_factory=list)
    closed_form: int = 0


def _pinv_psd(G: np.ndarray) -> np.ndarray:
    """Pseudo-inverse of a small symmetric positive semidefinite matrix."""
    s, V = np.linalg.eigh(G)
    keep = s > 1e-12 * max(float(s[-1]) if s.size else 0.0, 1e-300)
    return (V[:, keep] / s[keep]) @ V[:, keep].T


CHOLESKY_PIVOT = 1e-8
"""Smallest Cholesky pivot ``L_ii²``, relative to ``G``'s largest diagonal
entry, for which a Gram matrix ``G = B Bᵀ`` is treated as regular (its rows
independent); below it, :func:`_pinv_psd` (an eigendecomposition, about
twice the time of the factorization and solve on these sizes) decides the
rank."""


def _cholesky_factor(G: np.ndarray) -> np.ndarray | None:
    """MuJoCo's dense Cholesky factor (``mju_cholFactor``) of a small symmetric
    ``G``, made in a copy of ``G``: ``L`` (``G = L Lᵀ``) in its lower triangle,
    ``G``'s entries above. None when a pivot ``L_ii²`` is below
    :data:`CHOLESKY_PIVOT` times ``G``'s largest diagonal entry (``G`` singular
    or nearly so, or not positive definite: then ``G⁺`` is not ``G⁻¹``).
    MuJoCo's calls, not numpy's: on a 12x12 ``G`` factor and solve take 2.4
    µs, numpy's ``cholesky`` and ``solve`` 12.6 µs (their Python wrappers);
    and a second BLAS (scipy's) in the loop would bring a second thread pool,
    which on a loaded machine made solves up to 8 times slower."""
    n = G.shape[0]
    top = float(G.diagonal().max()) if n else 0.0
    if top <= 0.0:  # (no rows, or no positive pivot; NaN goes on and comes out NaN)
        return None
    L = np.array(G, dtype=float)  # factored in place
    if mujoco.mju_cholFactor(L, CHOLESKY_PIVOT * top) < n:
        return None
    return L


def _cholesky(G: np.ndarray) -> np.ndarray | None:
    """Lower Cholesky factor ``L`` (``G = L Lᵀ``, zeros above the diagonal)
    of :func:`_cholesky_factor`, or None."""
    L = _cholesky_factor(G)
    return None if L is None else np.tril(L)


def _chol_solve(G: np.ndarray, r: np.ndarray) -> np.ndarray | None:
    """``G⁻¹ r`` with :func:`_cholesky_factor` (``mju_cholSolve``), or None."""
    L = _cholesky_factor(G)
    if L is None:
        return None
    x = np.empty(G.shape[0])
    mujoco.mju_cholSolve(x, L, np.ascontiguousarray(r, dtype=float))
    return x


def _regular_solve(G: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``G⁻¹ r`` for a regular ``G = B Bᵀ + λ I`` (``λ > 0``): MuJoCo's
    Cholesky (:func:`_chol_solve`), numpy's LU solve when a pivot is below
    its test (``λ`` small against ``G``'s largest diagonal entry)."""
    y = _chol_solve(G, r)
    return np.linalg.solve(G, r) if y is None else y


def _overshoot(cx: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """How far each row value ``cx`` lies outside ``[lo, hi]`` [row units]
    (<= 0: within)."""
    return np.maximum(lo - cx, cx - hi)


def _crossed(cx: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[int]:
    """The rows whose value ``cx`` lies outside ``[lo, hi]`` by more than
    :data:`FEASIBILITY_TOLERANCE`."""
    return np.flatnonzero(_overshoot(cx, lo, hi) > FEASIBILITY_TOLERANCE).tolist()


def _gram_solve(B: np.ndarray, G: np.ndarray, r: np.ndarray, lam: float, nv: int) -> np.ndarray:
    """``u = Bᵀ G⁻¹ r`` with ``G = B Bᵀ + λ I`` (``G⁺`` when ``λ = 0``); zero
    without rows."""
    if r.size == 0:
        return np.zeros(nv)
    return B.T @ (_regular_solve(G, r) if lam > 0 else _psd_solve(G, r))


class _Unconstrained(NamedTuple):
    """A level's optimum with every inequality inactive, and its products:
    ``x``, ``Â = W^½ A_k``, ``W^½ b_k``, ``B = Â P``, ``G = B Bᵀ + λ I``,
    ``x_e = (I − P) x`` (None while ``P = I``)."""

    x: np.ndarray
    A_hat: np.ndarray
    b_hat: np.ndarray
    B: np.ndarray
    G: np.ndarray
    x_e: np.ndarray | None


def _inverse_cholesky(S: np.ndarray, norms: np.ndarray) -> np.ndarray | None:
    """``L⁻¹`` for ``S = C P Cᵀ = L Lᵀ`` (rows ``C`` projected by ``P``), or
    None when a pivot ``L_ii²`` is below :data:`CHOLESKY_PIVOT` times its
    row's squared norm ``norms_i = ‖c_i‖²`` (the row nearly a combination of
    the rows before it and of those ``P`` projects out)."""
    if S.shape[0] == 1:
        s = float(S[0, 0])
        return np.array([[1.0 / math.sqrt(s)]]) if s > CHOLESKY_PIVOT * float(norms[0]) else None
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        return None
    d = L.diagonal()
    if bool((d * d <= CHOLESKY_PIVOT * norms).any()):
        return None
    return np.linalg.inv(L)


def _psd_solve(G: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``G⁺ r`` for a small symmetric positive semidefinite ``G``: ``G⁻¹ r``
    when ``G`` is regular, else the pseudo-inverse."""
    y = _chol_solve(G, r)
    return _pinv_psd(G) @ r if y is None else y


class NullSpaceCascade:
    """The cascade's levels, one after the other.

    Keeps ``x`` (the step so far) and ``P``, the orthogonal projector onto the
    null space of every kept equality row (None while it is ``I``). Level
    ``k`` (equality rows ``Â = W^½ A_k``, ``r = W^½ (b_k − A_k x)``) minimizes
    ``‖Â (x + P v) − W^½ b_k‖² + λ_k ‖x + P v‖²``; with ``B = Â P``:

    .. math::

        u = B^T (B B^T + \\lambda_k I)^{-1} (r + B x), \\qquad
        x_k = (I − P) x + u

    This is the level's optimum when it meets every inequality (hard rows, kept
    inequality rows, the level's own rows with ``ω = 0``); otherwise
    :meth:`active_set` holds the active hard and kept rows at their bounds,
    and failing its certificate :meth:`level_problem` goes to the QP backend.
    Then the projector is updated with the level's equality rows
    (``P ← P − Bᵀ (B Bᵀ)^+ B``; held rows are this level's alone).
    """

    def __init__(self, hard: TaskRows, backend: QPBackend | None, relaxation: float, role: str):
        nv = hard.A.shape[1]
        self.backend, self.tau, self.role = backend, relaxation, role
        self.hard = hard
        self.nv = nv
        self.x = np.zeros(nv)
        self.P: np.ndarray | None = None  # None: still I (the products with it are skipped)
        # The inequality rows to respect, stacked: C x in [lo, hi], widened
        # by _allowed.
        self.C, self.lo, self.hi = hard.C, hard.d_lower, hard.d_upper
        self.s0 = np.zeros(hard.n_in)
        self._norm1: np.ndarray | None = None  # of C's rows, made when first needed
        self.slack = 0.0  # Σ feasibility errors of backend solutions so far
        self.held = 0  # levels solved by active_set
        self.released = 0  # rows released by dual_active_set's partial steps
        # kept equality rows E x = e (the hard ones, then each level's), as
        # blocks (A_j, x_j*) with e_j = A_j x_j*: stacked only for the backend
        self._kept: list[tuple[np.ndarray, np.ndarray]] = []
        if hard.n_eq:
            B = hard.A
            self.x = B.T @ (_pinv_psd(B @ B.T) @ hard.b)
            if not np.allclose(B @ self.x, hard.b, atol=FEASIBILITY_TOLERANCE):
                raise InfeasibleHardConstraints(
                    "the equality rows of level 0 admit no step (inconsistent equations)"
                )
            self._keep(hard.A)

    def kept_equalities(self) -> tuple[np.ndarray, np.ndarray]:
        """The kept equality rows ``E x = e``: level 0's, then each solved
        level's at what it achieved (``A_j x = A_j x_j*``)."""
        E = np.vstack([self.hard.A, *(A for A, _ in self._kept)])
        e = np.concatenate([self.hard.b, *(A @ x for A, x in self._kept)])
        return E, e

    def _keep(self, A: np.ndarray) -> None:
        """``P ← P − Bᵀ (B Bᵀ)⁺ B`` with ``B = A P``: with ``B Bᵀ = L Lᵀ``
        regular, ``Bᵀ (B Bᵀ)⁻¹ B = Yᵀ Y``, ``Y = L⁻¹ B``."""
        if A.shape[0] == 0:
            return
        B = A if self.P is None else A @ self.P
        G = B @ B.T
        L = _cholesky(G)
        if L is None:
            removed = B.T @ (_pinv_psd(G) @ B)
        else:
            Y = np.linalg.solve(L, B)
            removed = Y.T @ Y
        self.P = (np.eye(self.nv) if self.P is None else self.P) - removed

    @property
    def norm1(self) -> np.ndarray:
        """1-norm of each inequality row of :attr:`C`."""
        if self._norm1 is None or self._norm1.size != self.C.shape[0]:
            self._norm1 = np.abs(self.C).sum(axis=1)
        return self._norm1

    def _allowed(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds of :attr:`C`'s rows widened by their allowance: each row
        by ``(slack − s0)`` times its 1-norm (the feasibility errors of the
        backend solutions from its own level on; none while ``slack`` is 0)."""
        if self.slack > 0:
            extra = (self.slack - self.s0) * self.norm1
            return self.lo - extra, self.hi + extra
        return self.lo, self.hi

    def _excess(self, x: np.ndarray) -> np.ndarray:
        """Violation of each inequality row at ``x`` beyond its allowance (<= 0: met)."""
        return _overshoot(self.C @ x, *self._allowed())

    def candidate(self, rows: TaskRows, lam: float) -> np.ndarray:
        """The level's optimum with every inequality inactive (closed form)."""
        return self._unconstrained(rows, lam).x

    def _unconstrained(self, rows: TaskRows, lam: float) -> _Unconstrained:
        """:meth:`candidate` with the products that :meth:`active_set` reuses.
        ``x_e = (I − P) x`` (0 while ``P = I``) is the part of any step meeting
        the kept equality rows in their row space, and ``r + B x = W^½ b − Â x_e``."""
        sw = np.sqrt(rows.w_A)
        A_hat = sw[:, None] * rows.A
        b_hat = sw * rows.b
        if self.P is None:
            B, r, x_e = A_hat, b_hat, None
        else:
            B = A_hat @ self.P
            x_e = self.x - self.P @ self.x
            r = b_hat - A_hat @ x_e
        G = B @ B.T
        G.flat[:: G.shape[0] + 1] += lam
        u = _gram_solve(B, G, r, lam, self.nv)
        return _Unconstrained(u if x_e is None else x_e + u, A_hat, b_hat, B, G, x_e)

    def active_set(self, rows: TaskRows, lam: float, free: _Unconstrained) -> np.ndarray | None:
        """The level's optimum with a few hard or kept inequality rows active,
        in closed form, or None when it cannot be certified (the backend then
        solves the level).

        First the rows the unconstrained optimum ``free`` violates are held at
        their violated bounds (:meth:`face`), then also those that face's
        optimum violates (at most :data:`FACE_ROUNDS` faces); when a face's
        optimum has no KKT certificate otherwise, the rows to hold are found by
        the dual active-set method (:meth:`dual_active_set`) and their face is
        solved and certified in turn.
        """
        C = self.C
        if not C.shape[0]:
            return None  # only the level's own rows violated: their slacks need the backend
        lo, hi = self._allowed()
        cx = C @ free.x
        fixed = _crossed(cx, lo, hi)
        if not fixed:
            return None  # only the level's own rows violated
        upper = [bool(cx[i] > hi[i]) for i in fixed]
        for _ in range(FACE_ROUNDS):
            x, crossed = self.face(rows, lam, free, lo, hi, fixed, upper)
            if x is not None or not crossed:
                break
            fixed += crossed
            upper += [bool(cx_i > hi[i]) for i, cx_i in crossed.items()]
        if x is None:
            held = self.dual_active_set(lam, free, lo, hi)
            if held is not None and held[0]:
                x, _ = self.face(rows, lam, free, lo, hi, *held)
        return x

    def face(
        self,
        rows: TaskRows,
        lam: float,
        free: _Unconstrained,
        lo: np.ndarray,
        hi: np.ndarray,
        fixed: list[int],
        upper: list[bool],
    ) -> tuple[np.ndarray | None, dict[int, float]]:
        """The level's optimum with the inequality rows ``fixed`` of :attr:`C`
        held at their bounds (``hi`` where ``upper``, else ``lo``), if it is
        the level's optimum: None unless it carries a KKT certificate; and the
        rows of :attr:`C` that face's optimum violates (row: ``C_i x``; empty
        unless that is why it is None).

        The rows ``C_W x = t_W`` are held in addition to the kept equality
        rows. With ``S = C_W P C_Wᵀ = L Lᵀ`` (regular: else None),
        ``Y = L⁻¹ C_W P`` (so ``Y Yᵀ = I``) and ``Z = Â Yᵀ``, the projector onto
        the null space of both is ``P_W = P − Yᵀ Y``, and the optimum on that
        face is :meth:`candidate`'s with ``P_W``:

        .. math::

            x_p = x_e + Y^T L^{-1} (t_W − C_W x_e), \\qquad
            x_W = x_p + B_W^T (B B^T + \\lambda_k I − Z Z^T)^{-1} (W^½ b − Â x_p)

        with ``B_W = B − Z Y`` (so ``B_W B_Wᵀ = B Bᵀ − Z Zᵀ``) and ``x_p`` the
        point of least norm meeting the kept equality rows and the held rows.
        Its multipliers, from the gradient ``g = Âᵀ (Â x_W − W^½ b) + λ_k x_W``
        and ``g + Eᵀ μ + C_Wᵀ ν = 0``, are ``ν = −L⁻ᵀ Y g``. The certificate,
        which for this convex QP makes ``x_W`` THE optimum: every inequality
        row met within :data:`FEASIBILITY_TOLERANCE` (the level's own rows with
        ``ω = 0``), ``ν_i ≥ 0`` at an upper bound and ``ν_i ≤ 0`` at a lower
        one (either for a row with equal bounds), and the stationarity
        residual ``P_W g = 0``, both within :data:`KKT_TOLERANCE` of the
        gradient's scale.
        """
        C, P, A_hat, b_hat, x_e = self.C, self.P, free.A_hat, free.b_hat, free.x_e
        Cw = C.take(fixed, axis=0)
        t = np.array([hi[i] if up else lo[i] for i, up in zip(fixed, upper, strict=True)])
        PCt = Cw.T if P is None else P @ Cw.T
        Li = _inverse_cholesky(Cw @ PCt, (Cw * Cw).sum(axis=1))
        if Li is None:
            return None, {}  # held rows dependent on each other or on kept equalities
        Y = Li @ PCt.T
        x_p = Y.T @ (Li @ t) if x_e is None else x_e + Y.T @ (Li @ (t - Cw @ x_e))
        Z = A_hat @ Y.T
        u = _gram_solve(free.B - Z @ Y, free.G - Z @ Z.T, b_hat - A_hat @ x_p, lam, self.nv)
        x = x_p + u
        # u meets C_W u = 0 only to within about ε/λ_k (B_W Bᵀ_W + λ I is
        # nearly singular along the held rows): back onto the face, within P's
        # range (the kept equality rows unchanged).
        x += Y.T @ (Li @ (t - Cw @ x))
        cx = C @ x
        crossed = _crossed(cx, lo, hi)
        if crossed:
            if any(i in fixed for i in crossed):
                return None, {}  # a held row off its bound: rounding
            return None, {i: float(cx[i]) for i in crossed}
        if rows.n_in and self._violates(rows, x, FEASIBILITY_TOLERANCE):
            return None, {}  # the level's own rows need their slacks
        g = A_hat.T @ (A_hat @ x - b_hat) + lam * x
        Yg = Y @ g
        nu = -(Li.T @ Yg)
        # A bound on the gradient's terms: ‖Â‖² ‖x‖ + ‖Â‖ ‖W^½ b‖ + λ ‖x‖.
        a2 = float(np.dot(A_hat.ravel(), A_hat.ravel()))
        norm_x = math.sqrt(float(x @ x))
        scale = (a2 + lam) * norm_x + math.sqrt(a2 * float(b_hat @ b_hat))
        if not math.isfinite(scale):
            return None, {}
        tol = KKT_TOLERANCE * max(scale, 1e-300)
        # Multipliers per unit 1-norm of their row, of the right sign (either
        # for a row with equal bounds).
        norm1 = self.norm1
        for i, up, nu_i in zip(fixed, upper, nu.tolist(), strict=True):
            if (nu_i if up else -nu_i) * norm1[i] < -tol and hi[i] - lo[i] > FEASIBILITY_TOLERANCE:
                return None, {}
        stationarity = (g if P is None else P @ g) - Y.T @ Yg  # P_W g
        if float(np.abs(stationarity).max()) > tol:
            return None, {}
        return x, {}

    def dual_active_set(
        self, lam: float, free: _Unconstrained, lo: np.ndarray, hi: np.ndarray
    ) -> tuple[list[int], list[bool]] | None:
        """The inequality rows of :attr:`C` active at the level's optimum, as
        ``(rows, at upper bound)``, by Goldfarb and Idnani's dual active-set
        method from the unconstrained optimum, or None (``λ_k = 0``, dependent
        rows, no convergence within :data:`ACTIVE_SET_STEPS` steps).

        Rows are written ``n_iᵀ x ≥ b_i`` (``n = c, b = d_l`` at a lower bound,
        ``n = −c, b = −d_u`` at an upper one) with multipliers ``u_i ≥ 0``.
        ``M = (P − Bᵀ G⁻¹ B) / λ_k`` is the inverse of the level's Hessian on
        the null space of the kept equality rows. Each step takes the most
        violated row ``p``; with ``N`` the held rows' normals and
        ``S = Nᵀ M N``: primal direction ``z = M n_p − M N S⁻¹ Nᵀ M n_p``, dual
        direction ``r = S⁻¹ Nᵀ M n_p``; step ``t = min(t_1, t_2)`` with
        ``t_2 = (b_p − n_pᵀ x) / zᵀ n_p`` (``p`` becomes active) and
        ``t_1 = min_{r_i > 0} u_i / r_i`` (held row ``i`` released first).
        The rows only; :meth:`face` then solves and certifies their face.
        """
        if lam <= 0:
            return None
        C, P, B = self.C, self.P, free.B
        M = B.T @ np.linalg.solve(free.G, B) if B.shape[0] else np.zeros((self.nv, self.nv))
        M = ((np.eye(self.nv) if P is None else P) - M) / lam
        norm1 = self.norm1
        x = free.x
        held: list[int] = []
        normals: list[np.ndarray] = []
        u: list[float] = []
        for _ in range(ACTIVE_SET_STEPS):
            cx = C @ x
            below, above = lo - cx, cx - hi
            excess = np.maximum(below, above)
            p = int(np.argmax(excess / np.maximum(norm1, 1e-300)))  # (zero rows: no 0/0)
            if excess[p] <= FEASIBILITY_TOLERANCE:
                return held, [float(n @ C[i]) < 0 for i, n in zip(held, normals, strict=True)]
            if p in held:
                return None  # a held row off its bound: rounding
            n = C[p] if below[p] > above[p] else -C[p]
            b_p = lo[p] if below[p] > above[p] else -hi[p]
            u_p = 0.0
            while True:
                Mn = M @ n
                if held:
                    N = np.array(normals).T
                    MN = M @ N
                    S = N.T @ MN
                    r = _chol_solve(S, MN.T @ n)
                    if r is None:
                        return None
                    z = Mn - MN @ r
                else:
                    r, z = np.zeros(0), Mn
                zn = float(z @ n)
                t1, k = math.inf, -1
                for j, (r_j, u_j) in enumerate(zip(r.tolist(), u, strict=True)):
                    if r_j > 0 and u_j / r_j < t1:
                        t1, k = u_j / r_j, j
                t2 = (b_p - float(n @ x)) / zn if zn > 1e-10 * float(n @ Mn) else math.inf
                t = min(t1, t2)
                if t == math.inf:
                    return None  # infeasible with the held rows: the backend says so
                x = x + t * z
                u = [u_j - t * r_j for u_j, r_j in zip(u, r.tolist(), strict=True)]
                u_p += t
                if t2 <= t1:
                    held.append(p)
                    normals.append(n)
                    u.append(u_p)
                    break
                del held[k], normals[k], u[k]
                self.released += 1
        return None

    def _violates(self, rows: TaskRows, x: np.ndarray, tol: float) -> bool:
        """Whether ``x`` violates a kept row (beyond its allowance) or one of the
        level's own inequality rows by more than ``tol``."""
        if self.C.shape[0] and float(self._excess(x).max()) > tol:
            return True
        if rows.n_in:
            cx = rows.C @ x
            return bool(((cx < rows.d_lower - tol) | (cx > rows.d_upper + tol)).any())
        return False

    def level_problem(self, level: int, rows: TaskRows, lam: float) -> LevelProblem:
        """The level's QP over ``z = [x; ω]`` for the backend: the kept equality
        rows as equalities at their achieved values, the hard and kept
        inequality rows within their (widened) bounds, the level's own
        inequality rows with slacks. Sparse when the Jacobians are (OSQP's
        iterations then cost little)."""
        n, m = self.nv, rows.n_in
        WA = rows.w_A[:, None] * rows.A
        P = np.zeros((n + m, n + m))
        P[:n, :n] = rows.A.T @ WA
        P.flat[: n * (n + m + 1) : n + m + 1] += lam
        P.flat[n * (n + m + 1) :: n + m + 1] = rows.w_C
        q = np.zeros(n + m)
        q[:n] = -(WA.T @ rows.b)
        E, e = self.kept_equalities()
        n_e, n_c = E.shape[0], self.C.shape[0]
        A = np.zeros((n_e + n_c + m, n + m))
        A[:n_e, :n] = E
        A[n_e : n_e + n_c, :n] = self.C
        A[n_e + n_c :, :n] = rows.C
        A[n_e + n_c :, n:] = np.eye(m)
        lo, hi = self._allowed()
        l = np.concatenate([e, lo, rows.d_lower])
        u = np.concatenate([e, hi, rows.d_upper])
        return LevelProblem(level, P, q, A, l, u, n, self.role)

    def level(self, k: int, rows: TaskRows, lam: float, last: bool, exact: bool) -> tuple:
        """Solve level ``k`` (1-based): ``(x_k*, problem or None, violation)``.

        With ``exact`` (closed forms allowed): the closed-form candidate when it
        meets every inequality row, else (with a backend to fall back on)
        :meth:`active_set`'s certified optimum. Otherwise the backend's
        solution of :meth:`level_problem` (without a backend: None). A level
        solved in closed form has no problem and violation 0 (its kept
        inequality rows take ``τ = 0``).
        """
        x_k = None
        if exact:
            free = self._unconstrained(rows, lam)
            x_k = free.x
            if not math.isfinite(float(x_k.sum())):  # NaN or inf anywhere
                x_k = None
            elif self._violates(rows, x_k, FEASIBILITY_TOLERANCE):
                x_k = None if self.backend is None else self.active_set(rows, lam, free)
                self.held += x_k is not None
        problem, violation = None, 0.0
        if x_k is None:
            if self.backend is None:
                return None, None, 0.0
            problem = self.level_problem(k, rows, lam)
            solution = self.backend.solve(problem)
            if not solution.ok or solution.z is None:
                if solution.infeasible and k == 1:
                    raise InfeasibleHardConstraints(
                        f"the hard rows of level 0 admit no step ({solution.status})"
                    )
                raise QPFailure(k, solution.status, problem)
            violation = problem.max_violation(solution.z)
            x_k = solution.z[: problem.nv].copy()
        self.x = x_k
        if not last:
            s0 = self.slack
            self.slack += violation
            A_keep = rows.A[rows.w_A > 0]
            self._keep(A_keep)
            self._kept.append((A_keep, x_k))
            if rows.n_in:
                cx = rows.C @ x_k
                tau = self.tau if problem is not None else 0.0
                self.C = np.vstack([self.C, rows.C])
                self.lo = np.concatenate([self.lo, np.minimum(rows.d_lower, cx) - tau])
                self.hi = np.concatenate([self.hi, np.maximum(rows.d_upper, cx) + tau])
                self.s0 = np.concatenate([self.s0, np.full(rows.n_in, s0)])
        return x_k, problem, violation


def solve_cascade(
    hard: TaskRows,
    levels: Sequence[TaskRows],
    regularization: Sequence[Regularization],
    backend: QPBackend,
    relaxation: float = DEFAULT_RELAXATION,
    role: str = "step",
    closed_form: bool = True,
) -> CascadeStep:
    """Solve the cascade at one linearization point.

    Args:
        hard: Level-0 rows (hard constraints; assumed feasible, never solved alone).
        levels: Rows of levels 1..K, highest priority first.
        regularization: One :class:`Regularization` per level 1..K.
        backend: QP backend, or a hierarchical backend (``solve_hierarchy``).
        relaxation: ``τ`` [row units].
        role: Tag of the problems (``"step"`` or ``"correction"``) for backends
            that cache per problem.
        closed_form: Solve a level in closed form when no inequality is active
            (False: every level goes to the backend). A backend given as an
            object or a function (seed ``qp-solver``) always gets every level.

    Raises:
        InfeasibleHardConstraints: Level 1 is infeasible: only level 0's hard rows
            can make it so.
        QPFailure: Another level's QP failed; carries the level and the problem.
    """
    backend = as_backend(backend)
    errors = [rows.squared_error() for rows in levels]
    hierarchical = backend.solves_hierarchy
    closed_form = closed_form and backend.allows_closed_form
    if hierarchical:
        lambdas = [0.0] * len(levels)
    else:
        lambdas = [
            reg.weight(e) + rows.damping
            for rows, reg, e in zip(levels, regularization, errors, strict=True)
        ]
    if role == "correction" and closed_form and len(levels) == 1:
        x = _projection(hard, levels[0], lambdas[0])
        if x is not None:
            return CascadeStep(x, [x], errors, lambdas, [], [0.0], 1)
    if hierarchical:
        if role == "correction" and closed_form:
            # The projection back onto satisfied levels: exact in closed form
            # (λ = 0, like the hierarchical solve) unless an inequality is active.
            step = _exact(hard, levels, errors)
            if step is not None:
                return step
        return _solve_hierarchy(hard, levels, errors, backend)
    cascade = NullSpaceCascade(hard, backend, relaxation, role)
    level_x: list[np.ndarray] = []
    problems: list[LevelProblem | HierarchicalProblem] = []
    violations: list[float] = []
    n_exact = 0
    n_levels = len(levels)
    for k, rows in enumerate(levels):
        x_k, problem, violation = cascade.level(
            k + 1, rows, lambdas[k], k == n_levels - 1, closed_form
        )
        level_x.append(x_k)
        violations.append(violation)
        if problem is None:
            n_exact += 1
        else:
            problems.append(problem)
    return CascadeStep(level_x[-1].copy(), level_x, errors, lambdas, problems, violations, n_exact)


def _projection(hard: TaskRows, rows: TaskRows, lam: float) -> np.ndarray | None:
    """The correction's common case in closed form: one level of equality rows
    and only inequality rows above it (joint limits). With ``B = W^½ A``,
    ``r = W^½ b``:

    .. math::

        x = B^T (B B^T + \\lambda I)^{-1} r

    returned when it meets every hard row within :data:`FEASIBILITY_TOLERANCE`
    (then it is the level's optimum, as :meth:`NullSpaceCascade.candidate`
    finds it with ``P = I``), else None: other shapes, an active limit, and
    with ``λ = 0`` rows that are dependent (a Cholesky pivot below
    :data:`CHOLESKY_PIVOT`), go to :class:`NullSpaceCascade` and the backend.
    The same products without the cascade's bookkeeping: the solve loop
    corrects 1.2-1.6 times per iteration.
    """
    if hard.n_eq or rows.n_in or not rows.n_eq:
        return None
    sw = np.sqrt(rows.w_A)
    B = sw[:, None] * rows.A
    G = B @ B.T
    if lam > 0:
        G.flat[:: G.shape[0] + 1] += lam
    r = sw * rows.b
    y = _regular_solve(G, r) if lam > 0 else _chol_solve(G, r)
    if y is None:
        return None
    x = B.T @ y
    if not math.isfinite(float(x @ x)):
        return None
    if hard.n_in:
        if float(_overshoot(hard.C @ x, hard.d_lower, hard.d_upper).max()) > FEASIBILITY_TOLERANCE:
            return None
    return x


def _exact(hard: TaskRows, levels: Sequence[TaskRows], errors: list[float]) -> CascadeStep | None:
    """Every level in closed form with ``λ_k = 0``, or None if an inequality is active."""
    cascade = NullSpaceCascade(hard, None, 0.0, "correction")
    level_x = []
    for k, rows in enumerate(levels):
        x_k, _, _ = cascade.level(k + 1, rows, 0.0, k == len(levels) - 1, True)
        if x_k is None:
            return None
        level_x.append(x_k)
    n = len(levels)
    return CascadeStep(level_x[-1].copy(), level_x, errors, [0.0] * n, [], [0.0] * n, n)


def _solve_hierarchy(
    hard: TaskRows, levels: Sequence[TaskRows], errors: list[float], backend: QPBackend
) -> CascadeStep:
    """Every level in one call of a hierarchical backend."""
    problem = backend.hierarchy_problem(hard, levels)
    solution: QPSolution = backend.solve_hierarchy(problem)
    if not solution.ok or solution.z is None:
        if solution.infeasible:
            raise InfeasibleHardConstraints(
                f"the hard rows of level 0 admit no step ({solution.status})"
            )
        raise QPFailure(problem.levels[-1] if problem.levels else 1, solution.status, problem)
    return CascadeStep(
        solution.z.copy(), [], errors, [0.0] * len(levels), [problem], [], closed_form=0
    )
