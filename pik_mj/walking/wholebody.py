"""Whole-body walking pattern (irteus manual:
``:calc-walk-pattern-from-footstep-list``).

:func:`pik_mj.walking.gait.plan_gait` gives, per tick, both sole poses, the ZMP
reference and the preview-control CoM. Here every tick is turned into a whole-body
configuration by the prioritized IK (:func:`pik_mj.solve.solve`), warm-started
from the previous tick:

* level 0: joint limits;
* level 1: both soles on their planned poses (position, heading, sole flat);
* level 2: CoM on the preview trajectory (xy) at constant height (z), and the
  root body upright with the mid-feet heading;
* level 3: posture towards the initial pose.

The result is checked with the ZMP of the *generated motion* (irteus manual: ``calc-zmp``):
joint velocities and accelerations by finite differences, MuJoCo's inverse
dynamics for the wrench the ground must apply to the floating base, and the ZMP
of that wrench (:func:`pik_mj.dynamics.zmp_of_motion`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import mink
import numpy as np

from pik_mj.balance import convex_hull_2d, halfplanes_from_polygon, signed_distance
from pik_mj.dynamics import zmp_of_motion
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.ground import sole_size
from pik_mj.solve import solve
from pik_mj.spatial import rot_z, yaw_of
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.mink_adapter import MinkLimit, MinkTask
from pik_mj.walking.gait import DOUBLE_SUPPORT, Footstep, GaitParameters, GaitPlan, plan_gait

__all__ = [
    "DEFAULT_FEET",
    "WalkPattern",
    "calc_walk_pattern",
    "feet_from_robot",
    "sole_corners",
    "support_margin",
]

DEFAULT_FEET: dict[str, str] = {"rleg": "rleg_end", "lleg": "lleg_end"}
"""Sole frame (site, z up, x forward) of each leg of the sample humanoid."""

# ---------------------------------------------------------------------------
# Support polygon


def sole_corners(p_W: np.ndarray, yaw: float, size: Sequence[float]) -> np.ndarray:
    """Corners (4, 2) [m] of a sole rectangle ``size`` (length, width) [m] centred
    on the sole frame (:func:`pik_mj.robot.ground.sole_size` measures a robot's)."""
    hx, hy = 0.5 * float(size[0]), 0.5 * float(size[1])
    local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
    return np.asarray(p_W, dtype=float)[:2] + local @ rot_z(yaw)[:2, :2].T


def support_margin(
    plan: GaitPlan,
    zmp: np.ndarray,
    sole_size: Sequence[float],
) -> np.ndarray:
    """Signed distance of the ZMP to the support polygon at every tick [m].

    The support polygon of tick k is the convex hull of the soles in contact per
    the plan's support label (both in double support), at their planned poses;
    positive inside.

    Args:
        plan: The gait plan.
        zmp: ZMP per tick (K, 2) [m].
        sole_size: Sole length and width [m].

    Returns:
        (K,) signed distances [m].
    """
    zmp = np.asarray(zmp, dtype=float)
    if zmp.shape != (len(plan.t), 2):
        raise InvalidInput(f"zmp must have shape ({len(plan.t)}, 2), got {zmp.shape}")
    limbs = plan.params.all_limbs
    out = np.empty(len(plan.t))
    for k, label in enumerate(plan.support):
        feet = limbs if label == DOUBLE_SUPPORT else (label,)
        corners = np.vstack(
            [sole_corners(plan.feet_p[lb][k], plan.feet_yaw[lb][k], sole_size) for lb in feet]
        )
        out[k] = signed_distance(halfplanes_from_polygon(convex_hull_2d(corners)), zmp[k])
    return out


# ---------------------------------------------------------------------------
# Walk pattern


@dataclass(frozen=True)
class WalkPattern:
    """A whole-body walking pattern; row k is time ``t[k] = k dt``.

    Attributes:
        t: Times (K,) [s].
        dt: Sampling time [s].
        q: Configurations (K, nq): root pose (free joint) and joint angles.
        joint_names: Names of the robot's hinge/slide joints (``Robot.joint_names``).
        root_body: Name of the floating-base body.
        com: CoM of the IK solution (K, 3) [m].
        com_ref: Planned CoM (K, 3) [m] (preview control; constant height).
        zmp_ref: ZMP reference (K, 2) [m].
        zmp_cart: Cart-table ZMP of the planned CoM (K, 2) [m].
        zmp_computed: ZMP of the generated motion from inverse dynamics (K, 2) [m].
        feet_p: Achieved sole positions per limb (K, 3) [m].
        feet_R: Achieved sole rotations per limb (K, 3, 3).
        support: (K,) labels ``"double"`` or the supporting limb.
        plan: The gait plan the pattern follows.
        ik_iterations: IK iterations per tick (K,).
        ik_feet_error: Largest sole position error per tick (K,) [m].
        ik_com_error: CoM position error per tick (K,) [m].
        solve_time: Wall time of the IK over all ticks [s].
        sole_size: Length and width of the robot's soles [m] (its support polygons).
    """

    t: np.ndarray
    dt: float
    q: np.ndarray
    joint_names: tuple[str, ...]
    root_body: str
    com: np.ndarray
    com_ref: np.ndarray
    zmp_ref: np.ndarray
    zmp_cart: np.ndarray
    zmp_computed: np.ndarray
    feet_p: dict[str, np.ndarray]
    feet_R: dict[str, np.ndarray]
    support: np.ndarray
    plan: GaitPlan
    ik_iterations: np.ndarray
    ik_feet_error: np.ndarray
    ik_com_error: np.ndarray
    solve_time: float
    sole_size: tuple[float, float]

    @property
    def duration(self) -> float:
        """Total duration [s]."""
        return float(self.t[-1])

    def support_margin(self, which: str = "computed") -> np.ndarray:
        """:func:`support_margin` of ``zmp_computed``, ``zmp_cart`` or ``zmp_ref`` [m]
        with the robot's soles."""
        zmp = {"computed": self.zmp_computed, "cart": self.zmp_cart, "ref": self.zmp_ref}
        if which not in zmp:
            raise UnknownName("zmp", which, zmp)
        return support_margin(self.plan, zmp[which], self.sole_size)

    def zmp_tracking(self) -> dict[str, float]:
        """Max and RMS distance [m] of the cart-table and computed ZMPs to the reference."""
        out = {}
        for name, zmp in (("cart", self.zmp_cart), ("computed", self.zmp_computed)):
            e = np.linalg.norm(zmp - self.zmp_ref, axis=1)
            out[f"{name}_max"] = float(e.max())
            out[f"{name}_rms"] = float(np.sqrt(np.mean(e**2)))
        e = np.linalg.norm(self.zmp_computed - self.zmp_cart, axis=1)
        out["computed_vs_cart_max"] = float(e.max())
        out["computed_vs_cart_rms"] = float(np.sqrt(np.mean(e**2)))
        return out

    def __repr__(self) -> str:
        return (
            f"WalkPattern({len(self.plan.footsteps)} steps, {len(self.t)} ticks, "
            f"dt={self.dt}, duration={self.duration:.2f} s, IK {self.solve_time:.1f} s)"
        )


def feet_from_robot(
    robot: Robot, feet_frames: Mapping[str, str] = DEFAULT_FEET
) -> dict[str, Footstep]:
    """Current sole poses (position, heading) of the robot's legs.

    The heading is that of the sole frame's x axis projected on the ground,
    :math:`\\psi = \\mathrm{atan2}(R_{10}, R_{00})`.
    """
    out = {}
    for limb, site in feet_frames.items():
        X = robot.frame_pose(site, "site")
        out[limb] = Footstep(limb, X.translation(), yaw_of(X.rotation().as_matrix()))
    return out


@dataclass(frozen=True)
class _WalkTasks:
    """The IK stack of a walk's ticks (module docstring) and its tasks."""

    feet: dict[str, FrameTask]
    com: CentroidTask
    upright: FrameTask
    levels: list[list[Any]]

    @classmethod
    def of(
        cls,
        robot: Robot,
        initial_feet: Mapping[str, Footstep],
        feet_frames: Mapping[str, str],
        upright_body: str,
        thre: float,
        rthre: float,
    ) -> _WalkTasks:
        configuration, model = robot.configuration, robot.model
        feet = {
            lb: FrameTask(
                configuration,
                site,
                (initial_feet[lb].p_W, np.eye(3)),
                move_target_type="site",
                thre=thre,
                rthre=rthre,
                name=f"foot:{lb}",
            )
            for lb, site in feet_frames.items()
        }
        # all three axes of the CoM matched: xy on the plan, z constant
        com = CentroidTask(
            configuration, np.zeros(3), translation_axis=True, centroid_thre=thre, name="com"
        )
        upright = FrameTask(
            configuration,
            upright_body,
            (np.zeros(3), np.eye(3)),
            move_target_type="body",
            translation_axis=None,
            rthre=rthre,
            name=f"upright:{upright_body}",
        )
        posture = mink.PostureTask(model, cost=1e-2)
        posture.set_target(configuration.q.copy())
        levels: list[list[Any]] = [
            [MinkLimit(mink.ConfigurationLimit(model))],
            list(feet.values()),
            [com, upright],
            [MinkTask(posture, name="posture", check=False)],
        ]
        return cls(feet, com, upright, levels)

    def aim(self, plan: GaitPlan, k: int, com_ref: np.ndarray) -> None:
        """Set the targets to the plan's tick ``k``: the soles' poses, the CoM
        ``com_ref`` [m], the root upright with the mid-feet heading."""
        yaw_mid = 0.0
        for lb, task in self.feet.items():
            yaw = float(plan.feet_yaw[lb][k])
            task.set_target((plan.feet_p[lb][k], rot_z(yaw)))
            yaw_mid += yaw / len(self.feet)
        self.com.set_target(com_ref)
        self.upright.set_target((np.zeros(3), rot_z(yaw_mid)))


def calc_walk_pattern(
    robot: Robot,
    footsteps: Sequence[Footstep],
    params: GaitParameters | None = None,
    *,
    com_height: float | None = None,
    feet_frames: Mapping[str, str] = DEFAULT_FEET,
    upright_body: str | None = None,
    stop: int = 3,
    min_loop: int = 3,
    init_stop: int = 50,
    ik_thre: float = 1e-4,
    ik_rthre: float = 1e-3,
    qp_solver: object = "daqp",
    callback: Callable[[int, Robot], None] | None = None,
) -> WalkPattern:
    """Whole-body walking pattern from a footstep list (irteus manual:
    ``:calc-walk-pattern-from-footstep-list``).

    The initial feet are the robot's current sole poses; the CoM height is that
    of the current pose above the mean sole height unless given. Each tick k
    sets the targets of the levels (module docstring) to the plan's row k and
    runs :func:`pik_mj.solve.solve` from the previous tick's solution; tick 0
    gets ``init_stop`` iterations (the irteus manual's ``init-pose-function``: CoM over
    the feet). The robot is left in the last tick's configuration.

    The second differences taken by :func:`pik_mj.dynamics.zmp_of_motion` amplify
    tick-to-tick jitter of the IK by :math:`1/\\Delta t^2`, so the default runs a
    fixed number of iterations per tick (``min_loop = stop``) with tight
    thresholds, keeping the residual a smooth function of time.

    Args:
        robot: A floating-base robot standing on its feet (e.g. after
            ``reset_pose()``); its configuration is changed.
        footsteps: Executed footsteps (see :func:`plan_gait`).
        params: Gait parameters; defaults to ``GaitParameters()``.
        com_height: CoM height above the ground plane [m]; default: current.
        feet_frames: Sole site of each limb of ``params.all_limbs``.
        upright_body: Body kept upright with the mid-feet heading; default the
            robot's root body.
        stop: Most IK iterations per tick.
        min_loop: Fewest IK iterations per tick.
        init_stop: IK iterations at tick 0 (all run, so that the posture
            level has settled before the walk starts).
        ik_thre: Sole and CoM position tolerance [m].
        ik_rthre: Sole and upright rotation tolerance [rad].
        qp_solver: QP solver of :func:`pik_mj.solve.solve`. The exact active-set
            ``"daqp"`` by default: OSQP's approximate solutions leave a
            tick-to-tick jitter that the ZMP's second differences amplify.
        callback: Called as ``callback(k, robot)`` after tick k.

    Returns:
        The :class:`WalkPattern`.
    """
    params = GaitParameters() if params is None else params
    if params.gravity is None:  # the robot's world
        params = replace(params, gravity=float(np.linalg.norm(robot.model.opt.gravity)))
    if not robot.has_floating_base:
        raise InvalidInput("calc_walk_pattern needs a robot with a free joint on its root body")
    missing = [lb for lb in params.all_limbs if lb not in feet_frames]
    if missing:
        raise InvalidInput(
            f"feet_frames has no sole frame for limbs {missing}; got {dict(feet_frames)}"
        )
    feet_frames = {lb: feet_frames[lb] for lb in params.all_limbs}
    configuration = robot.configuration
    model = robot.model
    initial_feet = feet_from_robot(robot, feet_frames)
    soles = sole_size(robot, params.all_limbs)
    ground_z = float(np.mean([f.p_W[2] for f in initial_feet.values()]))
    if com_height is None:
        com_height = float(robot.com()[2]) - ground_z
    plan = plan_gait(initial_feet, footsteps, params, com_height=com_height)
    upright_body = robot.root_body if upright_body is None else upright_body

    tasks = _WalkTasks.of(robot, initial_feet, feet_frames, upright_body, ik_thre, ik_rthre)
    K = len(plan.t)
    q = np.empty((K, model.nq))
    com_achieved = np.empty((K, 3))
    feet_p = {lb: np.empty((K, 3)) for lb in feet_frames}
    feet_R = {lb: np.empty((K, 3, 3)) for lb in feet_frames}
    iterations = np.empty(K, dtype=int)
    feet_err = np.empty(K)
    com_ref = plan.com_W
    t0 = time.perf_counter()
    for k in range(K):
        tasks.aim(plan, k, com_ref[k])
        result = solve(
            configuration,
            tasks.levels,
            stop=init_stop if k == 0 else stop,
            min_loop=init_stop if k == 0 else min(min_loop, stop),
            revert_if_fail=False,
            qp_solver=qp_solver,
        )
        iterations[k] = result.iterations
        q[k] = configuration.q
        com_achieved[k] = robot.com()
        errs = []
        for lb, site in feet_frames.items():
            X = robot.frame_pose(site, "site")
            feet_p[lb][k] = X.translation()
            feet_R[lb][k] = X.rotation().as_matrix()
            errs.append(np.linalg.norm(feet_p[lb][k] - plan.feet_p[lb][k]))
        feet_err[k] = max(errs)
        if callback is not None:
            callback(k, robot)
    solve_time = time.perf_counter() - t0

    zmp_computed = zmp_of_motion(model, q, plan.dt, plan.ground_z, root_body=robot.root_body)
    return WalkPattern(
        t=plan.t,
        dt=plan.dt,
        q=q,
        joint_names=tuple(robot.joint_names),
        root_body=robot.root_body,
        com=com_achieved,
        com_ref=com_ref,
        zmp_ref=plan.zmp_ref,
        zmp_cart=plan.zmp,
        zmp_computed=zmp_computed,
        feet_p=feet_p,
        feet_R=feet_R,
        support=plan.support,
        plan=plan,
        ik_iterations=iterations,
        ik_feet_error=feet_err,
        ik_com_error=np.linalg.norm(com_achieved - com_ref, axis=1),
        solve_time=solve_time,
        sole_size=soles,
    )
