"""QP problems of the cascade and the backends that solve them.

Every level of the cascade is one convex QP over ``z = [x; ω]``::

    min  ½ zᵀ P z + qᵀ z    s.t.   l <= A_c z <= u

(equality rows have ``l = u``). :class:`LevelProblem` keeps the matrices dense so
a failing problem can be inspected and re-solved anywhere. Backends:

* :class:`OSQPBackend` (``"osqp"``, the default): CSC matrices with a fixed
  sparsity pattern per level and problem shape; after a level's first problem
  in a solve, only ``update()`` + warm start. ``make_backend("osqp")`` hands
  out one backend per thread and settings, kept across solves (a motion calls
  :func:`pik_mj.solve` every tick); a later solve reuses a level's workspace
  when the pattern is the same, reset to the state of a fresh setup, so that
  its result does not depend on the solves before it.
* :class:`~pik_mj.qp_daqp.DAQPBackend` (``"daqp"``): DAQP's dual active-set
  method, per level.
* :class:`~pik_mj.qp_daqp.HierarchicalBackend` (``"daqp-hqp"``): the whole
  hierarchy in one DAQP call (hierarchical least squares).
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

import numpy as np
import osqp
import scipy.sparse as sp

from pik_mj.exceptions import InvalidInput

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


def _interrupt_flag() -> Callable[[], int]:
    """OSQP's own Ctrl-C flag, read after a solve returns.

    OSQP swaps in its SIGINT handler for the length of ``solve()`` and checks
    the flag once per ADMM iteration; a Ctrl-C landing after the last check
    (the last iteration, the termination test, writing the solution) sets the
    flag and is never reported, and Python's handler never sees it. The flag
    is reset only when the next solve starts, so reading it right after the
    call catches those too. ``osqp_is_interrupted`` is exported by the
    ``builtin`` algebra's extension, the one this module uses.
    """
    from osqp import ext_builtin

    flag = ctypes.CDLL(ext_builtin.__file__).osqp_is_interrupted
    flag.restype = ctypes.c_int
    flag.argtypes = []
    return flag


_osqp_interrupted = _interrupt_flag()
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


_OSQP_RHO = 0.1
"""OSQP's default initial ``ρ`` (its setting ``rho``)."""

_UPPER: dict[int, np.ndarray] = {}


def _upper(n: int) -> np.ndarray:
    """The upper triangle (diagonal included) of an n x n matrix, as a mask
    (made once per size, read-only)."""
    if n not in _UPPER:
        mask = np.triu(np.ones((n, n), dtype=bool))
        mask.flags.writeable = False
        _UPPER[n] = mask
    return _UPPER[n]


def _masks(problem: LevelProblem) -> tuple[np.ndarray, np.ndarray]:
    """The sparsity patterns of a problem: ``P``'s upper triangle (diagonal
    always in) and ``A``.

    The pattern is the nonzeros as they are, although a posture's coincidental
    zeros (an aligned root) cost one more setup() when they fill in:
    densifying Jacobian rows up front was measured slower, as every later
    update refactorizes a denser KKT system.
    """
    P_mask = (problem.P != 0) & _upper(problem.P.shape[0])
    P_mask.flat[:: P_mask.shape[0] + 1] = True
    return P_mask, problem.A != 0


@dataclass
class _OSQPLevel:
    solver: osqp.OSQP
    P_pattern: _Pattern
    A_pattern: _Pattern
    epoch: int = 0  # the solve this workspace last served
    key: tuple = ()  # its key in OSQPBackend._levels (level and pattern)


@dataclass
class OSQPBackend:
    """OSQP with one cached solver per level and shape: set up once, then
    updated and warm-started. A solve's (:meth:`start`) first problem of a
    level reuses the workspace when its sparsity pattern is exactly the
    workspace's, with ``ρ`` and the iterates reset (the result of a fresh
    setup, bit for bit); otherwise it is set up afresh. A pattern that grows
    within a solve is set up again, grown.

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
    _current: dict[tuple, _OSQPLevel] = field(default_factory=dict, repr=False)
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
        it starts from a fresh setup's state)."""
        self._epoch += 1

    def solve(self, problem: LevelProblem) -> QPSolution:
        key = (problem.role, problem.level, problem.A.shape)
        cached = self._current.get(key)
        try:
            if (
                cached is not None
                and cached.epoch == self._epoch
                and cached.P_pattern.covers(problem.P)
                and cached.A_pattern.covers(problem.A)
            ):
                self._update(cached, problem)  # warm-started from the last problem
            else:
                # A level's first problem in this solve, or one whose pattern
                # grew: the workspace of exactly that pattern, in the state a
                # fresh setup() leaves (whatever solves it served before).
                P_mask, A_mask = _masks(problem)
                if cached is not None and cached.epoch == self._epoch:  # grow, never shrink
                    P_mask |= cached.P_pattern.mask
                    A_mask |= cached.A_pattern.mask
                cached = self._workspace(key, P_mask, A_mask, problem)
                self._current[key] = cached
        except osqp.OSQPException as exc:
            failed = self._current.pop(key, None)
            if failed is not None:  # its state is unknown: never serve it again
                self._levels.pop(failed.key, None)
            code = int(exc.args[0]) if exc.args else 0
            return QPSolution(None, f"OSQP: {_OSQP_ERRORS.get(code, f'error {code}')}", False)
        cached.epoch = self._epoch
        ext = cached.solver._solver
        ext.solve()
        info = ext.info
        status = info.status_val
        if status == _OSQP.OSQP_SIGINT or _osqp_interrupted():
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

    def _workspace(
        self, key: tuple, P_mask: np.ndarray, A_mask: np.ndarray, problem: LevelProblem
    ) -> _OSQPLevel:
        """The workspace of ``key`` with exactly this pattern, reset (see
        :meth:`_reset`), or a new one set up."""
        pattern = (key, P_mask.tobytes(), A_mask.tobytes())
        cached = self._levels.get(pattern)
        if cached is None:
            return self._setup(problem, pattern, P_mask, A_mask)
        self._levels.move_to_end(pattern)
        self._current[key] = cached  # (dropped by solve() if the update fails)
        self._update(cached, problem)
        self._reset(cached, problem)
        return cached

    def _update(self, cached: _OSQPLevel, problem: LevelProblem) -> None:
        """New values in the workspace's pattern (the extension's own update:
        osqp's Python wrapper spends ~4x the C solve time per call on
        bookkeeping for derivatives)."""
        ext = cached.solver._solver
        ext.update_data_vec(
            q=problem.q,
            l=np.maximum(problem.l, -_OSQP_INFTY),
            u=np.minimum(problem.u, _OSQP_INFTY),
        )
        ext.update_data_mat(
            P_x=cached.P_pattern.data(problem.P),
            P_i=None,
            A_x=cached.A_pattern.data(problem.A),
            A_i=None,
        )

    def _reset(self, cached: _OSQPLevel, problem: LevelProblem) -> None:
        """The state ``setup()`` leaves: the initial ``ρ`` (adaptive ``ρ``
        changed it) and a cold start. The KKT matrix is then refactored from
        the same values in the same pattern, so the iterates are those of a
        fresh setup, bit for bit (tested)."""
        ext = cached.solver._solver
        ext.update_rho(float(self.settings.get("rho", _OSQP_RHO)))
        if ext.get_settings().warm_starting:
            # (warm_start() also turns warm starting on: a workspace without
            # it, the correction's, cold-starts every solve by itself)
            ext.warm_start(np.zeros(problem.P.shape[0]), np.zeros(problem.A.shape[0]))

    def _setup(
        self, problem: LevelProblem, key: tuple, P_mask: np.ndarray, A_mask: np.ndarray
    ) -> _OSQPLevel:
        P_pattern, A_pattern = _Pattern(P_mask, _upper(problem.P.shape[0])), _Pattern(A_mask)
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
        level = _OSQPLevel(solver, P_pattern, A_pattern, self._epoch, key)
        self._levels[key] = level
        self._levels.move_to_end(key)
        while len(self._levels) > self.capacity:
            self._levels.popitem(last=False)
        return level


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
    if name in ("daqp", "daqp-hqp"):
        from pik_mj.qp_daqp import DAQPBackend, HierarchicalBackend

        return DAQPBackend(args) if name == "daqp" else HierarchicalBackend(args)
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
