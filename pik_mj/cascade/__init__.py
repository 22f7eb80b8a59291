"""One step of the priority cascade: one QP per level (prioritized-IK manual:
``prioritized-inverse-kinematics``; docs/priority.md).

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

from pik_mj.cascade.linalg import CHOLESKY_PIVOT
from pik_mj.cascade.nullspace import (
    ACTIVE_SET_STEPS,
    FACE_ROUNDS,
    FEASIBILITY_TOLERANCE,
    KKT_TOLERANCE,
    NullSpaceCascade,
)
from pik_mj.cascade.step import (
    DEFAULT_RELAXATION,
    CascadeStep,
    Regularization,
    per_level,
    solve_cascade,
)

__all__ = [
    "ACTIVE_SET_STEPS",
    "CHOLESKY_PIVOT",
    "DEFAULT_RELAXATION",
    "FACE_ROUNDS",
    "FEASIBILITY_TOLERANCE",
    "KKT_TOLERANCE",
    "CascadeStep",
    "NullSpaceCascade",
    "Regularization",
    "per_level",
    "solve_cascade",
]
