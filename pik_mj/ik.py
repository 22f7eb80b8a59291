"""irteus' inverse-kinematics API on the priority cascade (seed 001 ``:inverse-kinematics``,
``:fullbody-inverse-kinematics``).

Both functions build a stack of levels for :func:`pik_mj.solve.solve` and run it:

* :func:`inverse_kinematics` — level 0: joint limits, and every degree of freedom
  outside the used chains frozen (hard ``x_i = 0``; a floating base stays where it
  is); level 1: one frame task per target; level 2: look-at (if any); then the
  caller's ``extra_levels``; last: posture towards the start (not checked).
* :func:`fullbody_inverse_kinematics` — level 0: joint limits, frozen dofs and the
  root's displacement box (irteus ``:min``/``:max`` of the root-link virtual joint);
  level 1: feet fixed where they are and the centroid over the feet on the
  selected axes; level 2: the targets; then look-at, ``extra_levels``; last:
  posture and a root-motion cost (irteus ``root-link-virtual-joint-weight``).

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
import numpy as np

from .exceptions import InvalidInput
from .frames import Frame
from .robot import Robot
from .solve import SolveResult, solve
from .tasks.frame import ONE_DEGREE, FrameTask, as_pose, constrained_axes
from .tasks.linear import LinearTask
from .tasks.mink_adapter import MinkTask
from .tasks.task import Task, TaskRows

__all__ = [
    "DEFAULT_ROOT_BOUNDS",
    "DEFAULT_ROOT_WEIGHT",
    "CentroidTask",
    "LookAtTask",
    "fullbody_inverse_kinematics",
    "gaze_angle",
    "inverse_kinematics",
    "static_balance_point",
]

GRAVITY = 9.81
"""Magnitude of gravity [m/s²] used when the model's option gives none."""

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
# Tasks the cascade needs here. Each is used through one factory below
# (`_centroid_task`, `_look_at_task`): swapping to pik_mj.tasks.com /
# pik_mj.tasks.look_at is a one-line change there.


def _call_user(fn: Callable[..., Any], robot: Robot) -> Any:
    """Call a user callable with the robot if it takes an argument, else with none."""
    try:
        n = len(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        n = 1
    return fn(robot) if n >= 1 else fn()


def _vector3(value: Any, what: str) -> np.ndarray:
    v = np.asarray(value, dtype=float).reshape(-1) if value is not None else None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InvalidInput(f"{what} must be 3 finite numbers, got {value!r}")
    return v


class CentroidTask(Task):
    """Centroid (or an offset point such as the static balance point) onto a target.

    Seed ``target-centroid-pos-task``; irteus ``:centroid-offset-func`` replaces the
    centroid by the point it returns (its Jacobian is taken as the centroid's):

    .. math::

        e = S\\,(c_{\\mathrm{eff}} - c^*), \\qquad S J_{com}\\, x = -\\mathrm{clamp}(e)

    with ``S`` the rows of the matched axes (irteus axis names free an axis).

    Args:
        robot: The robot (its centroid and centroid Jacobian).
        target: Target position [m] (3,), or a callable of the robot returning it.
        axes: Axis specification (``"z"`` frees z, ``True`` matches all).
        offset: Callable of the robot returning the point used instead of the
            centroid [m], or None.
        thre: Stop-test tolerance on the norm of ``e`` [m].
        limit: Largest centroid motion asked of one iteration [m].
        weight: Row weight [cost/m²].
        name: Display name.
    """

    def __init__(
        self,
        robot: Robot,
        target: Any,
        *,
        axes: bool | str | None = "z",
        offset: Callable[..., Any] | None = None,
        thre: float = 1e-3,
        limit: float = 0.05,
        weight: float = 1.0,
        name: str = "centroid",
    ):
        self.robot = robot
        self.target = target if callable(target) else _vector3(target, "target_centroid_pos")
        self.rows = constrained_axes(axes, "centroid_axes")
        self.offset = offset
        self.thre, self.limit, self.weight = float(thre), float(limit), float(weight)
        self.name = name
        self.check = True

    def point(self) -> np.ndarray:
        """``c_eff``: the centroid, or the offset function's point [m]."""
        if self.offset is None:
            return self.robot.com()
        return _vector3(_call_user(self.offset, self.robot), "centroid_offset result")

    def target_now(self) -> np.ndarray:
        if callable(self.target):
            return _vector3(_call_user(self.target, self.robot), "target_centroid_pos result")
        return self.target

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        return (self.point() - self.target_now())[self.rows]

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        e = self.compute_error(configuration)
        n = float(np.linalg.norm(e))
        if n > self.limit:
            e = e * (self.limit / n)
        return TaskRows.equality(self.robot.com_jacobian()[self.rows], -e, self.weight)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return bool(np.linalg.norm(self.compute_error(configuration)) <= self.thre)


class LookAtTask(MinkTask):
    """Point a frame's gaze axis at a point (irteus ``:look-at``), via ``mink.LookAtTask``.

    .. math::

        e = a - \\frac{R_{WH}^T (p^* - p_{WH})}{\\|p^* - p_{WH}\\|}

    Args:
        robot: The robot.
        frame: Name of the gazing frame (the head limb's end frame).
        frame_type: Its type (``"site"``, ``"body"``, ``"geom"``).
        point: Point to look at [m], or a callable of the robot returning it
            (evaluated every iteration).
        axis: Gaze axis in the frame [-].
        thre: Stop-test tolerance on ``max |e|`` (≈ gaze angle [rad]).
        check: Whether the stop test looks at it (irteus: best effort, False).
    """

    def __init__(
        self,
        robot: Robot,
        frame: str,
        frame_type: str,
        point: Any,
        *,
        axis: Sequence[float] = (1.0, 0.0, 0.0),
        thre: float = 1e-2,
        check: bool = False,
    ):
        super().__init__(
            mink.LookAtTask(frame, frame_type, axis=axis, cost=1.0),
            name="look_at",
            threshold=thre,
            check=check,
        )
        self.robot = robot
        self.point = point if callable(point) else _vector3(point, "look_at")
        self._refresh()

    def _refresh(self) -> None:
        p = self.point
        if callable(p):
            p = _vector3(_call_user(p, self.robot), "look_at result")
        self.task.set_target(p)

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        self._refresh()
        return super().compute_rows(configuration)

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        self._refresh()
        return super().compute_error(configuration)


def _centroid_task(robot: Robot, target: Any, axes: Any, offset: Any, thre: float) -> Task:
    return CentroidTask(robot, target, axes=axes, offset=offset, thre=thre)


def _look_at_task(robot: Robot, point: Any, axis: Sequence[float]) -> Task:
    head = robot.limb("head")
    return LookAtTask(robot, head.end_frame, head.end_frame_type, point, axis=axis)


def static_balance_point(
    robot: Robot,
    external_forces: Sequence[tuple[str, Any, Any]],
    height: float,
) -> np.ndarray:
    """irteus ``:calc-static-balance-point``: the point at ``height`` [m] where the
    ground reaction balances gravity and the external wrenches (static extended ZMP).

    See the module docstring for the formula.

    Args:
        robot: The robot (mass, centroid, frame positions).
        external_forces: ``(frame, force [N] (3,), moment [N·m] (3,))`` applied at
            each named frame's origin, world frame.
        height: Height of the balance point (the soles' height) [m].

    Returns:
        ``(p_x, p_y, height)`` [m].
    """
    g = float(np.linalg.norm(robot.model.opt.gravity)) or GRAVITY
    mg = robot.mass * g
    c = robot.com()
    num = mg * c[:2]
    fz = 0.0
    for frame, f, n in _parse_forces(robot, external_forces):
        r = frame.position(robot.data)
        num[0] += (r[2] - height) * f[0] - r[0] * f[2] + n[1]
        num[1] += (r[2] - height) * f[1] - r[1] * f[2] - n[0]
        fz += f[2]
    if mg - fz <= 1e-9 * mg:
        raise InvalidInput(
            f"external forces lift the robot (sum f_z = {fz:.3g} N >= M g = {mg:.3g} N)"
        )
    return np.array([num[0] / (mg - fz), num[1] / (mg - fz), float(height)])


def _parse_forces(robot: Robot, external_forces: Any) -> list[tuple[Frame, np.ndarray, np.ndarray]]:
    if isinstance(external_forces, (str, bytes)) or not isinstance(external_forces, Sequence):
        raise InvalidInput("external_forces must be a list of (frame, force(3), moment(3))")
    out = []
    for i, item in enumerate(external_forces):
        if not isinstance(item, (tuple, list)) or len(item) != 3:
            raise InvalidInput(f"external_forces[{i}] must be (frame, force(3), moment(3))")
        name, f, n = item
        out.append(
            (
                Frame.find(robot.model, name),
                _vector3(f, f"external_forces[{i}] force [N]"),
                _vector3(n, f"external_forces[{i}] moment [N·m]"),
            )
        )
    return out


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
            out.append(as_pose(t, f"targets[{i}]"))
    return out


def _wrap_callable(fn: Callable[..., Any], robot: Robot, i: int) -> Callable[[Any], Any]:
    def target(_configuration: mink.Configuration) -> Any:
        return as_pose(_call_user(fn, robot), f"targets[{i}] callable result")

    return target


def _parse_limbs(robot: Robot, limbs: Any, n: int) -> list[str] | None:
    if limbs is None:
        return None
    limbs = [limbs] if isinstance(limbs, str) else list(limbs)
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
    names = [move_targets] if isinstance(move_targets, str) else list(move_targets)
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
        names = list(joints)
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
    if not (np.isfinite(weight) and weight >= 0):
        raise InvalidInput(f"posture_weight must be finite and >= 0 [cost/rad], got {weight}")
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
    thres = _as_list(thre, n, "thre", _float_single)
    rthres = _as_list(rthre, n, "rthre", _float_single)
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


def _extra(extra_levels: Any) -> list[list[Any]]:
    if extra_levels is None:
        return []
    if not isinstance(extra_levels, (list, tuple)) or not all(
        isinstance(level, (list, tuple)) for level in extra_levels
    ):
        raise InvalidInput("extra_levels must be a list of lists of tasks")
    return [list(level) for level in extra_levels]


def _limits(robot: Robot) -> mink.ConfigurationLimit:
    return mink.ConfigurationLimit(robot.model)


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
    extra_levels: Sequence[Sequence[Any]] | None = None,
    callback: Callable[..., None] | None = None,
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
        extra_levels: Levels inserted before the posture level.
        callback: Per-iteration callback (see :func:`pik_mj.solve.solve`).
        **solve_kwargs: Passed to :func:`pik_mj.solve.solve` (``min_loop``,
            ``qp_solver``, ...).

    Returns:
        The :class:`pik_mj.solve.SolveResult`.

    Raises:
        InvalidInput: Wrong target types/shapes, mismatched list lengths.
        UnknownName: Unknown limb, joint or frame names (valid ones listed).
    """
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
    extra_levels: Any,
) -> list[list[Any]]:
    if not isinstance(robot, Robot):
        raise InvalidInput(f"robot must be a pik_mj.robot.Robot, got {type(robot).__name__}")
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
    level0: list[Any] = [_limits(robot)]
    freeze = _freeze_task(robot, _dofs_of(robot, used, with_root=False))
    if freeze is not None:
        level0.append(freeze)
    levels: list[list[Any]] = [
        level0,
        list(_frame_tasks(robot, frames, poses, translation_axis, rotation_axis, thre, rthre)),
    ]
    if look_at is not None:
        levels.append([_look_at_task(robot, look_at, gaze_axis)])
    levels += _extra(extra_levels)
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
    feet = [fix_feet] if isinstance(fix_feet, str) else list(fix_feet)
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
    stop: int = 50,
    revert_if_fail: bool = True,
    joints: str | Sequence[str] | None = None,
    look_at: Any = None,
    gaze_axis: Sequence[float] = (1.0, 0.0, 0.0),
    posture_weight: float = 1e-2,
    extra_levels: Sequence[Sequence[Any]] | None = None,
    callback: Callable[..., None] | None = None,
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

    Raises:
        InvalidInput: No floating base, bad shapes, both ``centroid_offset`` and
            ``external_forces``.
        UnknownName: Unknown limb, joint or frame names.
    """
    if not isinstance(robot, Robot):
        raise InvalidInput(f"robot must be a pik_mj.robot.Robot, got {type(robot).__name__}")
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

    level0: list[Any] = [_limits(robot)]
    freeze = _freeze_task(robot, _dofs_of(robot, used, with_root=True))
    if freeze is not None:
        level0.append(freeze)
    if root_bounds is not None:
        lo, hi = (np.asarray(b, dtype=float) for b in root_bounds)
        if lo.shape != (6,) or hi.shape != (6,) or np.any(lo > hi):
            raise InvalidInput("root_bounds must be (lo (6,), hi (6,)) with lo <= hi")
        level0.append(_root_box(robot, lo, hi))
    weight = np.asarray(root_weight, dtype=float)
    if weight.shape != (6,) or np.any(weight <= 0):
        raise InvalidInput(f"root_weight must be 6 positive numbers, got {root_weight!r}")

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
        forces = list(external_forces)
        _parse_forces(robot, forces)
        height = float(np.mean([f.position(robot.data)[2] for f in foot_frames])) if feet else 0.0

        def centroid_offset(r: Robot) -> np.ndarray:
            return static_balance_point(r, forces, height)

    if centroid_axes is not None and centroid_axes is not False:
        if target_centroid_pos is None:
            if not foot_frames:
                raise InvalidInput("target_centroid_pos is needed when no feet are fixed")
            target_centroid_pos = np.mean([f.position(robot.data) for f in foot_frames], axis=0)
        level1.append(
            _centroid_task(
                robot, target_centroid_pos, centroid_axes, centroid_offset, centroid_thre
            )
        )
    levels: list[list[Any]] = [level0]
    if level1:
        levels.append(level1)
    if frames:
        levels.append(
            list(_frame_tasks(robot, frames, poses, translation_axis, rotation_axis, thre, rthre))
        )
    if look_at is not None:
        levels.append([_look_at_task(robot, look_at, gaze_axis)])
    levels += _extra(extra_levels)
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
    a_W = X.rotation().as_matrix() @ (np.asarray(axis, float) / np.linalg.norm(axis))
    d = _vector3(point, "point") - X.translation()
    return float(np.arccos(np.clip(a_W @ d / np.linalg.norm(d), -1.0, 1.0)))
