"""Gaze task (irteus manual: ``:look-at``, ``:look-at-target``).

A frame ``H`` of the robot (the head: its gaze axis ``a``, a unit vector in
``H``, default ``+x``) is turned so that the axis points at a target point
``p_T``. With ``r = p_T − p_WH`` and ``u = r / ‖r‖`` the unit direction to the
target, the error is the direction seen from the head minus the gaze axis,

.. math::

    e = R_{WH}^T u - a \\in \\mathbb{R}^3, \\qquad \\|e\\| = 2 \\sin(\\theta / 2)

(``θ`` the angle between gaze and target direction; ``e = 0`` only when
looking straight at the target, not away from it). Its Jacobian, with
``J_p``, ``J_ω`` the head's world Jacobians and ``J_T`` the target's (zero for
a fixed point):

.. math::

    J_e = R_{WH}^T \\Big( \\frac{I - u u^T}{\\|r\\|} (J_T - J_{p,H})
          + [u]_\\times J_{\\omega,H} \\Big)

(``d/dt (R^T u) = R^T \\dot u + R^T (u \\times \\omega)``). Each iteration asks
``J_e x = −e`` with ``‖e‖`` clamped to ``2 sin(r_limit / 2)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mink
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.spatial import skew
from pik_mj.tasks.frame import ONE_DEGREE
from pik_mj.tasks.task import EqualityTask, clamp_norm, diagonal_weights


class LookAtTask(EqualityTask):
    """Point a robot frame's gaze axis at a target (irteus manual: ``:look-at``).

    Args:
        configuration: Robot configuration (for name lookup).
        frame: The head frame (site, body or geom name), e.g. ``"head_end"``.
        target: A point (3,) [m], the name of a frame (its origin; may move with
            the robot), or a callable ``f(configuration) -> (3,)``.
        axis: Gaze axis in the head frame (normalized), default ``+x``.
        frame_type: ``"site"``, ``"body"``, ``"geom"`` or None (search).
        target_type: Same for a named target frame.
        weight: Weight(s) of the 3 rows [cost].
        rthre: Stop-test tolerance on the gaze angle [rad] (``rthre``).
        r_limit: Largest gaze rotation asked of one iteration [rad].
        check: Whether the solve loop's stop test looks at this task.
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        frame: str,
        target: Any,
        *,
        axis: Any = (1.0, 0.0, 0.0),
        frame_type: str | None = None,
        target_type: str | None = None,
        weight: float | np.ndarray = 1.0,
        rthre: float = ONE_DEGREE,
        r_limit: float = 0.3,
        check: bool = True,
        name: str | None = None,
    ):
        model = configuration.model
        self.frame = Frame.find(model, frame, frame_type)
        a = np.asarray(axis, dtype=float).reshape(-1)
        if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) < 1e-9:
            raise InvalidInput(f"axis must be a non-zero 3-vector, got {axis!r}")
        self.axis = a / np.linalg.norm(a)
        self.target_frame: Frame | None = None
        self.target_fn: Callable[[mink.Configuration], Any] | None = None
        self.target_point: np.ndarray | None = None
        self.set_target(target, target_type)
        self.weight = diagonal_weights(weight, 3, "weight")
        self.k, self.weights = 3, self.weight
        for label, v in (("rthre", rthre), ("r_limit", r_limit)):
            if not (np.isfinite(v) and v > 0):
                raise InvalidInput(f"{label} must be a positive finite angle [rad], got {v}")
        self.rthre, self.r_limit = float(rthre), float(r_limit)
        self.check = check
        self.name = name or f"look_at:{frame}"

    def set_target(self, target: Any, target_type: str | None = None) -> None:
        """Change the target: a point, a frame name, or a callable."""
        self.target_frame, self.target_fn, self.target_point = None, None, None
        if isinstance(target, str):
            self.target_frame = Frame.find(self.frame.model, target, target_type)
        elif callable(target):
            self.target_fn = target
        else:
            self.target_point = self._point(target, "target")

    @staticmethod
    def _point(value: Any, what: str) -> np.ndarray:
        p = np.asarray(value, dtype=float).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InvalidInput(f"{what} must be a finite point (3,) [m], got {value!r}")
        return p

    def target_position(self, configuration: mink.Configuration) -> np.ndarray:
        """``p_T`` [m] at the current configuration."""
        if self.target_frame is not None:
            return self.target_frame.position(configuration.data)
        if self.target_fn is not None:
            return self._point(self.target_fn(configuration), f"{self.name} target callable")
        assert self.target_point is not None
        return self.target_point

    def _geometry(self, configuration: mink.Configuration):
        data = configuration.data
        p_WH, R_WH = self.frame.position(data), self.frame.rotation(data)
        r = self.target_position(configuration) - p_WH
        dist = float(np.linalg.norm(r))
        if dist < 1e-9:
            raise InvalidInput(f"{self.name}: the target is at the head frame's origin")
        return R_WH, r / dist, dist

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """``e = R_WHᵀ u − a`` (3,), zero when looking at the target."""
        R_WH, u, _ = self._geometry(configuration)
        return R_WH.T @ u - self.axis

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """``d e / d q`` in the tangent space (3, nv)."""
        R_WH, u, dist = self._geometry(configuration)
        J_pH, J_wH = self.frame.jacobians(configuration.data)
        J_T = (
            self.target_frame.jacobians(configuration.data)[0]
            if self.target_frame is not None
            else np.zeros_like(J_pH)
        )
        P = (np.eye(3) - np.outer(u, u)) / dist
        return R_WH.T @ (P @ (J_T - J_pH) + skew(u) @ J_wH)

    def angle(self, configuration: mink.Configuration) -> float:
        """Angle between the gaze axis and the direction to the target [rad]."""
        R_WH, u, _ = self._geometry(configuration)
        return float(np.arccos(np.clip((R_WH @ self.axis) @ u, -1.0, 1.0)))

    def clamp(self, e: np.ndarray) -> np.ndarray:
        """``e`` scaled to norm ``2 sin(r_limit / 2)`` if longer (a copy): the
        chord of a gaze rotation of ``r_limit``."""
        return clamp_norm(e.copy(), 2.0 * np.sin(0.5 * self.r_limit))

    def satisfied_by(self, e: np.ndarray) -> bool:
        """Gaze angle ``θ = 2 asin(‖e‖ / 2)`` within ``rthre``."""
        return 2.0 * np.arcsin(min(0.5 * float(np.linalg.norm(e)), 1.0)) <= self.rthre

    def __repr__(self) -> str:
        target = (
            self.target_frame
            if self.target_frame is not None
            else ("callable" if self.target_fn is not None else self.target_point.tolist())
        )
        return (
            f"LookAtTask(name={self.name!r}, frame={self.frame}, axis={self.axis.tolist()}, "
            f"target={target}, rthre={self.rthre})"
        )
