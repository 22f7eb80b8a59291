"""The spatial helpers against numpy's own."""

from __future__ import annotations

import numpy as np

from pik_mj.spatial import cross_rows, skew


def test_cross_rows_is_numpys_cross_bit_for_bit():
    """Rows (k, 3) of every magnitude, and one vector against rows: the same
    products and differences as ``np.cross``, so the same bits; and
    ``[a]× b`` of :func:`skew` to rounding."""
    rng = np.random.default_rng(7)
    for k in (1, 4, 200):
        a = rng.normal(size=(k, 3)) * 10.0 ** rng.uniform(-8, 8, (k, 1))
        b = rng.normal(size=(k, 3)) * 10.0 ** rng.uniform(-8, 8, (k, 1))
        np.testing.assert_array_equal(cross_rows(a, b), np.cross(a, b))
        np.testing.assert_array_equal(cross_rows(a[0], b), np.cross(a[0], b))
        np.testing.assert_array_equal(cross_rows(a[0], b[0]), np.cross(a[0], b[0]))
        np.testing.assert_allclose(cross_rows(a[0], b[0]), skew(a[0]) @ b[0], rtol=1e-12)
    assert cross_rows(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0, 3)
