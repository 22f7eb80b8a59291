"""Small dense linear algebra of the cascade's closed forms: Cholesky
factors and solves of Gram matrices ``G = B Bᵀ (+ λ I)``, with the
pseudo-inverse where ``G`` is singular.

MuJoCo's dense Cholesky (``mju_cholFactor``, ``mju_cholSolve``) is used rather
than numpy's, whose Python wrappers cost more than the factorization on these
small sizes, and rather than scipy's, whose BLAS would bring a second thread
pool into the loop (two pools contend on a loaded machine).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

CHOLESKY_PIVOT = 1e-8
"""Smallest Cholesky pivot ``L_ii²``, relative to ``G``'s largest diagonal
entry, for which a Gram matrix ``G = B Bᵀ`` is treated as regular (its rows
independent); below it, :func:`pinv_psd` (an eigendecomposition, dearer
than the factorization) decides the rank."""


def pinv_psd(G: np.ndarray) -> np.ndarray:
    """Pseudo-inverse of a small symmetric positive semidefinite matrix."""
    s, V = np.linalg.eigh(G)
    keep = s > 1e-12 * max(float(s[-1]) if s.size else 0.0, 1e-300)
    return (V[:, keep] / s[keep]) @ V[:, keep].T


def cholesky_factor(G: np.ndarray) -> np.ndarray | None:
    """MuJoCo's dense Cholesky factor (``mju_cholFactor``) of a small symmetric
    ``G``, made in a copy of ``G``: ``L`` (``G = L Lᵀ``) in its lower triangle,
    ``G``'s entries above. None when a pivot ``L_ii²`` is below
    :data:`CHOLESKY_PIVOT` times ``G``'s largest diagonal entry (``G`` singular
    or nearly so, or not positive definite: then ``G⁺`` is not ``G⁻¹``)."""
    n = G.shape[0]
    top = float(G.diagonal().max()) if n else 0.0
    if top <= 0.0:  # (no rows, or no positive pivot; NaN goes on and comes out NaN)
        return None
    L = np.array(G, dtype=float)  # factored in place
    if mujoco.mju_cholFactor(L, CHOLESKY_PIVOT * top) < n:
        return None
    return L


def cholesky(G: np.ndarray) -> np.ndarray | None:
    """Lower Cholesky factor ``L`` (``G = L Lᵀ``, zeros above the diagonal)
    of :func:`cholesky_factor`, or None."""
    L = cholesky_factor(G)
    return None if L is None else np.tril(L)


def chol_solve(G: np.ndarray, r: np.ndarray) -> np.ndarray | None:
    """``G⁻¹ r`` with :func:`cholesky_factor` (``mju_cholSolve``), or None."""
    L = cholesky_factor(G)
    if L is None:
        return None
    x = np.empty(G.shape[0])
    mujoco.mju_cholSolve(x, L, np.ascontiguousarray(r, dtype=float))
    return x


def regular_solve(G: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``G⁻¹ r`` for a regular ``G = B Bᵀ + λ I`` (``λ > 0``): MuJoCo's
    Cholesky (:func:`chol_solve`), numpy's LU solve when a pivot is below
    its test (``λ`` small against ``G``'s largest diagonal entry)."""
    y = chol_solve(G, r)
    return np.linalg.solve(G, r) if y is None else y


def gram_solve(B: np.ndarray, G: np.ndarray, r: np.ndarray, lam: float, nv: int) -> np.ndarray:
    """``u = Bᵀ G⁻¹ r`` with ``G = B Bᵀ + λ I`` (``G⁺`` when ``λ = 0``); zero
    without rows."""
    if r.size == 0:
        return np.zeros(nv)
    return B.T @ (regular_solve(G, r) if lam > 0 else psd_solve(G, r))


def inverse_cholesky(S: np.ndarray, norms: np.ndarray) -> np.ndarray | None:
    """``L⁻¹`` for ``S = C P Cᵀ = L Lᵀ`` (rows ``C`` projected by ``P``), or
    None when a pivot ``L_ii²`` is below :data:`CHOLESKY_PIVOT` times its
    row's squared norm ``norms_i = ‖c_i‖²`` (the row nearly a combination of
    the rows before it and of those ``P`` projects out)."""
    if S.shape[0] == 1:
        s = float(S[0, 0])
        return np.array([[1.0 / math.sqrt(s)]]) if s > CHOLESKY_PIVOT * float(norms[0]) else None
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        return None
    d = L.diagonal()
    if bool((d * d <= CHOLESKY_PIVOT * norms).any()):
        return None
    return np.linalg.inv(L)


def psd_solve(G: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``G⁺ r`` for a small symmetric positive semidefinite ``G``: ``G⁻¹ r``
    when ``G`` is regular, else the pseudo-inverse."""
    y = chol_solve(G, r)
    return pinv_psd(G) @ r if y is None else y
