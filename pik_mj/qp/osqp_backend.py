"""OSQP, the cascade's default backend: one cached solver per level and sparsity
pattern, set up once, then updated and warm-started.

:class:`OSQPBackend` keeps CSC matrices with a fixed sparsity pattern per level
and problem shape; after a level's first problem in a solve, only
``update()`` + warm start. ``make_backend("osqp")`` hands out one backend per
thread and settings, kept across solves (a motion calls :func:`pik_mj.solve`
every tick); a later solve reuses a level's workspace when the pattern is the
same, reset to the state of a fresh setup, so that its result does not depend
on the solves before it.

An interrupted solve (Ctrl-C, which OSQP catches) raises :class:`KeyboardInterrupt`.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
import sys
import tempfile
from collections import OrderedDict
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import osqp
import scipy.sparse as sp

from pik_mj.exceptions import InvalidInput
from pik_mj.qp.adapters import QpsolversBackend
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.daqp_backend import DAQPBackend
from pik_mj.qp.problem import LevelProblem, QPSolution

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
    # keeps it through update(), so it would scale a level's later problems
    # by the first one's values.
    "scaling": 0,
    "verbose": False,
}
"""OSQP settings of the cascade. Tolerances are far tighter than OSQP's defaults
(1e-3) because each level's achieved values become the next levels' constraints,
and because a level's objective gradient is of the size of its error: at a
looser tolerance a foot error of that size is already "optimal" to OSQP and
drift accumulates while a hand reaches. Termination is checked every 5 ADMM
iterations (default 25): these problems converge in tens of iterations."""

OSQP_SETTINGS = tuple(
    sorted(
        {k for k in osqp.OSQP(algebra="builtin").ext.OSQPSettings.__dict__ if not k.startswith("_")}
        | {"solver_type", "cg_preconditioner"}
    )
)
"""Every key ``qp_args`` may hold for OSQP."""


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
    zeros (an aligned root) cost one more setup() when they fill in: a denser
    pattern would make every later update refactorize a denser KKT system.
    """
    P_mask = (problem.P != 0) & _upper(problem.P.shape[0])
    P_mask.flat[:: P_mask.shape[0] + 1] = True
    return P_mask, problem.A != 0


def _dense_backend(name: str) -> QPBackend:
    """The dense solver ``name``: DAQP (``"daqp"``), else a ``qpsolvers`` solver."""
    return DAQPBackend() if name == "daqp" else QpsolversBackend(name)


@dataclass
class _OSQPLevel:
    solver: osqp.OSQP
    P_pattern: _Pattern
    A_pattern: _Pattern
    epoch: int = 0  # the solve this workspace last served
    key: tuple = ()  # its key in OSQPBackend._levels (level and pattern)


@dataclass
class OSQPBackend(QPBackend):
    """OSQP with one cached solver per level and shape: set up once, then
    updated and warm-started. A solve's (:meth:`start`) first problem of a
    level reuses the workspace when its sparsity pattern is exactly the
    workspace's, with ``ρ`` and the iterates reset (the result of a fresh
    setup, bit for bit); otherwise it is set up afresh. A pattern that grows
    within a solve is set up again, grown.

    Args:
        settings: OSQP settings overriding :data:`OSQP_DEFAULTS` (keys:
            :data:`OSQP_SETTINGS`).
        fallback: A dense solver (``"daqp"``, dual active-set, exact, or another
            ``qpsolvers`` name) tried when OSQP does not reach its tolerance
            (ADMM can stall on degenerate, strongly conflicting levels); None
            to disable. Never used for an interrupted or infeasible problem.
        capacity: Workspaces kept (least recently used ones are dropped).

    Attributes:
        setups: OSQP ``setup()`` calls so far.
        fallbacks: Levels solved by the fallback so far.
    """

    allows_closed_form: ClassVar[bool] = True

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
        """One level's QP: in the level's workspace, warm-started from the
        level's last problem of this solve, or reset to a fresh setup's state;
        the fallback when OSQP does not reach its tolerance."""
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
        result = cached.solver.solve(raise_error=False)
        info = result.info
        status = info.status_val
        if status == _OSQP.OSQP_SIGINT or _osqp_interrupted():
            # OSQP caught Ctrl-C and returned; the user asked to stop.
            raise KeyboardInterrupt("interrupted during an OSQP solve")
        if status in _SOLVED:
            return QPSolution(np.array(result.x), info.status, True)
        text = f"OSQP: {_OSQP_STATUS_TEXT.get(status, info.status)}"
        if status in _INFEASIBLE:
            return QPSolution(None, text, False, infeasible=True)
        if self.fallback is not None:
            rescue = _dense_backend(self.fallback).solve(problem)
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
        """New values in the workspace's pattern (OSQP bounds its ``l``, ``u``
        at its own infinity)."""
        cached.solver.update(
            q=problem.q,
            l=problem.l,
            u=problem.u,
            Px=cached.P_pattern.data(problem.P),
            Ax=cached.A_pattern.data(problem.A),
        )

    def _reset(self, cached: _OSQPLevel, problem: LevelProblem) -> None:
        """The state ``setup()`` leaves: the initial ``ρ`` (adaptive ``ρ``
        changed it) and a cold start. The KKT matrix is then refactored from
        the same values in the same pattern, so the iterates are those of a
        fresh setup, bit for bit (tested)."""
        solver = cached.solver
        solver.update_settings(rho=float(self.settings.get("rho", _OSQP_RHO)))
        if solver.settings.warm_starting:
            # (warm_start() also turns warm starting on: a workspace without
            # it, the correction's, cold-starts every solve by itself)
            solver.warm_start(np.zeros(problem.P.shape[0]), np.zeros(problem.A.shape[0]))

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
        # modules by import on every construction
        solver = osqp.OSQP(algebra="builtin")
        P, A = P_pattern.csc(problem.P), A_pattern.csc(problem.A)
        solver.setup(P, problem.q, A, problem.l, problem.u, **settings)
        self.setups += 1
        level = _OSQPLevel(solver, P_pattern, A_pattern, self._epoch, key)
        self._levels[key] = level
        self._levels.move_to_end(key)
        while len(self._levels) > self.capacity:
            self._levels.popitem(last=False)
        return level


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


def checked_osqp_backend(settings: dict[str, Any]) -> OSQPBackend:
    """An :class:`OSQPBackend` with ``settings``, checked by OSQP itself: a 1x1
    problem is set up with them, and OSQP's own message on a value it refuses
    is raised in an :class:`InvalidInput`."""
    backend = OSQPBackend(settings)
    solver = osqp.OSQP(algebra="builtin")
    one = sp.csc_matrix(np.eye(1))
    try:
        with _captured_c_output() as text:
            solver.setup(one, np.zeros(1), one, -np.ones(1), np.ones(1), **backend.settings)
    except (osqp.OSQPException, ValueError, TypeError, AssertionError) as exc:
        message = " ".join(line.strip() for line in "".join(text).splitlines() if line.strip())
        raise InvalidInput(
            f"qp_args rejected by OSQP: {message or repr(exc)}; valid keys: {list(OSQP_SETTINGS)}"
        ) from None
    return backend
