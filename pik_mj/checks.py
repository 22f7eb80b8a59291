"""Checks of what a solve is given, where it enters, in one message style:
what was wrong, and what is valid.

Options are checked by :mod:`pik_mj.inputs` (numpy scalars accepted, bools
refused where a number is due); the configuration for finite, meaningful values
(naming the joint); the levels for shape. Tasks' rows are checked once at the
start of a solve (:func:`pik_mj.solve.evaluate_level`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.inputs import Q_LIMIT, joint_name
from pik_mj.tasks.mink_adapter import as_task
from pik_mj.tasks.task import Task

_FREE, _SLIDE = int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_SLIDE)

RANGE_TOLERANCE = 1e-5
"""[rad or m] How far past its range a joint may start without a warning: the
QP solvers' accuracy on a limit row (OSQP's ``eps_abs + eps_rel·|row|``, 1e-6
each), so that a solve started where the previous one ended is not warned of
its own solver's rounding."""


def check_configuration(configuration: object) -> mink.Configuration:
    """A :class:`mink.Configuration` with a usable ``q`` and model, or raise.

    Refused: another type (e.g. the ``MjModel`` itself); NaN, inf or
    ``|q_i| > Q_LIMIT`` in ``q``; a zero quaternion of a free or ball joint; a
    joint whose range is inverted. Warned (:class:`RuntimeWarning`): limited
    joints outside their range at the start (a joint-limit row then pulls them
    back in; with ``revert_if_fail`` an unsatisfied solve returns to this
    out-of-range start).
    """
    if not isinstance(configuration, mink.Configuration):
        hint = (
            "; build one with mink.Configuration(model)"
            if isinstance(configuration, (mujoco.MjModel, mujoco.MjData))
            else ""
        )
        raise InvalidInput(
            f"configuration must be a mink.Configuration, got {type(configuration).__name__}{hint}"
        )
    model = configuration.model
    q = configuration.q
    if q.shape != (model.nq,):
        raise InvalidInput(f"configuration.q has shape {q.shape}; the model has nq = {model.nq}")
    if q.size and not float(np.abs(q).max()) <= Q_LIMIT:  # (NaN fails too)
        bad = ~np.isfinite(q) | (np.abs(q) > Q_LIMIT)
        i = int(np.argmax(bad))
        j = int(np.searchsorted(model.jnt_qposadr, i, side="right")) - 1
        what = "NaN" if np.isnan(q[i]) else ("inf" if np.isinf(q[i]) else f"{q[i]:.3g}")
        raise InvalidInput(
            f"configuration.q[{i}] (joint {joint_name(model, j)!r}) is {what}; every "
            f"entry must be finite with |q| <= {Q_LIMIT:g} (rad or m)"
        )
    # joint types compared as ints (a pybind enum makes numpy loop in Python):
    # free 0 and ball 1 hold quaternions, slide 2 and hinge 3 have ranges
    kind = model.jnt_type
    adr = model.jnt_qposadr
    ranged = np.flatnonzero((kind >= _SLIDE) & (model.jnt_limited != 0))
    lo, hi = model.jnt_range[ranged].T
    # the first joint (in model order) with a zero quaternion or an inverted range
    bad = ranged[lo > hi].tolist()
    for j in np.flatnonzero(kind < _SLIDE).tolist():
        a = int(adr[j]) + (3 if kind[j] == _FREE else 0)
        w, x, y, z = q[a : a + 4].tolist()
        if w * w + x * x + y * y + z * z < 1e-18:  # ‖quaternion‖ < 1e-9
            bad.append(j)
    if bad:
        j = min(bad)
        if kind[j] < _SLIDE:
            raise InvalidInput(
                f"joint {model.joint(j).name!r}: its quaternion in configuration.q is "
                "zero; give a unit quaternion (w, x, y, z)"
            )
        lo_j, hi_j = model.jnt_range[j]
        raise InvalidInput(
            f"joint {model.joint(j).name!r} has an inverted range [{lo_j:g}, {hi_j:g}]; "
            "the lower limit must not exceed the upper"
        )
    # limited hinges and slides outside their range: warned
    values = q[adr[ranged]]
    outside = (values < lo - RANGE_TOLERANCE) | (values > hi + RANGE_TOLERANCE)
    if outside.any():
        listed = ", ".join(
            f"{model.joint(int(j)).name} {v:.4g} not in [{a:.4g}, {b:.4g}]"
            for j, v, a, b in zip(
                ranged[outside], values[outside], lo[outside], hi[outside], strict=True
            )
        )
        warnings.warn(
            f"the start configuration is outside the joint ranges: {listed}; joint-limit "
            "rows pull these joints back in range",
            RuntimeWarning,
            stacklevel=2,
        )
    return configuration


def normalize_levels(levels: Sequence[Sequence[object]], dt: float) -> list[list[Task]]:
    """Coerce and validate the user's levels (level 0 hard, then priorities)."""
    if isinstance(levels, (str, bytes)) or not isinstance(levels, Sequence):
        raise InvalidInput("levels must be a list of lists of tasks: [[hard...], [level1...], ...]")
    if len(levels) < 2:
        raise InvalidInput(
            f"levels has {len(levels)} entries; give level 0 (hard rows, may be empty) "
            "and at least one level to solve"
        )
    out: list[list[Task]] = []
    for k, level in enumerate(levels):
        if not isinstance(level, Sequence) or isinstance(level, (str, bytes)):
            raise InvalidInput(f"level {k} must be a list of tasks, got {type(level).__name__}")
        if k > 0 and len(level) == 0:
            raise InvalidInput(f"level {k} is empty; every level after level 0 needs a task")
        out.append([as_task(t, dt) for t in level])
    return out
