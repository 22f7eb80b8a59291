"""Whole-body walking pattern (irteus manual:
``:calc-walk-pattern-from-footstep-list``).

:func:`pik_mj.walking.gait.plan_gait` gives, per tick, both sole poses, the ZMP
reference and the preview-control CoM. Here every tick is turned into a whole-body
configuration by the prioritized IK (:func:`pik_mj.solve.solve`), warm-started
from the previous tick:

the stack of :mod:`pik_mj.walking.walk_tasks` (limits and self-collision; soles
and CoM; the root upright and the upper body still; posture), with the soles'
roll left to a lower level where the gait asks for rolling soles
(``GaitParameters.rolling_soles``, legs without ankle roll).

Each sole is the robot's :class:`~pik_mj.robot.ground.Sole` (its frame S fixed
to the foot body B, from MuJoCo's floor contacts), so no site is needed: a sole
target :math:`X_{WS}^*` is the foot body's target :math:`X_{WS}^* X_{BS}^{-1}`.

The result is checked with the ZMP of the *generated motion* (irteus manual:
``calc-zmp``): joint velocities and accelerations by finite differences, MuJoCo's
inverse dynamics for the wrench the ground must apply to the floating base, and
the ZMP of that wrench (:func:`pik_mj.dynamics.zmp_of_motion`), against the
support polygon of the soles' polygons (:mod:`pik_mj.walking.support`). Where it
leaves the polygon (the cart-table model leaves out the limbs' own momentum), the
CoM is corrected and every tick solved again (Kajita's two-stage preview
control): the preview controller run on the ZMP error
:math:`e = p^{ref} - p^{ID}` from rest gives :math:`\\Delta c`, and the CoM
reference becomes :math:`c + \\Delta c`, whose cart-table ZMP moves by what the
motion missed; repeated on the corrected motion's error while its ZMP still
leaves the polygon, at most :data:`MAX_CORRECTIONS` times.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from pik_mj.dynamics import zmp_of_motion
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot
from pik_mj.robot.ground import Sole, robot_soles
from pik_mj.solve import solve
from pik_mj.spatial import yaw_of
from pik_mj.walking.gait import Footstep, GaitParameters, GaitPlan, plan_gait
from pik_mj.walking.preview import PreviewController
from pik_mj.walking.support import support_margin
from pik_mj.walking.walk_tasks import (
    SELF_COLLISION_ORANGE,
    SELF_COLLISION_YELLOW,
    WalkTasks,
    bent_knees,
)

__all__ = [
    "MAX_CORRECTIONS",
    "SELF_COLLISION_ORANGE",
    "SELF_COLLISION_YELLOW",
    "WalkPattern",
    "bent_knees",
    "calc_walk_pattern",
    "corrected_plan",
    "feet_from_robot",
    "foot_force_sensors",
]

MAX_CORRECTIONS = 3
"""Most passes of the two-stage correction (module docstring)."""


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
        soles: Each leg's :class:`~pik_mj.robot.ground.Sole` (frame and polygon).
        force_sensors: Each leg's foot force/torque sensor (site name), for the
            legs that have one (:func:`foot_force_sensors`).
        self_collision_pairs: Geom pairs kept apart at level 0.
        zmp_corrections: How many times the CoM was corrected by the ZMP error of
            the previous pass (module docstring); ``com_ref`` and ``plan`` are the
            corrected ones.
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
    soles: dict[str, Sole]
    force_sensors: dict[str, str]
    self_collision_pairs: int = 0
    zmp_corrections: int = 0

    @property
    def duration(self) -> float:
        """Total duration [s]."""
        return float(self.t[-1])

    @property
    def outlines(self) -> dict[str, np.ndarray]:
        """Each leg's sole polygon in its sole frame (k, 2) [m]."""
        return {leg: sole.outline for leg, sole in self.soles.items()}

    def support_margin(self, which: str = "computed") -> np.ndarray:
        """:func:`pik_mj.walking.support.support_margin` of ``zmp_computed``,
        ``zmp_cart`` or ``zmp_ref`` [m] with the robot's soles."""
        zmp = {"computed": self.zmp_computed, "cart": self.zmp_cart, "ref": self.zmp_ref}
        if which not in zmp:
            raise UnknownName("zmp", which, zmp)
        return support_margin(self.plan, zmp[which], self.outlines)

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


def feet_from_robot(robot: Robot, soles: Mapping[str, Sole] | None = None) -> dict[str, Footstep]:
    """Current sole poses (position, heading) of the robot's legs.

    The heading is that of the sole frame's x axis projected on the ground,
    :math:`\\psi = \\mathrm{atan2}(R_{10}, R_{00})`.

    Args:
        robot: The robot, in its current configuration.
        soles: Its soles (default: :func:`pik_mj.robot.ground.robot_soles`).
    """
    soles = robot_soles(robot) if soles is None else soles
    out = {}
    for leg, sole in soles.items():
        p_WS, R_WS = sole.pose(robot.model, robot.data)
        out[leg] = Footstep(leg, p_WS, yaw_of(R_WS))
    return out


def foot_force_sensors(robot: Robot, soles: Mapping[str, Sole]) -> dict[str, str]:
    """Each leg's foot force/torque sensor (its site's name): of the robot's sensors
    with a force and a torque channel on the leg, the one on the sole's body or
    nearest above it (what measures the sole's contact wrench); legs without one
    are left out."""
    model = robot.model
    out = {}
    for leg, sole in soles.items():
        chain = [model.body(sole.body).id]
        while chain[-1] != 0:
            chain.append(int(model.body_parentid[chain[-1]]))
        found = [
            (chain.index(f.body_id), f.name)
            for f in robot.sensors(leg).force_sensors
            if f.force is not None and f.torque is not None and f.body_id in chain
        ]
        if found:
            out[leg] = min(found)[1]
    return out


def calc_walk_pattern(
    robot: Robot,
    footsteps: Sequence[Footstep],
    params: GaitParameters | None = None,
    *,
    com_height: float | None = None,
    soles: Mapping[str, Sole] | None = None,
    upright_body: str | None = None,
    self_collision: bool = True,
    stop: int = 3,
    min_loop: int = 3,
    init_stop: int = 50,
    ik_thre: float = 1e-4,
    ik_rthre: float = 1e-3,
    qp_solver: object = "daqp",
    callback: Callable[[int, Robot], None] | None = None,
    max_corrections: int = MAX_CORRECTIONS,
) -> WalkPattern:
    """Whole-body walking pattern from a footstep list (irteus manual:
    ``:calc-walk-pattern-from-footstep-list``).

    The initial feet are the robot's current sole poses; the CoM height is that
    of the current pose above the mean sole height unless given (a
    :class:`~pik_mj.walking.robot_gait.RobotGait` chooses one with the knees
    bent). Each tick k sets the targets of the levels (module docstring) to the
    plan's row k and runs :func:`pik_mj.solve.solve` from the previous tick's
    solution; tick 0 gets ``init_stop`` iterations (the irteus manual's
    ``init-pose-function``: CoM over the feet at its height). The robot is left
    in the last tick's configuration.

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
        soles: The soles of ``params.all_limbs`` (default:
            :func:`pik_mj.robot.ground.robot_soles`).
        upright_body: Body kept upright with the mid-feet heading; default the
            robot's root body.
        self_collision: Keep the robot's geoms apart (level 0).
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
        max_corrections: Most passes of the two-stage correction (module
            docstring; 0: none).

    Returns:
        The :class:`WalkPattern`.

    Raises:
        InvalidInput: A robot without a floating base, or soles missing a leg.
    """
    params = GaitParameters() if params is None else params
    if params.gravity is None:  # the robot's world
        params = replace(params, gravity=float(np.linalg.norm(robot.model.opt.gravity)))
    if not robot.has_floating_base:
        raise InvalidInput("calc_walk_pattern needs a robot with a free joint on its root body")
    soles = robot_soles(robot, params.all_limbs) if soles is None else soles
    missing = [lb for lb in params.all_limbs if lb not in soles]
    if missing:
        raise InvalidInput(f"soles has no sole for limbs {missing}; got {list(soles)}")
    soles = {lb: soles[lb] for lb in params.all_limbs}
    initial_feet = feet_from_robot(robot, soles)
    ground_z = float(np.mean([f.p_W[2] for f in initial_feet.values()]))
    if com_height is None:
        com_height = float(robot.com()[2]) - ground_z
    plan = plan_gait(initial_feet, footsteps, params, com_height=com_height)
    start = robot.configuration.q.copy()
    robot.configuration.update(bent_knees(robot, params.all_limbs))
    upright_body = robot.root_body if upright_body is None else upright_body
    tasks = WalkTasks.of(
        robot, soles, upright_body, ik_thre, ik_rthre, self_collision, params.rolling_soles
    )
    loops = (stop, min_loop, init_stop)
    ticks = _track(robot, plan, tasks, loops, qp_solver, callback)
    zmp_computed = zmp_of_motion(
        robot.model, ticks.q, plan.dt, plan.ground_z, root_body=robot.root_body
    )
    outlines = {lb: sole.outline for lb, sole in soles.items()}
    corrections = 0
    while corrections < max_corrections and support_margin(plan, zmp_computed, outlines).min() <= 0:
        corrections += 1
        plan = corrected_plan(plan, zmp_computed)
        robot.configuration.update(start)
        robot.configuration.update(bent_knees(robot, params.all_limbs))
        ticks = _track(robot, plan, tasks, loops, qp_solver, callback)
        zmp_computed = zmp_of_motion(
            robot.model, ticks.q, plan.dt, plan.ground_z, root_body=robot.root_body
        )
    return WalkPattern(
        t=plan.t,
        dt=plan.dt,
        q=ticks.q,
        joint_names=tuple(robot.joint_names),
        root_body=robot.root_body,
        com=ticks.com,
        com_ref=plan.com_W,
        zmp_ref=plan.zmp_ref,
        zmp_cart=plan.zmp,
        zmp_computed=zmp_computed,
        feet_p=ticks.feet_p,
        feet_R=ticks.feet_R,
        support=plan.support,
        plan=plan,
        ik_iterations=ticks.iterations,
        ik_feet_error=ticks.feet_error,
        ik_com_error=np.linalg.norm(ticks.com - plan.com_W, axis=1),
        solve_time=ticks.wall,
        soles=soles,
        force_sensors=foot_force_sensors(robot, soles),
        self_collision_pairs=tasks.pairs,
        zmp_corrections=corrections,
    )


def corrected_plan(plan: GaitPlan, zmp_computed: np.ndarray) -> GaitPlan:
    """``plan`` with its CoM corrected by the ZMP error of a motion that followed it
    (Kajita's two-stage preview control): the plan's preview controller run on
    :math:`e_k = p^{ref}_k - p^{ID}_k` from rest at the origin gives
    :math:`\\Delta c_k`; the CoM, its velocity, acceleration and cart-table ZMP are
    the plan's plus those of :math:`\\Delta c`.

    Args:
        plan: The gait plan the motion followed.
        zmp_computed: The motion's ZMP from inverse dynamics (K, 2) [m].
    """
    params = plan.params
    controller = PreviewController(
        plan.dt,
        plan.com_height,
        q=params.q,
        r=params.r,
        preview_time=params.preview_time,
        gravity=params.gravity,
    )
    delta = controller.run(plan.zmp_ref - zmp_computed, com0=np.zeros(2))
    return replace(
        plan,
        com=plan.com + delta.com,
        com_vel=plan.com_vel + delta.com_vel,
        com_acc=plan.com_acc + delta.com_acc,
        zmp=plan.zmp + delta.zmp,
    )


@dataclass(frozen=True)
class _Ticks:
    """The IK's results per tick (:class:`WalkPattern`'s fields of the same names)."""

    q: np.ndarray
    com: np.ndarray
    feet_p: dict[str, np.ndarray]
    feet_R: dict[str, np.ndarray]
    iterations: np.ndarray
    feet_error: np.ndarray
    wall: float


def _track(
    robot: Robot,
    plan: GaitPlan,
    tasks: WalkTasks,
    loops: tuple[int, int, int],
    qp_solver: object,
    callback: Callable[[int, Robot], None] | None,
) -> _Ticks:
    """Solve every tick of ``plan`` from the previous one (``loops``: ``stop``,
    ``min_loop``, ``init_stop``)."""
    stop, min_loop, init_stop = loops
    model, data, configuration = robot.model, robot.data, robot.configuration
    K = len(plan.t)
    q = np.empty((K, model.nq))
    com = np.empty((K, 3))
    feet_p = {lb: np.empty((K, 3)) for lb in tasks.soles}
    feet_R = {lb: np.empty((K, 3, 3)) for lb in tasks.soles}
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
        if k == 0:  # the posture of the walk: the first tick's
            for task in tasks.postures:
                task.set_target_from_configuration(configuration)
        q[k] = configuration.q
        com[k] = robot.com()
        errs = []
        for lb, sole in tasks.soles.items():
            feet_p[lb][k], feet_R[lb][k] = sole.pose(model, data)
            errs.append(np.linalg.norm(feet_p[lb][k] - plan.feet_p[lb][k]))
        feet_err[k] = max(errs)
        if callback is not None:
            callback(k, robot)
    wall = time.perf_counter() - t0
    return _Ticks(q, com, feet_p, feet_R, iterations, feet_err, wall)
