"""irteus ``:inverse-kinematics`` on the priority cascade: move targets onto targets,
the root fixed.

:func:`inverse_kinematics` builds a stack of levels for :func:`pik_mj.solve.solve`
and runs it:

* level 0: the guard level (:func:`pik_mj.robot.stack.guard_level`: joint limits,
  the MJCF couplings, every degree of freedom outside the used chains frozen,
  a floating base included);
* the ``collision_avoidance`` tasks (if any, above the targets);
* the robot kept clear of its world (``avoid_world``, :mod:`pik_mj.ik.world`);
* one frame task per target (irteus manual: ``:move-target``/``:target-coords``);
* look-at (if any); the caller's ``extra_levels``;
* last: posture towards the start (not checked).

Arguments are irteus' (:mod:`pik_mj.ik.arguments`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from pik_mj.callbacks import Callback
from pik_mj.exceptions import InvalidInput
from pik_mj.ik.arguments import (
    Target,
    as_tasks,
    check_model,
    check_solve_options,
    frame_tasks,
    look_at_task,
    parse_extra_levels,
    targets_and_frames,
    used_joints,
)
from pik_mj.ik.world import WorldAvoidance, world_avoidance
from pik_mj.robot import Robot
from pik_mj.robot.stack import guard_level, moving_dofs, posture_task
from pik_mj.solve import SolveResult, solve
from pik_mj.tasks.frame import ONE_DEGREE
from pik_mj.tasks.task import Task


def inverse_kinematics(
    robot: Robot,
    targets: Target | Sequence[Target],
    *,
    move_targets: str | Sequence[str] | None = None,
    limbs: str | Sequence[str] | None = None,
    translation_axis: Any = True,
    rotation_axis: Any = True,
    thre: float | Sequence[float] = 1e-3,
    rthre: float | Sequence[float] = ONE_DEGREE,
    stop: int = 50,
    revert_if_fail: bool = True,
    joints: str | Sequence[str] | None = None,
    look_at: Any = None,
    gaze_axis: Sequence[float] = (1.0, 0.0, 0.0),
    posture_weight: float = 1e-2,
    collision_avoidance: Task | Sequence[Task] = (),
    avoid_world: bool | WorldAvoidance = True,
    extra_levels: Sequence[Sequence[Any]] | None = None,
    callback: Callback | Sequence[Callback] | None = None,
    **solve_kwargs: Any,
) -> SolveResult:
    """irteus ``:inverse-kinematics``: bring move targets onto targets, root fixed.

    Args:
        robot: The robot; its configuration is updated in place (restored on failure
            when ``revert_if_fail``).
        targets: One target or a list: ``mink.SE3``, 4x4 array, ``(p, quat_wxyz)``,
            or a callable (of the robot, or of nothing) returning one, evaluated
            every iteration.
        move_targets: Frame names (site/body/geom) moved onto the targets; default
            the end frames of ``limbs``.
        limbs: Limb names, one per target (e.g. ``"rarm"``). A robot with one limb
            needs neither ``limbs`` nor ``move_targets``.
        translation_axis: irteus axis selection (``True``, ``None``, ``"z"`` frees z,
            ...), one for all or one per target, in the move target's frame.
        rotation_axis: Same for rotation.
        thre: Position tolerance [m], one or per target.
        rthre: Rotation tolerance [rad], one or per target.
        stop: Maximum iterations.
        revert_if_fail: Restore the start configuration when the targets are not met.
        joints: Joints that may move: None (the limbs' joints, or each move
            target's chain from the root when no limbs are given), ``"chain"``
            (the chains from the root), ``"all"``, or a list of joint names.
            Every other degree of freedom — a floating base included — is frozen.
        look_at: Point [m] (3,) or callable returning one: the head limb's end frame
            gazes at it (level 2, best effort, head joints only unless
            ``joints="chain"``).
        gaze_axis: Gaze axis of the head end frame [-].
        posture_weight: Cost of moving away from the start posture, last level
            [cost/rad²].
        collision_avoidance: Tasks of a level above the targets, e.g. a
            :class:`pik_mj.tasks.collision.CollisionAvoidanceTask` (irteus
            ``:collision-avoidance-link-pair``): a target that would need a
            collision is given up, not the clearance (as in
            :func:`fullbody_inverse_kinematics`).
        avoid_world: Keep the moving links clear of the robot's world (the floor,
            a counter, a wall) in a level directly above the targets
            (:mod:`pik_mj.ik.world`): True (default zones), False (off), or a
            :class:`pik_mj.ik.world.WorldAvoidance` (zones, planned contacts).
        extra_levels: Levels inserted before the posture level.
        callback: A per-iteration callback or a list of them (see
            :func:`pik_mj.solve.solve`).
        **solve_kwargs: Passed to :func:`pik_mj.solve.solve` (``min_loop``,
            ``qp_solver``, ...).

    Returns:
        The :class:`pik_mj.solve.SolveResult`.

    Raises:
        InvalidInput: Wrong target types/shapes, mismatched list lengths.
        UnknownName: Unknown limb, joint or frame names, unknown options (valid
            ones listed).
    """
    check_solve_options(inverse_kinematics, solve_kwargs)
    levels = build_levels(
        robot,
        targets,
        move_targets=move_targets,
        limbs=limbs,
        translation_axis=translation_axis,
        rotation_axis=rotation_axis,
        thre=thre,
        rthre=rthre,
        joints=joints,
        look_at=look_at,
        gaze_axis=gaze_axis,
        posture_weight=posture_weight,
        collision_avoidance=collision_avoidance,
        avoid_world=avoid_world,
        extra_levels=extra_levels,
    )
    return solve(
        robot.configuration,
        levels,
        stop=stop,
        revert_if_fail=revert_if_fail,
        callback=callback,
        **solve_kwargs,
    )


def build_levels(
    robot: Robot,
    targets: Any,
    *,
    move_targets: Any,
    limbs: Any,
    translation_axis: Any,
    rotation_axis: Any,
    thre: Any,
    rthre: Any,
    joints: Any,
    look_at: Any,
    gaze_axis: Sequence[float],
    posture_weight: float,
    collision_avoidance: Any,
    avoid_world: Any,
    extra_levels: Any,
) -> list[list[Any]]:
    """The stack of :func:`inverse_kinematics` (module docstring), its arguments checked.

    Raises:
        InvalidInput: Not a robot, nothing to solve, or a bad argument.
        UnknownName: Unknown limb, joint or frame names.
    """
    if not isinstance(robot, Robot):
        raise InvalidInput(f"robot must be a pik_mj.robot.Robot, got {type(robot).__name__}")
    if isinstance(targets, (list, tuple)) and len(targets) == 0:
        if look_at is None:
            raise InvalidInput("targets is empty and there is no look_at: nothing to solve")
        poses, frames, limb_names = [], [], None
        used: set[str] = set() if joints is None else used_joints(robot, joints, [], None)
    else:
        poses, frames, limb_names = targets_and_frames(robot, targets, limbs, move_targets)
        used = used_joints(robot, joints, frames, limb_names)
    if look_at is not None:
        head = robot.limb("head")
        if joints == "chain":
            used |= set(robot.joint_list(head.end_frame, head.end_frame_type))
        elif joints is None:
            used |= set(head.joints)
    levels: list[list[Any]] = [guard_level(robot.configuration, used)]
    avoid = as_tasks(collision_avoidance, "collision_avoidance")
    for i, task in enumerate(avoid):
        check_model(robot, task, f"collision_avoidance[{i}]")
    if avoid:
        levels.append(avoid)
    world = world_avoidance(robot, avoid_world, moving_dofs(robot.model, used))
    if world is not None:
        levels.append([world])
    if frames:
        levels.append(
            list(frame_tasks(robot, frames, poses, translation_axis, rotation_axis, thre, rthre))
        )
    if look_at is not None:
        # The gaze is best effort (irteus) unless it is all there is to solve.
        levels.append([look_at_task(robot, look_at, gaze_axis, check=not frames)])
    levels += parse_extra_levels(robot, extra_levels)
    levels.append([posture_task(robot.configuration, posture_weight)])
    return levels
