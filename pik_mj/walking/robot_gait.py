"""A gait derived from the robot: the walking parameters of the irteus manual's gait
generator (stride, step height, step and double-support times, the cart-table CoM
height, the reach of a step) from the robot's legs, soles and mass distribution.

From the start pose (:meth:`~pik_mj.robot.RobotModel.start_q`), with :math:`g` the
model's gravity, the soles :math:`S` (:func:`pik_mj.robot.ground.robot_soles`) and,
per leg, its *pitch joints* (axes within :data:`PITCH_AXIS` of the lateral axis:
hip pitch, knee, ankle pitch) at anchors :math:`a_1 \\ldots a_n`:

.. math::

    L = \\sum_i \\|a_{i+1} - a_i\\| + \\|p_S - a_n\\|, \\qquad
    H_0 = a_{1,z} - p_{S,z}

(leg length with the leg straight, hip height), the smaller over the legs. The
walk keeps the knees bent: the hip at :math:`H = \\min(H_0, \\kappa_H L)`, the
CoM lowered with it, and the horizontal reach of a leg is what a leg at
:math:`\\kappa_L L` leaves:

.. math::

    z_c = c_z - p_{S,z} - (H_0 - H), \\qquad
    r = \\sqrt{(\\kappa_L L)^2 - H^2}, \\qquad
    T_c = \\sqrt{z_c / g}

(:math:`T_c` the time constant of the cart-table's linear inverted pendulum).
Then, with :math:`\\ell \\times w` the sole's length and width and :math:`\\Delta t`
the sampling time:

.. math::

    s = \\min(\\rho_r r,\\ \\rho_\\ell \\ell), \\quad
    h = \\eta L, \\quad
    T = \\Delta t \\,\\mathrm{round}(\\tau T_c / \\Delta t), \\quad
    T_{ds} = \\min(T_c, T / 2)

stride, step height, step time and double-support time; a go-pos step reaches
:math:`s` forward, :math:`\\min(\\rho_r r / 2, w)` sideways, and turns the smaller
of 30° and half the hip yaw joint's range (the leg joint whose axis is within
:data:`PITCH_AXIS` of vertical; 0 without one). Every value can be given instead
(:func:`robot_gait` ``**overrides``); :meth:`RobotGait.table` prints what was
chosen and why.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot import Robot, RobotModel
from pik_mj.robot.ground import Sole, robot_soles
from pik_mj.robot.stack import guard_level, posture_task
from pik_mj.solve import solve
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.walking.footsteps import ReachLimits, go_pos, straight_steps
from pik_mj.walking.gait import Footstep, GaitParameters
from pik_mj.walking.rolling_gait import (
    ROLL_DOUBLE_SUPPORT,
    ROLL_SWAY,
    bounded_reach,
    rolling_values,
    sole_zmp_offsets,
)
from pik_mj.walking.walk_tasks import bent_knees, flat_sole_tasks

__all__ = [
    "DEFAULT_DT",
    "FOOT_CLEARANCE",
    "FOOT_RATIO",
    "HIP_RATIO",
    "LEG_RATIO",
    "PITCH_AXIS",
    "REACH_RATIO",
    "STEP_HEIGHT_RATIO",
    "STEP_TIME_RATIO",
    "SWAY_RATIO",
    "RobotGait",
    "gait_value",
    "leg_geometry",
    "robot_gait",
    "sideways_reach",
    "single_support_limit",
]

PITCH_AXIS = 0.9
"""|cos| of the angle within which a joint axis counts as lateral (pitch) or vertical (yaw)."""
HIP_RATIO = 0.9
"""κ_H: hip height over leg length while walking (knees bent)."""
LEG_RATIO = 0.97
"""κ_L: the longest a leg is stretched while walking, over its length."""
REACH_RATIO = 0.5
"""ρ_r: stride over the horizontal reach of a leg."""
FOOT_RATIO = 0.8
"""ρ_ℓ: stride over the sole's length at most."""
STEP_HEIGHT_RATIO = 0.06
"""η: swing height over leg length."""
STEP_TIME_RATIO = 3.0
"""τ: step time over the pendulum time constant T_c."""
FOOT_CLEARANCE = 0.03
"""[m] Gap kept between the soles' inner edges."""
SWAY_RATIO = 0.25
"""The CoM crosses between the feet in double support: a robot must move it
sideways by this fraction of the feet's separation (half of it at least)."""
MAX_TURN = math.radians(30.0)
"""Largest heading change of one step [rad] (the irteus manual's go-pos default)."""
DEFAULT_DT = 0.02
"""Sampling time of the pattern [s]: 50 Hz, one IK solve per tick."""


@dataclass(frozen=True)
class LegGeometry:
    """What the gait is derived from (module docstring).

    Attributes:
        leg_length: L [m], the shorter leg.
        hip_height: H_0 [m] in the start pose, the lower hip.
        com_height: CoM height above the soles in the start pose [m].
        sole_size: Length and width of the smaller sole [m].
        foot_separation: Lateral distance between the sole frames [m].
        hip_width: Lateral distance between the legs' first pitch joints (hips) [m].
        hip_yaw_range: Range [rad] of the hip yaw joint (the narrower of the legs),
            or None.
        gravity: |g| [m/s²].
    """

    leg_length: float
    hip_height: float
    com_height: float
    sole_size: tuple[float, float]
    foot_separation: float
    hip_width: float
    hip_yaw_range: tuple[float, float] | None
    gravity: float

    @property
    def walking_hip_height(self) -> float:
        """H = min(H_0, κ_H L) [m]: the hip's height with the knees bent."""
        return min(self.hip_height, HIP_RATIO * self.leg_length)

    @property
    def reach(self) -> float:
        """r = sqrt((κ_L L)² − H²) [m]: how far a leg reaches forward of the hip."""
        return math.sqrt(max((LEG_RATIO * self.leg_length) ** 2 - self.walking_hip_height**2, 0))


def leg_geometry(
    robot: RobotModel, soles: Mapping[str, Sole], legs: tuple[str, str] = ("rleg", "lleg")
) -> LegGeometry:
    """The legs' length and hip height, the soles, CoM height and the hip yaw range
    in the robot's start pose (module docstring).

    Raises:
        InvalidInput: A leg without a pitch joint (no knee to bend).
    """
    model = robot.model
    data = mujoco.MjData(model)
    data.qpos[:] = robot.start_q()
    mujoco.mj_forward(model, data)
    lengths, hips, yaws, hip_points = [], [], [], []
    feet = {leg: soles[leg].pose(model, data)[0] for leg in legs}
    for leg in legs:
        joints = [model.joint(j).id for j in robot.limb(leg).joints]
        pitch = [j for j in joints if abs(data.xaxis[j][1]) > PITCH_AXIS]
        if not pitch:
            within = math.degrees(math.acos(PITCH_AXIS))
            raise InvalidInput(
                f"leg {leg!r} has no pitch joint (axis within {within:.0f}° of lateral) in "
                "the start pose: it has no knee to walk with"
            )
        points = [data.xanchor[j] for j in pitch] + [feet[leg]]
        lengths.append(sum(float(np.linalg.norm(b - a)) for a, b in itertools.pairwise(points)))
        hips.append(float(points[0][2] - feet[leg][2]))
        hip_points.append(points[0])
        yaws += [tuple(model.jnt_range[j]) for j in joints if abs(data.xaxis[j][2]) > PITCH_AXIS]
    ground = float(np.mean([p[2] for p in feet.values()]))
    com = data.subtree_com[model.body(robot.root_body).id]
    sizes = np.array([soles[leg].size for leg in legs])
    yaw_range = None
    if yaws:
        half = min(min(abs(lo), abs(hi)) for lo, hi in yaws)
        yaw_range = (-half, half)
    return LegGeometry(
        leg_length=min(lengths),
        hip_height=min(hips),
        com_height=float(com[2]) - ground,
        sole_size=(float(sizes[:, 0].min()), float(sizes[:, 1].min())),
        foot_separation=float(np.linalg.norm((feet[legs[1]] - feet[legs[0]])[:2])),
        hip_width=float(np.linalg.norm((hip_points[1] - hip_points[0])[:2])),
        hip_yaw_range=yaw_range,
        gravity=float(np.linalg.norm(model.opt.gravity)),
    )


@dataclass(frozen=True)
class RobotGait:
    """The walking parameters chosen for a robot (module docstring).

    Attributes:
        stride: s, forward advance of a step relative to the other foot [m].
        step_height: h, swing height of the cycloid [m].
        step_time: T, duration of a step [s].
        double_support_time: T_ds, of each step, half at its start, half at its end [s].
        com_height: z_c, CoM height of the cart-table model above the soles [m].
        foot_separation: Lateral distance between the soles while walking [m].
        dt: Sampling time of the pattern [s].
        max_stride_y: Sideways widening of a go-pos step [m].
        max_turn: Heading change of a go-pos step [rad].
        max_inward: Narrowing of a go-pos step below the feet's separation [m].
        preview_time: Preview horizon of the preview control [s].
        geometry: What these were derived from.
        given: Names of the values that were given, not derived.
        rolling_soles: The legs sway the CoM only with the soles rolling
            (:mod:`pik_mj.walking.rolling_gait`); then the steps are shorter.
        initial_stand_time: Standing added before the first step [s].
        zmp_offsets: Each leg's ZMP reference point in its sole frame [m]
            (empty: the sole frame's origin).
    """

    stride: float
    step_height: float
    step_time: float
    double_support_time: float
    com_height: float
    foot_separation: float
    dt: float
    max_stride_y: float
    max_turn: float
    max_inward: float
    preview_time: float
    geometry: LegGeometry
    given: tuple[str, ...] = ()
    rolling_soles: bool = False
    initial_stand_time: float = 0.0
    zmp_offsets: Mapping[str, tuple[float, float, float]] = field(default_factory=dict)

    def parameters(self, **options: Any) -> GaitParameters:
        """The :class:`~pik_mj.walking.gait.GaitParameters` of this gait
        (``options``: its other fields, e.g. ``zmp_offsets``)."""
        own: dict[str, Any] = {"rolling_soles": self.rolling_soles}
        own["initial_stand_time"] = self.initial_stand_time
        if self.zmp_offsets:
            own["zmp_offsets"] = dict(self.zmp_offsets)
        return GaitParameters(
            step_time=self.step_time,
            step_height=self.step_height,
            dt=self.dt,
            double_support_ratio=self.double_support_time / self.step_time,
            preview_time=self.preview_time,
            gravity=self.geometry.gravity,
            **{**own, **options},
        )

    def reach_limits(self) -> ReachLimits:
        """The reach of a go-pos step (:class:`~pik_mj.walking.footsteps.ReachLimits`;
        a robot without hip yaw joint turns by at most 1 µrad a step)."""
        turn = max(self.max_turn, 1e-6)
        return ReachLimits(self.stride, self.max_stride_y, turn, self.max_inward)

    def straight_steps(
        self, n_steps: int, feet: Mapping[str, Footstep], *, first_limb: str = "lleg"
    ) -> list[Footstep]:
        """:func:`~pik_mj.walking.footsteps.straight_steps` of this gait's stride and
        foot separation from the stance ``feet``."""
        return straight_steps(
            n_steps,
            self.stride,
            feet,
            first_limb=first_limb,
            foot_separation=self.foot_separation,
        )

    def go_pos(
        self, x: float, y: float, theta: float, feet: Mapping[str, Footstep]
    ) -> list[Footstep]:
        """:func:`~pik_mj.walking.footsteps.go_pos` to ``(x [m], y [m], theta [rad])``
        within this gait's reach (:meth:`reach_limits`) and foot separation."""
        r = self.reach_limits()
        return go_pos(
            x,
            y,
            theta,
            feet,
            max_stride_x=r.max_stride_x,
            max_stride_y=r.max_stride_y,
            max_turn=r.max_turn,
            max_inward=r.max_inward,
            foot_separation=self.foot_separation,
        )

    def to_dict(self) -> dict[str, float]:
        """The values [m, s, rad], JSON-ready (with rolling soles also
        ``rolling_soles``, ``initial_stand_time`` and ``zmp_offsets``)."""
        values: dict[str, Any] = {
            f.name: getattr(self, f.name) for f in fields(self) if f.name in _DERIVED
        }
        if self.rolling_soles:
            values["rolling_soles"] = True
            values["initial_stand_time"] = self.initial_stand_time
            values["zmp_offsets"] = {lb: list(o) for lb, o in self.zmp_offsets.items()}
        return values

    def table(self) -> str:
        """One line per value: name, value with unit, and where it came from."""
        geo = self.geometry
        why = {
            "stride": f"min({REACH_RATIO} x reach {geo.reach:.3f} m, {FOOT_RATIO} x sole "
            f"length {geo.sole_size[0]:.3f} m)",
            "step_height": f"{STEP_HEIGHT_RATIO} x leg length {geo.leg_length:.3f} m",
            "step_time": f"{STEP_TIME_RATIO} x T_c = sqrt(z_c / g), rounded to dt",
            "double_support_time": "T_c (at most half a step)",
            "com_height": f"start CoM {geo.com_height:.3f} m lowered with the hip to "
            f"{HIP_RATIO} x leg length",
            "foot_separation": f"the hips' width {geo.hip_width:.3f} m (legs upright), at "
            f"least the sole's width + {FOOT_CLEARANCE} m, at most the start's "
            f"{geo.foot_separation:.3f} m",
            "dt": "pattern sampling",
            "max_stride_y": f"min({REACH_RATIO / 2} x reach, sole width {geo.sole_size[1]:.3f} m)",
            "max_turn": "min(30 deg, half the hip yaw range)",
            "max_inward": "0.1 x foot separation",
            "preview_time": "max(1.6 s, 2 steps)",
        }
        if self.rolling_soles:
            why |= {
                "stride": "the flat gait's, scaled by the step time",
                "step_height": "the flat gait's, scaled by the step time",
                "step_time": f"CoM sway {ROLL_SWAY} x the sideways reach with rolling soles",
                "double_support_time": f"{ROLL_DOUBLE_SUPPORT} x step time",
            }
        units = {"max_turn": "rad", "step_time": "s", "double_support_time": "s", "dt": "s"}
        units["preview_time"] = "s"
        lines = []
        for name in _DERIVED:
            value = getattr(self, name)
            unit = units.get(name, "m")
            shown = f"{value:.4g} {unit}" + (
                f" ({math.degrees(value):.1f} deg)" if unit == "rad" else ""
            )
            source = "given" if name in self.given else why[name]
            lines.append(f"  {name:<20} {shown:<22} {source}")
        if self.rolling_soles:
            lines += self._rolling_lines()
        return "\n".join(lines)

    def _rolling_lines(self) -> list[str]:
        """The table's lines of the rolling-sole gait (:mod:`~pik_mj.walking.rolling_gait`)."""
        offsets = ", ".join(
            f"{lb} ({o[0] * 1e3:+.0f}, {o[1] * 1e3:+.0f}) mm" for lb, o in self.zmp_offsets.items()
        )
        return [
            f"  {'rolling_soles':<20} {'yes':<22} no joint keeps a sole flat while the leg "
            "leans: the soles roll below the CoM, the pelvis rolls; steps scaled to the sway",
            f"  {'initial_stand_time':<20} {f'{self.initial_stand_time:.4g} s':<22} the flat "
            "gait's step time less this one",
            f"  {'zmp_offsets':<20} {offsets}: farthest from the sole's edges with the ankle "
            "within its torque",
        ]

    def __str__(self) -> str:
        return "gait:\n" + self.table()


_DERIVED = (
    "stride",
    "step_height",
    "step_time",
    "double_support_time",
    "com_height",
    "foot_separation",
    "dt",
    "max_stride_y",
    "max_turn",
    "max_inward",
    "preview_time",
)


def robot_gait(
    robot: Robot,
    soles: Mapping[str, Sole] | None = None,
    *,
    dt: float = DEFAULT_DT,
    **overrides: float,
) -> RobotGait:
    """The gait of ``robot`` (module docstring), each value of ``overrides`` (names
    of :class:`RobotGait`'s values) given instead of derived.

    Args:
        robot: The robot (its start pose is read, its configuration not changed).
        soles: Its soles (default :func:`pik_mj.robot.ground.robot_soles`).
        dt: Sampling time of the pattern [s].
        overrides: Values to use instead of the derived ones, e.g. ``stride=0.1``.

    Raises:
        UnknownName: An override that is not a value of the gait.
        InvalidInput: A value that is not a finite number > 0 (``max_turn``,
            ``max_inward`` >= 0), a step time shorter than 2 dt, or a robot that
            cannot walk this way: its CoM moves sideways less than half of
            :data:`SWAY_RATIO` times the feet's separation (:func:`sideways_reach`)
            both with the soles flat and with them rolling (bounded); the message
            gives the longest single support the flat reach allows
            (:func:`single_support_limit`). A robot that reaches it only with
            rolling soles (no ankle roll: Unitree H1) gets the rolling-sole gait
            (:mod:`pik_mj.walking.rolling_gait`; values given are kept).
    """
    for name in overrides:
        if name not in _DERIVED or name == "dt":
            raise UnknownName("gait value", name, [n for n in _DERIVED if n != "dt"])
    soles = robot_soles(robot) if soles is None else soles
    geo = leg_geometry(robot, soles)
    lowered = geo.hip_height - geo.walking_hip_height
    com_height = overrides.get("com_height", geo.com_height - lowered)
    reach = geo.reach
    tc = math.sqrt(com_height / geo.gravity)
    step_time = overrides.get("step_time", dt * max(2, round(STEP_TIME_RATIO * tc / dt)))
    stride = min(REACH_RATIO * reach, FOOT_RATIO * geo.sole_size[0])
    yaw = geo.hip_yaw_range
    gait = RobotGait(
        stride=stride,
        step_height=STEP_HEIGHT_RATIO * geo.leg_length,
        step_time=step_time,
        double_support_time=min(tc, 0.5 * step_time),
        com_height=com_height,
        foot_separation=min(
            geo.foot_separation, max(geo.hip_width, geo.sole_size[1] + FOOT_CLEARANCE)
        ),
        dt=float(dt),
        max_stride_y=min(0.5 * REACH_RATIO * reach, geo.sole_size[1]),
        max_turn=min(MAX_TURN, 0.5 * yaw[1]) if yaw else 0.0,
        max_inward=0.1 * geo.foot_separation,
        preview_time=max(1.6, 2.0 * step_time),
        geometry=geo,
    )
    gait = replace(gait, **overrides, given=tuple(overrides))
    _check(gait)
    need = SWAY_RATIO * gait.foot_separation
    reach = sideways_reach(robot, soles, need)
    if reach >= 0.5 * need:
        return gait
    rolled = sideways_reach(robot, soles, need, rolling_soles=True)
    edge = 0.5 * (gait.foot_separation - geo.sole_size[1])
    if rolled < 0.5 * need:
        limit = single_support_limit(reach, edge, tc)
        raise InvalidInput(
            f"the robot cannot move its CoM sideways with both soles flat: {reach * 1e3:.0f} mm "
            f"of the {need * 1e3:.0f} mm a step of the cart-table walk needs (its legs have "
            "no joint that keeps a sole flat while the leg leans sideways); with the ZMP on "
            f"the stance sole, {edge * 1e3:.0f} mm to the side, its CoM leaves that range after "
            f"{limit * 1e3:.0f} ms of single support (T_c {tc:.2f} s), of the "
            f"{gait.step_time - gait.double_support_time:.2f} s a step needs; with the soles "
            f"rolling about their long axis, {rolled * 1e3:.0f} mm"
        )
    flat = {"step_time": dt * max(2, round(STEP_TIME_RATIO * tc / dt))}
    flat |= {"stride": gait.stride, "step_height": gait.step_height}
    edge = 0.5 * gait.foot_separation
    values = rolling_values(rolled, edge, tc, dt, flat, overrides.get("step_time"))
    values = {k: v for k, v in values.items() if k not in overrides}
    step_time = values.get("step_time", gait.step_time)
    rolling = replace(
        gait,
        **values,
        preview_time=overrides.get("preview_time", max(1.6, 2.0 * step_time)),
        rolling_soles=True,
        zmp_offsets=sole_zmp_offsets(robot, soles, PITCH_AXIS),
    )
    _check(rolling)
    return rolling


def gait_value(text: str) -> tuple[str, float]:
    """``"name=value"`` (a command line's ``--gait stride=0.1``) as ``(name, value)``:
    a value of :class:`RobotGait` given instead of derived (:func:`robot_gait`).

    Raises:
        InvalidInput: Not ``name=value``, an unknown name, or a value that is no number.
    """
    name, sep, value = text.partition("=")
    valid = [n for n in _DERIVED if n != "dt"]
    if not sep or name.strip() not in valid:
        raise InvalidInput(f"give NAME=VALUE with NAME one of {valid}, got {text!r}")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise InvalidInput(f"{name.strip()}: {value!r} is not a number") from None


def sideways_reach(
    robot: Robot, soles: Mapping[str, Sole], distance: float, *, rolling_soles: bool = False
) -> float:
    """How far [m] the robot's CoM moves sideways, towards each foot, with both soles
    flat where they stand (the smaller of the two): the prioritized IK
    (:func:`pik_mj.solve.solve`) from the start pose with the knees bent
    (:func:`~pik_mj.walking.wholebody.bent_knees`), its joint limits, both feet at
    their poses, then the CoM ``distance`` [m] to the side at the same height. The
    robot's configuration is restored.

    The cart-table walk moves the CoM sideways between the feet during double
    support; a robot whose legs cannot (no roll joint between hip and sole
    that keeps the sole flat while the leg leans) reaches a few millimetres.
    With ``rolling_soles`` each sole's roll about its long axis is asked flat
    below the CoM, not with the feet (:mod:`pik_mj.walking.walk_tasks`), and the
    reach is what the soles' bounded roll allows
    (:func:`~pik_mj.walking.rolling_gait.bounded_reach`).
    """
    configuration = robot.configuration
    q0 = configuration.q.copy()
    model, data = robot.model, robot.data
    adr = model.jnt_dofadr[model.body_jntadr[robot.root_body_id]]
    configuration.update(robot.start_q())
    feet = [robot.frame_pose(sole.body, "body") for sole in soles.values()]
    start, lateral = robot.com(), _lateral(soles, model, data)
    reached = []
    try:
        for side in (-1.0, 1.0):
            configuration.update(bent_knees(robot, list(soles)))
            roll = "x" if rolling_soles else True  # "x": the roll about x free
            tasks = [
                FrameTask(configuration, sole.body, X, move_target_type="body", rotation_axis=roll)
                for sole, X in zip(soles.values(), feet, strict=True)
            ]
            flat = list(flat_sole_tasks(robot, soles).values()) if rolling_soles else []
            for task, X in zip(flat, feet, strict=False):
                task.set_target(X)
            com = CentroidTask(configuration, start + side * distance * lateral)
            levels = [
                guard_level(configuration, robot.joint_names, range(adr, adr + 6)),
                tasks,
                [com],
                *([flat] if flat else []),
                [posture_task(configuration, 1e-2)],
            ]
            solve(configuration, levels, stop=60, revert_if_fail=False, qp_solver="daqp")
            reach = float(abs((robot.com() - start) @ lateral))
            if rolling_soles:
                rotations = [sole.pose(model, data)[1] for sole in soles.values()]
                reach = bounded_reach(reach, rotations, min(s.size[1] for s in soles.values()))
            reached.append(reach)
    finally:
        configuration.update(q0)
    return min(reached)


def single_support_limit(reach: float, edge: float, tc: float) -> float:
    """The longest single support [s] after which the CoM is back within ``reach``
    [m] of the mid-feet, as both soles flat require when the swing foot lands.

    Both soles flat hold the CoM within :math:`\\pm r` (``reach``, at rest); the
    stance sole's ZMP is at least :math:`e` (``edge``: half the feet's separation
    less half the sole's width) to the side. The cart-table's pendulum,
    :math:`\\ddot c = (c - p) / T_c^2`, from :math:`c_0 = r` at rest with :math:`p = e`
    (the best case: the CoM as near the stance sole as it gets, the ZMP at its
    inner edge) moves the CoM away from the stance sole,
    :math:`c(t) = e - (e - r) \\cosh(t / T_c)`, past :math:`-r` at

    .. math::

        T_{ss} = T_c \\operatorname{arccosh}\\left(1 + \\frac{2 r}{e - r}\\right)

    (and still moving there, so a walk needs a single support well short of it).

    Args:
        reach: r [m], :func:`sideways_reach`.
        edge: e [m] > r.
        tc: T_c = sqrt(z_c / g) [s].
    """
    return tc * math.acosh(1.0 + 2.0 * reach / max(edge - reach, 1e-12))


def _lateral(soles: Mapping[str, Sole], model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Unit horizontal vector from the first sole to the second (3,)."""
    a, b = (sole.pose(model, data)[0] for sole in soles.values())
    d = (b - a) * [1.0, 1.0, 0.0]
    return d / max(float(np.linalg.norm(d)), 1e-12)


def _check(gait: RobotGait) -> None:
    for name in _DERIVED:
        value = getattr(gait, name)
        low_open = name not in ("max_turn", "max_inward")
        if not (
            isinstance(value, (int, float))
            and math.isfinite(value)
            and (value > 0 if low_open else value >= 0)
        ):
            bound = "> 0" if low_open else ">= 0"
            raise InvalidInput(f"gait value {name} must be a finite number {bound}, got {value!r}")
    if gait.step_time < 2 * gait.dt:
        raise InvalidInput(f"step_time {gait.step_time} s is shorter than 2 dt ({2 * gait.dt} s)")
    if gait.double_support_time >= gait.step_time:
        raise InvalidInput(
            f"double_support_time {gait.double_support_time} s must be shorter than the "
            f"step_time {gait.step_time} s"
        )
