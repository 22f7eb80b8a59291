"""irteus' inverse-kinematics API on the priority cascade (seed 001 ``:inverse-kinematics``,
``:fullbody-inverse-kinematics``).

Both functions build a stack of levels for :func:`pik_mj.solve.solve` and run it:

* :func:`inverse_kinematics` — level 0: joint limits, the MJCF couplings
  (:class:`~pik_mj.robot.couplings.CouplingTask`, when the model has any), and every
  degree of freedom outside the used chains frozen (hard ``x_i = 0``; a floating base stays where it
  is); then the ``collision_avoidance`` tasks (if any, above the targets); one
  frame task per target; look-at (if any); the caller's ``extra_levels``; last:
  posture towards the start (not checked).
* :func:`fullbody_inverse_kinematics` — level 0: joint limits, couplings, frozen dofs and the
  root's displacement box (irteus ``:min``/``:max`` of the root-link virtual joint);
  level 1: feet fixed where they are, the centroid over the feet on the
  selected axes and the ``collision_avoidance`` tasks; level 2: the targets;
  then look-at, ``extra_levels``; last: posture and a root-motion cost (irteus
  ``root-link-virtual-joint-weight``).

Names follow irteus: ``targets`` (``target-coords``), ``move_targets``
(``:move-target``), ``limbs`` (``:link-list`` of a limb), ``translation_axis`` /
``rotation_axis`` (naming an axis frees it), ``thre`` [m], ``rthre`` [rad],
``stop``, ``revert_if_fail``, ``centroid_axes`` (``:cog-translation-axis``),
``target_centroid_pos``, ``centroid_offset`` (``:centroid-offset-func``). The
static balance point of ``:calc-static-balance-point`` with external wrenches
``(f_i, n_i)`` at points ``r_i``, gravity ``M g`` at the centroid ``c`` and the
balance point at height ``h``:

.. math::

    p_x = \\frac{M g\\, c_x + \\sum_i \\big[(r_{i,z} - h) f_{i,x} - r_{i,x} f_{i,z} + n_{i,y}\\big]}
               {M g - \\sum_i f_{i,z}}, \\qquad
    p_y = \\frac{M g\\, c_y + \\sum_i \\big[(r_{i,z} - h) f_{i,y} - r_{i,y} f_{i,z} - n_{i,x}\\big]}
               {M g - \\sum_i f_{i,z}}
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj import dynamics, inputs
from pik_mj.callbacks import Callback
from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.robot import Robot
from pik_mj.robot.couplings import CouplingTask, find_couplings
from pik_mj.robot.ground import sole_polygons
from pik_mj.solve import SolveResult, solve
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import ONE_DEGREE, FrameTask, as_pose, constrained_axes
from pik_mj.tasks.joint_limit import JointLimitTask
from pik_mj.tasks.linear import LinearTask
from pik_mj.tasks.look_at import LookAtTask
from pik_mj.tasks.mink_adapter import MinkTask
from pik_mj.tasks.support_polygon import SupportPolygonTask
from pik_mj.tasks.task import Task

__all__ = [
    "DEFAULT_ROOT_BOUNDS",
    "DEFAULT_ROOT_WEIGHT",
    "fullbody_inverse_kinematics",
    "gaze_angle",
    "inverse_kinematics",
    "static_balance_point",
]

DEFAULT_ROOT_BOUNDS = (
    np.array([-0.5, -0.5, -0.5, *np.deg2rad([-20.0, -20.0, -10.0])]),
    np.array([0.5, 0.5, 0.025, *np.deg2rad([20.0, 20.0, 10.0])]),
)
"""irteus ``:min``/``:max`` of the root-link virtual joint in SI: displacement of the
root from its start (x, y, z [m]; roll, pitch, yaw [rad])."""

DEFAULT_ROOT_WEIGHT = np.array([0.1, 0.1, 0.1, 0.1, 0.5, 0.5])
"""irteus ``root-link-virtual-joint-weight``: relative freedom of the 6 root dofs."""

Target = Any  # mink.SE3 | 4x4 array | (p, quat_wxyz) | callable -> one of these


# ---------------------------------------------------------------------------
# The seed's tasks used here, each made by one factory (`_limits`,
# `_centroid_task`, `_look_at_task`): pik_mj.tasks.joint_limit, .com, .look_at.


def _call_user(fn: Callable[..., Any], robot: Robot) -> Any:
    """Call a user callable with the robot if it takes an argument, else with none."""
    try:
        n = len(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        n = 1
    return fn(robot) if n >= 1 else fn()


def _vector3(value: Any, what: str) -> np.ndarray:
    return inputs.vector(value, 3, what)


def _centroid_task(robot: Robot, target: Any, axes: Any, offset: Any, thre: float) -> Task:
    """Seed ``target-centroid-pos-task``; irteus' ``centroid-offset-func`` gives the
    point used instead of the CoM, pik_mj's ``com_offset`` what is added to it."""
    com_offset = None if offset is None else (lambda _c: _call_point(offset, robot) - robot.com())
    target_fn = (lambda _c: _call_point(target, robot)) if callable(target) else target
    return CentroidTask(
        robot.configuration,
        target_fn,
        root_body=robot.root_body,
        translation_axis=axes,
        centroid_thre=thre,
        com_offset=com_offset,
    )


def _look_at_task(robot: Robot, point: Any, axis: Sequence[float], check: bool = False) -> Task:
    """irteus ``:look-at``: the head limb's end frame gazes at ``point``."""
    head = robot.limb("head")
    target = (lambda _c: _call_point(point, robot)) if callable(point) else point
    return LookAtTask(
        robot.configuration,
        head.end_frame,
        target,
        axis=axis,
        frame_type=head.end_frame_type,
        check=check,
        name="look_at",
    )


def _call_point(fn: Callable[..., Any], robot: Robot) -> np.ndarray:
    return _vector3(_call_user(fn, robot), "callable result")


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
    parsed = _parse_forces(robot, external_forces)
    return dynamics.static_balance_point(
        robot.mass,
        robot.com(),
        [f for _, f, _ in parsed],
        [n for _, _, n in parsed],
        [frame.position(robot.data) for frame, _, _ in parsed],
        z=float(height),
        gravity=float(np.linalg.norm(robot.model.opt.gravity)),
    )


def _parse_forces(robot: Robot, external_forces: Any) -> list[tuple[Frame, np.ndarray, np.ndarray]]:
    return [
        (Frame.find(robot.model, name), f, n)
        for name, f, n in inputs.wrenches(external_forces, "external_forces")
    ]


# ---------------------------------------------------------------------------
# Input parsing


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


def _as_list(value: Any, n: int, what: str, single: Callable[[Any], bool]) -> list[Any]:
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


def _parse_targets(robot: Robot, targets: Any) -> list[Any]:
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
        return as_pose(_call_user(fn, robot), f"targets[{i}] callable result")

    return target


def _parse_limbs(robot: Robot, limbs: Any, n: int) -> list[str] | None:
    if limbs is None:
        return None
    limbs = [limbs] if isinstance(limbs, str) else list(inputs.names(limbs, "limbs"))
    for name in limbs:
        robot.limb(name)  # UnknownName lists the robot's limbs
    if len(limbs) != n:
        raise InvalidInput(f"{len(limbs)} limbs {limbs} for {n} targets; give one per target")
    return limbs


def _move_frames(robot: Robot, move_targets: Any, limbs: list[str] | None, n: int) -> list[Frame]:
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


def _chain_joints(robot: Robot, frame: Frame) -> list[str]:
    return robot.joint_list(frame.name, frame.frame_type)


def _used_joints(
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


def _dofs_of(robot: Robot, joint_names: set[str], with_root: bool) -> np.ndarray:
    model = robot.model
    dofs = [int(model.jnt_dofadr[model.joint(j).id]) for j in joint_names]
    if with_root:
        dofs += _root_dofs(robot).tolist()
    return np.array(sorted(dofs), dtype=int)


def _root_dofs(robot: Robot) -> np.ndarray:
    j = robot.model.body_jntadr[robot.root_body_id]
    return int(robot.model.jnt_dofadr[j]) + np.arange(6)


def _freeze_task(robot: Robot, moving: np.ndarray) -> LinearTask | None:
    nv = robot.model.nv
    frozen = np.setdiff1d(np.arange(nv), moving)
    if frozen.size == 0:
        return None
    A = np.zeros((frozen.size, nv))
    A[np.arange(frozen.size), frozen] = 1.0
    return LinearTask(A, np.zeros(frozen.size), name="frozen_dofs")


def _posture_task(robot: Robot, weight: float) -> MinkTask:
    weight = inputs.real(weight, "posture_weight", unit="cost/rad²", low=0)
    posture = mink.PostureTask(robot.model, cost=weight)
    posture.set_target_from_configuration(robot.configuration)
    return MinkTask(posture, name="posture", check=False)


def _frame_tasks(
    robot: Robot,
    frames: Sequence[Frame],
    targets: Sequence[Any],
    translation_axis: Any,
    rotation_axis: Any,
    thre: Any,
    rthre: Any,
) -> list[FrameTask]:
    n = len(frames)
    t_axes = _as_list(translation_axis, n, "translation_axis", _axis_single)
    r_axes = _as_list(rotation_axis, n, "rotation_axis", _axis_single)
    thres = [
        inputs.real(v, f"thre[{i}]" if n > 1 else "thre", unit="m", low=0, low_open=True)
        for i, v in enumerate(_as_list(thre, n, "thre", _float_single))
    ]
    rthres = [
        inputs.real(v, f"rthre[{i}]" if n > 1 else "rthre", unit="rad", low=0, low_open=True)
        for i, v in enumerate(_as_list(rthre, n, "rthre", _float_single))
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


def _check_solve_options(function: Callable[..., Any], options: dict[str, Any]) -> None:
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


def _extra(robot: Robot, extra_levels: Any) -> list[list[Any]]:
    if extra_levels is None:
        return []
    if not isinstance(extra_levels, (list, tuple)) or not all(
        isinstance(level, (list, tuple)) for level in extra_levels
    ):
        raise InvalidInput("extra_levels must be a list of lists of tasks")
    for k, level in enumerate(extra_levels):
        for i, task in enumerate(level):
            _check_model(robot, task, f"extra_levels[{k}][{i}]")
    return [list(level) for level in extra_levels]


def _check_model(robot: Robot, task: Any, where: str) -> None:
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


def _tasks(value: Any, what: str) -> list[Any]:
    """A task (pik_mj or mink) or a list/tuple of tasks, as a list."""
    if isinstance(value, (Task, mink.Task)):
        return [value]
    if not isinstance(value, (list, tuple)) or not all(
        isinstance(t, (Task, mink.Task)) for t in value
    ):
        raise InvalidInput(f"{what} must be a task or a list of tasks, got {value!r}")
    return list(value)


def _couplings(robot: Robot, used: set[str]) -> tuple[list[Task], set[str]]:
    """The model's MJCF couplings as a :class:`~pik_mj.robot.couplings.CouplingTask` (none
    without any), and ``used`` grown by every joint coupled to a used one: a
    coupled joint moves with its partner, it is not frozen."""
    found = find_couplings(robot.model).couplings
    if not found:
        return [], used
    model = robot.model
    groups = [
        {
            model.joint(int(model.dof_jntid[d])).name
            for c in (coupling.y, coupling.x)
            if c is not None
            for d in c.dofadr
        }
        for coupling in found
    ]
    used = set(used)
    grown = True
    while grown:
        grown = False
        for group in groups:
            if group & used and not group <= used:
                used |= group
                grown = True
    return [CouplingTask(robot.configuration, found)], used


def _limits(robot: Robot) -> Task:
    """Seed ``minmax-angle-task`` on every limited joint, hard at level 0."""
    return JointLimitTask.all_limited(robot.configuration)


# ---------------------------------------------------------------------------
# The two entry points


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
    _check_solve_options(inverse_kinematics, solve_kwargs)
    levels = _build_ik_levels(
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


def _build_ik_levels(
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
    extra_levels: Any,
) -> list[list[Any]]:
    if not isinstance(robot, Robot):
        raise InvalidInput(f"robot must be a pik_mj.robot.Robot, got {type(robot).__name__}")
    if isinstance(targets, (list, tuple)) and len(targets) == 0:
        if look_at is None:
            raise InvalidInput("targets is empty and there is no look_at: nothing to solve")
        poses, frames, limb_names = [], [], None
        used: set[str] = set() if joints is None else _used_joints(robot, joints, [], None)
    else:
        poses = _parse_targets(robot, targets)
        limb_names = _parse_limbs(robot, limbs, len(poses))
        frames = _move_frames(robot, move_targets, limb_names, len(poses))
        used = _used_joints(robot, joints, frames, limb_names)
    if look_at is not None:
        head = robot.limb("head")
        if joints == "chain":
            used |= set(robot.joint_list(head.end_frame, head.end_frame_type))
        elif joints is None:
            used |= set(head.joints)
    couplings, used = _couplings(robot, used)
    level0: list[Any] = [_limits(robot), *couplings]
    freeze = _freeze_task(robot, _dofs_of(robot, used, with_root=False))
    if freeze is not None:
        level0.append(freeze)
    levels: list[list[Any]] = [level0]
    avoid = _tasks(collision_avoidance, "collision_avoidance")
    for i, task in enumerate(avoid):
        _check_model(robot, task, f"collision_avoidance[{i}]")
    if avoid:
        levels.append(avoid)
    if frames:
        levels.append(
            list(_frame_tasks(robot, frames, poses, translation_axis, rotation_axis, thre, rthre))
        )
    if look_at is not None:
        # The gaze is best effort (irteus) unless it is all there is to solve.
        levels.append([_look_at_task(robot, look_at, gaze_axis, check=not frames)])
    levels += _extra(robot, extra_levels)
    levels.append([_posture_task(robot, posture_weight)])
    return levels


def _root_box(robot: Robot, lo: np.ndarray, hi: np.ndarray) -> LinearTask:
    """Per-step bounds keeping the root's displacement from its start inside [lo, hi].

    .. math::

        lo - d \\le x_{root} \\le hi - d, \\quad
        d = \\big(p_{WB} - p_{WB_0},\\; \\log(R_{WB_0}^T R_{WB})\\big)
    """
    nv = robot.model.nv
    dofs = _root_dofs(robot)
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
    A[np.arange(6), _root_dofs(robot)] = 1.0
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
            the fixed feet's soles, seed ``centroid-support-polygon-task``), or a
            list of tasks (e.g. a :class:`pik_mj.tasks.scfr.ScfrTask`).
        collision_avoidance: Tasks added to level 1 with the feet and the balance
            task, e.g. a :class:`pik_mj.tasks.collision.CollisionAvoidanceTask`
            (irteus ``:collision-avoidance-link-pair``). Above the targets: a
            target that would need a collision is given up, not the clearance.

    Raises:
        InvalidInput: No floating base, bad shapes, both ``centroid_offset`` and
            ``external_forces``.
        UnknownName: Unknown limb, joint or frame names.
    """
    if not isinstance(robot, Robot):
        raise InvalidInput(f"robot must be a pik_mj.robot.Robot, got {type(robot).__name__}")
    _check_solve_options(fullbody_inverse_kinematics, solve_kwargs)
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
        poses, frames, limb_names = [], [], []
    else:
        poses = _parse_targets(robot, targets)
        limb_names = _parse_limbs(robot, limbs, len(poses))
        frames = _move_frames(robot, move_targets, limb_names, len(poses))
    used = _used_joints(robot, joints, frames, limb_names or None) if frames else set()
    for x in feet:
        used |= set(robot.limb(x).joints)
    if look_at is not None:
        head = robot.limb("head")
        used |= set(head.joints)
    if isinstance(joints, str) and joints == "all":
        used = set(robot.joint_names)

    couplings, used = _couplings(robot, used)
    level0: list[Any] = [_limits(robot), *couplings]
    freeze = _freeze_task(robot, _dofs_of(robot, used, with_root=True))
    if freeze is not None:
        level0.append(freeze)
    if root_bounds is not None:
        if not isinstance(root_bounds, (list, tuple)) or len(root_bounds) != 2:
            raise InvalidInput(
                f"root_bounds must be (lo (6,), hi (6,)) or None, got {root_bounds!r}"
            )
        lo = inputs.vector(root_bounds[0], 6, "root_bounds lo", unit="m, rad")
        hi = inputs.vector(root_bounds[1], 6, "root_bounds hi", unit="m, rad")
        if np.any(lo > hi):
            raise InvalidInput(f"root_bounds must have lo <= hi, got lo {lo} > hi {hi}")
        level0.append(_root_box(robot, lo, hi))
    weight = inputs.vector(root_weight, 6, "root_weight")
    if np.any(weight <= 0):
        raise InvalidInput(f"root_weight must be 6 positive numbers, got {root_weight!r}")
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
    if target_centroid_pos is not None and not callable(target_centroid_pos):
        target_centroid_pos = inputs.vector(target_centroid_pos, 3, "target_centroid_pos", unit="m")

    level1: list[Any] = [
        FrameTask(
            robot.configuration,
            f.name,
            (f.position(robot.data), f.rotation(robot.data)),
            move_target_type=f.frame_type,
            name=f"foot:{f.name}",
        )
        for f in foot_frames
    ]
    if external_forces is not None:
        if centroid_offset is not None:
            raise InvalidInput("give centroid_offset or external_forces, not both")
        _parse_forces(robot, external_forces)
        forces = list(external_forces)
        height = float(np.mean([f.position(robot.data)[2] for f in foot_frames])) if feet else 0.0

        def centroid_offset(r: Robot) -> np.ndarray:
            return static_balance_point(r, forces, height)

    if not isinstance(balance, str):
        if centroid_offset is not None:
            raise InvalidInput("centroid_offset/external_forces need balance='centroid'")
        level1 += _tasks(balance, "balance")
    elif balance == "support_polygon":
        if centroid_offset is not None:
            raise InvalidInput("centroid_offset/external_forces need balance='centroid'")
        if not feet:
            raise InvalidInput("balance='support_polygon' needs fixed feet")
        level1.append(
            SupportPolygonTask(
                robot.configuration,
                sole_polygons(robot, tuple(feet)),
                root_body=robot.root_body,
                centroid_thre=centroid_thre,
            )
        )
    elif balance != "centroid":
        raise InvalidInput(
            f"balance {balance!r}: use 'centroid', 'support_polygon' or a list of tasks"
        )
    elif centroid_axes is not None and centroid_axes is not False:
        if target_centroid_pos is None:
            if not foot_frames:
                raise InvalidInput("target_centroid_pos is needed when no feet are fixed")
            target_centroid_pos = np.mean([f.position(robot.data) for f in foot_frames], axis=0)
        level1.append(
            _centroid_task(
                robot, target_centroid_pos, centroid_axes, centroid_offset, centroid_thre
            )
        )
    level1 += _tasks(collision_avoidance, "collision_avoidance")
    levels: list[list[Any]] = [level0]
    if level1:
        levels.append(level1)
    if frames:
        levels.append(
            list(_frame_tasks(robot, frames, poses, translation_axis, rotation_axis, thre, rthre))
        )
    if look_at is not None:
        levels.append([_look_at_task(robot, look_at, gaze_axis)])
    levels += _extra(robot, extra_levels)
    levels.append([_posture_task(robot, posture_weight), _root_cost(robot, weight, posture_weight)])
    return solve(
        robot.configuration,
        levels,
        stop=stop,
        revert_if_fail=revert_if_fail,
        callback=callback,
        **solve_kwargs,
    )


def gaze_angle(robot: Robot, point: Sequence[float], axis: Sequence[float] = (1, 0, 0)) -> float:
    """Angle [rad] between the head end frame's gaze axis and the direction to ``point``.

    .. math::

        \\theta = \\arccos\\big(\\hat a_W \\cdot (p - p_{WH}) / \\|p - p_{WH}\\|\\big)
    """
    head = robot.limb("head")
    X = robot.frame_pose(head.end_frame, head.end_frame_type)
    axis = _vector3(axis, "axis")
    if np.linalg.norm(axis) == 0.0:
        raise InvalidInput("axis must be a non-zero 3-vector, got [0, 0, 0]")
    a_W = X.rotation().as_matrix() @ (axis / np.linalg.norm(axis))
    d = _vector3(point, "point") - X.translation()
    return float(np.arccos(np.clip(a_W @ d / np.linalg.norm(d), -1.0, 1.0)))
