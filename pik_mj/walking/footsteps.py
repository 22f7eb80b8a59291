"""Footstep planning (irteus manual: ``:go-pos-params->footstep-list``).

The irteus manual's planner moves a mid-feet frame M towards the goal, at most
``forward-offset-length`` / ``outside-offset-length`` / ``rotate-rad`` per step,
and places the swing leg at M shifted sideways by half the foot separation; the
lateral part of the motion is taken only on the steps of the leg on the side of
motion (so the legs never cross), the first swing leg is the one on that side
(or on the side of the turn), and a last step brings the other foot next to it.

Here the goal is reached exactly: with n mid-frame moves of constant increment
:math:`(\\Delta x, \\Delta y_i, \\Delta\\theta)` expressed in the frame of M rotated
by half the turn of that move,

.. math::

    \\psi_i = \\psi_0 + i\\,\\Delta\\theta, \\quad \\Delta\\theta = \\theta / n,

    p_i = p_{i-1} + R(\\psi_{i-1} + \\Delta\\theta/2)\\,
          [\\Delta x,\\ \\lambda_i \\Delta y]^T,

(:math:`\\lambda_i = 1` on the leading leg's steps, else 0), the goal position is
linear in :math:`(\\Delta x, \\Delta y)`; a 2x2 solve gives them, and n is the
smallest count for which every step is within the reach limits
(:func:`relative_step`, :class:`ReachLimits`). When the turn alone carries the
mid frame past the goal's lateral offset (e.g. ``go_pos(0.5, 0.15, 45 deg)``),
:math:`\\Delta y` comes out slightly inward, which ``max_inward`` bounds; if no
count fits with the irteus manual's first leg, the other leg leads at that count.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.walking.gait import Footstep, mid_frame, normalize_feet, wrap_angle

__all__ = [
    "ReachLimits",
    "go_pos",
    "limb_sides",
    "relative_step",
    "straight_steps",
    "violated_reach_limits",
]

LEGS = ("rleg", "lleg")


@dataclass(frozen=True)
class ReachLimits:
    """Reach of one step, in the stance foot frame (defaults: ~1.5 m humanoid).

    A step lands the swing foot at :math:`(\\Delta x, \\Delta y, \\Delta\\psi)` in the
    frame of the foot that supports during that step (:func:`relative_step`).
    With :math:`s = \\pm 1` the side of the swing foot (+1 left) and :math:`w` the
    nominal foot separation it is within reach when

    .. math::

        |\\Delta x| \\le max\\_stride\\_x, \\quad
        -max\\_inward \\le s\\,\\Delta y - w \\le max\\_stride\\_y, \\quad
        |\\Delta\\psi| \\le max\\_turn.

    Attributes:
        max_stride_x: Forward/backward offset between the feet in [m] (the irteus
            manual's ``forward-offset-length``).
        max_stride_y: Sideways widening beyond the nominal separation in [m] (the
            irteus manual's ``outside-offset-length``).
        max_turn: Heading change between the feet in [rad] (``rotate-rad``).
        max_inward: Allowed narrowing below the nominal separation in [m].
    """

    max_stride_x: float = 0.15
    max_stride_y: float = 0.08
    max_turn: float = float(np.deg2rad(30.0))
    max_inward: float = 0.02

    def __post_init__(self) -> None:
        for name in ("max_stride_x", "max_stride_y", "max_turn"):
            value = float(getattr(self, name))
            if not np.isfinite(value) or value <= 0.0:
                raise InvalidInput(f"{name} must be finite and > 0, got {value!r}")
        if not np.isfinite(self.max_inward) or self.max_inward < 0.0:
            raise InvalidInput(f"max_inward must be finite and >= 0, got {self.max_inward}")


def relative_step(stance: Footstep, swing: Footstep) -> tuple[float, float, float]:
    """Landing pose of ``swing`` in the frame of ``stance``.

    .. math::

        [\\Delta x, \\Delta y] = R(\\psi_s)^T (p_w - p_s)_{xy}, \\quad
        \\Delta\\psi = \\mathrm{wrap}(\\psi_w - \\psi_s)

    Returns:
        ``(dx [m], dy [m], dyaw [rad])``.
    """
    d = swing.p_W - stance.p_W
    c, s = np.cos(stance.yaw), np.sin(stance.yaw)
    return (
        float(c * d[0] + s * d[1]),
        float(-s * d[0] + c * d[1]),
        float(wrap_angle(swing.yaw - stance.yaw)),
    )


def limb_sides(feet: Mapping[str, Footstep]) -> dict[str, float]:
    """Side of each foot in the mid-feet frame: +1 left, -1 right.

    Raises:
        InvalidInput: if the feet are not side by side (zero lateral separation).
    """
    p_M, yaw_M = mid_frame(feet)
    e_y = np.array([-np.sin(yaw_M), np.cos(yaw_M), 0.0])
    sides = {}
    for limb, foot in feet.items():
        lateral = float(e_y @ (foot.p_W - p_M))
        if abs(lateral) < 1e-6:
            raise InvalidInput(
                f"foot {limb!r} is not beside the other foot (lateral offset "
                f"{lateral:.2e} m in the mid-feet frame)"
            )
        sides[limb] = float(np.sign(lateral))
    if len(set(sides.values())) != len(sides):
        raise InvalidInput(f"feet must be on opposite sides, got sides {sides}")
    return sides


def violated_reach_limits(
    initial_feet: Mapping[str, Footstep],
    footsteps: Sequence[Footstep],
    limits: ReachLimits,
    foot_separation: float,
    *,
    atol: float = 1e-9,
) -> list[str]:
    """Describe every step of ``footsteps`` that is out of reach (empty if none).

    Each step is measured against the other foot where it stands at that time.
    """
    sides = limb_sides(initial_feet)
    stance = dict(initial_feet)
    problems = []
    for i, step in enumerate(footsteps):
        (other,) = (lb for lb in stance if lb != step.limb)
        dx, dy, dyaw = relative_step(stance[other], step)
        widening = sides[step.limb] * dy - foot_separation
        if abs(dx) > limits.max_stride_x + atol:
            problems.append(f"step {i} ({step.limb}): |dx| = {abs(dx):.4f} m")
        if widening > limits.max_stride_y + atol or widening < -limits.max_inward - atol:
            problems.append(f"step {i} ({step.limb}): widening {widening:.4f} m")
        if abs(dyaw) > limits.max_turn + atol:
            problems.append(f"step {i} ({step.limb}): |dyaw| = {abs(dyaw):.4f} rad")
        stance[step.limb] = step
    return problems


def _placed(limb: str, p_M: np.ndarray, yaw: float, lateral: float) -> Footstep:
    offset = lateral * np.array([-np.sin(yaw), np.cos(yaw), 0.0])
    return Footstep(limb, p_M + offset, yaw)


def _prepare(
    initial_feet: Mapping[str, Footstep | tuple[Sequence[float], float]],
    foot_separation: float | None,
) -> tuple[dict[str, Footstep], dict[str, float], np.ndarray, float, float]:
    feet = normalize_feet(initial_feet, LEGS)
    sides = limb_sides(feet)
    p_M, yaw_M = mid_frame(feet)
    if foot_separation is None:
        e_y = np.array([-np.sin(yaw_M), np.cos(yaw_M), 0.0])
        foot_separation = abs(float(e_y @ (feet["lleg"].p_W - feet["rleg"].p_W)))
    foot_separation = float(foot_separation)
    if not np.isfinite(foot_separation) or foot_separation <= 0.0:
        raise InvalidInput(f"foot_separation must be finite and > 0, got {foot_separation}")
    return feet, sides, p_M, yaw_M, foot_separation


def go_pos(
    x: float,
    y: float,
    theta: float,
    initial_feet: Mapping[str, Footstep | tuple[Sequence[float], float]],
    *,
    max_stride_x: float = 0.15,
    max_stride_y: float = 0.08,
    max_turn: float = float(np.deg2rad(30.0)),
    max_inward: float = 0.02,
    foot_separation: float | None = None,
    max_steps: int = 200,
) -> list[Footstep]:
    """Footsteps that end with both feet side by side at a goal (irteus manual: ``go-pos``).

    Args:
        x: Goal forward in the initial mid-feet frame in [m].
        y: Goal leftward in the initial mid-feet frame in [m].
        theta: Goal heading change (left positive) in [rad], |theta| <= pi.
        initial_feet: Stance of ``"rleg"`` and ``"lleg"``, ``{limb: Footstep |
            (p_W, yaw)}``.
        max_stride_x: See :class:`ReachLimits` [m].
        max_stride_y: See :class:`ReachLimits` [m].
        max_turn: See :class:`ReachLimits` [rad].
        max_inward: See :class:`ReachLimits` [m].
        foot_separation: Lateral distance between the feet at rest in [m];
            defaults to the initial one.
        max_steps: Largest number of mid-frame moves tried.

    Returns:
        The footsteps (for :func:`pik_mj.walking.gait.plan_gait`); empty when the
        goal is the current mid-feet frame. The final two put the feet at
        :math:`p_{goal} \\pm R(\\psi_{goal}) [0, w/2, 0]` with heading
        :math:`\\psi_{goal}`.
    """
    values = np.array([x, y, theta], dtype=float)
    if not np.all(np.isfinite(values)):
        raise InvalidInput(f"go_pos goal (x, y, theta) must be finite, got {values}")
    if abs(theta) > np.pi:
        raise InvalidInput(f"theta must be in [-pi, pi] [rad], got {theta}")
    limits = ReachLimits(max_stride_x, max_stride_y, max_turn, max_inward)
    feet, sides, p_M, yaw_M, sep = _prepare(initial_feet, foot_separation)
    if np.all(np.abs(values) < 1e-12):
        return []
    # As the irteus manual: lead with the leg on the side of the motion, else of
    # the turn; the other leg leads only if no step count within max_steps fits
    # the limits with that choice at that count.
    if abs(y) > 1e-12:
        lead_side = 1.0 if y > 0 else -1.0
    else:
        lead_side = 1.0 if theta > 0 else -1.0
    preferred = next(lb for lb in LEGS if sides[lb] == lead_side)
    leads = (preferred, next(lb for lb in LEGS if lb != preferred))
    for n in range(1, max_steps + 1):
        for lead in leads:
            steps = _go_pos_steps(n, lead, np.array([x, y]), theta, p_M, yaw_M, sides, sep)
            if not violated_reach_limits(feet, steps, limits, sep):
                return steps
    raise InvalidInput(
        f"go_pos({x}, {y}, {theta}) needs more than {max_steps} steps within "
        f"{limits}; raise max_steps or the reach limits"
    )


def _go_pos_steps(
    n: int,
    lead: str,
    goal_M: np.ndarray,
    theta: float,
    p_M: np.ndarray,
    yaw_M: float,
    sides: Mapping[str, float],
    sep: float,
) -> list[Footstep]:
    """Footsteps of n mid-frame moves led by ``lead`` (module docstring)."""
    trail = next(lb for lb in LEGS if lb != lead)
    dtheta = theta / n
    headings = (np.arange(n) + 0.5) * dtheta  # of each move, in the M0 frame
    lead_move = np.arange(n) % 2 == 0
    cols = np.array(
        [
            [np.cos(headings).sum(), -np.sin(headings[lead_move]).sum()],
            [np.sin(headings).sum(), np.cos(headings[lead_move]).sum()],
        ]
    )
    dx, dy = np.linalg.solve(cols, goal_M)
    moves = np.stack(
        [
            np.cos(headings) * dx - np.sin(headings) * dy * lead_move,
            np.sin(headings) * dx + np.cos(headings) * dy * lead_move,
        ],
        axis=1,
    )
    p_M0 = np.cumsum(moves, axis=0)  # mid frame after each move, in M0
    c, s = np.cos(yaw_M), np.sin(yaw_M)
    steps = []
    for i in range(n):
        limb = lead if i % 2 == 0 else trail
        yaw = yaw_M + (i + 1) * dtheta
        p_W = p_M + np.array(
            [c * p_M0[i, 0] - s * p_M0[i, 1], s * p_M0[i, 0] + c * p_M0[i, 1], 0.0]
        )
        steps.append(_placed(limb, p_W, yaw, 0.5 * sep * sides[limb]))
    closing = trail if (n - 1) % 2 == 0 else lead
    steps.append(_placed(closing, p_W, yaw, 0.5 * sep * sides[closing]))
    return steps


def straight_steps(
    n_steps: int,
    stride: float,
    initial_feet: Mapping[str, Footstep | tuple[Sequence[float], float]],
    *,
    first_limb: str = "lleg",
    foot_separation: float | None = None,
) -> list[Footstep]:
    """Walk straight ahead: n advancing steps and one closing step.

    Step i = 1..n puts the alternating swing foot (starting with ``first_limb``)
    at :math:`p_{M_0} + i \\cdot stride \\cdot e_x(\\psi_{M_0})` plus its half
    separation; a final step brings the other foot alongside. With
    ``straight_steps(4, 0.1, feet)`` this is the irteus manual's first walking example
    (lleg +100, rleg +200, lleg +300, rleg +400, lleg +400 [mm]).

    Args:
        n_steps: Number of advancing steps >= 0 (0 returns []).
        stride: Forward advance of each step relative to the other foot in [m]
            (negative walks backwards).
        initial_feet: Stance of ``"rleg"`` and ``"lleg"``.
        first_limb: Limb of the first step.
        foot_separation: Lateral distance between the feet while walking [m]
            (the steps take them there); defaults to the initial one.

    Returns:
        ``n_steps + 1`` footsteps (or none).
    """
    if isinstance(n_steps, bool) or int(n_steps) != n_steps or n_steps < 0:
        raise InvalidInput(f"n_steps must be an integer >= 0, got {n_steps!r}")
    stride = float(stride)
    if not np.isfinite(stride):
        raise InvalidInput(f"stride must be finite [m], got {stride}")
    if first_limb not in LEGS:
        raise UnknownName("limb", first_limb, LEGS)
    _, sides, p_M, yaw_M, sep = _prepare(initial_feet, foot_separation)
    if n_steps == 0:
        return []
    e_x = np.array([np.cos(yaw_M), np.sin(yaw_M), 0.0])
    other = next(lb for lb in LEGS if lb != first_limb)
    steps = []
    for i in range(1, int(n_steps) + 1):
        limb = first_limb if i % 2 == 1 else other
        steps.append(_placed(limb, p_M + i * stride * e_x, yaw_M, 0.5 * sep * sides[limb]))
    closing = other if int(n_steps) % 2 == 1 else first_limb
    steps.append(_placed(closing, p_M + n_steps * stride * e_x, yaw_M, 0.5 * sep * sides[closing]))
    return steps
