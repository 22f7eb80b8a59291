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
also keeps the robot's contacts at ``q(σ)`` (:class:`KnotContacts`: those
:meth:`~pik_mj.sim.physics.Physics.touching` lists, read from the probe's
arrays), the bodies' poses, and, for the torque plan, the contacts as maps of
generalized forces (:class:`~pik_mj.sim.torques.ContactSupport`, built on
demand at the knot's kinematics).

The knots lie on one grid (:func:`knot_grid`: every :data:`KNOT_SPACING` of
nominal time and at each waypoint); the ZMP plan adds the blends' ends
(:func:`knot_times`). The path's poses and rates at those times are computed
together, once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.dynamics import external_torques, inverse_dynamics_many
from pik_mj.sim.blends import BlendedPath
from pik_mj.sim.physics import External, Physics
from pik_mj.sim.timing import Timing
from pik_mj.sim.torques import (
    ContactSupport,
    root_free_dofs,
    root_wrench_maps,
    weight_torques,
)

__all__ = [
    "KNOT_SPACING",
    "Knot",
    "KnotContacts",
    "PathDynamics",
    "knot_grid",
    "knot_times",
    "robot_contacts",
]

KNOT_SPACING = 0.05
"""Nominal time [s] between the knots of the plans (at most)."""


def knot_grid(timing: Timing) -> np.ndarray:
    """Knot nominal times [s]: every :data:`KNOT_SPACING` and the waypoints'."""
    nominal = timing.nominal
    S = float(nominal[-1])
    grid = np.linspace(0.0, S, max(2, math.ceil(S / KNOT_SPACING) + 1))
    return np.unique(np.concatenate([grid, nominal]))


def knot_times(path: BlendedPath, grid: np.ndarray | None = None) -> np.ndarray:
    """:func:`knot_grid` (``grid`` when formed already) and the blends' ends
    (just inside each blend) [s]."""
    nominal, b = path.timing.nominal, path.half_width
    inner = 0.999 * b[b > 0]
    ends = np.concatenate([nominal[b > 0] - inner, nominal[b > 0] + inner])
    grid = knot_grid(path.timing) if grid is None else grid
    return np.unique(np.concatenate([grid, ends]))


@dataclass
class KnotContacts:
    """The robot's contacts at a knot (those of
    :meth:`~pik_mj.sim.physics.Physics.touching`, in MuJoCo's order), as arrays.

    Attributes:
        geom: The robot's geom of each contact (n,).
        points: Contact points ``p_WC`` (n, 3) [m].
        normals: Unit normals into the robot's geom (n, 3).
        friction: Sliding friction of each pair (n,).
        self_contact: Both geoms are the robot's (n,).
    """

    geom: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    friction: np.ndarray
    self_contact: np.ndarray


def robot_contacts(scene: Physics, probes: Sequence[tuple[np.ndarray, ...]]) -> list[KnotContacts]:
    """The :class:`KnotContacts` of each probe's contacts
    (:meth:`~pik_mj.sim.physics.Physics.probe_contacts` with friction), all
    read at once (:meth:`~pik_mj.sim.physics.Physics.robot_contact_rows`)."""
    ends = np.cumsum([len(p[1]) for p in probes]).tolist()
    geom, dist, exclude, frame, pos, friction = (
        np.concatenate(x) for x in zip(*probes, strict=True)
    )
    keep, robot, other, normal = scene.robot_contact_rows(geom, dist, exclude, frame)
    g, p, n, f = robot[keep], pos[keep], normal[keep], friction[keep]
    s = scene.system_geoms[other[keep]]
    ends = np.concatenate([[0], np.cumsum(keep)])[ends].tolist()  # of the kept, per probe
    starts = [0, *ends[:-1]]
    return [
        KnotContacts(g[a:b], p[a:b], n[a:b], f[a:b], s[a:b])
        for a, b in zip(starts, ends, strict=True)
    ]


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
        root_wrench: The root's ``T J_B^{-T}`` (6, 6)
            (:func:`~pik_mj.sim.torques.root_wrench_maps`), None without a free joint.
        support: The contacts' :class:`~pik_mj.sim.torques.ContactSupport`
            (None unless asked for).
    """

    sigma: float
    q: np.ndarray
    qpos: np.ndarray
    contacts: KnotContacts
    rest: np.ndarray
    inertia: np.ndarray
    velocity: np.ndarray
    damping: np.ndarray
    curvature: np.ndarray
    xpos: np.ndarray
    xmat: np.ndarray
    root_wrench: np.ndarray | None
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
        grid: The nominal times [s] of :func:`knot_grid` of ``path``'s timing.
        sigma: The nominal times [s] of :func:`knot_times` of ``path``.
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
        self.grid = knot_grid(path.timing)
        self.sigma = knot_times(path, self.grid)
        self._row = {s: i for i, s in enumerate(self.sigma.tolist())}
        self._poses = path.many(self.sigma)

    def at(self, sigma: float, support: bool = False) -> Knot:
        """The knot at nominal time ``σ`` [s]; ``support``: with its
        :class:`~pik_mj.sim.torques.ContactSupport`."""
        knot = self._knots.get(float(sigma))
        if knot is None:
            return self.many([sigma], support)[0]
        if support and knot.support is None:
            knot.support = self._support(knot)
        return knot

    def many(self, sigmas: Sequence[float], support: bool = False) -> list[Knot]:
        """The knots at the nominal times ``σ`` [s] (as :meth:`at`), those not
        evaluated yet evaluated together."""
        sigmas = [float(sigma) for sigma in sigmas]
        knots = self._knots
        missing = [sigma for sigma in dict.fromkeys(sigmas) if sigma not in knots]
        if missing:
            knots.update(zip(missing, self._evaluate(missing), strict=True))
        found = [knots[sigma] for sigma in sigmas]
        if support:
            for knot in found:
                if knot.support is None:
                    knot.support = self._support(knot)
        return found

    def _support(self, knot: Knot) -> ContactSupport:
        """The knot's :class:`~pik_mj.sim.torques.ContactSupport`: its
        environment contacts (not self-contacts, not a grasped object's) at its
        kinematics (``mj_kinematics``, ``mj_comPos``)."""
        m, d, c = self.scene.model, self.data, knot.contacts
        d.qpos[:] = knot.qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        bodies = m.geom_bodyid[c.geom]
        return ContactSupport.of_points(
            self.scene, d, c.points, c.normals, c.friction, bodies, c.self_contact, knot.root_wrench
        )

    def _poses_of(self, sigmas: list[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``q``, ``q'``, ``q''`` at the nominal times (those of :func:`knot_times`
        computed when made)."""
        rows = [self._row.get(sigma) for sigma in sigmas]
        if None in rows:
            return self.path.many(np.array(sigmas))
        return tuple(x[rows] for x in self._poses)

    def _evaluate(self, sigmas: list[float]) -> list[Knot]:
        self.evaluations += len(sigmas)
        scene, d = self.scene, self.data
        m, nv, k = scene.model, scene.robot.model.nv, len(sigmas)
        q, d1, d2 = self._poses_of(sigmas)
        if scene.grasps:  # the grasped objects in their frames
            qpos = np.array([scene.qpos_of(qk) for qk in q])
        else:  # the path's waypoints were checked: no check per knot
            qpos = np.empty((k, m.nq))
            qpos[:] = m.qpos0
            qpos[:, : scene.robot_nq] = q
        rates = np.zeros((k, 5, m.nv))  # (q̇, q̈) of the five: (0, 0), (0, q'), (0, q''),
        accels = np.zeros((k, 5, m.nv))  # (q', 0), (-q', 0) (the rest ones together)
        accels[:, 1, :nv], accels[:, 2, :nv] = d1, d2
        rates[:, 3, :nv] = d1
        rates[:, 4] = -rates[:, 3]
        S = float(self.path.timing.nominal[-1])
        external, weight = np.zeros((k, m.nv)), np.zeros((k, m.nv))
        xpos, xmat = np.empty((k, m.nbody, 3)), np.empty((k, m.nbody, 9))
        held, ramp, pushed = bool(scene.grasps), self.ramp and S > 0, bool(self.external)
        xpos_now, xmat_now = d.xpos, d.xmat
        root, dofs = scene.robot.root_body_id, root_free_dofs(scene)
        J_B = np.zeros((k, 6, m.nv)) if dofs is not None else None

        def loads(i: int) -> None:  # d holds the kinematics at qpos[i]
            if pushed:
                s = sigmas[i] / S if ramp else 1.0
                wrenches = [(f, s * F, s * M) for f, F, M in self.external]
                external[i] = external_torques(m, d, wrenches)
            if held:
                weight[i] = weight_torques(scene, d)
            xpos[i], xmat[i] = xpos_now, xmat_now
            if J_B is not None:
                mujoco.mj_jacBody(m, d, J_B[i, :3], J_B[i, 3:], root)

        taus = inverse_dynamics_many(m, d, qpos, rates, accels, loads)
        probes = [scene.probe_contacts(x, friction=True) for x in qpos]
        contacts = robot_contacts(scene, probes)
        g, accel, bend, plus, minus = np.transpose(taus, (1, 0, 2))
        rest, inertia, curvature = g - external - weight, accel - g, bend - g
        velocity, damping = 0.5 * (plus + minus) - g, 0.5 * (plus - minus)
        terms = (rest, inertia, velocity, damping, curvature)
        roots = [None] * k if J_B is None else root_wrench_maps(J_B[:, :, dofs], xpos[:, root])
        rows = zip(sigmas, q, qpos, contacts, *terms, xpos, xmat, roots, strict=True)
        return [Knot(*row) for row in rows]  # the arrays' rows (views), iterated in C
