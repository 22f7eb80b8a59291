"""The task contract of the cascade: the rows a task contributes at a configuration.

A task (prioritized-IK manual: ``inverse-kinematics-task``) contributes, at the current
configuration, equality rows and inequality rows over the step ``x = Δq``
(length ``nv``):

.. math::

    \\min_{x, \\omega}\\; (A x - b)^T W_A (A x - b) + \\omega^T W_C \\omega
    \\quad \\text{s.t.} \\quad d_l \\le C x + \\omega \\le d_u

A subclass implements :meth:`Task.compute_rows` (and usually
:meth:`Task.compute_error` and :meth:`Task.is_satisfied`); the cascade does the rest.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Sequence
from typing import NamedTuple

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput


class TaskRows(NamedTuple):
    """Equality and inequality rows of one task at one configuration.

    Attributes:
        A: Equality Jacobian, shape (m_eq, nv).
        b: Equality target, shape (m_eq,). Cost ``Σ w_A,i (A_i x - b_i)²``.
        w_A: Diagonal equality weights, shape (m_eq,), each >= 0.
        C: Inequality matrix, shape (m_in, nv).
        d_lower: Lower bounds of ``C x``, shape (m_in,); ``-inf`` for none.
        d_upper: Upper bounds of ``C x``, shape (m_in,); ``+inf`` for none.
        w_C: Diagonal slack weights, shape (m_in,), each > 0.
        damping: Extra Levenberg–Marquardt damping ``μ`` the task adds to its
            level's ``‖x‖²`` regularization (mink tasks' ``lm_damping``).
    """

    A: np.ndarray
    b: np.ndarray
    w_A: np.ndarray
    C: np.ndarray
    d_lower: np.ndarray
    d_upper: np.ndarray
    w_C: np.ndarray
    damping: float = 0.0

    @property
    def n_eq(self) -> int:
        return self.A.shape[0]

    @property
    def n_in(self) -> int:
        return self.C.shape[0]

    @staticmethod
    def empty(nv: int) -> TaskRows:
        z = np.zeros(0)
        return TaskRows(np.zeros((0, nv)), z, z, np.zeros((0, nv)), z, z, z)

    @staticmethod
    def equality(
        A: np.ndarray,
        b: np.ndarray,
        w_A: np.ndarray | float = 1.0,
        damping: float = 0.0,
    ) -> TaskRows:
        """Equality rows only: cost ``(A x - b)ᵀ diag(w_A) (A x - b)``."""
        A = np.atleast_2d(np.asarray(A, dtype=float))
        b = np.asarray(b, dtype=float).reshape(-1)
        w = _per_row(w_A, len(b))
        z = np.zeros(0)
        return TaskRows(A, b, w, np.zeros((0, A.shape[1])), z, z, z, damping)

    @staticmethod
    def inequality(
        C: np.ndarray,
        d_lower: np.ndarray | float,
        d_upper: np.ndarray | float,
        w_C: np.ndarray | float = 1.0,
    ) -> TaskRows:
        """Inequality rows only: ``d_lower <= C x + ω <= d_upper``, cost ``ωᵀ W_C ω``."""
        C = np.atleast_2d(np.asarray(C, dtype=float))
        m = C.shape[0]
        lo, hi, w = _per_row(d_lower, m), _per_row(d_upper, m), _per_row(w_C, m)
        z = np.zeros(0)
        return TaskRows(np.zeros((0, C.shape[1])), z, z, C, lo, hi, w)

    @staticmethod
    def stack(rows: Sequence[TaskRows], nv: int) -> TaskRows:
        """Concatenate the rows of several tasks (one priority level)."""
        if not rows:
            return TaskRows.empty(nv)
        if len(rows) == 1:
            return rows[0]
        return TaskRows(
            np.vstack([r.A for r in rows]),
            np.concatenate([r.b for r in rows]),
            np.concatenate([r.w_A for r in rows]),
            np.vstack([r.C for r in rows]),
            np.concatenate([r.d_lower for r in rows]),
            np.concatenate([r.d_upper for r in rows]),
            np.concatenate([r.w_C for r in rows]),
            float(sum(r.damping for r in rows)),
        )

    def squared_error(self, x: np.ndarray | None = None) -> float:
        """Weighted squared error of these rows at step ``x`` (``x = 0`` if None).

        .. math::

            e = (A x - b)^T W_A (A x - b) + \\sum_i w_{C,i}\\,
                \\mathrm{dist}(C_i x, [d_{l,i}, d_{u,i}])^2
        """
        if x is None:
            e = float(self.b @ (self.w_A * self.b))
            if self.n_in:
                viol = self.bound_distance()
                e += float(viol @ (self.w_C * viol))
            return e
        r_eq = self.A @ x - self.b
        viol = self.bound_distance(self.C @ x)
        return float(r_eq @ (self.w_A * r_eq) + viol @ (self.w_C * viol))

    def residual_norm(self, x: np.ndarray | None = None) -> float:
        """The unweighted residual the rows leave after a step ``x`` (``x = 0``
        if None) [row units], over the rows that constrain something: the
        equality rows of positive weight and every inequality row.

        .. math::

            \\|r(x)\\|, \\qquad r(x) = \\begin{bmatrix} (A x - b)_{w_A > 0} \\\\
                \\mathrm{dist}(C x, [d_l, d_u]) \\end{bmatrix}

        At ``x = 0`` it is the error the rows see: a task's error on the
        components it weights (for a mink task, times its ``gain``; for a
        clamped task, the clamp's).
        """
        A, b, w = self.A, self.b, self.w_A
        if w.size and not w.min() > 0:  # rows of weight 0 ask nothing
            keep = w > 0
            A, b = A[keep], b[keep]
        r_eq = -b if x is None else A @ x - b
        total = float(r_eq @ r_eq)
        if self.n_in:
            viol = self.bound_distance(None if x is None else self.C @ x)
            total += float(viol @ viol)
        return math.sqrt(total)

    def bound_distance(self, cx: np.ndarray | None = None) -> np.ndarray:
        """``dist(C x, [d_l, d_u])`` of each inequality row, from the row values
        ``cx = C x`` (``x = 0`` if None) [row units]."""
        if cx is None:
            return np.maximum(self.d_lower, 0.0) + np.maximum(-self.d_upper, 0.0)
        return np.maximum(self.d_lower - cx, 0.0) + np.maximum(cx - self.d_upper, 0.0)

    def violation(self) -> np.ndarray:
        """Unweighted violation of the rows at ``x = 0``: ``[-b; dist(0, [d_l, d_u])]``."""
        return np.concatenate([-self.b, self.bound_distance()])

    def validate(self, nv: int, owner: str) -> None:
        """Raise :class:`InvalidInput` naming ``owner`` if shapes or values are bad.

        Runs every iteration for every task, so the common case costs a handful
        of reductions: a NaN or inf anywhere makes a sum non-finite, and a NaN
        bound fails ``d_lower <= d_upper`` like an inverted one; only then are
        the arrays searched for the culprit.
        """
        self.check_shapes(nv, owner)
        m_eq, m_in = self.b.size, self.C.shape[0]
        ok = self.damping >= 0
        if m_eq:
            ok = ok and np.isfinite(self.A.sum() + self.b.sum() + self.w_A.sum())
            ok = ok and self.w_A.min() >= 0
        if m_in:
            ok = ok and np.isfinite(self.C.sum() + self.w_C.sum()) and self.w_C.min() > 0
            ok = ok and bool((self.d_lower <= self.d_upper).all())
        if not ok:
            self._raise_invalid(owner)

    def check_shapes(self, nv: int, owner: str) -> None:
        """Raise :class:`InvalidInput` naming ``owner`` if the shapes do not
        agree with each other and with ``nv`` (the first part of :meth:`validate`)."""
        m_eq, m_in = self.b.size, self.C.shape[0]
        if (
            self.A.shape != (m_eq, nv)
            or self.w_A.shape != (m_eq,)
            or self.C.shape != (m_in, nv)
            or not self.d_lower.shape == self.d_upper.shape == self.w_C.shape == (m_in,)
        ):
            raise InvalidInput(
                f"task {owner}: row shapes do not agree with nv = {nv}: A {self.A.shape}, "
                f"b {self.b.shape}, w_A {self.w_A.shape}, C {self.C.shape}, d_lower "
                f"{self.d_lower.shape}, d_upper {self.d_upper.shape}, w_C {self.w_C.shape}"
            )

    def _raise_invalid(self, owner: str) -> None:
        for name in ("A", "b", "w_A", "C", "w_C"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise InvalidInput(f"task {owner}: {name} contains NaN or inf")
        if np.isnan(self.d_lower).any() or np.isnan(self.d_upper).any():
            raise InvalidInput(f"task {owner}: inequality bounds contain NaN")
        if np.any(self.d_lower > self.d_upper):
            i = int(np.argmax(self.d_lower > self.d_upper))
            raise InvalidInput(
                f"task {owner}: inverted bounds on row {i}: "
                f"lower {self.d_lower[i]:.6g} > upper {self.d_upper[i]:.6g}"
            )
        raise InvalidInput(f"task {owner}: weights must be >= 0 (equality) and > 0 (slack)")


def _per_row(value: np.ndarray | float, m: int) -> np.ndarray:
    """``value`` (a number, or one per row) as a new array of ``m`` floats."""
    if isinstance(value, float):
        return np.full(m, value)
    value = np.asarray(value, dtype=float)
    return value.copy() if value.shape == (m,) else np.broadcast_to(value, (m,)).copy()


class TaskState(NamedTuple):
    """A task at one configuration: its rows, ``‖e‖`` (in its own units) and
    whether its stop test holds (:meth:`Task.evaluate`)."""

    rows: TaskRows
    error: float
    satisfied: bool


class Task(abc.ABC):
    """Base of pik_mj's own tasks (prioritized-IK manual: ``inverse-kinematics-task``).

    Attributes:
        name: Name shown in results and recordings.
        check: Whether the solve loop's stop test looks at this task
            (prioritized-IK manual: ``check``).
        finite_rows: Whether the rows are valid (finite, weights >= 0,
            bounds in order) at every finite configuration, their inputs
            checked where they enter, as a ``FrameTask``'s target. The solve
            loop validates every task's rows at its start (only their shapes
            for a task that declares this); afterwards it sums the stacked
            rows of each level at each configuration to check them finite,
            except for a level whose tasks all declare this (a subclass that
            makes its rows otherwise should set it back to False).
        model: The model the task was built on (its frame and joint ids are
            that model's), or None for a task that fits any model.
            :meth:`check_model` refuses a configuration of another model.
    """

    name: str = "task"
    check: bool = True
    finite_rows: bool = False
    model: mujoco.MjModel | None = None
    _accepted: mujoco.MjModel | None = None  # a copy of model seen by check_model

    def check_model(self, configuration: mink.Configuration) -> None:
        """Raise unless ``configuration`` is of the model the task was built on
        (:attr:`model`): that object, or a model of the same structure (the same
        ``nq``, ``nv``, body tree and names: a copy). The solve loop calls it on
        every task before its first iteration.

        Raises:
            InvalidInput: A configuration of another model (its ids would
                address other bodies and joints: the solve would converge on
                nonsense).
        """
        model = configuration.model
        if self.model is None or model is self.model or model is self._accepted:
            return
        if same_structure(self.model, model):
            self._accepted = model
            return
        raise InvalidInput(
            f"task {self.name!r} was built on model {_model_name(self.model)} (nq = "
            f"{self.model.nq}, nv = {self.model.nv}) and is solved on a configuration of "
            f"model {_model_name(model)} (nq = {model.nq}, nv = {model.nv}); build the "
            "task on the configuration it is solved with"
        )

    @abc.abstractmethod
    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        """Rows of this task linearized at ``configuration`` (prioritized-IK manual:
        ``:update``)."""

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """Unweighted error vector of the task (zero when perfectly achieved).

        The default is the equality residual at ``x = 0`` followed by the
        inequality violations; tasks whose ``b`` is clamped override it.
        """
        return self.compute_rows(configuration).violation()

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        """Stop test of the solve loop (prioritized-IK manual: ``:is-satisfied``)."""
        return bool(np.all(np.abs(self.compute_error(configuration)) <= 1e-6))

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, error norm and stop test at ``configuration``, as the solve loop
        uses them (once per iteration and task). Tasks that can share the work
        between the three override it."""
        error = self.compute_error(configuration)
        return TaskState(
            self.compute_rows(configuration),
            float(np.linalg.norm(error)),
            self.is_satisfied(configuration),
        )

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, check={self.check})"


class EqualityTask(Task):
    """Base of equality tasks: error, Jacobian and dimension in; rows, clamp and
    stop test out (mink's task contract).

    A subclass declares its dimension :attr:`k` and :attr:`weights` (``W_A``'s
    diagonal, shape (k,)) and implements :meth:`compute_error` ``e(q)`` and
    :meth:`compute_jacobian` ``J = de/dq`` (tangent space, shape (k, nv)), or
    :meth:`error_and_jacobian` when the two share work. The base turns them
    into the rows

    .. math::

        J x = -\\mathrm{clamp}(e), \\qquad
        \\text{cost } (J x + \\mathrm{clamp}(e))^T W_A (J x + \\mathrm{clamp}(e))

    (prioritized-IK manual: ``:update`` linearizes, ``p-limit``/``r-limit``
    bound the step asked of one iteration), and the stop test
    :meth:`satisfied_by` ``(e)`` reads the unclamped error. Subclasses override
    :meth:`clamp` (default: none) and :meth:`satisfied_by` (default:
    ``max |e_i| <= 1e-6``).
    """

    k: int
    weights: np.ndarray

    @abc.abstractmethod
    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """The error ``e`` (k,) at ``configuration``, unclamped, in the task's units."""

    @abc.abstractmethod
    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """``de/dq`` in the tangent space, shape (k, nv)."""

    def error_and_jacobian(
        self, configuration: mink.Configuration
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(e, J)`` at ``configuration``; override when they share work."""
        return self.compute_error(configuration), self.compute_jacobian(configuration)

    def clamp(self, e: np.ndarray) -> np.ndarray:
        """The error asked of one iteration (a copy, ``e`` is left untouched)."""
        return e.copy()

    def satisfied_by(self, e: np.ndarray) -> bool:
        """Stop test on the unclamped error ``e``."""
        return bool(np.max(np.abs(e), initial=0.0) <= 1e-6)

    def rows_from(self, e: np.ndarray, J: np.ndarray) -> TaskRows:
        """``J x = -clamp(e)`` with weights :attr:`weights`."""
        b = self.clamp(e)
        np.negative(b, out=b)
        return TaskRows(J, b, self.weights, *no_inequality(J.shape[1]))

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        return self.rows_from(*self.error_and_jacobian(configuration))

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return self.satisfied_by(self.compute_error(configuration))

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, ``‖e‖`` and stop test from one :meth:`error_and_jacobian`."""
        e, J = self.error_and_jacobian(configuration)
        return TaskState(self.rows_from(e, J), math.sqrt(float(e @ e)), self.satisfied_by(e))


def same_structure(a: mujoco.MjModel, b: mujoco.MjModel) -> bool:
    """Whether two models have the same configuration space and bodies: equal
    ``nq``, ``nv``, body tree and names (a copy of one model, or the same MJCF
    compiled twice)."""
    return (
        (a.nq, a.nv, a.nbody, a.njnt) == (b.nq, b.nv, b.nbody, b.njnt)
        and a.names == b.names
        and np.array_equal(a.body_parentid, b.body_parentid)
    )


def _model_name(model: mujoco.MjModel) -> str:
    """The model's name (``<mujoco model="...">``, the first of ``model.names``), quoted."""
    return repr(model.names.split(b"\0", 1)[0].decode() or "unnamed")


def frozen(M: np.ndarray) -> bool:
    """Read-only and owning its data: its values cannot change (a task may
    hand back such a matrix, e.g. a constant Jacobian, as the same object every
    evaluation; users of the rows may then keep what they derive from it)."""
    return not M.flags.writeable and M.base is None


_EMPTY = np.zeros(0)
_EMPTY.flags.writeable = False


_NO_INEQUALITY: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}


def no_inequality(nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(C, d_lower, d_upper, w_C)`` of rows without inequalities (shared,
    read-only empty arrays)."""
    empty = _NO_INEQUALITY.get(nv)
    if empty is None:
        C = np.zeros((0, nv))
        C.flags.writeable = False
        empty = _NO_INEQUALITY[nv] = (C, _EMPTY, _EMPTY, _EMPTY)
    return empty


_NO_EQUALITY: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def no_equality(nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, b, w_A)`` of rows without equalities (shared, read-only empty arrays)."""
    empty = _NO_EQUALITY.get(nv)
    if empty is None:
        A = np.zeros((0, nv))
        A.flags.writeable = False
        empty = _NO_EQUALITY[nv] = (A, _EMPTY, _EMPTY)
    return empty


def clamp_norm(v: np.ndarray, limit: float) -> np.ndarray:
    """``v`` scaled in place to norm ``limit`` if longer (prioritized-IK manual:
    ``p-limit``)."""
    norm = math.sqrt(float(v @ v))
    if norm > limit:
        v *= limit / norm
    return v


def within(e: np.ndarray, tol: np.ndarray, rows: np.ndarray) -> bool:
    """The prioritized-IK manual's tolerance (``thre``): a float bounds the norm
    of ``e``, a 3-vector bounds each matched axis (``rows``: the axes ``e``
    holds)."""
    if e.size == 0:
        return True
    if tol.ndim == 0:
        return math.sqrt(float(e @ e)) <= float(tol)
    return bool(np.all(np.abs(e) <= tol[rows]))


def tolerance(value: object, what: str, unit: str) -> np.ndarray:
    """A stop-test tolerance: a finite number >= 0, or a 3-vector of them (one
    per axis), as an array of shape () or (3,)."""
    valid = f"a finite number >= 0 or 3 of them [{unit}]"
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise InvalidInput(f"{what} must be {valid}, got {value!r}")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(f"{what} must be {valid}, got {value!r}") from None
    if arr.shape not in ((), (3,)) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InvalidInput(f"{what} must be {valid}, got {value!r}")
    return arr


MAX_WEIGHT = 1e12
"""Largest task weight accepted: the level's Hessian ``Jᵀ W J`` must stay far
from overflow and its condition number within what a QP solver can use."""


def diagonal_weights(w: float | Sequence[float] | np.ndarray, size: int, what: str) -> np.ndarray:
    """The prioritized-IK manual's weights of a diagonal ``W``: a float fills the
    diagonal, a vector gives it. Returns the diagonal, shape (size,)."""
    arr = np.asarray(w, dtype=float)
    if arr.ndim == 0:
        arr = np.full(size, float(arr))
    if arr.shape != (size,):
        raise InvalidInput(
            f"{what} must be a float or a vector of length {size}, got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)) or np.any(arr < 0) or np.any(arr > MAX_WEIGHT):
        raise InvalidInput(f"{what} must be finite, >= 0 and <= {MAX_WEIGHT:g}, got {arr}")
    return arr
