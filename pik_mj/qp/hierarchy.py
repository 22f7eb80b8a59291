"""A whole priority hierarchy as one DAQP hierarchical least-squares problem.

:class:`HierarchicalProblem` holds the cascade's rows in the form
``daqp.solve(..., break_points=...)`` reads: every level exact, solved
lexicographically in one call (:class:`~pik_mj.qp.daqp_backend.HierarchicalBackend`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pik_mj.tasks.task import TaskRows, frozen

DAQP_INF = 1e30
"""The bound DAQP reads as infinite: bounds beyond it are clamped to ``±DAQP_INF``."""
_SENTINELS = np.array([-DAQP_INF, DAQP_INF])
_SENTINELS.flags.writeable = False


_IDENTITIES: dict[int, np.ndarray] = {}


def _identity(n: int) -> np.ndarray:
    """``I`` (n x n), made once per size (DAQP reads it and never writes it;
    its Cython signature asks for a writable buffer)."""
    if n not in _IDENTITIES:
        _IDENTITIES[n] = np.eye(n)
    return _IDENTITIES[n]


class _Layout:
    """Where each block of a :class:`HierarchicalProblem` goes, for one stack
    shape (computed once per shape)."""

    def __init__(self, nv: int, n_eq0: int, C: np.ndarray, n_keep: list, n_in: list):
        n = nv + 1
        # the hard inequality rows this layout was made for (a copy unless no
        # one can write them: a stack buffer is refilled in place)
        self.C = C if frozen(C) else C.copy()
        nonzero = C != 0
        single = np.count_nonzero(nonzero, axis=1) == 1
        self.single_rows = np.flatnonzero(single)
        self.general_rows = np.flatnonzero(~single)
        self._bound_sources(C, nonzero)
        self.n_general = n_eq0 + self.general_rows.size
        self.blocks: list[tuple[int, int, int]] = []  # (first row, equality rows, rows)
        i = self.n_general
        break_points = [n + i]
        self.levels: list[int] = []
        for k, (n_eq, m_in) in enumerate(zip(n_keep, n_in, strict=True), start=1):
            size = n_eq + m_in
            self.blocks.append((i, n_eq, size))
            if size:
                i += size
                break_points.append(n + i)
                self.levels.append(k)
        self.A_shape = (i, n)
        # rows whose bounds may be infinite (inequality rows: equality rows'
        # targets are finite), clamped to ±DAQP_INF for DAQP
        self.infinite_bounds = self.general_rows.size > 0 or any(n_in)
        # the soft rows (after the hard general rows): first row and size of each
        # non-empty level block, for the per-level row norms in one pass
        sized = [(first - self.n_general, size) for first, _, size in self.blocks if size]
        self.block_starts = np.array([f for f, _ in sized], dtype=np.intp)
        self.block_sizes = np.array([z for _, z in sized], dtype=np.intp)
        self.n_bounds = n + i
        self.sense = np.zeros(n + i, dtype=np.intc)
        self.sense[n : n + n_eq0] = 5
        for first, n_eq, size in self.blocks:
            self.sense[n + first : n + first + n_eq] = 13  # equality (active, immutable), soft
            self.sense[n + first + n_eq : n + first + size] = 8  # inequality, soft
        self.break_points = np.array(break_points, dtype=np.intc)
        # The problem's arrays, rewritten in place by every problem of this
        # shape: every entry of A is written each time except the zero ``d``
        # column of the hard rows; the first n bounds start from ``bounds0``.
        self.A = np.zeros(self.A_shape)
        self.upper = np.empty(self.n_bounds)
        self.lower = np.empty(self.n_bounds)
        self.bounds0 = np.full((2, n), DAQP_INF)
        self.bounds0[1] = -DAQP_INF
        self.bounds0[:, nv] = 0.0  # d = 0

    def _bound_sources(self, C: np.ndarray, nonzero: np.ndarray) -> None:
        """Where the simple bounds of ``x`` come from: a single-entry row
        ``c x_i ∈ [l, u]`` bounds ``x_i`` below by ``l / c`` and above by
        ``u / c`` (``c > 0``; swapped for ``c < 0``). With
        ``v = [d_lower; d_upper; -INF; +INF]`` (:data:`DAQP_INF`), the bounds
        of the columns :attr:`bounded` are ``max_j v[lower_src] · scale`` and
        ``min_j v[upper_src] · scale`` over each column's rows (``j``, axis 0), padded with
        the ``∓INF`` entries (which also keep them within ±INF)."""
        m = C.shape[0]
        rows = self.single_rows
        cols = nonzero[rows].argmax(axis=1)
        coef = C[rows, cols]
        self.bounded, slot_of = np.unique(cols, return_inverse=True)
        width = 1 + (int(np.bincount(slot_of).max()) if rows.size else 0)
        shape = (width, self.bounded.size)  # (reduced over axis 0: numpy's fast one)
        self.lower_src = np.full(shape, 2 * m, dtype=np.intp)
        self.upper_src = np.full(shape, 2 * m + 1, dtype=np.intp)
        self.scale = np.ones(shape)
        filled = np.zeros(self.bounded.size, dtype=np.intp)
        for r, s, c in zip(rows.tolist(), slot_of.tolist(), coef.tolist(), strict=True):
            j = filled[s]
            self.lower_src[j, s], self.upper_src[j, s] = (r, m + r) if c > 0 else (m + r, r)
            self.scale[j, s] = 1.0 / c
            filled[s] += 1

    def fits(self, C: np.ndarray) -> bool:
        """Whether ``C`` holds the rows this layout was made for: the same
        read-only object, or equal values (a limit's rows rebuilt by a new
        solve, a refilled stack buffer; a read-only one is kept, so that the
        next call needs no comparison)."""
        if C is self.C:
            return True
        if C.shape != self.C.shape or not np.array_equal(C, self.C):
            return False
        if frozen(C):
            self.C = C
        return True


def _kept_rows(rows: TaskRows, memo: dict, level: int) -> tuple[np.ndarray | None, np.ndarray]:
    """``(indices, A[indices])`` of the equality rows of a level that go to
    DAQP (``(None, A)``: all of them).

    Left out: rows of weight 0 (weights are >= 0, validated where the rows
    entered), and the zero rows of a read-only ``A`` (a posture's rows of the
    free joint), found once per matrix and kept in ``memo`` with it and its
    other rows. Neither changes a level's optimum (a zero row's residual does
    not depend on ``x``) nor its norm ``D_k``.
    """
    A = rows.A
    weighted = int(np.count_nonzero(rows.w_A)) == rows.n_eq
    if not frozen(A) or not rows.n_eq:
        if weighted:
            return None, A
        keep = np.flatnonzero(rows.w_A)
        return keep, A[keep]
    held = memo.get(level)
    if held is None or held[0] is not A:
        nonzero = A.any(axis=1)
        keep = None if nonzero.all() else np.flatnonzero(nonzero)
        held = memo[level] = (A, nonzero, keep, A if keep is None else A[keep])
    _, nonzero, keep, kept = held
    if weighted:
        return keep, kept
    keep = np.flatnonzero(nonzero & (rows.w_A > 0))
    return keep, A[keep]


@dataclass
class HierarchicalProblem:
    """A whole priority hierarchy as one DAQP hierarchical least-squares problem.

    Variables ``z = [x; d]``: the step ``x`` (``nv``) and one auxiliary ``d``
    fixed at 0 by level 0. Level 0 holds the hard rows (single-entry rows as
    bounds on ``x``); level ``k`` holds its equality rows ``√w_i a_i x = √w_i b_i``
    and inequality rows ``√w_i c_i x ∈ √w_i [d_l, d_u]`` as soft constraints,
    each with ``β_i`` in the ``d`` column so that every row of the level has the
    same norm ``D_k = max_i w_i ‖a_i‖²`` (``β_i = √(D_k − w_i ‖a_i‖²)``). DAQP
    normalizes each row, so a level then minimizes ``Σ w_i r_i² / D_k``: exactly
    the weighted squared error of the cascade's level, up to the factor. Levels
    are solved lexicographically, each keeping what the levels above achieved
    (equality rows at their values, inequality rows within their bounds or at
    their achieved violation), ties broken by the least ``‖x‖²``: the cascade
    with ``λ_k → 0`` and ``τ = 0``.

    Attributes:
        H: Hessian ``I`` (nv + 1).
        A: General rows (hard rows with several entries, then each level's rows).
        bupper: Bounds: ``nv + 1`` simple bounds on ``z`` first, then one per row of A.
        blower: Lower bounds, same layout.
        sense: DAQP constraint types (0 inequality, 5 equality, +8 soft).
        break_points: End index (into the bounds) of each level, level 0 first.
        levels: Cascade level (1..K) of each soft block (empty levels are left out).
        nv: Step size.
    """

    H: np.ndarray
    A: np.ndarray
    bupper: np.ndarray
    blower: np.ndarray
    sense: np.ndarray
    break_points: np.ndarray
    levels: list[int]
    nv: int

    @classmethod
    def from_rows(
        cls,
        hard: TaskRows,
        levels: list[TaskRows],
        cache: dict | None = None,
        zero_rows: dict | None = None,
    ) -> HierarchicalProblem:
        """The problem of a cascade's rows; ``cache`` (a dict kept by the caller)
        holds the layout of each stack shape and its arrays, so that only values
        are written: ``A``, ``bupper`` and ``blower`` of a problem made with a
        cache are rewritten by the next problem of the same shape (copy them to
        keep them; the solve loop uses a problem before it makes the next).
        ``zero_rows`` (another dict kept by the caller) holds the zero rows of
        each level's read-only ``A`` (see :func:`_kept_rows`)."""
        nv = hard.A.shape[1]
        n = nv + 1
        C = hard.C
        memo = zero_rows if zero_rows is not None else {}
        n_keep, keeps = [], []
        shape: list = [nv, hard.n_eq]
        for j, rows in enumerate(levels):
            keep, kept = _kept_rows(rows, memo, j)
            k = kept.shape[0]
            n_keep.append(k)
            keeps.append((keep, kept))
            shape += (k, rows.n_eq, rows.n_in)
        shape = tuple(shape)  # type: ignore[assignment]
        layout = cache.get(shape) if cache is not None else None
        if layout is None or not layout.fits(C):  # new shape, or new hard rows
            layout = _Layout(nv, hard.n_eq, C, n_keep, [r.n_in for r in levels])
            if cache is not None:
                cache[shape] = layout
        A, upper, lower = layout.A, layout.upper, layout.lower
        upper[:n], lower[:n] = layout.bounds0
        # hard inequality rows with one entry: bounds on x (_Layout._bound_sources)
        if layout.bounded.size:
            v = np.concatenate((hard.d_lower, hard.d_upper, _SENTINELS))
            lower[layout.bounded] = (v[layout.lower_src] * layout.scale).max(axis=0)
            upper[layout.bounded] = (v[layout.upper_src] * layout.scale).min(axis=0)
        r = hard.n_eq
        if r:
            A[:r, :nv] = hard.A
            upper[n : n + r] = lower[n : n + r] = hard.b
        g = layout.n_general
        if g > r:
            A[r:g, :nv] = C[layout.general_rows]
            upper[n + r : n + g] = hard.d_upper[layout.general_rows]
            lower[n + r : n + g] = hard.d_lower[layout.general_rows]
        for rows, (keep, kept), (i, n_eq, size) in zip(levels, keeps, layout.blocks, strict=True):
            if size == 0:
                continue
            block = A[i : i + size]
            j = n + i
            if n_eq:
                w, b = (rows.w_A, rows.b) if keep is None else (rows.w_A[keep], rows.b[keep])
                sw = np.sqrt(w)
                np.multiply(sw[:, None], kept, out=block[:n_eq, :nv])
                np.multiply(sw, b, out=upper[j : j + n_eq])
                lower[j : j + n_eq] = upper[j : j + n_eq]
            if rows.n_in:
                sw_C = np.sqrt(rows.w_C)
                np.multiply(sw_C[:, None], rows.C, out=block[n_eq:, :nv])
                upper[j + n_eq : j + size] = sw_C * rows.d_upper
                lower[j + n_eq : j + size] = sw_C * rows.d_lower
        if layout.block_sizes.size:  # β_i = √(D_k − ‖row_i‖²), D_k the level's largest
            soft = A[g:]
            norms = np.einsum("ij,ij->i", soft[:, :nv], soft[:, :nv])
            D = np.maximum(np.maximum.reduceat(norms, layout.block_starts), 1e-300)
            np.subtract(np.repeat(D, layout.block_sizes), norms, out=norms)
            np.sqrt(np.maximum(norms, 0.0, out=norms), out=soft[:, nv])
        if layout.infinite_bounds:  # the rows' bounds within ±DAQP_INF (the first n are)
            for bound in (upper[n:], lower[n:]):
                np.minimum(bound, DAQP_INF, out=bound)
                np.maximum(bound, -DAQP_INF, out=bound)
        return cls(
            _identity(n),
            A,
            upper,
            lower,
            layout.sense.copy(),  # DAQP may write flags into it
            layout.break_points,
            layout.levels,
            nv,
        )

    def hard_violation(self, x: np.ndarray) -> float:
        """Largest violation of level 0's rows (bounds and general rows) at ``x``."""
        z = np.append(x, 0.0)
        n = z.size
        end = int(self.break_points[0])
        v = np.concatenate([z, self.A[: end - n] @ z])
        return float(np.max(np.maximum(self.blower[:end] - v, v - self.bupper[:end]), initial=0.0))
