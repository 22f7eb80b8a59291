"""irteus' arguments of the inverse-kinematics entry points, turned into tasks and checked.

Names follow irteus: ``targets`` (``target-coords``), ``move_targets``
(``:move-target``), ``limbs`` (``:link-list`` of a limb), ``translation_axis`` /
``rotation_axis`` (naming an axis frees it), ``thre`` [m], ``rthre`` [rad],
``joints`` (the joints a solve may move). A target is a ``mink.SE3``, a 4x4
array, ``(p, quat_wxyz)``, or a callable (of the robot, or of nothing) returning
one; per-target options are one value for all targets or one per target.
Used by :func:`pik_mj.ik.inverse_kinematics` and
:func:`pik_mj.ik.fullbody_inverse_kinematics`.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.robot import Robot
from pik_mj.solve import solve
from pik_mj.tasks.frame import FrameTask, as_pose
from pik_mj.tasks.look_at import LookAtTask
from pik_mj.tasks.mink_adapter import MinkTask
from pik_mj.tasks.task import Task

Target = Any
"""A target pose: ``mink.SE3``, 4x4 array, ``(p, quat_wxyz)``, or a callable
returning one."""


def call_user(fn: Callable[..., Any], robot: Robot) -> Any:
    """Call a user callable with the robot if it takes an argument, else with none."""
    try:
        n = len(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        n = 1
    return fn(robot) if n >= 1 else fn()


def call_point(fn: Callable[..., Any], robot: Robot) -> np.ndarray:
    """A user callable's point [m] (3,) (:func:`call_user`), checked."""
    return inputs.vector(call_user(fn, robot), 3, "callable result")


def look_at_task(robot: Robot, point: Any, axis: Sequence[float], check: bool = False) -> Task:
    """irteus ``:look-at``: the head limb's end frame gazes at ``point``."""
    head = robot.limb("head")
    target = (lambda _c: call_point(point, robot)) if callable(point) else point
    return LookAtTask(
        robot.configuration,
        head.end_frame,
        target,
        axis=axis,
        frame_type=head.end_frame_type,
        check=check,
        name="look_at",
    )


def _is_single_target(t: Any) -> bool:
    if isinstance(t, mink.SE3) or callable(t):
        return True
    if isinstance(t, np.ndarray) and t.shape == (4, 4):
        return True
    if isinstance(t, tuple) and len(t) == 2:
        try:
            return np.shape(t[0]) == (3,) and np.shape(t[1]) in ((4,), (3, 3))
        except ValueError:
            return False
    return False


def per_target(value: Any, n: int, what: str, single: Callable[[Any], bool]) -> list[Any]:
    """A per-target option: one value for all, or a list of ``n``."""
    if single(value):
        return [value] * n
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise InvalidInput(f"{what} must be one value or a list of {n} (one per target)")
    return list(value)


def _axis_single(v: Any) -> bool:
    return v is None or isinstance(v, (bool, str))


def _float_single(v: Any) -> bool:
    return np.ndim(v) == 0


def parse_targets(robot: Robot, targets: Any) -> list[Any]:
    """``targets`` (one or a list) as ``(p (3,), R (3, 3))`` poses, a callable
    wrapped into a function of the configuration returning one.

    Raises:
        InvalidInput: Not a pose, a callable or a list of those; a bad pose.
    """
    if _is_single_target(targets):
        targets = [targets]
    if not isinstance(targets, (list, tuple)):
        raise InvalidInput(
            "targets must be a pose (mink.SE3, 4x4 array, (p, quat_wxyz)), a callable "
            f"returning one, or a list of those; got {type(targets).__name__}"
        )
    out = []
    for i, t in enumerate(targets):
        if callable(t) and not isinstance(t, mink.SE3):
            out.append(_wrap_callable(t, robot, i))
        else:
            if isinstance(t, tuple) and len(t) == 2 and np.shape(t[1]) == (4,):
                t = (t[0], inputs.quaternion(t[1], f"targets[{i}] orientation"))
            out.append(as_pose(t, f"targets[{i}]"))
    return out


def _wrap_callable(fn: Callable[..., Any], robot: Robot, i: int) -> Callable[[Any], Any]:
    def target(_configuration: mink.Configuration) -> Any:
        return as_pose(call_user(fn, robot), f"targets[{i}] callable result")

    return target


def parse_limbs(robot: Robot, limbs: Any, n: int) -> list[str] | None:
    """``limbs`` (a name or one per target, ``n`` targets) as a list, or None.

    Raises:
        UnknownName: A limb the robot does not have.
        InvalidInput: Not ``n`` limbs.
    """
    if limbs is None:
        return None
    limbs = [limbs] if isinstance(limbs, str) else list(inputs.names(limbs, "limbs"))
    for name in limbs:
        robot.limb(name)  # UnknownName lists the robot's limbs
    if len(limbs) != n:
        raise InvalidInput(f"{len(limbs)} limbs {limbs} for {n} targets; give one per target")
    return limbs


def move_frames(robot: Robot, move_targets: Any, limbs: list[str] | None, n: int) -> list[Frame]:
    """The frames moved onto the ``n`` targets: ``move_targets`` by name, else the
    end frames of ``limbs`` (of the robot's only limb when it has one).

    Raises:
        InvalidInput: Neither given (and more than one limb), or not ``n`` of them.
        UnknownName: An unknown frame.
    """
    if move_targets is None:
        if limbs is None:
            if len(robot.limbs) == 1 and n == 1:
                limbs = list(robot.limbs)
            else:
                raise InvalidInput(
                    "give limbs=[...] or move_targets=[...] (one per target); "
                    f"the robot's limbs are {list(robot.limbs)}"
                )
        return [
            Frame.find(robot.model, robot.limb(x).end_frame, robot.limb(x).end_frame_type)
            for x in limbs
        ]
    names = (
        [move_targets]
        if isinstance(move_targets, str)
        else list(inputs.names(move_targets, "move_targets"))
    )
    if len(names) != n:
        raise InvalidInput(f"{len(names)} move_targets for {n} targets; give one per target")
    return [Frame.find(robot.model, m) for m in names]


def targets_and_frames(
    robot: Robot, targets: Any, limbs: Any, move_targets: Any
) -> tuple[list[Any], list[Frame], list[str] | None]:
    """The parsed targets (:func:`parse_targets`), the limbs (one per target, or None)
    and the frames moved onto them (:func:`move_frames`)."""
    poses = parse_targets(robot, targets)
    limb_names = parse_limbs(robot, limbs, len(poses))
    return poses, move_frames(robot, move_targets, limb_names, len(poses)), limb_names


def _chain_joints(robot: Robot, frame: Frame) -> list[str]:
    return robot.joint_list(frame.name, frame.frame_type)


def used_joints(
    robot: Robot,
    joints: Any,
    frames: Sequence[Frame],
    limbs: Sequence[str] | None,
) -> set[str]:
    """Joint names the solve may move (irteus ``:link-list``)."""
    if isinstance(joints, str):
        if joints == "all":
            return set(robot.joint_names)
        if joints != "chain":
            raise InvalidInput(f"joints {joints!r}: use None, 'chain', 'all' or a list of names")
        return {j for f in frames for j in _chain_joints(robot, f)}
    if joints is not None:
        names = list(inputs.names(joints, "joints"))
        robot.angle_vector(names)  # UnknownName / InvalidInput for bad names
        return set(names)
    used: set[str] = set()
    for i, f in enumerate(frames):
        used |= set(robot.limb(limbs[i]).joints) if limbs else set(_chain_joints(robot, f))
    return used


def root_dofs(robot: Robot) -> np.ndarray:
    """Tangent-space indices (6,) of the root body's free joint."""
    j = robot.model.body_jntadr[robot.root_body_id]
    return int(robot.model.jnt_dofadr[j]) + np.arange(6)


def frame_tasks(
    robot: Robot,
    frames: Sequence[Frame],
    targets: Sequence[Any],
    translation_axis: Any,
    rotation_axis: Any,
    thre: Any,
    rthre: Any,
) -> list[FrameTask]:
    """One :class:`~pik_mj.tasks.frame.FrameTask` per frame onto its target, with the
    per-target axes (irteus: naming an axis frees it) and tolerances ``thre`` [m],
    ``rthre`` [rad].

    Raises:
        InvalidInput: A per-target option of the wrong length, a tolerance <= 0.
    """
    n = len(frames)
    t_axes = per_target(translation_axis, n, "translation_axis", _axis_single)
    r_axes = per_target(rotation_axis, n, "rotation_axis", _axis_single)
    thres = [
        inputs.real(v, f"thre[{i}]" if n > 1 else "thre", unit="m", low=0, low_open=True)
        for i, v in enumerate(per_target(thre, n, "thre", _float_single))
    ]
    rthres = [
        inputs.real(v, f"rthre[{i}]" if n > 1 else "rthre", unit="rad", low=0, low_open=True)
        for i, v in enumerate(per_target(rthre, n, "rthre", _float_single))
    ]
    return [
        FrameTask(
            robot.configuration,
            f.name,
            targets[i],
            move_target_type=f.frame_type,
            translation_axis=t_axes[i],
            rotation_axis=r_axes[i],
            thre=thres[i],
            rthre=rthres[i],
            name=f"target:{f.name}",
        )
        for i, f in enumerate(frames)
    ]


def check_solve_options(function: Callable[..., Any], options: dict[str, Any]) -> None:
    """``options`` (the wrapper's ``**solve_kwargs``) are :func:`pik_mj.solve.solve`'s.

    Raises:
        UnknownName: An option neither ``function`` nor ``solve`` has (lists them).
    """
    inputs.options(
        options,
        function,
        f"{function.__name__} option",
        also=solve,
        positional=("robot", "targets", "configuration", "levels"),
    )


def parse_extra_levels(robot: Robot, extra_levels: Any) -> list[list[Any]]:
    """The caller's ``extra_levels`` (lists of tasks) as lists, each task checked
    with :func:`check_model`; ``[]`` for None.

    Raises:
        InvalidInput: Not a list of lists, or a task made for another model.
    """
    if extra_levels is None:
        return []
    if not isinstance(extra_levels, (list, tuple)) or not all(
        isinstance(level, (list, tuple)) for level in extra_levels
    ):
        raise InvalidInput("extra_levels must be a list of lists of tasks")
    for k, level in enumerate(extra_levels):
        for i, task in enumerate(level):
            check_model(robot, task, f"extra_levels[{k}][{i}]")
    return [list(level) for level in extra_levels]


def check_model(robot: Robot, task: Any, where: str) -> None:
    """A mink task or limit made for another model (a posture task's ``nq``, a
    limit's ``model``) named as such, before mink fails on its shapes."""
    inner = task.task if isinstance(task, MinkTask) else task
    model = getattr(inner, "model", None)
    nq = model.nq if isinstance(model, mujoco.MjModel) else getattr(inner, "nq", None)
    nv = model.nv if isinstance(model, mujoco.MjModel) else getattr(inner, "k", None)
    if isinstance(nq, int) and (nq, nv) != (robot.model.nq, robot.model.nv):
        raise InvalidInput(
            f"{where}: {type(inner).__name__} was made for a model with nq={nq}, nv={nv}, but "
            f"the robot has nq={robot.model.nq}, nv={robot.model.nv}; make it from robot.model"
        )


def as_tasks(value: Any, what: str) -> list[Any]:
    """A task (pik_mj or mink) or a list/tuple of tasks, as a list."""
    if isinstance(value, (Task, mink.Task)):
        return [value]
    if not isinstance(value, (list, tuple)) or not all(
        isinstance(t, (Task, mink.Task)) for t in value
    ):
        raise InvalidInput(f"{what} must be a task or a list of tasks, got {value!r}")
    return list(value)
