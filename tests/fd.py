"""Finite differences on the configuration manifold, shared by the Jacobian tests."""

from __future__ import annotations

from collections.abc import Callable

import mink
import mujoco
import numpy as np


def fd_jacobian(
    model: mujoco.MjModel,
    q: np.ndarray,
    f: Callable[[mink.Configuration], np.ndarray],
    eps: float = 1e-6,
    configuration: mink.Configuration | None = None,
) -> np.ndarray:
    """Central differences of ``f(configuration)`` along each tangent direction:

    .. math::

        J_{:,i} = \\frac{f(q \\oplus \\epsilon e_i) - f(q \\oplus -\\epsilon e_i)}{2\\epsilon}

    with ``⊕`` MuJoCo's ``mj_integratePos``. Evaluated on ``configuration`` (restored
    to ``q`` afterwards) or on a fresh one.
    """
    cfg = mink.Configuration(model) if configuration is None else configuration
    columns = []
    for i in range(model.nv):
        values = []
        for sign in (1.0, -1.0):
            qq = np.array(q, dtype=float)
            v = np.zeros(model.nv)
            v[i] = sign * eps
            mujoco.mj_integratePos(model, qq, v, 1.0)
            cfg.update(qq)
            values.append(np.asarray(f(cfg), dtype=float))
        columns.append((values[0] - values[1]) / (2 * eps))
    cfg.update(np.array(q, dtype=float))
    return np.column_stack(columns)
