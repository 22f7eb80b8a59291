"""Checks of user input where it enters the top layer, with one message style.

Every check returns the value in the form the caller uses (a float, an int, an
array, a tuple of names, a path) or raises :class:`~pik_mj.exceptions.InvalidInput`
saying what was wrong and what is valid::

    thre must be a finite number > 0 [m], got '1mm'

Numbers are Python or numpy numbers (``np.float64(0.1)``, ``np.int64(50)``);
booleans and strings are never numbers. :func:`configuration` checks a whole
``qpos`` joint by joint (NaN/inf, overflow, zero quaternions) and names the
joint, :func:`mink_configuration` the ``mink.Configuration`` a solve starts
from (the same checks, and the model's joint ranges); :func:`output_path`
checks that a file can be written before any work starts.
"""

from __future__ import annotations

import errno
import inspect
import math
import os
import warnings
from collections.abc import Callable, Iterable, Sequence, Set
from pathlib import Path
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName

__all__ = [
    "Q_LIMIT",
    "as_pose",
    "configuration",
    "flag",
    "flat_vector",
    "integer",
    "mink_configuration",
    "names",
    "options",
    "output_path",
    "quaternion",
    "real",
    "rotation_matrix",
    "vector",
    "wrenches",
]

Q_LIMIT = 1e6
"""Largest ``|q_i|`` [rad or m] accepted in a configuration or a placement: beyond
it a value is an overflow or a units mistake, not a pose."""


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _show(value: Any) -> str:
    """``value`` for a message: arrays as lists, the rest as its repr."""
    if isinstance(value, np.ndarray):
        return repr(value.tolist())
    return repr(value)


def _range_text(
    low: float | None, high: float | None, low_open: bool, high_open: bool, unit: str
) -> str:
    parts = []
    if low is not None:
        parts.append(f"{'>' if low_open else '>='} {low:g}")
    if high is not None:
        parts.append(f"{'<' if high_open else '<='} {high:g}")
    text = " and ".join(parts)
    return (f" {text}" if text else "") + (f" [{unit}]" if unit else "")


def real(
    value: Any,
    what: str,
    *,
    unit: str = "",
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """``value`` as a finite float within ``[low, high]`` (``low_open``/``high_open``:
    the bound itself excluded).

    Raises:
        InvalidInput: Not a number (a string, a bool, None, a list), NaN/inf, or out
            of the range; the message gives the valid range and its unit.
    """
    valid = "a finite number" + _range_text(low, high, low_open, high_open, unit)
    if not _is_number(value):
        raise InvalidInput(f"{what} must be {valid}, got {_show(value)}")
    v = float(value)
    if (
        not math.isfinite(v)
        or (low is not None and (v <= low if low_open else v < low))
        or (high is not None and (v >= high if high_open else v > high))
    ):
        raise InvalidInput(f"{what} must be {valid}, got {_show(value)}")
    return v


def integer(value: Any, what: str, *, low: int | None = None) -> int:
    """``value`` as an int ``>= low`` (Python or numpy integers; bools refused).

    Raises:
        InvalidInput: Not an integer, or below ``low``.
    """
    valid = "an integer" + ("" if low is None else f" >= {low}")
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise InvalidInput(f"{what} must be {valid}, got {_show(value)}")
    if low is not None and value < low:
        raise InvalidInput(f"{what} must be {valid}, got {_show(value)}")
    return int(value)


def flag(value: Any, what: str) -> bool:
    """``value`` as a bool (Python or numpy booleans only: ``"no"`` is not False).

    Raises:
        InvalidInput: Not a boolean.
    """
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidInput(f"{what} must be True or False, got {_show(value)}")
    return bool(value)


def vector(value: Any, n: int, what: str, *, unit: str = "") -> np.ndarray:
    """``value`` as a finite float array of shape ``(n,)``.

    Raises:
        InvalidInput: Not ``n`` numbers, or NaN/inf among them.
    """
    valid = f"{n} finite numbers" + (f" [{unit}]" if unit else "")
    if isinstance(value, (str, bytes)) or value is None:
        raise InvalidInput(f"{what} must be {valid}, got {_show(value)}")
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{what} must be {valid}, got {_show(value)}") from None
    if v.shape != (n,):
        raise InvalidInput(f"{what} must be {valid}, got shape {v.shape}: {_show(value)}")
    if not np.all(np.isfinite(v)):
        raise InvalidInput(f"{what} must be {valid}, got NaN or inf: {_show(value)}")
    return v


def flat_vector(value: Any, n: int, what: str, *, unit: str = "") -> np.ndarray:
    """``value`` flattened (a column, a row, nested lists), as :func:`vector`
    of length ``n``.

    Raises:
        InvalidInput: Not ``n`` numbers, or NaN/inf among them.
    """
    try:
        flat: Any = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        flat = value  # refused by vector(), which names it
    return vector(flat, n, what, unit=unit)


def quaternion(value: Any, what: str) -> np.ndarray:
    """``value`` as a unit quaternion (w, x, y, z): 4 finite numbers of non-zero
    norm, normalized (without overflow: scaled by its largest entry first).

    Raises:
        InvalidInput: Not 4 finite numbers, or a zero quaternion.
    """
    quat = vector(value, 4, f"{what} (a quaternion w, x, y, z)")
    scale = np.max(np.abs(quat))
    if scale == 0.0 or not np.isfinite(1.0 / scale):
        raise InvalidInput(
            f"{what} is a zero quaternion {_show(value)}; give a non-zero quaternion (w, x, y, z)"
        )
    quat = quat / scale
    return quat / np.linalg.norm(quat)


def rotation_matrix(value: Any, what: str, also: str = "") -> np.ndarray:
    """A rotation ``R`` (3x3) from a ``mink.SO3``, a wxyz quaternion (normalized)
    or a proper orthonormal 3x3 matrix; :class:`InvalidInput` naming ``what``
    otherwise (a zero or non-finite quaternion named as such). ``also`` lists
    the caller's other valid values for the message."""
    if isinstance(value, mink.SO3):
        return value.as_matrix()
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = np.zeros(0)
    if arr.shape == (4,):
        if not (np.all(np.isfinite(arr)) and np.linalg.norm(arr) > 0):
            raise InvalidInput(
                f"{what}: the quaternion {value!r} has zero length or is not finite; "
                "give a non-zero wxyz quaternion"
            )
        return mink.SO3(arr / np.linalg.norm(arr)).as_matrix()
    if (
        arr.shape == (3, 3)
        and np.all(np.isfinite(arr))
        and np.allclose(arr.T @ arr, np.eye(3), atol=1e-6)
        and np.linalg.det(arr) > 0
    ):
        return arr
    valid = f"{also}, " if also else ""
    raise InvalidInput(
        f"{what} {value!r} is not valid; use {valid}a wxyz quaternion, a rotation matrix "
        "or a mink.SO3"
    )


def as_pose(value: Any, what: str = "pose") -> tuple[np.ndarray, np.ndarray]:
    """``(p_W (3,), R_W (3,3))`` from a ``mink.SE3``, a 4x4 matrix, or
    ``(position, quaternion wxyz)``."""
    if isinstance(value, mink.SE3):
        p, R = value.translation(), value.rotation().as_matrix()
    elif isinstance(value, np.ndarray) and value.shape == (4, 4):
        p, R = value[:3, 3], value[:3, :3]
    elif isinstance(value, (tuple, list)) and len(value) == 2:
        p = np.asarray(value[0], dtype=float)
        quat = np.asarray(value[1], dtype=float)
        if quat.shape == (3, 3):
            R = quat
        elif quat.shape == (4,) and np.linalg.norm(quat) > 0:
            R = mink.SO3(quat / np.linalg.norm(quat)).as_matrix()
        else:
            raise InvalidInput(f"{what}: orientation must be a wxyz quaternion or 3x3 matrix")
    else:
        raise InvalidInput(
            f"{what} must be a mink.SE3, a 4x4 matrix or (position, quat_wxyz); "
            f"got {type(value).__name__}"
        )
    p = np.asarray(p, dtype=float).reshape(-1)
    R = np.asarray(R, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)) or not np.all(np.isfinite(R)):
        raise InvalidInput(f"{what}: position must be 3 finite numbers, rotation finite")
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6):
        raise InvalidInput(f"{what}: rotation is not orthonormal")
    return p, R


def names(value: Any, what: str) -> tuple[str, ...]:
    """``value`` as a tuple of names: a list or tuple of strings (one string alone is
    refused: ``"abc"`` would be three names).

    Raises:
        InvalidInput: Not a sequence of strings.
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, Set, np.ndarray)):
        raise InvalidInput(f"{what} must be a list of names, got {_show(value)}")
    out = tuple(str(x) if isinstance(x, np.str_) else x for x in value)
    for i, name in enumerate(out):
        if not isinstance(name, str):
            raise InvalidInput(f"{what}[{i}] must be a name (a string), got {name!r}")
    return out


def options(
    given: Iterable[str],
    function: Callable[..., Any],
    what: str,
    *,
    also: Callable[..., Any] | None = None,
    positional: Sequence[str] = (),
) -> None:
    """Keyword options passed on through ``**options`` are ``function``'s (or
    ``also``'s): an unknown one is named with the valid ones listed, instead of
    Python's ``TypeError`` from deep inside the call.

    Raises:
        UnknownName: An option neither function takes.
    """
    valid = {
        name
        for f in (function, also)
        if f is not None
        for name, p in inspect.signature(f).parameters.items()
        if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL) and name not in ("self", *positional)
    }
    for name in given:
        if name not in valid:
            raise UnknownName(what, name, valid)


def wrenches(value: Any, what: str) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``value`` as wrenches ``(frame name, force (3,) [N], moment (3,) [N·m])``.

    Raises:
        InvalidInput: Not a list of such triples, a frame that is not a name, or
            a force or moment that is not 3 finite numbers.
    """
    form = "(frame, force (3,) [N], moment (3,) [N·m])"
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise InvalidInput(f"{what} must be a list of {form}, got {_show(value)}")
    out = []
    for i, item in enumerate(value):
        if not isinstance(item, (tuple, list)) or len(item) != 3:
            raise InvalidInput(f"{what}[{i}] must be {form}, got {_show(item)}")
        frame, force, moment = item
        if not isinstance(frame, str):
            raise InvalidInput(f"{what}[{i}]: the frame must be a name, got {frame!r}")
        out.append(
            (
                frame,
                vector(force, 3, f"{what}[{i}] force at {frame!r}", unit="N"),
                vector(moment, 3, f"{what}[{i}] moment at {frame!r}", unit="N·m"),
            )
        )
    return out


_JOINT_WIDTH = {
    int(mujoco.mjtJoint.mjJNT_FREE): 7,
    int(mujoco.mjtJoint.mjJNT_BALL): 4,
    int(mujoco.mjtJoint.mjJNT_SLIDE): 1,
    int(mujoco.mjtJoint.mjJNT_HINGE): 1,
}
# joint types compared as ints (a pybind enum makes numpy loop in Python):
# free 0 and ball 1 hold quaternions, slide 2 and hinge 3 have ranges
_FREE, _SLIDE = int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_SLIDE)

RANGE_TOLERANCE = 1e-5
"""[rad or m] How far past its range a joint may start a solve without a
warning: the QP solvers' accuracy on a limit row (OSQP's
``eps_abs + eps_rel·|row|``, 1e-6 each), so that a solve started where the
previous one ended is not warned of its own solver's rounding."""


def joint_name(model: mujoco.MjModel, j: int) -> str:
    """The name of joint ``j`` (``joint #j`` when it has none)."""
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint #{j}"


def configuration(
    model: mujoco.MjModel, q: Any, what: str = "q", *, sizes: Sequence[int] = ()
) -> np.ndarray:
    """``q`` as a configuration of ``model`` (a copy), checked joint by joint
    (:func:`check_joint_values`).

    Args:
        model: The model ``q`` belongs to.
        q: ``nq`` numbers (or one of ``sizes``: a prefix of them, e.g. the robot's
            own joints).
        what: Name of the argument in messages.
        sizes: Other accepted lengths.

    Raises:
        InvalidInput: Not numbers, the wrong length (the model's ``nq`` given: the
            pose of another model), NaN/inf or ``|q_i| >`` :data:`Q_LIMIT` (the
            joint named), or a free/ball joint's zero quaternion.
    """
    valid = (model.nq, *sizes)
    if isinstance(q, (str, bytes)) or q is None:
        raise InvalidInput(f"{what} must be {model.nq} numbers (the model's nq), got {q!r}")
    try:
        v = np.array(q, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(
            f"{what} must be {model.nq} numbers (the model's nq), got {q!r}"
        ) from None
    if v.ndim != 1 or len(v) not in valid:
        _wrong_shape(model, v, what, valid)
    check_joint_values(model, v, what)
    return v


def _wrong_shape(model: mujoco.MjModel, v: np.ndarray, what: str, valid: Sequence[int]) -> None:
    lengths = " or ".join(str(n) for n in dict.fromkeys(valid))
    raise InvalidInput(
        f"{what} has shape {v.shape}, but this model's configuration has {lengths} "
        "numbers: a pose of another model?"
    )


def check_joint_values(model: mujoco.MjModel, v: np.ndarray, what: str) -> None:
    """Refuse a configuration ``v`` (``nq`` numbers, or a prefix of them) of
    ``model`` holding a meaningless value, naming the first joint (in model
    order) that holds one: NaN or inf, ``|q_i| >`` :data:`Q_LIMIT` (an
    overflow or a units mistake), or a free or ball joint's zero quaternion.

    Raises:
        InvalidInput: The fault, the joint and the entry of ``what`` named.
    """
    n = len(v)
    kind, adr = model.jnt_type, model.jnt_qposadr
    # the first fault of each kind: (joint, 0 = value / 1 = quaternion, entry)
    faults: list[tuple[int, int, int]] = []
    if n and not float(np.abs(v).max()) <= Q_LIMIT:  # (NaN fails too)
        i = int(np.argmax(~np.isfinite(v) | (np.abs(v) > Q_LIMIT)))
        faults.append((int(np.searchsorted(adr, i, side="right")) - 1, 0, i))
    for j in np.flatnonzero(kind < _SLIDE).tolist():
        a = int(adr[j]) + (3 if kind[j] == _FREE else 0)
        if a + 4 > n:
            break
        w, x, y, z = v[a : a + 4].tolist()
        if w * w + x * x + y * y + z * z < 1e-18:  # ‖quaternion‖ < 1e-9
            faults.append((j, 1, a))
            break
    if not faults:
        return
    j, fault, i = min(faults)
    name = joint_name(model, j)
    a = int(adr[j])
    values = v[a : a + _JOINT_WIDTH[int(kind[j])]]
    if fault == 1:
        quat = values[-4:].tolist()
        raise InvalidInput(
            f"joint {name!r}: its quaternion in {what} is zero; give a unit quaternion "
            f"(w, x, y, z) ({what}: joint {name!r} has a zero quaternion {quat})"
        )
    finite = np.isfinite(values)
    if not finite.all():
        i = a + int(np.argmin(finite))
        fault_text = "NaN" if np.isnan(v[i]) else "inf"
        joint_text = "holds NaN or inf"
    else:
        fault_text = f"{v[i]:.3g}"
        joint_text = (
            f"is at {values.tolist()}, beyond {Q_LIMIT:g} [rad or m]: an overflow or a "
            "units mistake"
        )
    raise InvalidInput(
        f"{what}[{i}] (joint {name!r}) is {fault_text}; every entry must be finite with "
        f"|q| <= {Q_LIMIT:g} (rad or m) ({what}: joint {name!r} {joint_text})"
    )


def mink_configuration(value: object) -> mink.Configuration:
    """A :class:`mink.Configuration` with a usable ``q`` and model, or raise
    (the configuration a solve starts from).

    Refused: another type (e.g. the ``MjModel`` itself); a ``q`` that
    :func:`check_joint_values` refuses; a joint whose range is inverted.
    Warned (:class:`RuntimeWarning`): limited joints outside their range by more
    than :data:`RANGE_TOLERANCE` (a joint-limit row then pulls them back in;
    with ``revert_if_fail`` an unsatisfied solve returns to this out-of-range
    start).

    Raises:
        InvalidInput: The fault named.
    """
    if not isinstance(value, mink.Configuration):
        hint = (
            "; build one with mink.Configuration(model)"
            if isinstance(value, (mujoco.MjModel, mujoco.MjData))
            else ""
        )
        raise InvalidInput(
            f"configuration must be a mink.Configuration, got {type(value).__name__}{hint}"
        )
    model = value.model
    q = value.q
    if q.shape != (model.nq,):
        _wrong_shape(model, q, "configuration.q", (model.nq,))
    check_joint_values(model, q, "configuration.q")
    kind = model.jnt_type
    ranged = np.flatnonzero((kind >= _SLIDE) & (model.jnt_limited != 0))
    lo, hi = model.jnt_range[ranged].T
    inverted = ranged[lo > hi]
    if inverted.size:
        j = int(inverted[0])
        raise InvalidInput(
            f"joint {joint_name(model, j)!r} has an inverted range "
            f"[{model.jnt_range[j, 0]:g}, {model.jnt_range[j, 1]:g}]; the lower limit "
            "must not exceed the upper"
        )
    values = q[model.jnt_qposadr[ranged]]
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
    return value


def output_path(path: Any, what: str) -> Path:
    """``path`` as a file that can be written, checked before any work starts.

    The check writes nothing that stays: missing directories are created and a
    missing file is created, then both removed again; an existing file is opened
    for appending (its content kept).

    Raises:
        InvalidInput: Not a path, a directory, below a file, or not writable (the
            operating system's reason given; a full file system, a device that
            refuses writes such as ``/dev/full``).
    """
    if not isinstance(path, (str, os.PathLike)) or os.fspath(path) in ("", b""):
        raise InvalidInput(f"{what} must be a file path, got {path!r}")
    p = Path(os.fsdecode(os.fspath(path))).expanduser()
    if p.is_dir():
        raise InvalidInput(f"{what} {str(p)!r} is a directory; give a file path in it")
    made: list[Path] = []
    parent = p.absolute().parent
    while not parent.exists():
        made.append(parent)
        parent = parent.parent
    if not parent.is_dir():
        raise InvalidInput(f"{what} {str(p)!r} cannot be written: {str(parent)!r} is a file")
    existed = p.exists()
    try:
        for d in reversed(made):
            d.mkdir()
        with open(p, "ab", buffering=0) as f:
            f.write(b"")  # a device such as /dev/full refuses even this
            if p.is_file() and os.statvfs(p).f_bavail == 0:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    except OSError as exc:
        raise InvalidInput(f"{what} {str(p)!r} cannot be written: {exc.strerror or exc}") from None
    finally:
        if not existed and p.is_file():
            p.unlink()
        for d in made:
            if d.is_dir() and not any(d.iterdir()):
                d.rmdir()
    return p
