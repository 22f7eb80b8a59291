"""QP problems of the cascade and the backends that solve them.

Every level of the cascade is one convex QP over ``z = [x; ω]``::

    min  ½ zᵀ P z + qᵀ z    s.t.   l <= A_c z <= u

(:class:`LevelProblem`, dense, so that a failing problem can be inspected and
re-solved anywhere). A backend is a :class:`QPBackend`, which declares what the
cascade may ask of it (:mod:`pik_mj.qp.backend`). Backends:

* :class:`OSQPBackend` (``"osqp"``, the default): one cached OSQP solver per
  level and sparsity pattern, updated and warm-started
  (:mod:`pik_mj.qp.osqp_backend`).
* :class:`DAQPBackend` (``"daqp"``): DAQP's dual active-set method, per level.
* :class:`HierarchicalBackend` (``"daqp-hqp"``): the whole hierarchy in one
  DAQP call (hierarchical least squares, :class:`HierarchicalProblem`).
* any other ``qpsolvers`` name, an object with ``solve(problem)``, or a function
  (prioritized-IK manual: ``qp-solver``); ``qp_args`` are the solver's settings
  (``qp-args``). :func:`make_backend` makes one from any of these.

Solver statuses become pik_mj's exceptions in :mod:`pik_mj.cascade`, with the
solver's own explanation in the message; an interrupted solve (Ctrl-C, which
OSQP catches) raises :class:`KeyboardInterrupt`.
"""

from pik_mj.qp.adapters import CallableBackend, ObjectBackend, QpsolversBackend
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.daqp_backend import DAQP_SETTINGS, DAQPBackend, HierarchicalBackend
from pik_mj.qp.hierarchy import HierarchicalProblem
from pik_mj.qp.make import QP_SOLVERS, as_backend, make_backend
from pik_mj.qp.osqp_backend import OSQP_DEFAULTS, OSQP_SETTINGS, OSQPBackend
from pik_mj.qp.problem import LevelProblem, QPSolution

__all__ = [
    "DAQP_SETTINGS",
    "OSQP_DEFAULTS",
    "OSQP_SETTINGS",
    "QP_SOLVERS",
    "CallableBackend",
    "DAQPBackend",
    "HierarchicalBackend",
    "HierarchicalProblem",
    "LevelProblem",
    "OSQPBackend",
    "ObjectBackend",
    "QPBackend",
    "QPSolution",
    "QpsolversBackend",
    "as_backend",
    "make_backend",
]
