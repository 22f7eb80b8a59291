r"""The geometry of a played path: :class:`BlendedPath`, the waypoints joined
by straight steps in joint space with smooth blends at the interior waypoints
of each segment.

Between waypoints ``q_i`` and ``q_{i+1}`` (nominal times ``σ_i``, step time
``T_i``, tangent step ``Δq_i``, ``mj_differentiatePos``) the path is straight
at the rate ``v_i = Δq_i / T_i``. Where a segment's path turns at an interior
waypoint ``w`` it is played through a blend of half-width
``b_w = ½ min(T_{w-1}, T_w)`` whose rate turns from ``v_{w-1}`` to ``v_w`` along
the smoothstep ``s(x) = 3x² - 2x³``:

.. math::

    q(σ) = q_w \oplus \Big(v_{w-1} (u - b_w) + 2 b_w\, Δv_w \big(x^3 - \tfrac{x^4}{2}\big)\Big),
    \quad q' = v_{w-1} + Δv_w\, s(x), \quad q'' = \frac{Δv_w}{2 b_w}\, 6 x (1 - x)

with ``u = σ - σ_w + b_w \in [0, 2 b_w]``, ``x = u / 2 b_w`` and
``Δv_w = v_w - v_{w-1}``: ``q'`` and ``q''`` are continuous (no impulse of the
joints' acceleration for the servos to absorb, no jump of the torques the
path needs). The blend is the quartic Bézier curve with control points
``q_w ⊕ (-b_w v_{w-1})``, ``q_w ⊕ (-b_w v_{w-1} / 2)``, ``q_w``,
``q_w ⊕ b_w v_w / 2``, ``q_w ⊕ b_w v_w``: it stays in the convex hull of points
of the straight path within half a step of ``q_w`` (so, to first order, does
whatever the solve kept linear in ``q`` there: the feet, the CoM inside its
polygon) and passes ``3 b_w Δv_w / 16`` from ``q_w``; each joint's rate stays
between its rates on the two steps, so within the velocity limits that timed
them. Segment boundaries (where the motion is at rest,
:class:`~pik_mj.sim.timing.Timing`) and waypoints next to a step of zero time
are passed exactly.
"""

from __future__ import annotations

import mujoco
import numpy as np

from pik_mj.sim.timing import Timing

__all__ = ["BlendedPath"]


class BlendedPath:
    """The waypoints ``q`` (n, nq) joined as the module docstring says.

    Args:
        model: The robot's model (``mj_integratePos``).
        q: Waypoints (n, nq).
        dv: Tangent steps ``Δq_i`` (n - 1, nv) between them.
        timing: Their :class:`~pik_mj.sim.timing.Timing` (step times, segments).

    Attributes:
        half_width: ``b_w`` [s] of each waypoint (n,) (0: passed exactly).
    """

    def __init__(self, model: mujoco.MjModel, q: np.ndarray, dv: np.ndarray, timing: Timing):
        self.model, self.q, self.timing = model, np.asarray(q, float), timing
        n = len(self.q)
        steps = timing.steps
        self.rates = np.zeros((max(n - 1, 0), model.nv))
        moving = steps > 0
        self.rates[moving] = dv[moving] / steps[moving, None]
        self.half_width = np.zeros(n)
        interior = np.zeros(n, dtype=bool)
        for a, b in zip(timing.first, timing.last, strict=True):
            interior[a:b] = True  # strictly inside [a - 1, b]
        interior[0] = False
        for w in np.flatnonzero(interior):
            if w < n - 1:
                self.half_width[w] = 0.5 * min(steps[w - 1], steps[w])
        self._dv = np.asarray(dv, float)

    def offsets(
        self, sigma: np.ndarray, dofs: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At nominal times ``σ`` (k,) [s]: the waypoint ``w`` (k,) and tangent
        offset ``δ`` (k, nv) with ``q(σ) = q_w ⊕ δ``, ``q'`` (k, nv) [rad/s] and
        ``q''`` (k, nv) [rad/s²] (zero at and after the last waypoint); with
        ``dofs``, their columns of those dofs only (k, len(dofs))."""
        sigma = np.atleast_1d(np.asarray(sigma, dtype=float))
        nominal, steps, b = self.timing.nominal, self.timing.steps, self.half_width
        rates = self.rates if dofs is None else self.rates[:, dofs]
        n, nv = len(self.q), rates.shape[1]
        i = self.timing.step_of(sigma)
        k = len(sigma)
        w, delta = i.copy(), np.zeros((k, nv))
        d1, d2 = np.zeros((k, nv)), np.zeros((k, nv))
        inside = i < n - 1
        s = sigma - nominal[i]  # time since waypoint i
        # on which side: the blend after waypoint i, the blend before i + 1, or straight
        T = np.where(inside, steps[np.minimum(i, max(n - 2, 0))] if n > 1 else 0.0, 0.0)
        bn = np.where(inside, b[np.minimum(i + 1, n - 1)], 0.0)
        after = inside & (s < b[i])
        before = inside & ~after & (s > T - bn) & (bn > 0)
        straight = inside & ~after & ~before
        if straight.any():
            r = rates[i[straight]]
            delta[straight], d1[straight] = s[straight, None] * r, r
        blend = after | before
        if blend.any():  # the blend after waypoint i or before i + 1, both at once
            c = np.where(after, i, i + 1)[blend]
            bw = b[c][:, None]
            v_in, v_out = rates[c - 1], rates[c]
            u = np.where(after, s, s - T)[blend][:, None] + bw  # σ - σ_w + b_w in [0, 2 b_w]
            turn, x = v_out - v_in, u / (2.0 * bw)
            w[blend] = c
            delta[blend] = v_in * (u - bw) + 2.0 * bw * turn * (x**3 - 0.5 * x**4)
            d1[blend] = v_in + turn * (3.0 * x**2 - 2.0 * x**3)
            d2[blend] = turn / (2.0 * bw) * 6.0 * x * (1.0 - x)
        return w, delta, d1, d2

    def at(self, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``q(σ)`` (nq,), ``q'`` (nv,) [rad/s] and ``q''`` (nv,) [rad/s²] at one
        nominal time ``σ`` [s]."""
        (q,), (d1,), (d2,) = self.many(np.array([sigma]))
        return q, d1, d2

    def many(self, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`at` at each of the nominal times ``σ`` (k,) [s]: ``q`` (k, nq),
        ``q'`` and ``q''`` (k, nv)."""
        w, delta, d1, d2 = self.offsets(sigma)
        q = self.q[w].copy()
        for qk, dk in zip(q, delta, strict=True):
            mujoco.mj_integratePos(self.model, qk, dk, 1.0)
        return q, d1, d2
