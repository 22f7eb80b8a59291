"""QP problems of the cascade and the backends that solve them.

Every level of the cascade is one convex QP over ``z = [x; ω]``::

    min  ½ zᵀ P z + qᵀ z    s.t.   l <= A_c z <= u

(equality rows have ``l = u``). :class:`LevelProblem` keeps the matrices dense so
a failing problem can be inspected and re-solved anywhere; the OSQP backend
turns them into CSC matrices with a *fixed* sparsity pattern per level and,
from the second iteration on, only ``update()``s values and warm-starts, since
``setup()`` dominates at this problem size.

A backend is any object with ``solve(problem) -> QPSolution``; seed 000's
``qp-solver``/``qp-args`` map to :func:`make_backend`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

import numpy as np
import osqp
import scipy.sparse as sp

from .exceptions import InvalidInput

OSQP_DEFAULTS: dict[str, Any] = {
    "eps_abs": 1e-6,
    "eps_rel": 1e-6,
    "check_termination": 5,
    # Kept rows of higher levels are intervals of width 2τ (τ = 1e-5); OSQP's
    # infeasibility certificate must be far finer than that or it reports a
    # feasible level as primal infeasible.
    "eps_prim_inf": 1e-7,
    # Polishing stays off: OSQP 1.x prints an unguarded "Polishing not needed"
    # line whenever no constraint is active (osqp/osqp#785) and can accept a
    # polished point far outside tolerance (osqp/osqp#790).
    "polishing": False,
    "max_iter": 20000,
    "warm_starting": True,
    "adaptive_rho": True,
    "verbose": False,
}
"""OSQP settings of the cascade. Tolerances are far tighter than OSQP's defaults
(1e-3) because each level's achieved values become the next levels' constraints,
and because a level's objective gradient is of the size of its error: at 1e-5 a
foot error of 1e-5 m is already "optimal" to OSQP and drift accumulates to 1e-4 m
while a hand reaches; 1e-6 holds it at ~2e-5 m for +25% time per iteration.
Termination is checked every 5 ADMM
iterations (default 25): these problems converge in tens of iterations."""


@dataclass
class LevelProblem:
    """The QP of one priority level, dense, ready to hand to any QP solver.

    Attributes:
        level: Priority level k >= 1.
        P: Hessian, shape (n, n), symmetric positive definite on ``x``.
        q: Linear term, shape (n,).
        A: Constraint matrix, shape (m, n).
        l: Lower bounds, shape (m,) (``-inf`` allowed).
        u: Upper bounds, shape (m,) (``+inf`` allowed).
        nv: Number of step variables ``x`` (the first ``nv`` entries of ``z``).
        role: ``"step"`` for the cascade's step, ``"correction"`` for the
            projection that re-solves satisfied levels; backends cache solvers
            per ``(role, level)``.
    """

    level: int
    P: np.ndarray
    q: np.ndarray
    A: np.ndarray
    l: np.ndarray
    u: np.ndarray
    nv: int
    role: str = "step"

    @property
    def n_slack(self) -> int:
        return self.P.shape[0] - self.nv

    def objective(self, z: np.ndarray) -> float:
        return float(0.5 * z @ self.P @ z + self.q @ z)

    def max_violation(self, z: np.ndarray) -> float:
        Az = self.A @ z
        return float(np.max(np.maximum(self.l - Az, Az - self.u), initial=0.0))


class QPSolution(NamedTuple):
    """Outcome of one QP solve: ``z`` (None on failure), solver status, success."""

    z: np.ndarray | None
    status: str
    ok: bool


class QPBackend(Protocol):
    def solve(self, problem: LevelProblem) -> QPSolution: ...


class _Pattern:
    """A fixed CSC sparsity pattern taken from a dense matrix's nonzeros.

    ``data(M)`` extracts ``M``'s values in CSC order; ``covers(M)`` tells whether
    every nonzero of ``M`` (within ``region`` if given) lies inside the pattern
    (else the pattern must grow and the solver must be set up again). With the
    upper triangle as region, the full symmetric ``P`` is read directly.
    """

    def __init__(self, mask: np.ndarray, region: np.ndarray | None = None):
        self.mask = mask
        cols, rows = np.nonzero(mask.T)  # column-major order = CSC order
        self.rows, self.cols = rows, cols
        self.flat = rows * mask.shape[1] + cols
        # entries of the matrices handed in that must be zero: outside the
        # pattern, within ``region`` (the upper triangle for OSQP's P)
        self.outside = np.flatnonzero(~mask if region is None else region & ~mask)
        self.indptr = np.concatenate([[0], np.cumsum(mask.sum(axis=0))]).astype(np.int64)

    def data(self, M: np.ndarray) -> np.ndarray:
        return M.ravel().take(self.flat)

    def covers(self, M: np.ndarray) -> bool:
        return not M.ravel().take(self.outside).any()

    def csc(self, M: np.ndarray) -> sp.csc_matrix:
        return sp.csc_matrix((self.data(M), self.rows, self.indptr), shape=M.shape)


_OSQP_INFTY = 1e30
_SOLVED = (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)


@dataclass
class _OSQPLevel:
    solver: osqp.OSQP
    P_pattern: _Pattern
    A_pattern: _Pattern
    shape: tuple[int, int]


@dataclass
class OSQPBackend:
    """OSQP with one cached solver per level: setup once, then update + warm start.

    Args:
        settings: OSQP settings overriding :data:`OSQP_DEFAULTS`.
        fallback: A dense ``qpsolvers`` solver tried when OSQP does not reach its
            tolerance (ADMM can stall on degenerate, strongly conflicting levels);
            ``"daqp"`` (dual active-set, exact) by default, None to disable.

    Attributes:
        setups: OSQP ``setup()`` calls so far.
        fallbacks: Levels solved by the fallback so far.
    """

    settings: dict[str, Any] = field(default_factory=dict)
    fallback: str | None = "daqp"
    setups: int = 0
    fallbacks: int = 0
    _levels: dict[tuple[str, int], _OSQPLevel] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.settings = {**OSQP_DEFAULTS, **self.settings}

    def solve(self, problem: LevelProblem) -> QPSolution:
        P = problem.P
        cached = self._levels.get((problem.role, problem.level))
        shape = problem.A.shape
        if (
            cached is None
            or cached.shape != shape  # (m, n): P is (n, n)
            or not cached.P_pattern.covers(P)
            or not cached.A_pattern.covers(problem.A)
        ):
            cached = self._setup(problem, cached)
        else:
            # The extension's own update/solve: osqp's Python wrapper spends ~4x
            # the C solve time per call on bookkeeping for derivatives.
            ext = cached.solver._solver
            ext.update_data_vec(
                q=problem.q,
                l=np.maximum(problem.l, -_OSQP_INFTY),
                u=np.minimum(problem.u, _OSQP_INFTY),
            )
            ext.update_data_mat(
                P_x=cached.P_pattern.data(P),
                P_i=None,
                A_x=cached.A_pattern.data(problem.A),
                A_i=None,
            )
        ext = cached.solver._solver
        ext.solve()
        info = ext.info
        if info.status_val in _SOLVED:
            return QPSolution(np.array(ext.solution.x), info.status, True)
        if self.fallback is not None:
            rescue = QpsolversBackend(self.fallback).solve(problem)
            if rescue.ok:
                self.fallbacks += 1
                return QPSolution(rescue.z, f"{self.fallback} after OSQP {info.status}", True)
        return QPSolution(None, info.status, False)

    def _setup(self, problem: LevelProblem, old: _OSQPLevel | None) -> _OSQPLevel:
        # The pattern is the nonzeros as they are, although a posture's
        # coincidental zeros (an aligned root) cost one more setup() when they
        # fill in: densifying Jacobian rows up front was measured slower, as
        # every later update refactorizes a denser KKT system.
        upper = np.triu(np.ones(problem.P.shape, dtype=bool))
        P_mask = (problem.P != 0) & upper
        P_mask[np.diag_indices_from(P_mask)] = True
        A_mask = problem.A != 0
        if old is not None and old.shape == problem.A.shape:  # grow, never shrink
            P_mask |= old.P_pattern.mask
            A_mask |= old.A_pattern.mask
        P_pattern, A_pattern = _Pattern(P_mask, upper), _Pattern(A_mask)
        settings = dict(self.settings)
        if problem.role == "correction":
            # The correction ends on a level whose null space only the
            # regularization fixes: warm-started from an earlier solution, ADMM
            # would stop with that solution's null-space motion in it.
            settings["warm_starting"] = False
        # naming the algebra spares OSQP() probing for its optional CUDA/MKL
        # modules by import on every construction (~0.3 ms)
        solver = osqp.OSQP(algebra="builtin")
        solver.setup(
            P_pattern.csc(problem.P),
            problem.q,
            A_pattern.csc(problem.A),
            problem.l,
            problem.u,
            **settings,
        )
        self.setups += 1
        level = _OSQPLevel(solver, P_pattern, A_pattern, problem.A.shape)
        self._levels[(problem.role, problem.level)] = level
        return level


@dataclass
class QpsolversBackend:
    """Any dense solver known to ``qpsolvers`` (e.g. ``"daqp"``), for comparison."""

    solver: str
    kwargs: dict[str, Any] = field(default_factory=dict)

    def solve(self, problem: LevelProblem) -> QPSolution:
        import qpsolvers

        A, l, u = problem.A, problem.l, problem.u
        eq = l == u
        upper = ~eq & np.isfinite(u)
        lower = ~eq & np.isfinite(l)
        G = np.vstack([A[upper], -A[lower]])
        h = np.concatenate([u[upper], -l[lower]])
        z = qpsolvers.solve_qp(
            problem.P,
            problem.q,
            G if G.size else None,
            h if h.size else None,
            A[eq] if eq.any() else None,
            l[eq] if eq.any() else None,
            solver=self.solver,
            **self.kwargs,
        )
        return QPSolution(z, "solved" if z is not None else "failed", z is not None)


@dataclass
class CallableBackend:
    """Seed ``qp-solver`` as a function: ``fn(problem, **qp_args) -> z or None``."""

    fn: Callable[..., np.ndarray | None]
    kwargs: dict[str, Any] = field(default_factory=dict)

    def solve(self, problem: LevelProblem) -> QPSolution:
        z = self.fn(problem, **self.kwargs)
        return QPSolution(None if z is None else np.asarray(z, float), "callable", z is not None)


def make_backend(qp_solver: object = "osqp", qp_args: dict[str, Any] | None = None) -> QPBackend:
    """Backend from seed-style ``qp_solver`` / ``qp_args``.

    Args:
        qp_solver: ``"osqp"`` (default), another ``qpsolvers`` solver name, an object
            with ``solve(problem)``, or a function ``fn(problem, **qp_args)``.
        qp_args: Settings for the solver.
    """
    args = dict(qp_args or {})
    if isinstance(qp_solver, str):
        if qp_solver == "osqp":
            return OSQPBackend(args)
        import qpsolvers

        if qp_solver not in qpsolvers.available_solvers:
            raise InvalidInput(
                f"unknown qp_solver {qp_solver!r}; valid: {sorted(qpsolvers.available_solvers)}"
            )
        return QpsolversBackend(qp_solver, args)
    if hasattr(qp_solver, "solve"):
        return qp_solver  # type: ignore[return-value]
    if callable(qp_solver):
        return CallableBackend(qp_solver, args)
    raise InvalidInput(f"qp_solver must be a name, a backend or a function, got {qp_solver!r}")
