"""Static check and physics hold of one pose of a robot rebuilt from its source:
what ``pik-mj validate`` runs on the ``robot`` entry of a run's JSON.

A pose is checked before it is simulated: NaN/inf and zero quaternions are bad
input (:class:`~pik_mj.exceptions.InvalidInput`, the joint named), so is a ``q``
of another length (the pose of another model); joints outside their range
(:func:`joint_limit_violations`) fail the verdict, each named with its excess.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import inputs
from pik_mj.exceptions import UnknownName
from pik_mj.robot import Robot, RobotSource
from pik_mj.sim.criteria import HoldCriteria
from pik_mj.sim.grasp import GraspLike
from pik_mj.sim.hold import HoldReport
from pik_mj.sim.physics import External
from pik_mj.sim.scene import Scene
from pik_mj.sim.static import StaticReport

__all__ = ["JOINT_LIMIT_TOLERANCE", "balance_report", "joint_limit_violations", "validate_pose"]

JOINT_LIMIT_TOLERANCE = 1e-4
"""[rad or m] How far a joint may be past its range before a validated pose
fails: well above the IK's own violations (level 0 holds the limits within the
QP's tolerance), far below anything a servo would notice."""


def joint_limit_violations(
    model: mujoco.MjModel, q: ArrayLike, tolerance: float = JOINT_LIMIT_TOLERANCE
) -> list[dict[str, Any]]:
    """The limited joints of ``model`` that ``q`` puts outside their range.

    A hinge or slide joint is outside when ``q_j < lower - tol`` or
    ``q_j > upper + tol``; a ball joint when its rotation angle
    ``θ = 2 atan2(‖v‖, |w|)`` of its quaternion ``(w, v)`` exceeds its range's
    upper value (MuJoCo's ball limit) by more than ``tol``.

    Returns:
        ``{"joint", "value", "lower", "upper", "excess", "unit"}`` per joint
        outside (``excess`` > 0: how far past the nearer bound; ``unit``: ``"rad"``
        or ``"m"``), in joint order.
    """
    q = np.asarray(q, dtype=float)
    out = []
    for j in np.flatnonzero(model.jnt_limited):
        a = int(model.jnt_qposadr[j])
        lower, upper = (float(x) for x in model.jnt_range[j])
        kind = int(model.jnt_type[j])
        unit = "m" if kind == int(mujoco.mjtJoint.mjJNT_SLIDE) else "rad"
        if kind in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            value = float(q[a])
            excess = max(lower - value, value - upper)
        elif kind == int(mujoco.mjtJoint.mjJNT_BALL):
            w, v = q[a], q[a + 1 : a + 4]
            value = 2.0 * math.atan2(float(np.linalg.norm(v)), abs(float(w)))
            lower, excess = 0.0, value - upper
        else:
            continue
        if excess > tolerance:
            out.append(
                {
                    "joint": inputs.joint_name(model, int(j)),
                    "value": value,
                    "lower": lower,
                    "upper": upper,
                    "excess": excess,
                    "unit": unit,
                }
            )
    return out


def describe_violation(v: Mapping[str, Any]) -> str:
    """One violation of :func:`joint_limit_violations` in words."""
    side = "below" if v["value"] < v["lower"] else "above"
    unit = v.get("unit", "")
    return (
        f"joint {v['joint']!r} at {v['value']:.4g} {unit} is {v['excess']:.4g} {unit} {side} "
        f"its range [{v['lower']:.4g}, {v['upper']:.4g}] {unit}"
    )


def balance_report(
    static: StaticReport, hold: HoldReport | None, robot: Mapping[str, Any] | None = None
) -> dict[str, Any]:
    """``{"robot", "static", "hold", "passed"}``: a pose's static check and hold,
    passed when the pose is in static equilibrium and (if it ran) the hold passed."""
    return {
        "robot": None if robot is None else dict(robot),
        "static": static.to_dict(),
        "hold": None if hold is None else hold.to_dict(),
        "passed": bool(static.feasible and (hold is None or hold.passed)),
    }


def validate_pose(
    source: RobotSource | Mapping[str, Any] | str,
    q: ArrayLike | str | None = None,
    duration: float = 3.0,
    *,
    mu: float | None = None,
    allowed: Sequence[str] | None = None,
    grasps: Sequence[GraspLike] = (),
    external: Sequence[External] = (),
    callback: Any = None,
) -> dict[str, Any]:
    """Static check and physics hold of one pose (for ``pik-mj validate``).

    Args:
        source: The robot's :class:`~pik_mj.robot.RobotSource` (or its
            ``to_dict()``, or a model name / MJCF path).
        q: Robot configuration (the robot's ``nq``; or only its own joints,
            :attr:`~pik_mj.robot.Robot.own_nq`, the environment then at its start),
            the name of one of its keyframes, or None for its start pose.
        duration: Hold duration [s].
        mu: Friction coefficient of the equilibrium LP (None: MuJoCo's).
        allowed: Robot geoms allowed to touch the environment (default: its soles).
        grasps: Objects held by robot frames (see :meth:`Scene.from_robot`).
        external: Wrenches ``(frame, force, moment)`` on the robot in the static
            check and the hold.
        callback: Hold callbacks (e.g. a recorder's ``hold_logger()``).

    Returns:
        :func:`balance_report` with the source under ``"robot"``, the joints
        outside their range under ``"joint_limits"``
        (:func:`joint_limit_violations`; any makes ``passed`` False) and
        ``"checked": "hold"``: a pose alone has no motion to play, so its verdict
        is a hold's, not a validated motion's.

    Raises:
        UnknownName: No such keyframe (or model, site, frame).
        InvalidInput: ``q`` of the wrong length (the pose of another model),
            NaN/inf or beyond :data:`pik_mj.inputs.Q_LIMIT`, or a zero quaternion;
            the joint is named.
    """
    if isinstance(source, str):
        source = RobotSource(source)
    robot = Robot.from_source(source)
    if isinstance(q, str):
        keys = [robot.model.key(k).name for k in range(robot.model.nkey)]
        if q not in keys:
            raise UnknownName("keyframe", q, keys)
        q = robot.model.key(q).qpos
    if q is not None:
        model_name = robot.source.model if robot.source is not None else "the model"
        q = inputs.configuration(
            robot.model, q, f"q (a pose of {str(model_name)!r})", sizes=(robot.own_nq,)
        )
        full = robot.configuration.q.copy()
        full[: len(q)] = q
        robot.configuration.update(full)
    q_robot = robot.configuration.q.copy()
    violations = joint_limit_violations(robot.model, q_robot)
    scene = Scene.from_robot(robot, allowed_contacts=allowed, grasps=grasps)
    static = scene.static_check(q_robot, mu=mu, external=external)
    hold = scene.hold(
        q_robot,
        duration,
        criteria=HoldCriteria(allowed=allowed),
        external=external,
        callback=callback,
    )
    report = balance_report(static, hold, robot.source.to_dict() if robot.source else None)
    report["joint_limits"] = violations
    report["passed"] = bool(report["passed"] and not violations)
    report["checked"] = "hold"
    return report
