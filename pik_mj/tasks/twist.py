"""The twist error of a frame task and its Jacobian, from mink's own tasks.

The body twist from the target frame ``T`` to the move target ``M``:

.. math::

    e = \\log(T_{WT}^{-1} T_{WM})
      = \\big(J_l^{-1}(\\phi)\\, R_{WT}^T (p_{WM} - p_{WT}),\\ \\phi\\big),
    \\qquad \\phi = \\log(R_{WT}^T R_{WM}),

with ``J = J_r^{-1}(e) V``, ``V`` the body twist Jacobian. mink computes both:
``FrameTask`` (a fixed or callable target pose) with the opposite sign,
``log(T_WM⁻¹ T_WT)``, and ``RelativeFrameTask`` (another robot frame as the
target, target pose identity) with this one.
"""

from __future__ import annotations

import math

import mink
import numpy as np

from pik_mj.frames import Frame
from pik_mj.spatial import matrix_to_quat

Pose = tuple[np.ndarray, np.ndarray]
"""``(p_W (3,) [m], R_W (3, 3))``."""


def se3(p: np.ndarray, R: np.ndarray) -> mink.SE3:
    """``mink.SE3`` of ``(p, R)``: the wxyz quaternion of ``R`` by
    ``mju_mat2Quat``, as ``SO3.from_matrix`` makes it (the same bits, without
    an ``SO3`` object)."""
    wxyz_xyz = np.empty(7)
    wxyz_xyz[:4] = matrix_to_quat(R)
    wxyz_xyz[4:] = p
    return mink.SE3(wxyz_xyz)


class Twist:
    """mink's task of one move target's twist error, pointed at the target:
    made once per kind of target and target frame, its target pose set only
    when it changes (a fixed pose once, a callable's pose at each evaluation).

    Args:
        move_target: The robot frame ``M`` that moves.
    """

    def __init__(self, move_target: Frame) -> None:
        self.move_target = move_target
        self.task: mink.FrameTask | mink.RelativeFrameTask | None = None
        self.target: object = None  # the frame or pose the task was pointed at
        self.relative = False

    def toward_frame(self, frame: Frame) -> None:
        """Point at another robot frame (both move): mink's
        ``RelativeFrameTask`` toward the identity."""
        if self.task is None or self.target is not frame:
            M = self.move_target
            task = mink.RelativeFrameTask(
                M.name, M.frame_type, frame.name, frame.frame_type, 1.0, 1.0
            )
            task.set_target(mink.SE3.identity())
            self.task, self.target, self.relative = task, frame, True

    def toward_pose(self, pose: Pose | None) -> None:
        """Point at a pose in the world (None: a callable's, not known yet):
        mink's ``FrameTask``, its target set when ``pose`` is a new object."""
        if self.task is None or self.relative:
            M = self.move_target
            self.task = mink.FrameTask(M.name, M.frame_type, 1.0, 1.0)
            self.target, self.relative = None, False
        if pose is not None and self.target is not pose:
            self.task.set_target(se3(*pose))
            self.target = pose

    def error(
        self, configuration: mink.Configuration, jacobian: bool = True, negated: bool = False
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The twist error ``e`` (6,) toward the target last pointed at, or
        with ``negated`` its negative, and, if asked, its Jacobian (6, nv)
        (new arrays each call)."""
        task = self.task
        assert task is not None  # (pointed at a target first)
        opposite = not self.relative  # mink's FrameTask error is -e
        e = task.compute_error(configuration)
        if opposite != negated:
            np.negative(e, out=e)
        if not jacobian:
            return e, None
        J = task.compute_jacobian(configuration)
        if opposite:
            np.negative(J, out=J)
        return e, J


def twist_distances(
    ux: float, uy: float, uz: float, rx: float, ry: float, rz: float
) -> tuple[float, float]:
    """``(‖p_WM - p_WT‖ [m], θ [rad])`` from the twist ``(ρ, φ)``: ``θ = ‖φ‖``
    and the translation ``J_l(φ) ρ``, with ``J_l(φ) = I + (1 - cos θ)/θ² [φ]×
    + (θ - sin θ)/θ³ [φ]×²`` (series below ``θ = 10^{-2}``); Python floats."""
    theta2 = rx * rx + ry * ry + rz * rz
    if theta2 < 1e-4:
        a, b = 0.5 - theta2 / 24.0, 1.0 / 6.0 - theta2 / 120.0
    else:
        theta = math.sqrt(theta2)
        a = (1.0 - math.cos(theta)) / theta2
        b = (theta - math.sin(theta)) / (theta2 * theta)
    cx, cy, cz = ry * uz - rz * uy, rz * ux - rx * uz, rx * uy - ry * ux  # φ × ρ
    dx, dy, dz = ry * cz - rz * cy, rz * cx - rx * cz, rx * cy - ry * cx  # φ × (φ × ρ)
    px, py, pz = ux + a * cx + b * dx, uy + a * cy + b * dy, uz + a * cz + b * dz
    return math.sqrt(px * px + py * py + pz * pz), math.sqrt(theta2)
