r"""The torques a timed path needs, and the timing that keeps them within what
the robot's drives deliver (:func:`plan_torques`).

At knots ``σ_k`` of the path's nominal time (of the grid every
:data:`KNOT_SPACING` and at each waypoint, :class:`~pik_mj.sim.timing.Timing`:
the segments' ends, and the grid's knots between them where the plan linear
between its knots would miss the torques by more than :data:`KNOT_TOLERANCE`,
found by bisection) the reference is ``q(σ)``, ``q̇ = q' σ̇`` and
``q̈ = q' σ̈`` with ``q' = dq/dσ`` (the blends' curvature ``q'' σ̇²`` at the
path's interior waypoints, :class:`~pik_mj.sim.blends.BlendedPath`, smooth and
bounded, is left to the servos' feedback), so the torques the servo joints
need are

.. math::

    τ = τ_s + P\,\big(M(q)\, q'\, \ddot σ + c(q, q')\, \dot σ^2 + D q'\, \dot σ\big)

``τ_s`` the torques at rest (:func:`pik_mj.sim.torques.holding_torques`: gravity,
the least-norm contact forces within their friction pyramids, the external
wrenches), ``M q'``, the velocity product ``c`` and the joints' damping ``D q'``
from MuJoCo's inverse dynamics (``mj_inverse`` at ``q̈ = q'`` and at
``q̇ = ±q'``), and ``P`` the map that lets the contacts carry the free joint's
part of a generalized force (the least-norm contact forces that apply it,
without their limits: the moving part is small beside the weight). With the
drive's bounds ``[τ_min, τ_max]`` at the knot's pose
(:func:`pik_mj.sim.drives.servo_bounds`: force and control ranges, the gains
of a position actuator near a range end, the joint giving way a little):

* ``τ_s`` outside the bounds at a knot: the drives cannot hold the path even
  quasi-statically; the joint, its torque and bound are a
  :class:`~pik_mj.sim.drives.DriveShortfall` and the path is not played;
* ``τ`` outside ``ρ [τ_min, τ_max]`` (``ρ`` = :data:`DRIVE_RESERVE`; the rest
  is left to the servo's feedback): the knot's segment is slowed down.
  Stretching a segment's duration by ``c`` scales ``σ̇`` by ``1/c`` and ``σ̈`` by
  ``1/c²`` at every ``σ``; the stretch is the smallest ``c`` (bisection, at most
  :data:`MAX_STRETCH`) that brings every knot of the segment inside (or, where
  ``τ_s`` is already past ``ρ`` of a bound, no farther out than ``τ_s``).

The moving torques are the servos' feed-forward (:meth:`TorquePlan.at`,
linear in ``σ`` between knots): they go through the actuators' controls
(:class:`~pik_mj.sim.servos.ServoLaw`), so MuJoCo clamps them with the rest.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from pik_mj.sim.blends import BlendedPath
from pik_mj.sim.drives import DriveShortfall, servo_bounds, shortfalls
from pik_mj.sim.knots import KNOT_SPACING, PathDynamics, knot_grid
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.timing import Timing

__all__ = [
    "DRIVE_RESERVE",
    "KNOT_SPACING",
    "KNOT_TOLERANCE",
    "MAX_STRETCH",
    "TorquePlan",
    "plan_torques",
]

KNOT_TOLERANCE = 0.005
"""Share of the largest rest torque by which the plan linear between two knots
may miss the feed-forward at the knot between them (:func:`_refined`)."""

DRIVE_RESERVE = 0.8
"""Share ``ρ`` of a drive's torque bounds a path's planned torques may use."""

MAX_STRETCH = 10.0
"""Largest factor by which a segment is slowed down for its drives."""


@dataclass
class TorquePlan:
    """The torques of a path (module docstring), at knots with an equilibrium.

    Attributes:
        sigma: Knot nominal times [s] (k,).
        rest: ``τ_s`` (k, nv) [N·m or N] on the robot's dofs.
        inertia: ``P M q'`` (k, nv) [N·m·s²]: per unit ``σ̈``.
        velocity: ``P c(q, q')`` (k, nv) [N·m·s²]: per unit ``σ̇²``.
        damping: ``P D q'`` (k, nv) [N·m·s]: per unit ``σ̇``.
        shortfalls: Joints whose drive cannot hold a knot's pose at rest (the
            worst knot of each); empty when the path can be played.
        stretched: Segments slowed down for their drives, ``{segment index: c}``.
    """

    sigma: np.ndarray
    rest: np.ndarray
    inertia: np.ndarray
    velocity: np.ndarray
    damping: np.ndarray
    shortfalls: list[DriveShortfall] = field(default_factory=list)
    stretched: dict[int, float] = field(default_factory=dict)

    def at(
        self,
        sigma: np.ndarray,
        rate: np.ndarray,
        accel: np.ndarray,
        dofs: np.ndarray | None = None,
    ) -> np.ndarray | None:
        """The feed-forward (n, nv) at nominal times ``σ`` [s] with ``σ̇`` [-] and
        ``σ̈`` [1/s]: each term linear in ``σ`` between knots, constant outside;
        with ``dofs``, its columns of those dofs only (n, len(dofs)); None
        without knots."""
        if not len(self.sigma):
            return None
        sigma = np.atleast_1d(np.asarray(sigma, dtype=float))
        last = len(self.sigma) - 1
        k = np.minimum(np.maximum(np.searchsorted(self.sigma, sigma, side="right") - 1, 0), last)
        nxt = np.minimum(k + 1, last)
        span = self.sigma[nxt] - self.sigma[k]
        ratio = (sigma - self.sigma[k]) / np.where(span > 0, span, 1)
        w = np.where(span > 0, np.minimum(np.maximum(ratio, 0), 1), 0)[:, None]
        v = 1 - w
        rate, accel = np.asarray(rate, float)[:, None], np.asarray(accel, float)[:, None]

        def lerp(a: np.ndarray) -> np.ndarray:
            a = a if dofs is None else a[:, dofs]
            return v * a[k] + w * a[nxt]

        return (
            lerp(self.rest)
            + lerp(self.inertia) * accel
            + lerp(self.velocity) * rate**2
            + lerp(self.damping) * rate
        )


class _Knots:
    """The reference's poses and rates at knots (the plan's workspace)."""

    def __init__(self, scene: Physics, timing: Timing, dynamics: PathDynamics):
        self.scene, self.timing, self.dynamics = scene, timing, dynamics
        self.rm = scene.robot.model
        self.actuators = np.array([scene.servo_actuators[j] for j in scene.servo_joints], int)

    def parts(self, sigma: float) -> tuple[np.ndarray, np.ndarray | None]:
        """``q(σ)`` and ``τ_s``, ``P M q'``, ``P c(q, q')``, ``P D q'`` (4, nv of
        the robot) at a knot (:class:`~pik_mj.sim.knots.Knot`), or None without
        an equilibrium."""
        knot = self.dynamics.at(sigma, support=True)
        support, nv = knot.support, self.rm.nv
        rest = support.hold(knot.rest)
        if rest is None:
            return knot.q, None
        return knot.q, np.array(
            [
                rest[:nv],
                support.carry(knot.inertia)[:nv],
                support.carry(knot.velocity)[:nv],
                support.carry(knot.damping)[:nv],
            ]
        )

    def bounds(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Torque bounds (k, servos) of the servo joints at rest at the poses ``qs``
        (:func:`~pik_mj.sim.drives.servo_bounds`)."""
        model, nq = self.scene.model, self.scene.robot_nq
        qpos = np.tile(model.qpos0, (len(qs), 1))
        qpos[:, :nq] = qs
        return servo_bounds(model, self.actuators, qpos)


def _fits(
    plan: TorquePlan, dofs: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Per knot, at rates ``(σ̇, σ̈)`` (k,) each: the moving torques
    ``τ_s + P M q' σ̈ + P c σ̇² + P D q' σ̇`` (:meth:`TorquePlan.at` at the knots
    themselves) are within ``ρ`` of the bounds (or no farther out than at rest);
    rates with leading axes (..., k) give (..., k)."""
    rest, inertia, velocity, damping = (
        x[:, dofs] for x in (plan.rest, plan.inertia, plan.velocity, plan.damping)
    )
    top = np.maximum(DRIVE_RESERVE * hi, rest) + 1e-9
    bottom = np.minimum(DRIVE_RESERVE * lo, rest) - 1e-9

    def fits(rate: np.ndarray, accel: np.ndarray) -> np.ndarray:
        rate, accel = rate[..., None], accel[..., None]
        tau = rest + inertia * accel + velocity * rate**2 + damping * rate
        return ((tau <= top) & (tau >= bottom)).all(axis=-1)

    return fits


def _stretch(plan: TorquePlan, knots: _Knots, lo: np.ndarray, hi: np.ndarray) -> None:
    """Slow down each segment whose knots need it (:meth:`Timing.stretch_until`;
    ``_fits`` is knot by knot)."""
    fits = _fits(plan, knots.scene.servo_dofs, lo, hi)
    plan.stretched.update(knots.timing.stretch_until(plan.sigma, fits, MAX_STRETCH))


def _refined(grid: np.ndarray, knots: _Knots, evaluate) -> dict[int, tuple]:
    """The knots of ``grid`` evaluated (``{index: evaluate(σ)}``): the ends of
    each segment (where its timing rests), and between two evaluated knots
    ``a < b`` the middle one ``m``; the knots strictly between ``a`` and ``b``
    other than ``m`` are evaluated (recursively on ``[a, m]`` and ``[m, b]``)
    only where the plan linear between ``a`` and ``b`` misses ``m``'s
    feed-forward at the timing's rates (:meth:`TorquePlan.at`) by more than
    :data:`KNOT_TOLERANCE` of the largest rest torque at ``a`` and ``b`` on any
    servo joint, or where a knot has no equilibrium. A path smooth at the
    tolerance's scale is planned on a few knots; a turn at a waypoint, or a
    torque that bends, gets the grid's knots around it."""
    done: dict[int, tuple] = {}
    servo: dict[int, tuple[np.ndarray, float] | None] = {}  # the servo joints' columns

    def get(i: int) -> tuple[np.ndarray, float] | None:
        evaluated(i)
        if i not in servo:
            part = done[i][1]
            servo[i] = None if part is None else _servo_part(part, dofs)
        return servo[i]

    def evaluated(i: int) -> None:
        if i not in done:
            done[i] = evaluate(float(grid[i]))

    dofs = knots.scene.servo_dofs
    _, rate, accel = knots.timing.progress(knots.timing.times_of(grid))
    sigma = grid.tolist()
    ends = np.searchsorted(grid, np.unique(knots.timing.span))
    stack = [(int(a), int(b)) for a, b in itertools.pairwise(ends)]
    evaluated(int(ends[0]))
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            evaluated(b)
            continue
        m = (a + b) // 2
        parts = [get(a), get(m), get(b)]
        if any(p is None for p in parts) or not _linear(
            (sigma[a], sigma[m], sigma[b]), parts, (rate[m], accel[m])
        ):
            stack += [(a, m), (m, b)]
    return done


def _servo_part(part: np.ndarray, dofs: np.ndarray) -> tuple[np.ndarray, float]:
    """A knot's terms (4, nv) on the servo joints' dofs (4, servos) and
    ``max |τ_s|`` over them (:func:`_linear`'s scale)."""
    servo = part[:, dofs]
    return servo, np.abs(servo[0]).max(initial=0.0)


def _linear(
    sigma: tuple[float, float, float],
    parts: list[tuple[np.ndarray, float]],
    rates: tuple[float, float],
) -> bool:
    """The plan linear between the knots ``σ_a``, ``σ_b`` gives ``σ_m``'s
    feed-forward at ``(σ̇, σ̈)`` within :data:`KNOT_TOLERANCE` (:func:`_refined`):
    ``|Σ_i g_i ((1 - w) a_i + w b_i - m_i)| ≤ tol · max(|a_0|, |b_0|)`` on the
    servo joints, ``g = (1, σ̈, σ̇², σ̇)``, ``w = (σ_m - σ_a) / (σ_b - σ_a)``;
    ``parts``: the knots' :func:`_servo_part`."""
    (a, scale_a), (m, _), (b, scale_b) = parts
    w = (sigma[1] - sigma[0]) / (sigma[2] - sigma[0])
    rate, accel = rates
    gains = np.array([[1.0], [accel], [rate**2], [rate]])
    term = gains * ((1 - w) * a + w * b - m)
    error = term[0] + term[1] + term[2] + term[3]
    return bool((np.abs(error) <= KNOT_TOLERANCE * max(scale_a, scale_b)).all())


def plan_torques(
    scene: Physics,
    q: np.ndarray,
    dv: np.ndarray,
    timing: Timing,
    external: Sequence[External] = (),
    ramp: bool = False,
    dynamics: PathDynamics | None = None,
) -> TorquePlan:
    """The torque plan of the path ``q`` (waypoints (n, nq), steps ``dv`` (n - 1,
    nv)) with ``timing``, whose segments it slows down where the drives need
    (module docstring; ``timing.stretch`` is updated). ``ramp``: the external
    wrenches grow with the path's progress ``σ / S``. ``dynamics``: the path's
    knots when evaluated already (shared with the ZMP plan; default: new)."""
    if dynamics is None:
        path = BlendedPath(scene.robot.model, q, dv, timing)
        dynamics = PathDynamics(scene, path, external, ramp)
    knots = _Knots(scene, timing, dynamics)
    grid = dynamics.grid if dynamics.path.timing is timing else knot_grid(timing)
    found = _refined(grid, knots, knots.parts)  # _refined picks the knots
    kept, parts, poses = [], [], []
    for i in sorted(found):
        qk, part = found[i]
        if part is not None:
            kept.append(grid[i])
            parts.append(part)
            poses.append(qk)
    nv = scene.robot.model.nv
    table = np.array(parts).reshape(-1, 4, nv)
    plan = TorquePlan(np.array(kept), *(table[:, i].copy() for i in range(4)))
    if not kept or not len(scene.servo_joints):
        return plan
    lo, hi = knots.bounds(np.array(poses))
    rest = plan.rest[:, scene.servo_dofs]
    if np.any((rest > hi) | (rest < lo)):  # a drive short at rest: name the joints
        where = [f"t = {tk:.2f} s of the path" for tk in timing.times_of(plan.sigma)]
        plan.shortfalls = shortfalls(list(scene.servo_joints), rest, lo, hi, where)
    if not plan.shortfalls:
        _stretch(plan, knots, lo, hi)
    return plan
