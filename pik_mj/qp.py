"""QP problems of the cascade and the backends that solve them.

Every level of the cascade is one convex QP over ``z = [x; ω]``::

    min  ½ zᵀ P z + qᵀ z    s.t.   l <= A_c z <= u

(equality rows have ``l = u``). :class:`LevelProblem` keeps the matrices dense so
a failing problem can be inspected and re-solved anywhere. Backends:

* :class:`OSQPBackend` (``"osqp"``, the default): CSC matrices with a fixed
  sparsity pattern per level and problem shape; after a level's first problem
  in a solve, only ``update()`` + warm start. ``make_backend("osqp")`` hands
  out one backend per thread and settings, kept across solves (a motion calls
  :func:`pik_mj.solve` every tick); each solve sets its levels up afresh once,
  so that its result does not depend on the solves before it.
* :class:`DAQPBackend` (``"daqp"``): DAQP's dual active-set method, per level.
* :class:`HierarchicalBackend` (``"daqp-hqp"``): the whole hierarchy in one
  DAQP call (hierarchical least squares, :class:`HierarchicalProblem`).
* any other ``qpsolvers`` name, an object with ``solve(problem)``, or a function
  (seed ``qp-solver``); ``qp_args`` are the solver's settings (seed ``qp-args``).

Solver statuses become pik_mj's exceptions in :mod:`pik_mj.cascade`, with the
solver's own explanation in the message; an interrupted solve (Ctrl-C, which
OSQP catches) raises :class:`KeyboardInterrupt`.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
import sys
import tempfile
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, NamedTuple, Protocol

import daqp
import numpy as np
import osqp
import scipy.sparse as sp

from .exceptions import InvalidInput
from .tasks.task import TaskRows

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
    "max_iter": 300,
    "warm_starting": True,
    "adaptive_rho": True,
    # A fixed interval: the default (0) derives it from the measured setup
    # time, which makes the iterates, and so the solves, depend on the
    # machine's load.
    "adaptive_rho_interval": 25,
    # No Ruiz scaling: OSQP computes it at setup() from the first problem and
    # keeps it through update(); off, the same ADMM iterations and time were
    # measured on these problems.
    "scaling": 0,
    "verbose": False,
}
"""OSQP settings of the cascade. Tolerances are far tighter than OSQP's defaults
(1e-3) because each level's achieved values become the next levels' constraints,
and because a level's objective gradient is of the size of its error: at 1e-5 a
foot error of 1e-5 m is already "optimal" to OSQP and drift accumulates to 1e-4 m
while a hand reaches; 1e-6 holds it at ~2e-5 m for +25% time per iteration.
Termination is checked every 5 ADMM
iterations (default 25): these problems converge in tens of iterations."""

OSQP_SETTINGS = tuple(
    sorted(
        {k for k in osqp.OSQP(algebra="builtin").ext.OSQPSettings.__dict__ if not k.startswith("_")}
        | {"solver_type", "cg_preconditioner"}
    )
)
"""Every key ``qp_args`` may hold for OSQP."""

DAQP_SETTINGS = (
    "primal_tol",
    "dual_tol",
    "zero_tol",
    "pivot_tol",
    "progress_tol",
    "cycle_tol",
    "iter_limit",
    "fval_bound",
    "eps_prox",
    "eta_prox",
    "rel_subopt",
    "abs_subopt",
    "sing_tol",
    "refactor_tol",
    "time_limit",
)
"""Every key ``qp_args`` may hold for DAQP (``"daqp"`` and ``"daqp-hqp"``)."""

_DAQP_EXIT = {
    1: "optimal",
    2: "optimal with soft constraints violated",
    3: "a level of the hierarchy could not be solved (kept the solution above it)",
    -1: "primal infeasible",
    -2: "cycling detected",
    -3: "unbounded",
    -4: "iteration limit reached",
    -5: "non-convex problem",
    -6: "overdetermined initial active set",
    -7: "time limit reached",
    -8: "unsupported problem",
}
_DAQP_INF = 1e30


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
    """Outcome of one QP solve: ``z`` (None on failure), solver status, success,
    and whether the solver proved the problem infeasible."""

    z: np.ndarray | None
    status: str
    ok: bool
    infeasible: bool = False


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
_OSQP = osqp.SolverStatus
_SOLVED = (_OSQP.OSQP_SOLVED, _OSQP.OSQP_SOLVED_INACCURATE)
_INFEASIBLE = (_OSQP.OSQP_PRIMAL_INFEASIBLE, _OSQP.OSQP_PRIMAL_INFEASIBLE_INACCURATE)
_OSQP_ERRORS = {
    1: "data validation error (non-finite or inconsistent matrices)",
    2: "settings validation error",
    3: "linear system solver initialization error",
    4: "non-convex problem: P is not positive semidefinite (weights or rows too large?)",
    5: "memory allocation error",
}
_OSQP_STATUS_TEXT = {
    _OSQP.OSQP_PRIMAL_INFEASIBLE: "primal infeasible: the constraints admit no step",
    _OSQP.OSQP_PRIMAL_INFEASIBLE_INACCURATE: "primal infeasible (inaccurate): the "
    "constraints admit no step",
    _OSQP.OSQP_DUAL_INFEASIBLE: "dual infeasible: the objective is unbounded",
    _OSQP.OSQP_DUAL_INFEASIBLE_INACCURATE: "dual infeasible (inaccurate)",
    _OSQP.OSQP_MAX_ITER_REACHED: "maximum number of ADMM iterations (max_iter) reached",
    _OSQP.OSQP_TIME_LIMIT_REACHED: "time limit (time_limit) reached",
    _OSQP.OSQP_NON_CVX: "non-convex problem detected",
    _OSQP.OSQP_UNSOLVED: "unsolved",
}


@dataclass
class _OSQPLevel:
    solver: osqp.OSQP
    P_pattern: _Pattern
    A_pattern: _Pattern
    epoch: int = 0  # the solve this workspace last served


@dataclass
class OSQPBackend:
    """OSQP with one cached solver per level and shape: set up at the level's
    first problem of a solve (:meth:`start`), then updated and warm-started.

    Args:
        settings: OSQP settings overriding :data:`OSQP_DEFAULTS` (keys:
            :data:`OSQP_SETTINGS`).
        fallback: A dense solver (``"daqp"``, dual active-set, exact) tried when
            OSQP does not reach its tolerance (ADMM can stall on degenerate,
            strongly conflicting levels); None to disable. Never used for an
            interrupted or infeasible problem.
        capacity: Workspaces kept (least recently used ones are dropped).

    Attributes:
        setups: OSQP ``setup()`` calls so far.
        fallbacks: Levels solved by the fallback so far.
    """

    settings: dict[str, Any] = field(default_factory=dict)
    fallback: str | None = "daqp"
    capacity: int = 32
    setups: int = 0
    fallbacks: int = 0
    _levels: OrderedDict[tuple, _OSQPLevel] = field(default_factory=OrderedDict, repr=False)
    _epoch: int = 0

    def __post_init__(self) -> None:
        unknown = sorted(set(self.settings) - set(OSQP_SETTINGS))
        if unknown:
            raise InvalidInput(
                f"qp_args has unknown OSQP settings {unknown}; valid: {list(OSQP_SETTINGS)}"
            )
        self.settings = {**OSQP_DEFAULTS, **self.settings}

    def start(self) -> None:
        """A new solve begins (see :meth:`solve`: each level's first problem in
        it is set up afresh)."""
        self._epoch += 1

    def solve(self, problem: LevelProblem) -> QPSolution:
        P = problem.P
        key = (problem.role, problem.level, problem.A.shape)
        cached = self._levels.get(key)
        try:
            if (
                cached is None
                or cached.epoch != self._epoch
                or not cached.P_pattern.covers(P)
                or not cached.A_pattern.covers(problem.A)
            ):
                # A level's first problem in a solve is set up afresh: OSQP's
                # update path reproduces a fresh setup only to rounding, and a
                # solve's result must not depend on the solves before it.
                old = cached if cached is not None and cached.epoch == self._epoch else None
                cached = self._setup(problem, key, old)
            else:
                self._levels.move_to_end(key)
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
        except osqp.OSQPException as exc:
            self._levels.pop(key, None)
            code = int(exc.args[0]) if exc.args else 0
            return QPSolution(None, f"OSQP: {_OSQP_ERRORS.get(code, f'error {code}')}", False)
        cached.epoch = self._epoch
        ext = cached.solver._solver
        ext.solve()
        info = ext.info
        status = info.status_val
        if status == _OSQP.OSQP_SIGINT:
            # OSQP caught Ctrl-C and returned; the user asked to stop.
            raise KeyboardInterrupt("interrupted during an OSQP solve")
        if status in _SOLVED:
            return QPSolution(np.array(ext.solution.x), info.status, True)
        text = f"OSQP: {_OSQP_STATUS_TEXT.get(status, info.status)}"
        if status in _INFEASIBLE:
            return QPSolution(None, text, False, infeasible=True)
        if self.fallback is not None:
            rescue = make_backend(self.fallback).solve(problem)
            if rescue.ok:
                self.fallbacks += 1
                return QPSolution(rescue.z, f"{self.fallback} after {text}", True)
            return QPSolution(None, f"{text}; {self.fallback}: {rescue.status}", False)
        return QPSolution(None, text, False)

    def _setup(self, problem: LevelProblem, key: tuple, old: _OSQPLevel | None) -> _OSQPLevel:
        # The pattern is the nonzeros as they are, although a posture's
        # coincidental zeros (an aligned root) cost one more setup() when they
        # fill in: densifying Jacobian rows up front was measured slower, as
        # every later update refactorizes a denser KKT system.
        upper = np.triu(np.ones(problem.P.shape, dtype=bool))
        P_mask = (problem.P != 0) & upper
        P_mask[np.diag_indices_from(P_mask)] = True
        A_mask = problem.A != 0
        if old is not None:  # grow, never shrink
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
            np.maximum(problem.l, -_OSQP_INFTY),
            np.minimum(problem.u, _OSQP_INFTY),
            **settings,
        )
        self.setups += 1
        level = _OSQPLevel(solver, P_pattern, A_pattern, self._epoch)
        self._levels[key] = level
        self._levels.move_to_end(key)
        while len(self._levels) > self.capacity:
            self._levels.popitem(last=False)
        return level


def _daqp_status(exitflag: int) -> str:
    return f"DAQP exitflag {exitflag}: {_DAQP_EXIT.get(exitflag, 'unknown')}"


def _check_daqp_settings(settings: dict[str, Any]) -> dict[str, Any]:
    unknown = sorted(set(settings) - set(DAQP_SETTINGS))
    if unknown:
        raise InvalidInput(
            f"qp_args has unknown DAQP settings {unknown}; valid: {list(DAQP_SETTINGS)}"
        )
    for k, v in settings.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise InvalidInput(f"qp_args[{k!r}] must be a number, got {v!r}")
        if not (np.isfinite(v) and v >= 0) and k not in ("eps_prox", "eta_prox"):
            raise InvalidInput(f"qp_args[{k!r}] must be a finite number >= 0, got {v!r}")
    return dict(settings)


@dataclass
class DAQPBackend:
    """DAQP (dual active-set, exact) on one level at a time (``"daqp"``).

    ``l <= A z <= u`` goes to DAQP as is (rows with ``l = u`` are equalities).
    """

    settings: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.settings = _check_daqp_settings(self.settings)

    def solve(self, problem: LevelProblem) -> QPSolution:
        A = np.ascontiguousarray(problem.A, dtype=float)
        u = np.minimum(problem.u, _DAQP_INF)
        lo = np.maximum(problem.l, -_DAQP_INF)
        sense = np.where(lo == u, 5, 0).astype(np.intc)
        P = np.ascontiguousarray(problem.P, dtype=float)
        z, _, exitflag, _ = daqp.solve(P, problem.q.astype(float), A, u, lo, sense, **self.settings)
        ok = exitflag in (1, 2)
        return QPSolution(np.array(z) if ok else None, _daqp_status(exitflag), ok, exitflag == -1)


_IDENTITIES: dict[int, np.ndarray] = {}


def _identity(n: int) -> np.ndarray:
    """``I`` (n x n), made once per size (DAQP reads it and never writes it;
    its Cython signature asks for a writable buffer)."""
    if n not in _IDENTITIES:
        _IDENTITIES[n] = np.eye(n)
    return _IDENTITIES[n]


class _Layout:
    """Where each block of a :class:`HierarchicalProblem` goes, for one stack
    shape (computed once per shape)."""

    def __init__(self, nv: int, n_eq0: int, C: np.ndarray, n_keep: list, n_in: list):
        n = nv + 1
        self.C = C  # the hard inequality rows this layout was made for
        nonzero = C != 0
        single = np.count_nonzero(nonzero, axis=1) == 1
        self.single_rows = np.flatnonzero(single)
        self.general_rows = np.flatnonzero(~single)
        cols = nonzero[self.single_rows].argmax(axis=1)
        coef = C[self.single_rows, cols]
        self.sides = []
        for side in (coef > 0, coef < 0):
            if side.any():
                c = cols[side]
                unique = np.unique(c).size == c.size
                self.sides.append((self.single_rows[side], c, coef[side], unique))
        self.n_general = n_eq0 + self.general_rows.size
        self.blocks: list[tuple[int, int, int]] = []  # (first row, equality rows, rows)
        i = self.n_general
        break_points = [n + i]
        self.levels: list[int] = []
        for k, (n_eq, m_in) in enumerate(zip(n_keep, n_in, strict=True), start=1):
            size = n_eq + m_in
            self.blocks.append((i, n_eq, size))
            if size:
                i += size
                break_points.append(n + i)
                self.levels.append(k)
        self.A_shape = (i, n)
        self.n_bounds = n + i
        self.sense = np.zeros(n + i, dtype=np.intc)
        self.sense[n : n + n_eq0] = 5
        for first, n_eq, size in self.blocks:
            self.sense[n + first : n + first + n_eq] = 13  # equality (active, immutable), soft
            self.sense[n + first + n_eq : n + first + size] = 8  # inequality, soft
        self.break_points = np.array(break_points, dtype=np.intc)


@dataclass
class HierarchicalProblem:
    """A whole priority hierarchy as one DAQP hierarchical least-squares problem.

    Variables ``z = [x; d]``: the step ``x`` (``nv``) and one auxiliary ``d``
    fixed at 0 by level 0. Level 0 holds the hard rows (single-entry rows as
    bounds on ``x``); level ``k`` holds its equality rows ``√w_i a_i x = √w_i b_i``
    and inequality rows ``√w_i c_i x ∈ √w_i [d_l, d_u]`` as soft constraints,
    each with ``β_i`` in the ``d`` column so that every row of the level has the
    same norm ``D_k = max_i w_i ‖a_i‖²`` (``β_i = √(D_k − w_i ‖a_i‖²)``). DAQP
    normalizes each row, so a level then minimizes ``Σ w_i r_i² / D_k``: exactly
    the weighted squared error of the cascade's level, up to the factor. Levels
    are solved lexicographically, each keeping what the levels above achieved
    (equality rows at their values, inequality rows within their bounds or at
    their achieved violation), ties broken by the least ``‖x‖²``: the cascade
    with ``λ_k → 0`` and ``τ = 0``.

    Attributes:
        H: Hessian ``I`` (nv + 1).
        A: General rows (hard rows with several entries, then each level's rows).
        bupper: Bounds: ``nv + 1`` simple bounds on ``z`` first, then one per row of A.
        blower: Lower bounds, same layout.
        sense: DAQP constraint types (0 inequality, 5 equality, +8 soft).
        break_points: End index (into the bounds) of each level, level 0 first.
        levels: Cascade level (1..K) of each soft block (empty levels are left out).
        nv: Step size.
    """

    H: np.ndarray
    A: np.ndarray
    bupper: np.ndarray
    blower: np.ndarray
    sense: np.ndarray
    break_points: np.ndarray
    levels: list[int]
    nv: int

    @classmethod
    def from_rows(
        cls, hard: TaskRows, levels: list[TaskRows], cache: dict | None = None
    ) -> HierarchicalProblem:
        """The problem of a cascade's rows; ``cache`` (a dict kept by the caller)
        holds the layout of each stack shape, so that only values are written."""
        nv = hard.A.shape[1]
        n = nv + 1
        C = hard.C
        keeps = [rows.w_A > 0 for rows in levels]
        n_keep = [int(np.count_nonzero(k)) for k in keeps]
        shape = (nv, hard.n_eq, *((k, r.n_eq, r.n_in) for k, r in zip(n_keep, levels, strict=True)))
        layout = cache.get(shape) if cache is not None else None
        if layout is None or layout.C is not C:  # new shape, or new hard rows
            layout = _Layout(nv, hard.n_eq, C, n_keep, [r.n_in for r in levels])
            if cache is not None:
                cache[shape] = layout
        A = np.zeros(layout.A_shape)
        upper = np.empty(layout.n_bounds)
        lower = np.empty(layout.n_bounds)
        upper[:n], lower[:n] = _DAQP_INF, -_DAQP_INF
        upper[nv] = lower[nv] = 0.0  # d = 0
        # hard inequality rows with one entry c x_i in [l, u]: bounds on x_i,
        # one side of the rows (c > 0, then c < 0) at a time
        for rows_, cols, coef, unique in layout.sides:
            a, b = hard.d_lower[rows_] / coef, hard.d_upper[rows_] / coef
            lo_i, hi_i = (a, b) if coef[0] > 0 else (b, a)
            if unique:  # at most one row per variable on this side (joint limits)
                lower[cols] = np.maximum(lower[cols], lo_i)
                upper[cols] = np.minimum(upper[cols], hi_i)
            else:
                np.maximum.at(lower, cols, lo_i)
                np.minimum.at(upper, cols, hi_i)
        r = hard.n_eq
        A[:r, :nv] = hard.A
        upper[n : n + r] = lower[n : n + r] = hard.b
        g = layout.n_general
        if g > r:
            A[r:g, :nv] = C[layout.general_rows]
            upper[n + r : n + g] = hard.d_upper[layout.general_rows]
            lower[n + r : n + g] = hard.d_lower[layout.general_rows]
        for rows, keep, (i, n_eq, size) in zip(levels, keeps, layout.blocks, strict=True):
            if size == 0:
                continue
            block = A[i : i + size]
            j = n + i
            if n_eq == rows.n_eq:
                sw = np.sqrt(rows.w_A)
                np.multiply(sw[:, None], rows.A, out=block[:n_eq, :nv])
                upper[j : j + n_eq] = lower[j : j + n_eq] = sw * rows.b
            else:
                sw = np.sqrt(rows.w_A[keep])
                np.multiply(sw[:, None], rows.A[keep], out=block[:n_eq, :nv])
                upper[j : j + n_eq] = lower[j : j + n_eq] = sw * rows.b[keep]
            if rows.n_in:
                sw_C = np.sqrt(rows.w_C)
                np.multiply(sw_C[:, None], rows.C, out=block[n_eq:, :nv])
                upper[j + n_eq : j + size] = sw_C * rows.d_upper
                lower[j + n_eq : j + size] = sw_C * rows.d_lower
            norms = np.einsum("ij,ij->i", block[:, :nv], block[:, :nv])
            np.sqrt(np.maximum(max(float(norms.max()), 1e-300) - norms, 0.0), out=block[:, nv])
        np.clip(upper, -_DAQP_INF, _DAQP_INF, out=upper)
        np.clip(lower, -_DAQP_INF, _DAQP_INF, out=lower)
        return cls(
            _identity(n),
            A,
            upper,
            lower,
            layout.sense.copy(),  # DAQP may write flags into it
            layout.break_points,
            layout.levels,
            nv,
        )

    def hard_violation(self, x: np.ndarray) -> float:
        """Largest violation of level 0's rows (bounds and general rows) at ``x``."""
        z = np.append(x, 0.0)
        n = z.size
        end = int(self.break_points[0])
        v = np.concatenate([z, self.A[: end - n] @ z])
        return float(np.max(np.maximum(self.blower[:end] - v, v - self.bupper[:end]), initial=0.0))


@dataclass
class HierarchicalBackend:
    """The whole cascade in one DAQP call (``"daqp-hqp"``), see
    :class:`HierarchicalProblem`. Each level is solved exactly (no ``λ_k``, no
    ``τ``), so the per-level regularization options do not apply."""

    settings: dict[str, Any] = field(default_factory=dict)
    layouts: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.settings = _check_daqp_settings(self.settings)

    def solve_hierarchy(self, problem: HierarchicalProblem) -> QPSolution:
        z, _, exitflag, _ = daqp.solve(
            problem.H,
            np.zeros(problem.nv + 1),
            problem.A,
            problem.bupper,
            problem.blower,
            problem.sense,
            problem.break_points,
            **self.settings,
        )
        status = _daqp_status(exitflag)
        x = np.array(z[: problem.nv])
        tol = 1e-6 + 10 * float(self.settings.get("primal_tol", 1e-6))
        if exitflag in (1, 2) or (exitflag == 3 and problem.hard_violation(x) <= tol):
            return QPSolution(x, status, True)
        # Was level 0 itself infeasible? (DAQP reports a failed level as exitflag 3.)
        end = int(problem.break_points[0])
        n = problem.nv + 1
        _, _, alone, _ = daqp.solve(
            problem.H,
            np.zeros(n),
            np.ascontiguousarray(problem.A[: end - n]),
            problem.bupper[:end],
            problem.blower[:end],
            problem.sense[:end],
        )
        return QPSolution(None, status, False, infeasible=alone == -1)

    def solve(self, problem: LevelProblem) -> QPSolution:
        """One level alone (not used by the cascade, which hands this backend the
        whole hierarchy): DAQP's plain QP."""
        return DAQPBackend(self.settings).solve(problem)


@dataclass
class QpsolversBackend:
    """Any dense solver known to ``qpsolvers``, for comparison."""

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
    """Seed ``qp-solver`` as a function: ``fn(problem, **qp_args) -> z or None``.

    A result of the wrong shape or with NaN/inf raises :class:`InvalidInput`
    naming the function; None is a failed solve.
    """

    fn: Callable[..., np.ndarray | None]
    kwargs: dict[str, Any] = field(default_factory=dict)

    def solve(self, problem: LevelProblem) -> QPSolution:
        z = self.fn(problem, **self.kwargs)
        if z is None:
            return QPSolution(None, f"qp_solver {_name(self.fn)} returned None", False)
        name = _name(self.fn)
        try:
            z = np.asarray(z, dtype=float)
        except (TypeError, ValueError):
            raise InvalidInput(
                f"qp_solver {name} returned {type(z).__name__}; return z (n,) or None"
            ) from None
        n = problem.P.shape[0]
        if z.shape != (n,):
            raise InvalidInput(
                f"qp_solver {name} returned shape {z.shape} for a problem of {n} "
                f"variables (level {problem.level}); return z of shape ({n},) or None"
            )
        if not np.all(np.isfinite(z)):
            raise InvalidInput(
                f"qp_solver {name} returned NaN or inf (level {problem.level}); "
                "return finite z or None"
            )
        return QPSolution(z, f"qp_solver {name}", True)


def _name(fn: object) -> str:
    return getattr(fn, "__qualname__", None) or repr(fn)


QP_SOLVERS = ("osqp", "daqp", "daqp-hqp")
"""Backends by name (besides any other installed ``qpsolvers`` solver)."""

_SHARED = threading.local()


def make_backend(qp_solver: object = "osqp", qp_args: dict[str, Any] | None = None) -> QPBackend:
    """Backend from seed-style ``qp_solver`` / ``qp_args``, validated here.

    Named backends are shared per thread and settings, so OSQP workspaces live
    across solves.

    Args:
        qp_solver: ``"osqp"`` (default), ``"daqp"``, ``"daqp-hqp"``, another
            ``qpsolvers`` solver name, an object with ``solve(problem)``, or a
            function ``fn(problem, **qp_args)``.
        qp_args: Settings for the solver.

    Raises:
        InvalidInput: Unknown solver name, unknown setting or a value the solver
            refuses (with the solver's own message).
    """
    if qp_args is not None and not isinstance(qp_args, dict):
        raise InvalidInput(f"qp_args must be a dict of solver settings, got {qp_args!r}")
    args = dict(qp_args or {})
    if isinstance(qp_solver, str):
        try:
            key = (qp_solver, tuple(sorted(args.items())))
            hash(key)
        except TypeError:
            return _new_backend(qp_solver, args)
        cache = getattr(_SHARED, "backends", None)
        if cache is None:
            cache = _SHARED.backends = {}
        if key not in cache:
            cache[key] = _new_backend(qp_solver, args)
        return cache[key]
    if hasattr(qp_solver, "solve") or hasattr(qp_solver, "solve_hierarchy"):
        return qp_solver  # type: ignore[return-value]
    if callable(qp_solver):
        return CallableBackend(qp_solver, args)
    raise InvalidInput(
        f"qp_solver must be a name {list(QP_SOLVERS)}, a backend or a function, got {qp_solver!r}"
    )


def _new_backend(name: str, args: dict[str, Any]) -> Any:
    if name == "osqp":
        backend = OSQPBackend(args)
        _probe_osqp(backend.settings)
        return backend
    if name == "daqp":
        return DAQPBackend(args)
    if name == "daqp-hqp":
        return HierarchicalBackend(args)
    import qpsolvers

    if name not in qpsolvers.available_solvers:
        valid = sorted({*QP_SOLVERS, *qpsolvers.available_solvers})
        raise InvalidInput(f"unknown qp_solver {name!r}; valid: {valid}")
    return QpsolversBackend(name, args)


@contextlib.contextmanager
def _captured_c_output() -> Iterator[list[str]]:
    """What C code prints inside the block: through Python's ``sys.stdout`` /
    ``sys.stderr`` (OSQP's extension prints with ``PySys_WriteStdout``) or
    straight to file descriptors 1 and 2."""
    out: list[str] = []
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    sys.stderr.flush()
    text = io.StringIO()
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        saved = [os.dup(1), os.dup(2)]
        try:
            os.dup2(tmp.fileno(), 1)
            os.dup2(tmp.fileno(), 2)
            with contextlib.redirect_stdout(text), contextlib.redirect_stderr(text):
                yield out
        finally:
            libc.fflush(None)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            tmp.seek(0)
            out.append(text.getvalue() + tmp.read().decode(errors="replace"))


def _probe_osqp(settings: dict[str, Any]) -> None:
    """Set up a 1x1 problem with ``settings``: OSQP's own validation, its message
    in an :class:`InvalidInput`."""
    solver = osqp.OSQP(algebra="builtin")
    one = sp.csc_matrix(np.eye(1))
    try:
        with _captured_c_output() as text:
            solver.setup(one, np.zeros(1), one, -np.ones(1), np.ones(1), **settings)
    except (osqp.OSQPException, ValueError, TypeError, AssertionError) as exc:
        message = " ".join(line.strip() for line in "".join(text).splitlines() if line.strip())
        raise InvalidInput(
            f"qp_args rejected by OSQP: {message or repr(exc)}; valid keys: {list(OSQP_SETTINGS)}"
        ) from None
