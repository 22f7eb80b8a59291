r"""The dynamics of a path's reference at its knots, evaluated once for both
plans of a motion: the torque plan (:mod:`pik_mj.sim.effort`) and the ZMP plan
(:mod:`pik_mj.sim.zmp`) read the same :class:`Knot`.

At a knot ``σ`` of the played path (:class:`~pik_mj.sim.blends.BlendedPath`:
``q(σ)``, ``q' = dq/dσ``, ``q'' = d²q/dσ²``), with the external wrenches ``w_e``
at their load ``s(σ)`` (``σ / S`` with a ramp, else 1) and the grasped
objects' weights ``m_o g``, the reference's generalized forces at rates
``(σ̇, σ̈)`` are

.. math::

    Q = Q_s + Q_a\, \ddot σ + (Q_v + Q_c)\, \dot σ^2 + Q_d\, \dot σ

    Q_s = τ(0, 0) - \sum_e J_e^T s\, w_e - \sum_o J_{p,o}^T m_o g, \quad
    Q_a = τ(0, q') - τ(0, 0) = M q', \quad
    Q_c = τ(0, q'') - τ(0, 0) = M q''

    Q_v = \tfrac12\big(τ(q', 0) + τ(-q', 0)\big) - τ(0, 0) = c(q, q'), \quad
    Q_d = \tfrac12\big(τ(q', 0) - τ(-q', 0)\big) = D q'

with ``τ(q̇, q̈)`` MuJoCo's inverse dynamics at ``q`` without constraints
(:func:`pik_mj.dynamics.inverse_dynamics`: five ``mj_inverse`` at one
configuration, the position stage computed once). The torque plan leaves the
blends' curvature ``Q_c`` to the servos; the ZMP plan includes it. Each knot
also keeps the robot's contacts at ``q(σ)`` (:meth:`~pik_mj.sim.physics.Physics.touching`),
the bodies' poses, and, for the torque plan, the contacts as maps of
generalized forces (:class:`~pik_mj.sim.torques.ContactSupport`).

The knots lie on one grid (:func:`knot_grid`: every :data:`KNOT_SPACING` of
nominal time and at each waypoint); the ZMP plan adds the blends' ends
(:func:`knot_times`). The path's poses and rates at those times are computed
together, once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pik_mj.dynamics import external_torques, inverse_dynamics
from pik_mj.sim.blends import BlendedPath
from pik_mj.sim.physics import ContactInfo, External, Physics
from pik_mj.sim.timing import Timing
from pik_mj.sim.torques import ContactSupport, weight_torques

__all__ = ["KNOT_SPACING", "Knot", "PathDynamics", "knot_grid", "knot_times"]

KNOT_SPACING = 0.05
"""Nominal time [s] between the knots of the plans (at most)."""


def knot_grid(timing: Timing) -> np.ndarray:
    """Knot nominal times [s]: every :data:`KNOT_SPACING` and the waypoints'."""
    nominal = timing.nominal
    S = float(nominal[-1])
    grid = np.linspace(0.0, S, max(2, math.ceil(S / KNOT_SPACING) + 1))
    return np.unique(np.concatenate([grid, nominal]))


def knot_times(path: BlendedPath) -> np.ndarray:
    """:func:`knot_grid` and the blends' ends (just inside each blend) [s]."""
    nominal, b = path.timing.nominal, path.half_width
    inner = 0.999 * b[b > 0]
    ends = np.concatenate([nominal[b > 0] - inner, nominal[b > 0] + inner])
    return np.unique(np.concatenate([knot_grid(path.timing), ends]))


@dataclass
class Knot:
    """The reference at one knot (module docstring); generalized forces (nv of
    the scene's model) [N, N·m].

    Attributes:
        sigma: Nominal time ``σ`` [s].
        q: Robot configuration ``q(σ)``.
        qpos: The scene's configuration at ``q``.
        contacts: The robot's contacts at ``qpos``.
        rest, inertia, velocity, damping, curvature: ``Q_s``, ``Q_a``, ``Q_v``,
            ``Q_d``, ``Q_c``.
        xpos, xmat: The bodies' positions (nbody, 3) and orientations (nbody, 9).
        support: The contacts' :class:`~pik_mj.sim.torques.ContactSupport`
            (None unless asked for).
    """

    sigma: float
    q: np.ndarray
    qpos: np.ndarray
    contacts: list[ContactInfo]
    rest: np.ndarray
    inertia: np.ndarray
    velocity: np.ndarray
    damping: np.ndarray
    curvature: np.ndarray
    xpos: np.ndarray
    xmat: np.ndarray
    support: ContactSupport | None = None


class PathDynamics:
    """The :class:`Knot` of each nominal time of ``path`` asked for, each
    evaluated once.

    Args:
        scene: The scene.
        path: The played path.
        external: Wrenches ``(frame, force, moment)`` acting on the robot.
        ramp: The wrenches grow with the path's progress ``σ / S``.

    Attributes:
        evaluations: Knots evaluated so far (each ``mj_inverse`` batch counts once).
    """

    def __init__(
        self,
        scene: Physics,
        path: BlendedPath,
        external: Sequence[External] = (),
        ramp: bool = False,
    ):
        self.scene, self.path = scene, path
        self.external = [(f, np.asarray(F, float), np.asarray(M, float)) for f, F, M in external]
        self.ramp = bool(ramp)
        self.data = scene.workspace()  # every evaluation writes qpos, qvel, qacc
        self._knots: dict[float, Knot] = {}
        self.evaluations = 0
        sigma = knot_times(path)
        self._poses = dict(zip(sigma.tolist(), zip(*path.many(sigma), strict=True), strict=True))

    def at(self, sigma: float, support: bool = False) -> Knot:
        """The knot at nominal time ``σ`` [s]; ``support``: with its
        :class:`~pik_mj.sim.torques.ContactSupport`."""
        return self.many([sigma], support)[0]

    def many(self, sigmas: Sequence[float], support: bool = False) -> list[Knot]:
        """The knots at the nominal times ``σ`` [s] (as :meth:`at`), those not
        evaluated yet evaluated together."""
        sigmas = [float(sigma) for sigma in sigmas]
        missing = [
            sigma
            for sigma in dict.fromkeys(sigmas)
            if (knot := self._knots.get(sigma)) is None or (support and knot.support is None)
        ]
        if missing:
            self._knots.update(zip(missing, self._evaluate(missing, support), strict=True))
        return [self._knots[sigma] for sigma in sigmas]

    def _evaluate(self, sigmas: list[float], support: bool) -> list[Knot]:
        self.evaluations += len(sigmas)
        scene, d = self.scene, self.data
        m, nv, k = scene.model, scene.robot.model.nv, len(sigmas)
        poses = [self._poses.get(sigma) or self.path.at(sigma) for sigma in sigmas]
        v, a, zero = np.zeros((k, m.nv)), np.zeros((k, m.nv)), np.zeros((k, m.nv))
        v[:, :nv], a[:, :nv] = [p[1] for p in poses], [p[2] for p in poses]
        rates = np.stack([zero, zero, v, -v, zero], axis=1)  # (q̇, q̈) of the five
        accels = np.stack([zero, v, zero, zero, a], axis=1)
        S = float(self.path.timing.nominal[-1])
        taus, external, weight = np.empty((k, 5, m.nv)), np.empty((k, m.nv)), np.empty((k, m.nv))
        qpos, contacts, supports, xpos, xmat = [], [], [], [], []
        for i, sigma in enumerate(sigmas):
            qpos.append(scene.qpos_of(poses[i][0]))
            taus[i] = inverse_dynamics(m, d, qpos[i], rates[i], accels[i])
            s = sigma / S if (self.ramp and S > 0) else 1.0
            external[i] = external_torques(m, d, [(f, s * F, s * M) for f, F, M in self.external])
            weight[i] = weight_torques(scene, d)
            contacts.append(scene.touching(qpos[i]))
            supports.append(ContactSupport(scene, d, contacts[i]) if support else None)
            xpos.append(d.xpos.copy())
            xmat.append(d.xmat.copy())
        g, accel, plus, minus, bend = np.transpose(taus, (1, 0, 2))
        rest, inertia, curvature = g - external - weight, accel - g, bend - g
        velocity, damping = 0.5 * (plus + minus) - g, 0.5 * (plus - minus)
        return [
            Knot(
                sigma,
                poses[i][0],
                qpos[i],
                contacts[i],
                rest[i],
                inertia[i],
                velocity[i],
                damping[i],
                curvature[i],
                xpos[i],
                xmat[i],
                supports[i],
            )
            for i, sigma in enumerate(sigmas)
        ]
