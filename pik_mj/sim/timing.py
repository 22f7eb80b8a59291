r"""The time parameterization of a path of waypoints (a solve's iterates):
:class:`Timing`.

The waypoints ``q_i`` sit at nominal times ``σ_i = Σ_{k<i} T_k`` along a path
linear between them in joint space (``mj_integratePos``), ``T_i`` the time of
step ``i`` at the velocity limits (:mod:`pik_mj.sim.reference`). Each segment
``k`` (one solve's iterates, from the pose before its first iterate to its last)
spans the nominal times ``[σ_a, σ_b]`` (``S_k = σ_b - σ_a``) and is travelled
with the minimum-jerk time scaling

.. math::

    \sigma(t) = \sigma_a + S_k\, m(τ), \quad m(τ) = 10 τ^3 - 15 τ^4 + 6 τ^5,
    \quad τ = (t - t_k) / D_k, \qquad D_k = c_k\, \tfrac{15}{8}\, S_k

which starts and ends at rest with zero acceleration. With ``c_k = 1`` its peak
rate ``dσ/dt = 15 S_k / 8 D_k = 1`` keeps every joint within its velocity
limit; a stretch ``c_k > 1`` (what the drives and the balance need,
:mod:`pik_mj.sim.reference`) slows the whole segment down. Between waypoints
``i`` and ``i + 1`` the straight path is

.. math::

    q(t) = q_i \oplus α\, Δq_i, \quad α = \frac{σ(t) - σ_i}{T_i}, \qquad
    \dot q = \frac{Δq_i}{T_i}\, \dot σ, \qquad \ddot q = \frac{Δq_i}{T_i}\, \ddot σ

(:meth:`Timing.piece`); the path played turns at the interior waypoints
through blends (:class:`~pik_mj.sim.blends.BlendedPath`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

__all__ = ["PEAK_RATE", "Timing", "min_jerk"]

PEAK_RATE = 15.0 / 8.0
"""Largest value of ``dm/dτ`` of the minimum-jerk profile."""


def min_jerk(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``m(τ)``, ``m'(τ)``, ``m''(τ)`` of the minimum-jerk profile, ``τ`` clipped to [0, 1]."""
    t = np.minimum(np.maximum(tau, 0.0), 1.0)
    t2, rest = t**2, 1.0 - t
    return (
        t**3 * (10.0 - 15.0 * t + 6.0 * t2),
        30.0 * t2 * rest**2,
        60.0 * t * rest * (1.0 - 2.0 * t),
    )


_HALVINGS_AT_ONCE = 3
"""Halvings of :meth:`Timing.stretch_until`'s bisection tried in one call of
its ``fits`` (the ``2^l - 1`` midpoints of ``l`` levels)."""


def _midpoints(low: float, high: float, levels: int) -> list[float]:
    """The midpoints ``½ (a + b)`` a bisection of ``[low, high]`` may try in
    its next ``levels`` halvings, as a binary heap (node ``i``'s lower half at
    ``2 i + 1``, its upper half at ``2 i + 2``)."""
    spans, out = [(low, high)], []
    for _ in range(levels):
        halves = []
        for a, b in spans:
            c = 0.5 * (a + b)
            out.append(c)
            halves += [(a, c), (c, b)]
        spans = halves
    return out


def _starts(durations: np.ndarray) -> np.ndarray:
    """Start time [s] of each segment of ``durations`` (m,), and the end of the last."""
    return np.concatenate([[0.0], np.cumsum(durations)])


_INVERSE_TABLE = (np.linspace(0.0, 1.0, 4001), min_jerk(np.linspace(0.0, 1.0, 4001))[0])
"""``τ`` and ``m(τ)`` on a grid: the table :meth:`Timing.times_of` inverts ``m`` on."""


class Timing:
    """The timing of a path (module docstring).

    Args:
        steps: Nominal time ``T_i`` [s] of each step between waypoints (n - 1,).
        segments: Segment label of each waypoint (n,); a new label starts a segment.

    Attributes:
        nominal: Nominal time ``σ_i`` [s] of each waypoint (n,).
        first, last: First and last waypoint of each segment (m,).
        span: ``[σ_a, σ_b]`` [s] of each segment (m, 2).
        stretch: ``c_k`` of each segment (m,) (1: at the velocity limits).
    """

    def __init__(self, steps: np.ndarray, segments: Sequence[str]):
        self.steps = np.asarray(steps, dtype=float)
        n = len(self.steps) + 1
        self.nominal = np.concatenate([[0.0], np.cumsum(self.steps)])
        firsts = [0] + [i for i in range(1, n) if segments[i] != segments[i - 1]]
        self.first = np.array(firsts, dtype=int)
        self.last = np.array([f - 1 for f in firsts[1:]] + [n - 1], dtype=int)
        self.span = np.array(
            [
                [self.nominal[max(a - 1, 0)], self.nominal[b]]
                for a, b in zip(self.first, self.last, strict=True)
            ]
        )
        self.stretch = np.ones(len(self.first))
        self._clock: tuple[bytes, np.ndarray, np.ndarray] | None = None

    @property
    def durations(self) -> np.ndarray:
        """``D_k`` [s] of each segment."""
        return self._durations_starts()[0].copy()

    @property
    def starts(self) -> np.ndarray:
        """Start time ``t_k`` [s] of each segment, and the end of the last (m + 1,)."""
        return self._durations_starts()[1].copy()

    @property
    def duration(self) -> float:
        """Time [s] of the whole path."""
        return float(self._durations_starts()[1][-1])

    def _durations_starts(self) -> tuple[np.ndarray, np.ndarray]:
        """:attr:`durations` and :attr:`starts`, formed again only when
        :attr:`stretch` changed (read-only: shared by the calls)."""
        key = self.stretch.tobytes()
        if self._clock is None or self._clock[0] != key:
            durations = self.stretch * PEAK_RATE * (self.span[:, 1] - self.span[:, 0])
            self._clock = (key, durations, _starts(durations))
        return self._clock[1], self._clock[2]

    def segment_of(self, t: np.ndarray) -> np.ndarray:
        """Index of the segment running at each time ``t`` [s] (the last one after the end)."""
        return self._segments(t)[0]

    def _segments(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`segment_of`, :attr:`durations` and :attr:`starts` (formed once)."""
        durations, starts = self._durations_starts()
        k = np.searchsorted(starts, np.asarray(t, float), side="right") - 1
        return np.minimum(np.maximum(k, 0), len(self.first) - 1), durations, starts

    def progress(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``σ(t)`` [s], ``dσ/dt`` [-] and ``d²σ/dt²`` [1/s] at times ``t`` [s]."""
        return self._progress(t)[:3]

    def _progress(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`progress` and :meth:`segment_of` at times ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        k, durations, starts = self._segments(t)
        D = durations[k]
        (s0, s1), t0 = self.span[k].T, starts[k]
        moving = D > 0
        Dsafe = np.where(moving, D, 1.0)
        tau = np.where(moving, (t - t0) / Dsafe, 1.0)
        m, dm, ddm = min_jerk(tau)
        S = s1 - s0
        sigma = s0 + S * m
        live = moving & (tau < 1.0)
        rate = np.where(live, S / Dsafe * dm, 0.0)
        accel = np.where(live, S / Dsafe**2 * ddm, 0.0)
        return sigma, rate, accel, k

    def times_of(self, sigma: np.ndarray) -> np.ndarray:
        """The time [s] at which the path reaches each nominal time ``σ`` [s]
        (the minimum-jerk profile inverted; a ``σ`` on a segment boundary: the
        boundary's time)."""
        sigma = np.atleast_1d(np.asarray(sigma, dtype=float))
        table, m = _INVERSE_TABLE
        k = np.searchsorted(self.span[:, 1], sigma, side="left")
        k = np.minimum(np.maximum(k, 0), len(self.first) - 1)
        durations, starts = self._durations_starts()
        (s0, s1), t0, D = self.span[k].T, starts[k], durations[k]
        moving = s1 > s0
        frac = np.where(moving, (sigma - s0) / np.where(moving, s1 - s0, 1.0), 1.0)
        return t0 + D * np.interp(np.minimum(np.maximum(frac, 0.0), 1.0), m, table)

    def stretch_until(
        self,
        sigma: np.ndarray,
        fits: Callable[[np.ndarray, np.ndarray], np.ndarray],
        max_stretch: float,
    ) -> dict[int, float]:
        """Slow down each segment with a knot that does not fit until all its knots
        do: its stretch ``c_k`` multiplied by the least ``c`` in ``[1, max_stretch]``
        (bisection, 30 halvings) at which ``fits(σ̇', σ̈')`` holds on every knot of
        the segment, its rates ``σ̇ / c`` and ``σ̈ / c²`` (the other knots' as they
        are). ``fits`` gives, per knot at nominal times ``sigma`` [s], whether it
        fits at rates ``(σ̇, σ̈)`` (..., k) each, knot by knot (any leading axes:
        the halvings are tried :data:`_HALVINGS_AT_ONCE` levels at a time, every
        midpoint of those levels in one call). Returns the segments slowed,
        ``{k: c_k}``."""
        _, rate, accel, segment = self._progress(self.times_of(sigma))
        out = {}
        for k in np.unique(segment[~fits(rate, accel)]):
            mine = segment == k
            low, high = 1.0, max_stretch
            for levels in (_HALVINGS_AT_ONCE,) * (30 // _HALVINGS_AT_ONCE):
                tree = _midpoints(low, high, levels)
                c = np.array(tree)[:, None]
                c2 = np.array([x**2 for x in tree])[:, None]
                ok = fits(np.where(mine, rate / c, rate), np.where(mine, accel / c2, accel))
                ok = np.all(ok[:, mine], axis=1)
                node = 0  # the bisection's path down the tree
                for _ in range(levels):
                    low, high = (low, tree[node]) if ok[node] else (tree[node], high)
                    node = 2 * node + (1 if ok[node] else 2)
            self.stretch[k] *= high
            out[int(k)] = float(self.stretch[k])
        return out

    def waypoint_times(self) -> np.ndarray:
        """Time [s] of each waypoint: ``σ(t_i) = σ_i``."""
        return self.times_of(self.nominal)

    def piece(self, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The step ``i`` each nominal time ``σ`` [s] falls in and ``α = (σ - σ_i) / T_i``
        (``α = 0`` on the last waypoint and on steps of zero time)."""
        sigma = np.asarray(sigma, dtype=float)
        n = len(self.nominal)
        i = self.step_of(sigma)
        inside = i < n - 1
        T = np.where(inside, self.steps[np.minimum(i, n - 2)] if n > 1 else 0.0, 0.0)
        alpha = np.where(T > 0, (sigma - self.nominal[i]) / np.where(T > 0, T, 1.0), 0.0)
        return i, alpha

    def step_of(self, sigma: np.ndarray) -> np.ndarray:
        """The step ``i`` each nominal time ``σ`` [s] falls in (``σ_i ≤ σ < σ_{i+1}``;
        the first before the start, the last waypoint at and after the end)."""
        last = len(self.nominal) - 1
        i = np.searchsorted(self.nominal, np.asarray(sigma, dtype=float), side="right") - 1
        return np.minimum(np.maximum(i, 0), last)
