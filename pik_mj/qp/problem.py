"""The QP of one priority level, and what a backend returns for it.

Every level of the cascade is one convex QP over ``z = [x; ω]``::

    min  ½ zᵀ P z + qᵀ z    s.t.   l <= A z <= u

(equality rows have ``l = u``), kept dense so that a failing problem can be
inspected and re-solved anywhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


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
        """Number of slack variables ``ω`` (the entries of ``z`` after ``x``)."""
        return self.P.shape[0] - self.nv

    def objective(self, z: np.ndarray) -> float:
        """``½ zᵀ P z + qᵀ z``."""
        return float(0.5 * z @ self.P @ z + self.q @ z)

    def max_violation(self, z: np.ndarray) -> float:
        """Largest violation of ``l <= A z <= u`` at ``z`` [row units] (0: feasible)."""
        Az = self.A @ z
        return float(np.max(np.maximum(self.l - Az, Az - self.u), initial=0.0))


class QPSolution(NamedTuple):
    """Outcome of one QP solve: ``z`` (None on failure), solver status, success,
    and whether the solver proved the problem infeasible."""

    z: np.ndarray | None
    status: str
    ok: bool
    infeasible: bool = False
