"""What irteus computes of a posed robot besides solving: the static balance point
(``:calc-static-balance-point``) and the gaze angle of the head.

The static balance point with external wrenches ``(f_i, n_i)`` at points ``r_i``,
gravity ``M g`` at the centroid ``c`` and the balance point at height ``h``:

.. math::

    p_x = \\frac{M g\\, c_x + \\sum_i \\big[(r_{i,z} - h) f_{i,x} - r_{i,x} f_{i,z} + n_{i,y}\\big]}
               {M g - \\sum_i f_{i,z}}, \\qquad
    p_y = \\frac{M g\\, c_y + \\sum_i \\big[(r_{i,z} - h) f_{i,y} - r_{i,y} f_{i,z} - n_{i,x}\\big]}
               {M g - \\sum_i f_{i,z}}
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from pik_mj import dynamics, inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.robot import Robot


def static_balance_point(
    robot: Robot,
    external_forces: Sequence[tuple[str, Any, Any]],
    height: float,
) -> np.ndarray:
    """irteus ``:calc-static-balance-point``: the point at ``height`` [m] where the
    ground reaction balances gravity and the external wrenches (static extended ZMP).

    Computed by :func:`pik_mj.dynamics.static_balance_point` (formula in the module
    docstring).

    Args:
        robot: The robot (mass, centroid, frame positions).
        external_forces: ``(frame, force [N] (3,), moment [N·m] (3,))`` applied at
            each named frame's origin, world frame.
        height: Height of the balance point (the soles' height) [m].

    Returns:
        ``(p_x, p_y, height)`` [m].
    """
    height = inputs.real(height, "height", unit="m")
    parsed = parse_forces(robot, external_forces)
    return dynamics.static_balance_point(
        robot.mass,
        robot.com(),
        [f for _, f, _ in parsed],
        [n for _, _, n in parsed],
        [frame.position(robot.data) for frame, _, _ in parsed],
        z=float(height),
        gravity=float(np.linalg.norm(robot.model.opt.gravity)),
    )


def parse_forces(robot: Robot, external_forces: Any) -> list[tuple[Frame, np.ndarray, np.ndarray]]:
    """``external_forces`` as ``(frame, force [N] (3,), moment [N·m] (3,))``, each
    frame found in the robot's model.

    Raises:
        InvalidInput: Not a list of ``(name, force, moment)``.
        UnknownName: An unknown frame.
    """
    return [
        (Frame.find(robot.model, name), f, n)
        for name, f, n in inputs.wrenches(external_forces, "external_forces")
    ]


def gaze_angle(robot: Robot, point: Sequence[float], axis: Sequence[float] = (1, 0, 0)) -> float:
    """Angle [rad] between the head end frame's gaze axis and the direction to ``point``.

    .. math::

        \\theta = \\arccos\\big(\\hat a_W \\cdot (p - p_{WH}) / \\|p - p_{WH}\\|\\big)
    """
    head = robot.limb("head")
    X = robot.frame_pose(head.end_frame, head.end_frame_type)
    axis = inputs.vector(axis, 3, "axis")
    if np.linalg.norm(axis) == 0.0:
        raise InvalidInput("axis must be a non-zero 3-vector, got [0, 0, 0]")
    a_W = X.rotation().as_matrix() @ (axis / np.linalg.norm(axis))
    d = inputs.vector(point, 3, "point") - X.translation()
    return float(np.arccos(np.clip(a_W @ d / np.linalg.norm(d), -1.0, 1.0)))
