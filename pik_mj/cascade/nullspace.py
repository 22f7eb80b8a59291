"""The cascade's levels solved one after the other in the null space of the
levels above (:class:`NullSpaceCascade`): in closed form, with an active set
of hard and kept inequality rows, or by the QP backend."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pik_mj.cascade.linalg import (
    chol_solve,
    cholesky,
    gram_solve,
    inverse_cholesky,
    pinv_psd,
)
from pik_mj.exceptions import InfeasibleHardConstraints, QPFailure
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.problem import LevelProblem
from pik_mj.tasks.task import TaskRows

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


def overshoot(cx: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """How far each row value ``cx`` lies outside ``[lo, hi]`` [row units]
    (<= 0: within)."""
    return np.maximum(lo - cx, cx - hi)


def _crossed(cx: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[int]:
    """The rows whose value ``cx`` lies outside ``[lo, hi]`` by more than
    :data:`FEASIBILITY_TOLERANCE`."""
    return np.flatnonzero(overshoot(cx, lo, hi) > FEASIBILITY_TOLERANCE).tolist()


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
            self.x = B.T @ (pinv_psd(B @ B.T) @ hard.b)
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
        L = cholesky(G)
        if L is None:
            removed = B.T @ (pinv_psd(G) @ B)
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
        return overshoot(self.C @ x, *self._allowed())

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
        u = gram_solve(B, G, r, lam, self.nv)
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
        Li = inverse_cholesky(Cw @ PCt, (Cw * Cw).sum(axis=1))
        if Li is None:
            return None, {}  # held rows dependent on each other or on kept equalities
        Y = Li @ PCt.T
        x_p = Y.T @ (Li @ t) if x_e is None else x_e + Y.T @ (Li @ (t - Cw @ x_e))
        Z = A_hat @ Y.T
        u = gram_solve(free.B - Z @ Y, free.G - Z @ Z.T, b_hat - A_hat @ x_p, lam, self.nv)
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
                    r = chol_solve(S, MN.T @ n)
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
