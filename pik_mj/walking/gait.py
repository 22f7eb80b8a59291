"""Gait timing, ZMP reference, swing trajectories and CoM (irteus manual, "歩行動作生成").

irteus manual: ``:calc-walk-pattern-from-footstep-list`` and the ``gait-generator``
it runs.
This module produces everything except the joint angles: per tick the ZMP
reference, both feet, the support state and the CoM from the preview controller.
The whole-body IK per tick is done elsewhere on top of a :class:`GaitPlan`.

Mapping to the irteus manual's ``footstep-list``: its first element only names the
leg that is considered already placed (its coordinates are taken from the robot,
not from the element), and stepping starts at the second element. Here the
current stance of every limb is given explicitly as ``initial_feet`` and
``footsteps`` holds only the executed steps, i.e. the manual's
``(cdr footstep-list)``.

Timeline (irteus manual: ``gait-generator``), with step time :math:`T`, double support
ratio :math:`r` and :math:`S` footsteps: phase 0 stands for :math:`T_0 + T` with
the ZMP at its start point (:math:`T_0` the ``initial_stand_time``, 0 by
default), phases :math:`1 \\ldots S` execute one footstep each, and phase
:math:`S+1` stands for :math:`T` with the ZMP at its end point, so

.. math::

    t_{total} = T_0 + (S + 2) T, \\qquad t_k = k \\Delta t,\\ k = 0 \\ldots
    \\lfloor t_{total} / \\Delta t \\rfloor

(the local time of phase 0 runs from :math:`-T_0`).

Within a phase (local time :math:`\\tau \\in [0, T)`, :math:`t_m = r T / 2`) the
first and last :math:`t_m` are double support and the ZMP reference moves
linearly from the previous support point to the current one and on to the next
one, crossing each phase boundary at their midpoint:

.. math::

    p^{ref}(\\tau) = \\begin{cases}
      z_j + \\frac{t_m - \\tau}{2 t_m} (z_{j-1} - z_j) & \\tau < t_m \\\\
      z_j + \\frac{\\tau - (T - t_m)}{2 t_m} (z_{j+1} - z_j) & \\tau > T - t_m \\\\
      z_j & \\text{otherwise.}
    \\end{cases}

The swing foot follows a cycloid over single support, :math:`\\sigma = (\\tau -
t_m) / ((1 - r) T) \\in [0, 1]`, :math:`\\phi = 2 \\pi \\sigma`:

.. math::

    s = \\frac{\\phi - \\sin\\phi}{2\\pi}, \\quad
    p_{xy} = p^{src}_{xy} + s (p^{dst}_{xy} - p^{src}_{xy}), \\quad
    p_z = p^{src}_z + s (p^{dst}_z - p^{src}_z) + h \\frac{1 - \\cos\\phi}{2},
    \\quad \\psi = \\psi^{src} + s\\, \\mathrm{wrap}(\\psi^{dst} - \\psi^{src}),

so velocity is zero at lift-off and touch-down and the foot rises :math:`h` above
the straight line at mid-swing.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.spatial import STANDARD_GRAVITY, rot_z
from pik_mj.walking.preview import PreviewController

__all__ = [
    "Footstep",
    "GaitParameters",
    "GaitPlan",
    "mid_frame",
    "normalize_feet",
    "plan_gait",
    "wrap_angle",
]

DOUBLE_SUPPORT = "double"


def wrap_angle(angle: float | np.ndarray) -> float | np.ndarray:
    """Angle wrapped to [-pi, pi) [rad]."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


@dataclass(frozen=True)
class Footstep:
    """Pose of a limb's sole frame on the ground.

    Attributes:
        limb: Limb that moves there (e.g. ``"rleg"``, ``"lleg"``).
        p_W: Sole frame origin in the world (3,) in [m].
        yaw: Sole frame heading about world z in [rad].
    """

    limb: str
    p_W: np.ndarray
    yaw: float

    def __post_init__(self) -> None:
        if not isinstance(self.limb, str):
            raise InvalidInput(f"Footstep.limb must be a str, got {self.limb!r}")
        p = np.asarray(self.p_W, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InvalidInput(f"Footstep.p_W must be a finite (3,) position [m], got {self.p_W!r}")
        yaw = float(self.yaw)
        if not np.isfinite(yaw):
            raise InvalidInput(f"Footstep.yaw must be finite [rad], got {self.yaw!r}")
        p = p.copy()
        p.flags.writeable = False
        object.__setattr__(self, "p_W", p)
        object.__setattr__(self, "yaw", yaw)

    @property
    def R_WF(self) -> np.ndarray:
        """Rotation of the sole frame in the world (3, 3)."""
        return rot_z(self.yaw)

    def point(self, p_F: np.ndarray) -> np.ndarray:
        """World position of a point given in the sole frame [m]."""
        return self.p_W + self.R_WF @ np.asarray(p_F, dtype=float)

    def __repr__(self) -> str:
        x, y, z = self.p_W
        return f"Footstep({self.limb!r}, p_W=[{x:.4f}, {y:.4f}, {z:.4f}], yaw={self.yaw:.4f})"


def normalize_feet(
    feet: Mapping[str, Footstep | tuple[Sequence[float], float]],
    all_limbs: Sequence[str],
) -> dict[str, Footstep]:
    """Stance of every limb as ``{limb: Footstep}`` from Footsteps or ``(p, yaw)``.

    Args:
        feet: One entry per limb of ``all_limbs``.
        all_limbs: Valid limb names.

    Returns:
        Dict ordered as ``all_limbs``.
    """
    out: dict[str, Footstep] = {}
    for limb, value in feet.items():
        if limb not in all_limbs:
            raise UnknownName("limb", limb, all_limbs)
        if isinstance(value, Footstep):
            if value.limb != limb:
                raise InvalidInput(f"feet[{limb!r}] is a Footstep of limb {value.limb!r}")
            out[limb] = value
        else:
            try:
                p, yaw = value
            except (TypeError, ValueError) as exc:
                raise InvalidInput(
                    f"feet[{limb!r}] must be a Footstep or (p (3,), yaw), got {value!r}"
                ) from exc
            out[limb] = Footstep(limb, np.asarray(p, dtype=float), yaw)
    missing = [limb for limb in all_limbs if limb not in out]
    if missing:
        raise InvalidInput(f"feet is missing limbs {missing}; need all of {list(all_limbs)}")
    return {limb: out[limb] for limb in all_limbs}


def mid_frame(feet: Mapping[str, Footstep]) -> tuple[np.ndarray, float]:
    """Mid-feet frame (irteus manual: ``:foot-midcoords``): mean position and mean heading.

    .. math::

        p_{WM} = \\frac{1}{n}\\sum_i p_{WF_i}, \\quad
        \\psi_M = \\mathrm{atan2}\\Big(\\sum_i \\sin\\psi_i, \\sum_i \\cos\\psi_i\\Big)

    Returns:
        ``(p_WM (3,) [m], yaw_M [rad])``.
    """
    steps = list(feet.values())
    p = np.mean([f.p_W for f in steps], axis=0)
    yaw = float(np.arctan2(sum(np.sin(f.yaw) for f in steps), sum(np.cos(f.yaw) for f in steps)))
    return p, yaw


def _finite(
    name: str,
    value: float,
    *,
    low: float | None = None,
    low_open: bool = False,
    high: float | None = None,
    high_open: bool = False,
) -> float:
    value = float(value)
    ok = np.isfinite(value)
    if ok and low is not None:
        ok = value > low if low_open else value >= low
    if ok and high is not None:
        ok = value < high if high_open else value <= high
    if not ok:
        lo = "" if low is None else ("(" if low_open else "[") + f"{low}"
        hi = "" if high is None else f"{high}" + (")" if high_open else "]")
        raise InvalidInput(
            f"{name} must be finite and in {lo or '(-inf'}, {hi or 'inf)'}; got {value!r}"
        )
    return value


@dataclass(frozen=True)
class GaitParameters:
    """Parameters of :func:`plan_gait` (irteus manual:
    ``:calc-walk-pattern-from-footstep-list``).

    Attributes:
        step_time: Duration of one step T in [s] (irteus manual: ``default-step-time``).
        step_height: Cycloid height h of the swing foot in [m].
        dt: Sampling time of the plan and of preview control in [s] (the irteus
            manual's default is 0.1 s; 0.01 s gives smooth trajectories).
        double_support_ratio: Fraction r of each step in double support, in [0, 1);
            half at the start, half at the end of the step.
        zmp_offsets: ZMP reference point per limb in its sole frame (3,) in [m];
            missing limbs use zero.
        start_with_double_support: Initial ZMP at the mean of all feet (True) or of
            the feet that support the first step (False).
        end_with_double_support: Final ZMP at the mean of all feet (True) or of the
            feet that supported the last step (False).
        all_limbs: The two legs, in order.
        q: Preview control weight on the ZMP error [1/m^2].
        r: Preview control weight on the jerk increment [s^6/m^2].
        preview_time: Preview horizon in [s].
        gravity: Gravitational acceleration in [m/s^2]; None: the robot model's
            (:func:`pik_mj.walking.wholebody.calc_walk_pattern`), or
            :data:`pik_mj.spatial.STANDARD_GRAVITY` for a plan made without one.
        initial_stand_time: T_0, standing added before the first step [s] (module
            docstring).
        rolling_soles: Let the soles roll about their long axis below the CoM and
            the root roll (:mod:`pik_mj.walking.walk_tasks`): for legs without
            ankle roll.
    """

    step_time: float = 1.0
    step_height: float = 0.05
    dt: float = 0.01
    double_support_ratio: float = 0.2
    zmp_offsets: Mapping[str, Sequence[float]] = field(default_factory=dict)
    start_with_double_support: bool = True
    end_with_double_support: bool = True
    all_limbs: tuple[str, ...] = ("rleg", "lleg")
    q: float = 1.0
    r: float = 1e-6
    preview_time: float = 1.6
    gravity: float | None = None
    initial_stand_time: float = 0.0
    rolling_soles: bool = False

    def __post_init__(self) -> None:
        _finite("initial_stand_time", self.initial_stand_time, low=0.0)
        _finite("step_time", self.step_time, low=0.0, low_open=True)
        _finite("step_height", self.step_height, low=0.0)
        _finite("dt", self.dt, low=0.0, low_open=True)
        if self.dt > self.step_time:
            raise InvalidInput(f"dt ({self.dt} s) must not exceed step_time ({self.step_time} s)")
        _finite(
            "double_support_ratio",
            self.double_support_ratio,
            low=0.0,
            high=1.0,
            high_open=True,
        )
        _finite("q", self.q, low=0.0, low_open=True)
        _finite("r", self.r, low=0.0, low_open=True)
        _finite("preview_time", self.preview_time, low=0.0, low_open=True)
        if self.gravity is not None:
            _finite("gravity", self.gravity, low=0.0, low_open=True)
        limbs = tuple(self.all_limbs)
        if len(limbs) != 2 or len(set(limbs)) != 2 or not all(isinstance(x, str) for x in limbs):
            raise InvalidInput(f"all_limbs must be two distinct limb names, got {self.all_limbs!r}")
        object.__setattr__(self, "all_limbs", limbs)
        offsets: dict[str, np.ndarray] = {}
        for limb, offset in dict(self.zmp_offsets).items():
            if limb not in limbs:
                raise UnknownName("limb", limb, limbs)
            o = np.asarray(offset, dtype=float)
            if o.shape != (3,) or not np.all(np.isfinite(o)):
                raise InvalidInput(
                    f"zmp_offsets[{limb!r}] must be a finite (3,) offset [m], got {offset!r}"
                )
            offsets[limb] = o
        for limb in limbs:
            offsets.setdefault(limb, np.zeros(3))
        object.__setattr__(self, "zmp_offsets", offsets)


@dataclass(frozen=True)
class GaitPlan:
    """Walking pattern without joint angles; row k is time ``t[k] = k dt``.

    Attributes:
        t: Sample times (K,) in [s].
        dt: Sampling time in [s].
        zmp_ref: ZMP reference (K, 2) in [m], world x, y.
        feet_p: Sole frame origin per limb, (K, 3) in [m].
        feet_yaw: Sole frame heading per limb, (K,) in [rad] (unwrapped).
        support: (K,) labels: ``"double"`` or the single support limb.
        swing_phase: (K,) single-support time ratio :math:`\\sigma \\in [0, 1]` of the
            current phase (0 in phases without a step).
        step_index: (K,) phase of each sample: 0 initial stand, j = 1..S footstep
            ``footsteps[j-1]``, S+1 final stand.
        com: CoM (K, 2) in [m] from preview control of ``zmp_ref``.
        com_vel: CoM velocity (K, 2) in [m/s].
        com_acc: CoM acceleration (K, 2) in [m/s^2].
        zmp: Cart-table ZMP of the CoM trajectory (K, 2) in [m].
        com_height: Constant CoM height above the ground plane z_ground [m].
        ground_z: Height of the ZMP plane (mean initial sole height) [m].
        footsteps: The executed footsteps.
        initial_feet: Stance before walking.
        final_feet: Stance after walking.
        final_midpoint: Mean of the final sole positions (3,) in [m].
        params: The parameters used.
    """

    t: np.ndarray
    dt: float
    zmp_ref: np.ndarray
    feet_p: dict[str, np.ndarray]
    feet_yaw: dict[str, np.ndarray]
    support: np.ndarray
    swing_phase: np.ndarray
    step_index: np.ndarray
    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    zmp: np.ndarray
    com_height: float
    ground_z: float
    footsteps: tuple[Footstep, ...]
    initial_feet: dict[str, Footstep]
    final_feet: dict[str, Footstep]
    final_midpoint: np.ndarray
    params: GaitParameters

    @property
    def duration(self) -> float:
        """Total duration :math:`(S + 2) T` in [s]."""
        return (len(self.footsteps) + 2) * self.params.step_time

    @property
    def com_W(self) -> np.ndarray:
        """CoM (K, 3) in [m] with z = ground_z + com_height."""
        z = np.full((len(self.t), 1), self.ground_z + self.com_height)
        return np.hstack([self.com, z])

    def __repr__(self) -> str:
        return (
            f"GaitPlan({len(self.footsteps)} steps, {len(self.t)} samples, "
            f"dt={self.dt}, duration={self.duration} s)"
        )


def plan_gait(
    initial_feet: Mapping[str, Footstep | tuple[Sequence[float], float]],
    footsteps: Sequence[Footstep],
    params: GaitParameters | None = None,
    *,
    com_height: float,
) -> GaitPlan:
    """Walking pattern (feet, ZMP reference, CoM) from a footstep list.

    Each footstep names the limb that swings and where its sole lands; the other
    limb supports. The ZMP point of a foot F is :math:`p_{WF} + R_{WF}\\,o_F` with
    ``params.zmp_offsets[F]`` = :math:`o_F`; the support point of a phase is the
    mean over its support feet. See the module docstring for the timeline, the
    ZMP interpolation and the cycloid.

    Args:
        initial_feet: Stance of both limbs, ``{limb: Footstep | (p_W, yaw)}``.
        footsteps: Executed steps (the irteus manual's footstep-list without its first
            element).
        params: Gait parameters; defaults to :class:`GaitParameters()`.
        com_height: CoM height above the ground plane in [m].

    Returns:
        The :class:`GaitPlan`.
    """
    params = GaitParameters() if params is None else params
    com_height = _finite("com_height", com_height, low=0.0, low_open=True)
    limbs = params.all_limbs
    feet0 = normalize_feet(initial_feet, limbs)
    steps = tuple(footsteps)
    for i, step in enumerate(steps):
        if not isinstance(step, Footstep):
            raise InvalidInput(f"footsteps[{i}] must be a Footstep, got {type(step).__name__}")
        if step.limb not in limbs:
            raise UnknownName("limb", step.limb, limbs)
    stances = _stances(feet0, steps)
    T, dt, T0 = params.step_time, params.dt, params.initial_stand_time
    n_samples = int(np.floor((T0 + (len(steps) + 2) * T) / dt + 1e-9)) + 1
    t = np.arange(n_samples) * dt
    phase = np.clip(np.floor((t - T0) / T + 1e-9).astype(int), 0, len(steps) + 1)
    tau = t - T0 - phase * T
    zmp_ref = _zmp_reference(_support_points(stances, steps, params), phase, tau, params)
    feet_p, feet_yaw, support, swing_phase = _feet(stances, steps, phase, tau, params)
    controller = PreviewController(
        dt,
        com_height,
        q=params.q,
        r=params.r,
        preview_time=params.preview_time,
        gravity=STANDARD_GRAVITY if params.gravity is None else params.gravity,
    )
    result = controller.run(zmp_ref[:, :2])
    final_feet = {lb: Footstep(lb, stances[-1][lb].p_W, stances[-1][lb].yaw) for lb in limbs}
    return GaitPlan(
        t=t,
        dt=dt,
        zmp_ref=zmp_ref[:, :2],
        feet_p=feet_p,
        feet_yaw=feet_yaw,
        support=support,
        swing_phase=swing_phase,
        step_index=phase,
        com=result.com,
        com_vel=result.com_vel,
        com_acc=result.com_acc,
        zmp=result.zmp,
        com_height=com_height,
        ground_z=float(np.mean([f.p_W[2] for f in feet0.values()])),
        footsteps=steps,
        initial_feet=feet0,
        final_feet=final_feet,
        final_midpoint=np.mean([f.p_W for f in final_feet.values()], axis=0),
        params=params,
    )


def _stances(feet0: dict[str, Footstep], steps: tuple[Footstep, ...]) -> list[dict[str, Footstep]]:
    """The stance after each footstep, ``stances[0]`` the initial one; a foot's
    heading stays continuous (no 2 pi jumps)."""
    stances = [dict(feet0)]
    for step in steps:
        stance = dict(stances[-1])
        src = stance[step.limb]
        yaw = src.yaw + float(wrap_angle(step.yaw - src.yaw))
        stance[step.limb] = Footstep(step.limb, step.p_W, yaw)
        stances.append(stance)
    return stances


def _support_points(
    stances: list[dict[str, Footstep]], steps: tuple[Footstep, ...], params: GaitParameters
) -> np.ndarray:
    """The ZMP support point of each phase (S + 2, 3) [m]: the mean of the ZMP
    points of its support feet (module docstring)."""
    limbs, offsets, n_steps = params.all_limbs, params.zmp_offsets, len(steps)

    def zmp_point(feet: Mapping[str, Footstep], support: Sequence[str]) -> np.ndarray:
        return np.mean([feet[lb].point(offsets[lb]) for lb in support], axis=0)

    z = np.empty((n_steps + 2, 3))
    if params.start_with_double_support or n_steps == 0:
        z[0] = zmp_point(stances[0], limbs)
    else:
        z[0] = zmp_point(stances[0], [lb for lb in limbs if lb != steps[0].limb])
    for j, step in enumerate(steps, start=1):
        z[j] = zmp_point(stances[j - 1], [lb for lb in limbs if lb != step.limb])
    if params.end_with_double_support or n_steps == 0:
        z[-1] = zmp_point(stances[-1], limbs)
    else:
        z[-1] = zmp_point(stances[-1], [lb for lb in limbs if lb != steps[-1].limb])
    return z


def _zmp_reference(
    z: np.ndarray, phase: np.ndarray, tau: np.ndarray, params: GaitParameters
) -> np.ndarray:
    """The ZMP reference (K, 3) [m] at the samples of ``phase`` (index) and
    ``tau`` (local time [s]): the support points ``z`` joined linearly over
    each double support (module docstring)."""
    T = params.step_time
    t_m = 0.5 * params.double_support_ratio * T
    cur = z[phase]
    prev = z[np.maximum(phase - 1, 0)]
    nxt = z[np.minimum(phase + 1, len(z) - 1)]
    zmp_ref = cur.copy()
    if t_m > 0.0:
        a = tau < t_m
        zmp_ref[a] += ((t_m - tau[a]) / (2.0 * t_m))[:, None] * (prev[a] - cur[a])
        e = tau > T - t_m
        zmp_ref[e] += ((tau[e] - (T - t_m)) / (2.0 * t_m))[:, None] * (nxt[e] - cur[e])
    return zmp_ref


def _feet(
    stances: list[dict[str, Footstep]],
    steps: tuple[Footstep, ...],
    phase: np.ndarray,
    tau: np.ndarray,
    params: GaitParameters,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Both feet at every sample (``feet_p`` (K, 3) [m], ``feet_yaw`` (K,)
    [rad]), the support label and the swing phase (:class:`GaitPlan`): the
    swing foot on its cycloid (module docstring), the others on their stance."""
    limbs, n_steps, T = params.all_limbs, len(steps), params.step_time
    t_m = 0.5 * params.double_support_ratio * T
    n_samples = len(phase)
    sigma = np.clip((tau - t_m) / (T - 2.0 * t_m), 0.0, 1.0)
    stepping = (phase >= 1) & (phase <= n_steps)
    swing_phase = np.where(stepping, sigma, 0.0)
    eps = 1e-9 * T  # samples on a phase boundary up to rounding count as on it
    single = stepping & (tau > t_m + eps) & (tau < T - t_m - eps)
    support = np.full(n_samples, DOUBLE_SUPPORT, dtype=object)
    feet_p = {lb: np.empty((n_samples, 3)) for lb in limbs}
    feet_yaw = {lb: np.empty(n_samples) for lb in limbs}
    phi = 2.0 * np.pi * sigma
    s = (phi - np.sin(phi)) / (2.0 * np.pi)
    lift = 0.5 * params.step_height * (1.0 - np.cos(phi))
    for j in range(n_steps + 2):
        rows = phase == j
        swing = steps[j - 1].limb if 1 <= j <= n_steps else None
        for lb in limbs:
            src = stances[max(j - 1, 0)][lb]  # stance at the start of phase j
            if lb != swing:
                feet_p[lb][rows] = src.p_W
                feet_yaw[lb][rows] = src.yaw
                continue
            dst = stances[j][lb]
            sj = s[rows]
            p = src.p_W + sj[:, None] * (dst.p_W - src.p_W)
            p[:, 2] += lift[rows]
            feet_p[lb][rows] = p
            feet_yaw[lb][rows] = src.yaw + sj * (dst.yaw - src.yaw)
        if swing is not None:
            support[rows & single] = next(lb for lb in limbs if lb != swing)
    return feet_p, feet_yaw, support, swing_phase
