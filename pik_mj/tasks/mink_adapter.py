"""mink tasks and limits as cascade rows, unchanged.

* A :class:`mink.Task` (``FrameTask``, ``ComTask``, ``PostureTask``,
  ``RelativeFrameTask``, ...) becomes equality rows
  ``J x = -α e`` with weights ``cost²`` and its ``lm_damping`` as level damping:
  exactly the term mink's own single QP minimizes, ``‖J Δq + α e‖²_W``.
* Any other :class:`BaseTask` goes through its weighted residual
  (``compute_qp_residual``) or, failing that, its objective ``(H, c)`` factored
  as ``H = Lᵀ L``.
* A :class:`mink.Limit` becomes inequality rows ``G x <= h``: hard at level 0,
  with slacks at any other level.
"""

from __future__ import annotations

import math

import mink
import mujoco
import numpy as np
from mink.tasks.task import BaseTask

from pik_mj.exceptions import InvalidInput
from pik_mj.tasks.task import Task, TaskRows, TaskState, no_equality, no_inequality

_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


class MinkTask(Task):
    """A :class:`BaseTask` used as an equality task of the cascade.

    Args:
        task: The mink task, used unchanged.
        name: Display name (defaults to the mink class name).
        threshold: Stop-test tolerance on the error, in the task's units.
            For frame tasks, the first value applies to the translation norm [m]
            and the second to the rotation norm [rad]; otherwise it bounds
            ``max |e_i|``. Components of cost 0 are no part of the error norm
            or the stop test (:meth:`weighted_part`).
        check: Whether the solve loop's stop test looks at this task.
    """

    def __init__(
        self,
        task: BaseTask,
        name: str | None = None,
        threshold: float | tuple[float, float] | None = None,
        check: bool = True,
    ):
        if not isinstance(task, BaseTask):
            raise InvalidInput(f"expected a BaseTask, got {type(task).__name__}")
        self.task = task
        # a mink.Task (error and Jacobian), else a BaseTask's residual or
        # objective; asked once (an ABC's isinstance is not free)
        self._error_task = isinstance(task, mink.Task)
        self.name = name or type(task).__name__
        self.check = check
        self._is_frame = isinstance(task, (mink.FrameTask, mink.RelativeFrameTask))
        self._cost_bytes = b""  # the task's cost values the weights were made from
        self._cost_values = np.zeros(0)
        self._weights = np.zeros(0)
        # a PostureTask's Jacobian (constant, see _jacobian) and the model it
        # was made for
        self._J: np.ndarray | None = None
        self._J_model: mujoco.MjModel | None = None
        if self._error_task and isinstance(getattr(task, "k", None), int):
            self._weights_for(task.k)
        if threshold is None:
            threshold = (1e-3, np.deg2rad(1.0)) if self._is_frame else 1e-3
        self.threshold = threshold

    def _jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """The task's Jacobian at ``configuration``.

        A :class:`mink.PostureTask`'s is ``I`` with the free joints' columns
        zeroed, whatever the configuration (its ``compute_jacobian`` depends on
        the model only): the same matrix is made once per model
        (:func:`_posture_jacobian`) and kept read-only, so that the level's
        checks and the backends, which keep what they derive from a read-only
        matrix, need not look at it again.
        """
        task = self.task
        if type(task) is mink.PostureTask:
            model = configuration.model
            if self._J is None or self._J_model is not model:
                self._J, self._J_model = _posture_jacobian(model), model
            return self._J
        return np.asarray(task.compute_jacobian(configuration), dtype=float)

    def _weights_for(self, k: int) -> np.ndarray:
        """``cost²`` as the weights of ``k`` rows, recomputed only when the task's
        cost values change (mink's ``set_cost`` writes into the same array)."""
        cost = np.asarray(self.task.cost, dtype=float)
        cost_bytes = cost.tobytes()
        if cost_bytes != self._cost_bytes:
            self._cost_bytes, self._cost_values = cost_bytes, cost.copy()
            self._weights = np.broadcast_to(self._cost_values**2, (k,)).copy()
        if self._weights.shape != (k,):
            return np.broadcast_to(self._cost_values**2, (k,)).copy()
        return self._weights

    def _task_rows(self, error: np.ndarray, configuration: mink.Configuration) -> TaskRows:
        """Rows of a :class:`mink.Task` whose error at ``configuration`` is ``error``."""
        task = self.task
        jacobian = self._jacobian(configuration)
        weights = self._weights_for(error.size)
        gain = task.gain
        mu = (
            task.lm_damping * gain * gain * float(error @ (weights * error))
            if task.lm_damping
            else 0.0
        )
        if jacobian.ndim != 2:
            return TaskRows.equality(jacobian, -gain * error, weights, mu)
        return TaskRows(jacobian, -gain * error, weights, *no_inequality(jacobian.shape[1]), mu)

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        task = self.task
        if self._error_task:
            return self._task_rows(task.compute_error(configuration), configuration)
        residual = task.compute_qp_residual(configuration)
        if residual is not None:
            weighted_jacobian, weighted_error, mu = residual
            return TaskRows.equality(weighted_jacobian, weighted_error, 1.0, mu)
        H, c = task.compute_qp_objective(configuration)
        # xᵀ H x + 2 cᵀ x = ‖L x - b‖² + const with H = V diag(s) Vᵀ, L = diag(√s) Vᵀ.
        s, V = np.linalg.eigh(0.5 * (H + H.T))
        keep = s > 1e-12 * max(1.0, float(s.max(initial=0.0)))
        sqrt_s = np.sqrt(s[keep])
        L = sqrt_s[:, None] * V[:, keep].T
        b = -(V[:, keep].T @ c) / sqrt_s
        return TaskRows.equality(L, b, 1.0)

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        if self._error_task:
            return np.asarray(self.task.compute_error(configuration), dtype=float)
        return self.compute_rows(configuration).violation()

    def weighted_part(self, e: np.ndarray) -> np.ndarray:
        """``e`` with the components of cost 0 zeroed: the task asks nothing
        of them (a posture weighting a few joints, a frame task without an
        orientation cost), so its error norm and stop test read the others."""
        if not self._error_task:
            return e
        weights = self._weights_for(e.size)
        if not weights.size or weights.min() > 0:
            return e
        return np.where(weights > 0, e, 0.0)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return self._satisfied_by(self.weighted_part(self.compute_error(configuration)))

    def _satisfied_by(self, e: np.ndarray) -> bool:
        if self._is_frame:
            thre, rthre = self.threshold  # type: ignore[misc]
            return bool(np.linalg.norm(e[:3]) <= thre and np.linalg.norm(e[3:]) <= rthre)
        return bool(e.size == 0 or np.abs(e).max() <= float(self.threshold))  # type: ignore[arg-type]

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, error norm and stop test from one ``compute_error``."""
        if not self._error_task:
            return super().evaluate(configuration)
        e = np.asarray(self.task.compute_error(configuration), dtype=float)
        rows = self._task_rows(e, configuration)
        e = self.weighted_part(e)
        return TaskState(rows, math.sqrt(float(e @ e)), self._satisfied_by(e))

    def __repr__(self) -> str:
        return f"MinkTask({self.task!r}, name={self.name!r})"


def _posture_jacobian(model: mujoco.MjModel) -> np.ndarray:
    """A :class:`mink.PostureTask`'s Jacobian on ``model``, as its
    ``compute_jacobian`` makes it at any configuration: ``I`` (nv) with the
    free joints' columns zeroed (the six dofs from each free joint's
    ``jnt_dofadr``, as ``mink.get_freejoint_dims`` lists them); read-only."""
    J = np.eye(model.nv)
    for a in model.jnt_dofadr[model.jnt_type == _FREE].tolist():
        J[:, a : a + 6] = 0.0
    J.flags.writeable = False
    return J


class MinkLimit(Task):
    """A :class:`mink.Limit` as inequality rows ``G x <= h``.

    Args:
        limit: The mink limit, used unchanged.
        dt: Time step handed to ``compute_qp_inequalities`` [s] (velocity limits
            bound ``x`` by ``v_max · dt``).
        name: Display name.
        slack_weight: Slack weight when used below level 0.
        check_margin: Violation tolerated by the stop test, in the rows' units.
    """

    def __init__(
        self,
        limit: mink.Limit,
        dt: float = 1.0,
        name: str | None = None,
        slack_weight: float = 1.0,
        check_margin: float = 1e-5,
    ):
        if not isinstance(limit, mink.Limit):
            raise InvalidInput(f"expected a mink.Limit, got {type(limit).__name__}")
        if not (np.isfinite(dt) and dt > 0):
            raise InvalidInput(f"dt must be a positive finite time [s], got {dt}")
        self.limit = limit
        self.dt = float(dt)
        self.name = name or type(limit).__name__
        self.slack_weight = slack_weight
        self.check_margin = check_margin
        self.check = True
        # lower bounds (-inf) and slack weights of the last row count, reused
        self._bounds: tuple[np.ndarray, np.ndarray] | None = None
        self._G: np.ndarray | None = None
        # a ConfigurationLimit's box rows, made here (None: not a box)
        self._box = _BoxRows.of(limit)
        # box rows: G constant, h from the configuration and the model's ranges
        self.finite_rows = self._box is not None
        if self._box is not None:
            self._bounds = self._bounds_of(self._box.G.shape[0])
            # the rows' constant arrays, all but h, in TaskRows order
            self._box_rows = (
                *no_equality(self._box.G.shape[1]),
                self._box.G,
                self._bounds[0],
            )

    def _bounds_of(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        """Lower bounds (``-inf``) and slack weights of ``m`` rows."""
        return np.full(m, -np.inf), np.full(m, float(self.slack_weight))

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        box = self._box
        if box is None:
            return self._mink_rows(configuration)
        return TaskRows(*self._box_rows, box.h(configuration), self._bounds[1])  # type: ignore[index]

    def _mink_rows(self, configuration: mink.Configuration) -> TaskRows:
        """The rows from ``compute_qp_inequalities``."""
        G, h = self.limit.compute_qp_inequalities(configuration, self.dt)
        nv = configuration.model.nv
        if G is None or h is None:
            return TaskRows.empty(nv)
        G = np.atleast_2d(np.asarray(G, dtype=float))
        h = np.asarray(h, dtype=float).reshape(-1)
        if self._bounds is None or self._bounds[0].shape != h.shape:
            self._bounds = self._bounds_of(h.size)
        lower, weights = self._bounds
        # The same (read-only) G object while its values stay (ConfigurationLimit
        # builds the same matrix every call): users of the rows may cache what
        # they derive from it, and checks of its values need not be repeated.
        held = self._G
        if held is not None and held.shape == G.shape and (held == G).all():
            G = held
        else:
            G.flags.writeable = False
            self._G = G
        A, b, w = no_equality(G.shape[1])
        return TaskRows(A, b, w, G, lower, h, weights)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return self.evaluate(configuration).satisfied

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows once; the error is their violation at ``x = 0`` (``max(-h, 0)``),
        satisfied within ``check_margin``."""
        rows = self.compute_rows(configuration)
        h = rows.d_upper
        if not h.size:
            return TaskState(rows, 0.0, True)
        worst = -float(h.min())
        error = float(np.linalg.norm(np.maximum(-h, 0.0))) if worst > 0 else 0.0
        return TaskState(rows, error, worst <= self.check_margin)

    def __repr__(self) -> str:
        return f"MinkLimit({type(self.limit).__name__}, name={self.name!r}, dt={self.dt})"


class _BoxRows:
    """The rows of a :class:`mink.ConfigurationLimit` without limited ball
    joints, computed as mink computes them but without rebuilding ``G``:

    .. math::

        G = \\begin{bmatrix} P \\\\ -P \\end{bmatrix}, \\qquad
        h = g \\begin{bmatrix} (q_{max} \\ominus q)_I \\\\ (q \\ominus q_{min})_I \\end{bmatrix}

    (``P`` the limit's ``projection_matrix``, ``I`` its ``indices``, ``g`` its
    ``gain``, ``⊖`` MuJoCo's ``mj_differentiatePos``), the same operations in
    the same order, so the same bits (``tests/test_tasks.py`` compares them
    with mink's own at random and out-of-range postures). mink's call rebuilds
    ``[P; -P]`` (2 nv x nv entries) every time; here ``G`` is made once per
    adapter, read-only, so that users of the rows may cache what they derive
    from it.
    """

    def __init__(self, limit: mink.ConfigurationLimit):
        self.limit = limit
        P = limit.projection_matrix
        self.G = np.vstack([P, -P])
        self.G.flags.writeable = False
        nv = limit.model.nv
        # q_max ⊖ q and q ⊖ q_min, one buffer; h takes I from each half at once
        self._dq = np.empty(2 * nv)
        self._dq_max, self._dq_min = self._dq[:nv], self._dq[nv:]
        indices = np.asarray(limit.indices)
        self._rows = np.concatenate([indices, indices + nv])

    @staticmethod
    def of(limit: mink.Limit) -> _BoxRows | None:
        """The box rows of ``limit`` if it is a ConfigurationLimit with limited
        joints and none of them a ball joint (whose rows mink makes otherwise),
        else None."""
        if type(limit) is not mink.ConfigurationLimit or limit.projection_matrix is None:
            return None
        model = limit.model
        ball = (model.jnt_type == int(mujoco.mjtJoint.mjJNT_BALL)) & (model.jnt_limited != 0)
        return None if ball.any() else _BoxRows(limit)

    def h(self, configuration: mink.Configuration) -> np.ndarray:
        """``h`` at ``configuration`` (a new array)."""
        limit = self.limit
        q = configuration.data.qpos
        mujoco.mj_differentiatePos(limit.model, self._dq_max, 1.0, q, limit.upper)
        mujoco.mj_differentiatePos(limit.model, self._dq_min, 1.0, limit.lower, q)
        h = self._dq.take(self._rows)
        h *= limit.gain
        return h


def as_task(item: object, dt: float = 1.0) -> Task:
    """Coerce what a user put in a level into a :class:`Task`.

    Accepts pik_mj tasks, :class:`BaseTask` and :class:`mink.Limit`.
    """
    if isinstance(item, Task):
        return item
    if isinstance(item, BaseTask):
        return MinkTask(item)
    if isinstance(item, mink.Limit):
        return MinkLimit(item, dt=dt)
    raise InvalidInput(
        f"a level holds {type(item).__name__}; valid entries are pik_mj tasks, "
        "mink.Task/BaseTask (equality rows) and mink.Limit (inequality rows)"
    )
