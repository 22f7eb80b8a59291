"""irteus ``:fullbody-inverse-kinematics`` on the priority cascade: feet fixed, the
centroid over the feet, targets reached, the floating base free within bounds.

:func:`fullbody_inverse_kinematics` builds a stack of levels for
:func:`pik_mj.solve.solve` and runs it:

* level 0: the guard level (:func:`pik_mj.robot.stack.guard_level`: joint limits,
  couplings, frozen dofs, the root's six free) and the root's displacement box
  (irteus ``:min``/``:max`` of the root-link virtual joint);
* level 1: feet fixed where they are, the balance task (the centroid over the feet
  on the selected axes, or inside the support polygon) and the
  ``collision_avoidance`` tasks;
* the robot kept clear of its world (``avoid_world``, :mod:`pik_mj.ik.world`);
* then the targets; look-at, ``extra_levels``;
* last: posture and a root-motion cost (irteus ``root-link-virtual-joint-weight``).

Names follow irteus (:mod:`pik_mj.ik.arguments`), plus ``centroid_axes``
(``:cog-translation-axis``), ``target_centroid_pos``, ``centroid_offset``
(``:centroid-offset-func``) and ``external_forces``, whose static balance point
(:func:`pik_mj.ik.measures.static_balance_point`) replaces the centroid.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import mink
import numpy as np

from pik_mj import inputs
from pik_mj.callbacks import Callback
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.ik.arguments import (
    Target,
    as_tasks,
    call_point,
    check_solve_options,
    frame_tasks,
    look_at_task,
    parse_extra_levels,
    root_dofs,
    targets_and_frames,
    used_joints,
)
from pik_mj.ik.measures import parse_forces, static_balance_point
from pik_mj.ik.world import WorldAvoidance, world_avoidance
from pik_mj.robot import Robot
from pik_mj.robot.ground import sole_polygons
from pik_mj.robot.stack import guard_level, moving_dofs, posture_task
from pik_mj.solve import SolveResult, solve
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import ONE_DEGREE, FrameTask, constrained_axes
from pik_mj.tasks.linear import LinearTask
from pik_mj.tasks.support_polygon import SupportPolygonTask
from pik_mj.tasks.task import Task

DEFAULT_ROOT_BOUNDS = (
    np.array([-0.5, -0.5, -0.5, *np.deg2rad([-20.0, -20.0, -10.0])]),
    np.array([0.5, 0.5, 0.025, *np.deg2rad([20.0, 20.0, 10.0])]),
)
"""irteus ``:min``/``:max`` of the root-link virtual joint in SI: displacement of the
root from its start (x, y, z [m]; roll, pitch, yaw [rad])."""

DEFAULT_ROOT_WEIGHT = np.array([0.1, 0.1, 0.1, 0.1, 0.5, 0.5])
"""irteus ``root-link-virtual-joint-weight``: relative freedom of the 6 root dofs."""


def fullbody_inverse_kinematics(
    robot: Robot,
    targets: Target | Sequence[Target],
    *,
    move_targets: str | Sequence[str] | None = None,
    limbs: str | Sequence[str] | None = None,
    translation_axis: Any = True,
    rotation_axis: Any = True,
    thre: float | Sequence[float] = 1e-3,
    rthre: float | Sequence[float] = ONE_DEGREE,
    fix_feet: bool | str | Sequence[str] = ("rleg", "lleg"),
    root_bounds: tuple[Sequence[float], Sequence[float]] | None = DEFAULT_ROOT_BOUNDS,
    root_weight: Sequence[float] = DEFAULT_ROOT_WEIGHT,
    centroid_axes: bool | str | None = "z",
    target_centroid_pos: Any = None,
    centroid_offset: Callable[..., Any] | None = None,
    external_forces: Sequence[tuple[str, Any, Any]] | None = None,
    centroid_thre: float = 1e-3,
    balance: str | Sequence[Task] = "centroid",
    collision_avoidance: Task | Sequence[Task] = (),
    avoid_world: bool | WorldAvoidance = True,
    stop: int = 50,
    revert_if_fail: bool = True,
    joints: str | Sequence[str] | None = None,
    look_at: Any = None,
    gaze_axis: Sequence[float] = (1.0, 0.0, 0.0),
    posture_weight: float = 1e-2,
    extra_levels: Sequence[Sequence[Any]] | None = None,
    callback: Callback | Sequence[Callback] | None = None,
    **solve_kwargs: Any,
) -> SolveResult:
    """irteus ``:fullbody-inverse-kinematics``: feet fixed, centroid over the feet,
    targets reached, the floating base free within ``root_bounds``.

    Arguments shared with :func:`inverse_kinematics` mean the same; ``targets`` are
    the targets besides the feet (may be empty: ``[]``).

    Args:
        fix_feet: Limbs whose end frames stay where they are (level 1); ``True`` =
            ``("rleg", "lleg")``; ``None`` = none.
        root_bounds: ``(lo (6,), hi (6,))`` bounds of the root's displacement from
            its start (x, y, z [m]; roll, pitch, yaw [rad]), hard; None = unbounded.
        root_weight: irteus root-link virtual-joint weight (6,): root dof ``i``
            costs ``posture_weight / root_weight[i]`` per unit step, last level.
        centroid_axes: Axes of the centroid left free (irteus
            ``:cog-translation-axis``, default ``"z"``); None = no centroid task.
        target_centroid_pos: Target [m] (3,) or callable; default: midpoint of the
            fixed feet's end frames at the start.
        centroid_offset: Callable returning the point used instead of the centroid
            (irteus ``:centroid-offset-func``) [m].
        external_forces: ``(frame, force [N], moment [N·m])`` acting on the robot;
            the static balance point replaces the centroid (implies
            ``centroid_offset``).
        centroid_thre: Tolerance on the centroid error [m].
        balance: Level-1 balance task besides the feet: ``"centroid"`` (the
            centroid, or the offset point, over ``target_centroid_pos`` on the
            matched axes), ``"support_polygon"`` (the centroid inside the hull of
            the fixed feet's soles, prioritized-IK manual: ``centroid-support-polygon-task``), or a
            list of tasks (e.g. a :class:`pik_mj.tasks.scfr.ScfrTask`).
        collision_avoidance: Tasks added to level 1 with the feet and the balance
            task, e.g. a :class:`pik_mj.tasks.collision.CollisionAvoidanceTask`
            (irteus ``:collision-avoidance-link-pair``). Above the targets: a
            target that would need a collision is given up, not the clearance.
        avoid_world: Keep the robot clear of its world's geometry (the floor, a
            counter, a wall) in a level directly above the targets
            (:mod:`pik_mj.ik.world`): True (default zones), False (off), or a
            :class:`pik_mj.ik.world.WorldAvoidance` (zones, planned contacts such
            as a hand meant to touch a wall). Contacts the robot makes at the start
            (the feet on the floor) are left to it.

    Raises:
        InvalidInput: No floating base, bad shapes, both ``centroid_offset`` and
            ``external_forces``.
        UnknownName: Unknown limb, joint or frame names.
    """
    if not isinstance(robot, Robot):
        raise InvalidInput(f"robot must be a pik_mj.robot.Robot, got {type(robot).__name__}")
    check_solve_options(fullbody_inverse_kinematics, solve_kwargs)
    if not robot.has_floating_base:
        raise InvalidInput(
            f"fullbody_inverse_kinematics needs a floating base; root body "
            f"{robot.root_body!r} has no free joint (use inverse_kinematics)"
        )
    feet = _feet(robot, fix_feet)
    foot_frames = [
        Frame.find(robot.model, robot.limb(x).end_frame, robot.limb(x).end_frame_type) for x in feet
    ]
    if isinstance(targets, (list, tuple)) and len(targets) == 0:
        poses, frames, limb_names = [], [], None
    else:
        poses, frames, limb_names = targets_and_frames(robot, targets, limbs, move_targets)
    used = _moving_joints(robot, joints, frames, limb_names, feet, look_at)
    level0 = guard_level(robot.configuration, used, root_dofs(robot))
    if root_bounds is not None:
        level0.append(_root_box(robot, *_bounds(root_bounds)))
    weight = _root_weight(root_weight)
    _check_centroid_options(centroid_thre, centroid_offset, centroid_axes)
    if target_centroid_pos is not None and not callable(target_centroid_pos):
        target_centroid_pos = inputs.vector(target_centroid_pos, 3, "target_centroid_pos", unit="m")
    level1 = _foot_tasks(robot, foot_frames)
    level1 += _balance_tasks(
        robot,
        balance,
        feet,
        foot_frames,
        centroid_axes=centroid_axes,
        target_centroid_pos=target_centroid_pos,
        centroid_offset=centroid_offset,
        external_forces=external_forces,
        centroid_thre=centroid_thre,
    )
    level1 += as_tasks(collision_avoidance, "collision_avoidance")
    levels: list[list[Any]] = [level0]
    if level1:
        levels.append(level1)
    world = world_avoidance(robot, avoid_world, moving_dofs(robot.model, used, root_dofs(robot)))
    if world is not None:
        levels.append([world])
    if frames:
        levels.append(
            list(frame_tasks(robot, frames, poses, translation_axis, rotation_axis, thre, rthre))
        )
    if look_at is not None:
        levels.append([look_at_task(robot, look_at, gaze_axis)])
    levels += parse_extra_levels(robot, extra_levels)
    levels.append(
        [
            posture_task(robot.configuration, posture_weight),
            _root_cost(robot, weight, posture_weight),
        ]
    )
    return solve(
        robot.configuration,
        levels,
        stop=stop,
        revert_if_fail=revert_if_fail,
        callback=callback,
        **solve_kwargs,
    )


def _moving_joints(
    robot: Robot,
    joints: Any,
    frames: Sequence[Frame],
    limb_names: Sequence[str] | None,
    feet: Sequence[str],
    look_at: Any,
) -> set[str]:
    """The joints the solve may move: those of the targets' chains
    (:func:`~pik_mj.ik.arguments.used_joints`), the fixed feet's legs, the head's
    with a look-at; every joint for ``joints="all"``."""
    used = used_joints(robot, joints, frames, limb_names) if frames else set()
    for x in feet:
        used |= set(robot.limb(x).joints)
    if look_at is not None:
        used |= set(robot.limb("head").joints)
    if isinstance(joints, str) and joints == "all":
        used = set(robot.joint_names)
    return used


def _bounds(root_bounds: Any) -> tuple[np.ndarray, np.ndarray]:
    """``root_bounds`` as ``(lo (6,), hi (6,))`` [m, rad], checked.

    Raises:
        InvalidInput: Not two 6-vectors with ``lo <= hi``.
    """
    if not isinstance(root_bounds, (list, tuple)) or len(root_bounds) != 2:
        raise InvalidInput(f"root_bounds must be (lo (6,), hi (6,)) or None, got {root_bounds!r}")
    lo = inputs.vector(root_bounds[0], 6, "root_bounds lo", unit="m, rad")
    hi = inputs.vector(root_bounds[1], 6, "root_bounds hi", unit="m, rad")
    if np.any(lo > hi):
        raise InvalidInput(f"root_bounds must have lo <= hi, got lo {lo} > hi {hi}")
    return lo, hi


def _root_weight(root_weight: Any) -> np.ndarray:
    """``root_weight`` as 6 positive numbers.

    Raises:
        InvalidInput: Not 6 finite numbers > 0.
    """
    weight = inputs.vector(root_weight, 6, "root_weight")
    if np.any(weight <= 0):
        raise InvalidInput(f"root_weight must be 6 positive numbers, got {root_weight!r}")
    return weight


def _foot_tasks(robot: Robot, foot_frames: Sequence[Frame]) -> list[Any]:
    """Each fixed foot's end frame held where it is (position and orientation)."""
    return [
        FrameTask(
            robot.configuration,
            f.name,
            (f.position(robot.data), f.rotation(robot.data)),
            move_target_type=f.frame_type,
            name=f"foot:{f.name}",
        )
        for f in foot_frames
    ]


def _check_centroid_options(centroid_thre: Any, centroid_offset: Any, centroid_axes: Any) -> None:
    """Raises InvalidInput for a tolerance <= 0, an offset that is no callable, bad axes."""
    if np.ndim(centroid_thre) == 0:
        inputs.real(centroid_thre, "centroid_thre", unit="m", low=0, low_open=True)
    elif np.any(inputs.vector(centroid_thre, 3, "centroid_thre", unit="m") <= 0):
        raise InvalidInput(f"centroid_thre must be > 0 [m], got {centroid_thre!r}")
    if centroid_offset is not None and not callable(centroid_offset):
        raise InvalidInput(
            f"centroid_offset must be a callable returning a point [m], got {centroid_offset!r}"
        )
    if centroid_axes is not None:
        constrained_axes(centroid_axes, "centroid_axes")


def _balance_tasks(
    robot: Robot,
    balance: Any,
    feet: Sequence[str],
    foot_frames: Sequence[Frame],
    *,
    centroid_axes: Any,
    target_centroid_pos: Any,
    centroid_offset: Callable[..., Any] | None,
    external_forces: Any,
    centroid_thre: Any,
) -> list[Any]:
    """The level-1 balance tasks of :func:`fullbody_inverse_kinematics` (its
    ``balance`` argument): the caller's tasks, the support polygon of the fixed
    feet's soles, or the centroid (or the offset point, or the static balance point
    under ``external_forces``) over ``target_centroid_pos`` (default: the midpoint
    of the fixed feet's end frames).

    Raises:
        InvalidInput: Conflicting options, or balance needing feet when none are fixed.
    """
    if external_forces is not None:
        if centroid_offset is not None:
            raise InvalidInput("give centroid_offset or external_forces, not both")
        parse_forces(robot, external_forces)
        forces = list(external_forces)
        height = (
            float(np.mean([f.position(robot.data)[2] for f in foot_frames])) if foot_frames else 0.0
        )

        def centroid_offset(r: Robot) -> np.ndarray:
            return static_balance_point(r, forces, height)

    if not isinstance(balance, str):
        if centroid_offset is not None:
            raise InvalidInput("centroid_offset/external_forces need balance='centroid'")
        return as_tasks(balance, "balance")
    if balance == "support_polygon":
        if centroid_offset is not None:
            raise InvalidInput("centroid_offset/external_forces need balance='centroid'")
        if not feet:
            raise InvalidInput("balance='support_polygon' needs fixed feet")
        return [
            SupportPolygonTask(
                robot.configuration,
                sole_polygons(robot, tuple(feet)),
                root_body=robot.root_body,
                centroid_thre=centroid_thre,
            )
        ]
    if balance != "centroid":
        raise InvalidInput(
            f"balance {balance!r}: use 'centroid', 'support_polygon' or a list of tasks"
        )
    if centroid_axes is None or centroid_axes is False:
        return []
    if target_centroid_pos is None:
        if not foot_frames:
            raise InvalidInput("target_centroid_pos is needed when no feet are fixed")
        target_centroid_pos = np.mean([f.position(robot.data) for f in foot_frames], axis=0)
    return [
        _centroid_task(robot, target_centroid_pos, centroid_axes, centroid_offset, centroid_thre)
    ]


def _centroid_task(robot: Robot, target: Any, axes: Any, offset: Any, thre: float) -> Task:
    """The centroid over ``target`` on ``axes`` (prioritized-IK manual:
    ``target-centroid-pos-task``); irteus' ``centroid-offset-func`` gives the point
    used instead of the CoM, pik_mj's ``com_offset`` what is added to it."""
    com_offset = None if offset is None else (lambda _c: call_point(offset, robot) - robot.com())
    target_fn = (lambda _c: call_point(target, robot)) if callable(target) else target
    return CentroidTask(
        robot.configuration,
        target_fn,
        root_body=robot.root_body,
        translation_axis=axes,
        centroid_thre=thre,
        com_offset=com_offset,
    )


def _root_box(robot: Robot, lo: np.ndarray, hi: np.ndarray) -> LinearTask:
    """Per-step bounds keeping the root's displacement from its start inside [lo, hi].

    .. math::

        lo - d \\le x_{root} \\le hi - d, \\quad
        d = \\big(p_{WB} - p_{WB_0},\\; \\log(R_{WB_0}^T R_{WB})\\big)
    """
    nv = robot.model.nv
    dofs = root_dofs(robot)
    C = np.zeros((6, nv))
    C[np.arange(6), dofs] = 1.0
    p0, quat0 = robot.root_pose()
    R0 = mink.SO3(quat0)

    def displacement() -> np.ndarray:
        p, quat = robot.root_pose()
        return np.concatenate([p - p0, (R0.inverse() @ mink.SO3(quat)).log()])

    return LinearTask(
        C=C,
        d_lower=lambda _c: lo - displacement(),
        d_upper=lambda _c: hi - displacement(),
        name="root_bounds",
    )


def _root_cost(robot: Robot, weight: np.ndarray, posture_weight: float) -> LinearTask:
    nv = robot.model.nv
    A = np.zeros((6, nv))
    A[np.arange(6), root_dofs(robot)] = 1.0
    return LinearTask(A, np.zeros(6), w_A=posture_weight / weight, name="root_motion", check=False)


def _feet(robot: Robot, fix_feet: Any) -> list[str]:
    if fix_feet is True:
        missing = [x for x in ("rleg", "lleg") if x not in robot.limbs]
        if missing:
            raise InvalidInput(
                f"fix_feet=True needs limbs 'rleg' and 'lleg'; the robot has {list(robot.limbs)}"
            )
        return ["rleg", "lleg"]
    if fix_feet is None or fix_feet is False:
        return []
    feet = [fix_feet] if isinstance(fix_feet, str) else list(inputs.names(fix_feet, "fix_feet"))
    for name in feet:
        robot.limb(name)
    return feet
