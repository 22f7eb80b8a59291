"""Centre of mass of the robot (prioritized-IK manual: ``cog-task``,
``target-centroid-pos-task``).

The robot's CoM ``p_WG`` is MuJoCo's subtree CoM of the robot's top-level body
``B`` (``data.subtree_com[B]``), so bodies of the environment (a kettle, a
table) do not count; its Jacobian comes from ``mj_jacSubtreeCom``:

.. math::

    p_{WG} = \\frac{1}{M} \\sum_{i \\in \\mathrm{subtree}(B)} m_i\\, p_{W i}, \\qquad
    \\dot p_{WG} = J_{com}\\, \\dot q

:class:`CentroidTask` brings the CoM (plus an optional offset) onto a target,
on the axes selected in a frame ``F``:

.. math::

    e = R_{WF}^T (p_{WG} + o - p_{WT}), \\qquad
    J = R_{WF}^T \\big(J_{com} + [e_W]_\\times J_{\\omega,F}\\big)

(the second term only when ``F`` is a frame of the robot that turns with it).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame, robot_root_body
from pik_mj.inputs import rotation_matrix
from pik_mj.spatial import skew
from pik_mj.tasks.frame import AxisSpec, constrained_axes
from pik_mj.tasks.task import EqualityTask, clamp_norm, diagonal_weights, tolerance, within

Vector3Fn = Callable[[mink.Configuration], Any]


def _body_name(model: mujoco.MjModel, b: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body#{b}"


def com_position(configuration: mink.Configuration, body: int) -> np.ndarray:
    """``p_WG`` [m] of the subtree of ``body``, shape (3,)."""
    return configuration.data.subtree_com[body].copy()


def com_jacobian(configuration: mink.Configuration, body: int) -> np.ndarray:
    """``J_com`` [m per tangent unit] of the subtree of ``body``, shape (3, nv)."""
    J = np.zeros((3, configuration.model.nv))
    mujoco.mj_jacSubtreeCom(configuration.model, configuration.data, J, body)
    return J


def vector3(value: Any, what: str) -> np.ndarray:
    """A finite 3-vector or :class:`InvalidInput`."""
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InvalidInput(f"{what} must be 3 numbers, got {value!r}") from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InvalidInput(f"{what} must be 3 finite numbers [m], got {value!r}")
    return arr


def frame_rotation_option(model: mujoco.MjModel, value: Any, frame_type: str | None):
    """``"world"`` → None, a rotation (3x3, quaternion wxyz, ``mink.SO3``) → 3x3,
    any other string → a :class:`Frame` of the robot."""
    if isinstance(value, str):
        return None if value == "world" else Frame.find(model, value, frame_type)
    return rotation_matrix(value, "frame", "'world', a frame name")


class CentroidTask(EqualityTask):
    """Bring the robot's CoM onto a target position (prioritized-IK manual:
    ``target-centroid-pos-task``).

    Args:
        configuration: Robot configuration.
        target: Target ``p_WT`` [m] (3 numbers, world) or a callable
            ``f(configuration) -> p_WT`` evaluated every iteration.
        root_body: The robot's top-level body (see :func:`robot_root_body`).
        translation_axis: ``cog-translation-axis`` (prioritized-IK manual), in
            irteus' convention (see :func:`~pik_mj.tasks.frame.constrained_axes`):
            naming an axis FREES it. The default ``"z"`` matches x and y and
            leaves the CoM height free.
        frame: ``cog-translation-coords`` (prioritized-IK manual): ``"world"``
            (default), a fixed rotation ``R_WF`` (3x3, quaternion wxyz,
            ``mink.SO3``), or the name of a robot frame (site/body/geom) that
            turns with the robot. Axes, weights and thresholds are expressed in
            it.
        frame_type: Type of a named ``frame`` (None: search).
        w: Weight(s), float or 3-vector in ``frame`` [cost/m²].
        centroid_thre: Stop-test tolerance [m]: a float bounds the norm of the
            matched error, a 3-vector bounds each matched axis.
        p_limit: Largest CoM displacement asked of one iteration [m].
        com_offset: Optional callable ``f(configuration) -> (3,)`` [m] added to the
            CoM (irteus ``centroid-offset-func``, e.g. the balance point under
            external forces). Its own dependence on ``q`` is not differentiated.
        check: Whether the solve loop's stop test looks at this task.
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        target: Any,
        *,
        root_body: str | None = None,
        translation_axis: AxisSpec = "z",
        frame: Any = "world",
        frame_type: str | None = None,
        w: float | np.ndarray = 1.0,
        centroid_thre: float | np.ndarray = 1e-3,
        p_limit: float = 0.1,
        com_offset: Vector3Fn | None = None,
        check: bool = True,
        name: str | None = None,
    ):
        model = configuration.model
        self.root_body = robot_root_body(model, root_body)
        self.root_body_name = _body_name(model, self.root_body)
        self.target_fn: Vector3Fn | None = None
        self.target: np.ndarray | None = None
        self.set_target(target)
        self.rows = constrained_axes(translation_axis, "translation_axis")
        self.frame = frame_rotation_option(model, frame, frame_type)
        self.w = diagonal_weights(w, 3, "w")
        self.k = self.rows.size
        self.weights = self.w[self.rows]
        if not (np.isfinite(p_limit) and p_limit > 0):
            raise InvalidInput(f"p_limit must be a positive finite number [m], got {p_limit}")
        self.p_limit = float(p_limit)
        self.centroid_thre = tolerance(centroid_thre, "centroid_thre", "m")
        if com_offset is not None and not callable(com_offset):
            raise InvalidInput("com_offset must be a callable f(configuration) -> 3-vector")
        self.com_offset = com_offset
        self.check = check
        self.name = name or "centroid"

    def set_target(self, target: Any) -> None:
        """Change the target: a world position [m] or a callable."""
        if callable(target):
            self.target_fn, self.target = target, None
        else:
            self.target_fn, self.target = None, vector3(target, "target")

    def target_now(self, configuration: mink.Configuration) -> np.ndarray:
        """``p_WT`` [m] at the current configuration."""
        if self.target_fn is not None:
            return vector3(self.target_fn(configuration), f"{self.name} target callable")
        assert self.target is not None
        return self.target

    def com(self, configuration: mink.Configuration) -> np.ndarray:
        """``p_WG + o`` [m]: the CoM plus ``com_offset``."""
        c = com_position(configuration, self.root_body)
        if self.com_offset is not None:
            c = c + vector3(self.com_offset(configuration), f"{self.name} com_offset")
        return c

    def _R_WF(self, configuration: mink.Configuration) -> np.ndarray:
        if self.frame is None:
            return np.eye(3)
        if isinstance(self.frame, Frame):
            return self.frame.rotation(configuration.data)
        return self.frame

    def _error_world(self, configuration: mink.Configuration) -> np.ndarray:
        return self.com(configuration) - self.target_now(configuration)

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """Matched components of ``R_WFᵀ (p_WG + o − p_WT)`` [m], unclamped."""
        e_W = self._error_world(configuration)
        return (self._R_WF(configuration).T @ e_W)[self.rows]

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """``d e / d q`` in the tangent space, shape (rows, nv)."""
        J = com_jacobian(configuration, self.root_body)
        if isinstance(self.frame, Frame):
            _, J_w = self.frame.jacobians(configuration.data)
            J = J + skew(self._error_world(configuration)) @ J_w
        return (self._R_WF(configuration).T @ J)[self.rows]

    def clamp(self, e: np.ndarray) -> np.ndarray:
        """``e`` scaled to norm ``p_limit`` if longer (a copy)."""
        return clamp_norm(e.copy(), self.p_limit)

    def satisfied_by(self, e: np.ndarray) -> bool:
        return within(e, self.centroid_thre, self.rows)

    def __repr__(self) -> str:
        frame = (
            "world"
            if self.frame is None
            else (self.frame if isinstance(self.frame, Frame) else "fixed rotation")
        )
        target = "callable" if self.target_fn is not None else np.round(self.target, 4).tolist()
        return (
            f"CentroidTask(name={self.name!r}, root_body={self.root_body_name!r}, target={target}, "
            f"matched_axes={self.rows.tolist()}, frame={frame}, p_limit={self.p_limit})"
        )
