"""The timing of a path (:mod:`pik_mj.sim.timing`) against the formulas written out."""

import bisect

import numpy as np

from pik_mj.sim.timing import PEAK_RATE, Timing, min_jerk


def _timing() -> Timing:
    steps = np.array([0.3, 0.0, 0.5, 0.2, 0.4])  # a step of zero time inside
    return Timing(steps, ["a", "a", "a", "b", "b", "b"])


def test_progress_follows_a_stretch_changed_in_place():
    """The segments' durations and starts are formed again when ``stretch``
    changes (in place, as ``stretch_until`` does): ``σ(t)`` is the
    minimum-jerk formula of the stretched segment."""
    timing = _timing()
    t = np.linspace(-0.1, 3.5, 37)
    timing.progress(t)  # formed at stretch 1
    timing.stretch[0] *= 2.0
    (s0, s1), (u0, u1) = timing.span
    D0, D1 = 2.0 * PEAK_RATE * (s1 - s0), PEAK_RATE * (u1 - u0)
    assert timing.duration == D0 + D1
    np.testing.assert_array_equal(timing.starts, [0.0, D0, D0 + D1])
    sigma, rate, _ = timing.progress(t)
    first = t < D0
    m, dm, _ = min_jerk(t[first] / D0)
    np.testing.assert_allclose(sigma[first], s0 + (s1 - s0) * m, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rate[first], (s1 - s0) / D0 * dm, rtol=0, atol=1e-12)
    m, _, _ = min_jerk((t[~first] - D0) / D1)
    np.testing.assert_allclose(sigma[~first], u0 + (u1 - u0) * m, rtol=0, atol=1e-12)


def test_step_of_is_the_last_waypoint_at_or_before_sigma():
    """``step_of`` is the bisection rule ``σ_i ≤ σ`` (clamped to the waypoints),
    on and between the nominal times, and the step ``piece`` reports."""
    timing = _timing()
    nominal = timing.nominal.tolist()
    sigma = np.concatenate([timing.nominal, np.linspace(-1.0, 2.5, 71)])
    want = [min(max(bisect.bisect_right(nominal, s) - 1, 0), len(nominal) - 1) for s in sigma]
    np.testing.assert_array_equal(timing.step_of(sigma), want)
    np.testing.assert_array_equal(timing.piece(sigma)[0], want)
