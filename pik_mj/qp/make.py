"""The backend a solve uses, from what the user gave (prioritized-IK manual:
``qp-solver``, ``qp-args``): a name, a backend, an object or a function."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from pik_mj.exceptions import InvalidInput
from pik_mj.qp.adapters import CallableBackend, ObjectBackend, QpsolversBackend
from pik_mj.qp.backend import QPBackend
from pik_mj.qp.daqp_backend import DAQPBackend, HierarchicalBackend
from pik_mj.qp.osqp_backend import checked_osqp_backend

QP_SOLVERS = ("osqp", "daqp", "daqp-hqp")
"""Backends by name (besides any other installed ``qpsolvers`` solver)."""

_NAMED: dict[str, Callable[[dict[str, Any]], QPBackend]] = {
    "osqp": checked_osqp_backend,
    "daqp": DAQPBackend,
    "daqp-hqp": HierarchicalBackend,
}

_SHARED = threading.local()


def make_backend(qp_solver: object = "osqp", qp_args: dict[str, Any] | None = None) -> QPBackend:
    """Backend from ``qp_solver`` / ``qp_args`` (prioritized-IK manual:
    ``qp-solver``, ``qp-args``), validated here.

    Named backends are shared per thread and settings, so OSQP workspaces live
    across solves.

    Args:
        qp_solver: ``"osqp"`` (default), ``"daqp"``, ``"daqp-hqp"``, another
            ``qpsolvers`` solver name, a :class:`QPBackend`, an object with
            ``solve(problem)``, or a function ``fn(problem, **qp_args)``.
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
    return as_backend(qp_solver, args)


def as_backend(backend: object, args: dict[str, Any] | None = None) -> QPBackend:
    """``backend`` as a :class:`QPBackend`: itself when it is one (it declares
    its capabilities); a user's object with ``solve(problem)`` or a function
    ``fn(problem, **args)``, wrapped (:class:`ObjectBackend`,
    :class:`CallableBackend`: every level to it, nothing declared).

    Raises:
        InvalidInput: Neither a backend, nor an object with ``solve(problem)``,
            nor a function.
    """
    if isinstance(backend, QPBackend):
        return backend
    if callable(getattr(backend, "solve", None)):
        return ObjectBackend(backend)
    if callable(backend):
        return CallableBackend(backend, dict(args or {}))
    raise InvalidInput(
        f"qp_solver must be a name {list(QP_SOLVERS)}, a backend or a function, got {backend!r}"
    )


def _new_backend(name: str, args: dict[str, Any]) -> QPBackend:
    """A new backend of the solver ``name`` with settings ``args``."""
    if name in _NAMED:
        return _NAMED[name](args)
    import qpsolvers  # (its solvers' imports take a while: only when named)

    if name not in qpsolvers.available_solvers:
        valid = sorted({*QP_SOLVERS, *qpsolvers.available_solvers})
        raise InvalidInput(f"unknown qp_solver {name!r}; valid: {valid}")
    return QpsolversBackend(name, args)
