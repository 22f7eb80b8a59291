"""The gait of legs that sway the CoM on rolling soles (no ankle roll, e.g. Unitree
H1; :mod:`pik_mj.walking.walk_tasks`): shorter, smaller steps, a longer first
stand, and the ZMP reference where the sole's polygon and the ankle's torque
leave the most room.

With both soles flat such legs cannot move the CoM sideways; rolling the soles a
fraction of a degree lets the pelvis roll, and the CoM reaches :math:`r` sideways
(:func:`pik_mj.walking.robot_gait.sideways_reach` with ``rolling_soles``). The
cart-table CoM of a walk whose ZMP alternates between the soles, :math:`\\pm e`
with :math:`e` half the feet's separation, sways in step :math:`T` by
:math:`A = e\\,(1 - 1/\\cosh(T / (2 T_c)))` about the middle (the periodic
solution). The step keeps that sway at :data:`ROLL_SWAY` of the reach, and the
rest of the step is scaled with it:

.. math::

    T = 2 T_c \\operatorname{arccosh} \\frac{1}{1 - \\rho_s r / e}, \\qquad
    \\kappa = T / T_f, \\qquad
    T_{ds} = \\rho_{ds} T, \\qquad s = \\kappa s_f, \\qquad h = \\kappa h_f,
    \\qquad T_0 = T_f - T

(:math:`T_f`, :math:`s_f`, :math:`h_f` the flat-sole gait's step time, stride and
step height; times rounded to the sampling time): the first stand lasts as long
as the flat gait's step, so that the preview control starts the sway from rest
as smoothly as it would there.

**ZMP reference** (:func:`sole_zmp_offsets`): in single support one ankle pitch
joint carries the robot's weight :math:`m g` at the ZMP. Of the sole polygon's
points :math:`c` (its half-planes :math:`a_j^T c + b_j \\ge 0`) where that
ankle's torque :math:`\\tau(c) = m g\\, u^T (c - p_A)` (:math:`u` the horizontal
normal of its axis) stays within :data:`ANKLE_TORQUE_RATIO` of its limit, the
one farthest from the polygon's edges (a linear program):

.. math::

    \\max_{c, \\rho}\\ \\rho \\quad \\text{s.t.} \\quad a_j^T c + b_j \\ge \\rho,
    \\quad |m g\\, u^T (c - p_A)| \\le \\rho_\\tau \\tau_{max}.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import mujoco
import numpy as np
from scipy.optimize import linprog

from pik_mj.balance import convex_hull_2d, halfplanes_from_polygon
from pik_mj.robot import Robot
from pik_mj.robot.ground import Sole
from pik_mj.walking.drive import torque_limits

__all__ = [
    "ANKLE_TORQUE_RATIO",
    "ROLL_DOUBLE_SUPPORT",
    "ROLL_LIFT",
    "ROLL_SWAY",
    "bounded_reach",
    "rolling_values",
    "sole_zmp_offsets",
]

ROLL_SWAY = 0.3
"""ρ_s: the steady CoM sway over the sideways reach with rolling soles."""
ROLL_DOUBLE_SUPPORT = 0.2
"""ρ_ds: double support over step time (the irteus manual's default ratio)."""
ROLL_LIFT = 1e-3
"""[m] The most a rolled sole's polygon may rise at one side (within the softness of
MuJoCo's contacts, so that the whole polygon still carries the robot)."""
ANKLE_TORQUE_RATIO = 0.75
"""ρ_τ: the share of an ankle's torque limit the ZMP reference may ask of it."""


def rolling_values(
    reach: float,
    edge: float,
    tc: float,
    dt: float,
    flat: Mapping[str, float],
    step_time: float | None = None,
) -> dict[str, float]:
    """The values of the rolling-sole gait (module docstring).

    Args:
        reach: r [m], the CoM's sideways reach with rolling soles.
        edge: e [m], half the feet's separation.
        tc: T_c = sqrt(z_c / g) [s].
        dt: Sampling time [s].
        flat: The flat-sole gait's ``step_time`` [s], ``stride`` [m] and
            ``step_height`` [m].
        step_time: T [s] when given instead of derived.

    Returns:
        ``step_time``, ``double_support_time``, ``initial_stand_time`` [s],
        ``stride``, ``step_height`` [m].
    """
    sway = min(ROLL_SWAY * reach, 0.9 * edge)
    step = 2.0 * tc * math.acosh(1.0 / (1.0 - sway / edge))
    if step_time is None:
        step_time = min(dt * max(2, round(step / dt)), flat["step_time"])
    kappa = step_time / flat["step_time"]
    return {
        "step_time": step_time,
        "double_support_time": dt * max(1, round(ROLL_DOUBLE_SUPPORT * step_time / dt)),
        "initial_stand_time": max(flat["step_time"] - step_time, 0.0),
        "stride": kappa * flat["stride"],
        "step_height": kappa * flat["step_height"],
    }


def bounded_reach(reach: float, soles_R: list[np.ndarray], width: float) -> float:
    """The sideways reach [m] of the CoM with the soles' roll bounded: ``reach`` [m]
    found with the soles rolled by :math:`\\psi` (the largest of ``soles_R``, each
    sole frame's rotation (3, 3), roll :math:`\\operatorname{atan2}(R_{21}, R_{22})`),
    scaled to the roll :math:`\\psi_{max}` that lifts a side of a sole ``width`` [m]
    wide by :data:`ROLL_LIFT`. The pelvis roll :math:`\\phi` that moves the CoM
    needs a sole roll of second order in it (module docstring of
    :mod:`pik_mj.walking.walk_tasks`), :math:`\\psi \\propto r^2`:

    .. math::

        \\psi_{max} = \\arcsin(\\ell / w), \\qquad
        r' = r \\min\\left(1, \\sqrt{\\psi_{max} / \\psi}\\right)
    """
    roll = max(abs(math.atan2(R[2, 1], R[2, 2])) for R in soles_R)
    bound = math.asin(min(ROLL_LIFT / width, 1.0))
    return reach * min(1.0, math.sqrt(bound / max(roll, 1e-12)))


def sole_zmp_offsets(
    robot: Robot, soles: Mapping[str, Sole], pitch_axis: float
) -> dict[str, tuple[float, float, float]]:
    """Each sole's ZMP reference point in its sole frame [m] (module docstring),
    in the robot's start pose.

    Args:
        robot: The robot (its start pose is read, its configuration not changed).
        soles: Its soles.
        pitch_axis: |cos| of the angle within which a joint axis counts as
            lateral: each leg's last such joint is its ankle pitch.
    """
    model = robot.model
    data = mujoco.MjData(model)
    data.qpos[:] = robot.start_q()
    mujoco.mj_forward(model, data)
    weight = float(model.body_subtreemass[robot.root_body_id]) * float(
        np.linalg.norm(model.opt.gravity)
    )
    out = {}
    for leg, sole in soles.items():
        p_WS, R_WS = sole.pose(model, data)
        joints = [model.joint(j).id for j in robot.limb(leg).joints]
        joint = [j for j in joints if abs(data.xaxis[j][1]) > pitch_axis][-1]
        anchor = (R_WS.T @ (data.xanchor[joint] - p_WS))[:2]
        axis = R_WS.T @ data.xaxis[joint]
        u = np.array([axis[1], -axis[0]])  # τ(c) = m g u^T (c - p_A)
        limit = float(np.min(np.abs(torque_limits(model, [joint]))))
        hp = halfplanes_from_polygon(convex_hull_2d(sole.outline))
        rows = [np.c_[-np.asarray(hp.A), np.ones(len(hp.b))]]
        bounds = [np.asarray(hp.b)]
        if math.isfinite(limit) and np.linalg.norm(u) > 0:
            reach = ANKLE_TORQUE_RATIO * limit / weight
            rows.append(np.array([[*u, 0.0], [*-u, 0.0]]))
            bounds.append(np.array([reach + u @ anchor, reach - u @ anchor]))
        lp = linprog(
            [0.0, 0.0, -1.0],
            A_ub=np.vstack(rows),
            b_ub=np.concatenate(bounds),
            bounds=[(None, None)] * 3,
        )
        c = lp.x[:2] if lp.status == 0 else np.zeros(2)
        out[leg] = (float(c[0]), float(c[1]), 0.0)
    return out
