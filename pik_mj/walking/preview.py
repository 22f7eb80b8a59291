"""Preview control of the cart-table model (irteus manual, "歩行動作生成"; Kajita 2003).

irteus manual classes: ``riccati-equation``, ``preview-controller``,
``extended-preview-controller`` and ``preview-control-cart-table-cog-trajectory-
generator``. One axis (x or y) of the CoM is the cart-table system with jerk input

.. math::

    x_{k+1} = A x_k + b u_k, \\quad p_k = c x_k, \\quad
    x_k = [x, \\dot x, \\ddot x]^T,

    A = \\begin{bmatrix} 1 & \\Delta t & \\Delta t^2/2 \\\\ 0 & 1 & \\Delta t \\\\
    0 & 0 & 1 \\end{bmatrix}, \\quad
    b = \\begin{bmatrix} \\Delta t^3/6 \\\\ \\Delta t^2/2 \\\\ \\Delta t \\end{bmatrix},
    \\quad c = [1, 0, -z_c/g],

rewritten as the extended (error) system in :math:`x^*_k = [p_k, \\Delta x_k]`,
input :math:`\\Delta u_k = u_k - u_{k-1}`:

.. math::

    x^*_{k+1} = \\tilde A x^*_k + \\tilde b \\Delta u_k, \\quad
    \\tilde A = \\begin{bmatrix} 1 & cA \\\\ 0 & A \\end{bmatrix}, \\quad
    \\tilde b = \\begin{bmatrix} cb \\\\ b \\end{bmatrix}, \\quad
    \\tilde c = [1, 0, 0, 0].

The control minimizing :math:`\\sum_j Q (p^{ref}_j - p_j)^2 + R \\Delta u_j^2` with
the reference held at :math:`p^{ref}_{k+N}` beyond the preview horizon is

.. math::

    \\Delta u_k = -K x^*_k + \\sum_{j=1}^{N} f_j p^{ref}_{k+j}.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.spatial import STANDARD_GRAVITY

__all__ = [
    "PreviewController",
    "PreviewGains",
    "PreviewResult",
    "cart_table_model",
    "extended_system",
    "preview_gains",
    "solve_riccati_by_iteration",
]


def _positive_finite(name: str, value: float) -> float:
    value = float(value)
    if not np.isfinite(value) or value <= 0.0:
        raise InvalidInput(f"{name} must be a finite number > 0, got {value!r}")
    return value


def cart_table_model(
    dt: float, com_height: float, gravity: float = STANDARD_GRAVITY
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Discrete cart-table model of one horizontal CoM axis.

    .. math::

        x_{k+1} = A x_k + b u_k, \\quad p_k = c x_k, \\quad c = [1, 0, -z_c/g]

    Args:
        dt: Sampling time in [s].
        com_height: CoM height :math:`z_c` above the ZMP plane in [m].
        gravity: Gravitational acceleration :math:`g` in [m/s^2].

    Returns:
        ``(A (3, 3), b (3, 1), c (1, 3))``.
    """
    dt = _positive_finite("dt", dt)
    com_height = _positive_finite("com_height", com_height)
    gravity = _positive_finite("gravity", gravity)
    A = np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    b = np.array([[dt**3 / 6.0], [0.5 * dt * dt], [dt]])
    c = np.array([[1.0, 0.0, -com_height / gravity]])
    return A, b, c


def extended_system(
    A: np.ndarray, b: np.ndarray, c: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Extended (error) system of the irteus manual, state :math:`x^*_k = [p_k, \\Delta x_k]`.

    .. math::

        \\tilde A = \\begin{bmatrix} I & cA \\\\ 0 & A \\end{bmatrix}, \\quad
        \\tilde b = \\begin{bmatrix} cb \\\\ b \\end{bmatrix}, \\quad
        \\tilde c = [I, 0]

    Args:
        A: State matrix (n, n).
        b: Input matrix (n, m).
        c: Output matrix (o, n).

    Returns:
        ``(A_t (o+n, o+n), b_t (o+n, m), c_t (o, o+n))``.
    """
    A, b, c = (np.atleast_2d(np.asarray(M, dtype=float)) for M in (A, b, c))
    n, o = A.shape[0], c.shape[0]
    if A.shape != (n, n) or b.shape[0] != n or c.shape[1] != n:
        raise InvalidInput(
            f"inconsistent shapes A {A.shape}, b {b.shape}, c {c.shape}; "
            "need A (n, n), b (n, m), c (o, n)"
        )
    A_t = np.zeros((o + n, o + n))
    A_t[:o, :o] = np.eye(o)
    A_t[:o, o:] = c @ A
    A_t[o:, o:] = A
    b_t = np.vstack([c @ b, b])
    c_t = np.hstack([np.eye(o), np.zeros((o, n))])
    return A_t, b_t, c_t


def solve_riccati_by_iteration(
    A: np.ndarray,
    b: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    *,
    rtol: float = 1e-14,
    max_iterations: int = 1_000_000,
) -> tuple[np.ndarray, int]:
    """Stationary solution of the irteus manual's Riccati recursion, iterated from P = 0.

    .. math::

        P \\leftarrow Q + A^T P A - A^T P b (b^T P b + R)^{-1} b^T P A

    (with :math:`Q = \\tilde c^T Q \\tilde c` for the preview controller), iterated
    until :math:`\\max|P_{i+1} - P_i| \\le rtol \\cdot \\max(1, \\max|P_{i+1}|)`.

    Args:
        A: State matrix (n, n).
        b: Input matrix (n, m).
        Q: State weight (n, n), symmetric positive semi-definite.
        R: Input weight (m, m), symmetric positive definite.
        rtol: Relative convergence tolerance on the entries of P.
        max_iterations: Iterations after which :class:`PikError` is raised.

    Returns:
        ``(P (n, n), iterations)``.
    """
    P = np.zeros_like(Q, dtype=float)
    for iteration in range(1, max_iterations + 1):
        PA = P @ A
        Pb = P @ b
        gain = np.linalg.solve(b.T @ Pb + R, Pb.T @ A)
        P_next = Q + A.T @ PA - (A.T @ Pb) @ gain
        P_next = 0.5 * (P_next + P_next.T)
        change = np.abs(P_next - P).max()
        P = P_next
        if change <= rtol * max(1.0, np.abs(P).max()):
            return P, iteration
    raise PikError(
        f"Riccati recursion did not converge in {max_iterations} iterations "
        f"(last change {change:.3e}); is (A, b) stabilizable?"
    )


@dataclass(frozen=True)
class PreviewGains:
    """Gains of the extended preview controller (one axis).

    Attributes:
        K: State feedback gain (1, 4), :math:`K = (\\tilde b^T P \\tilde b + R)^{-1}
            \\tilde b^T P \\tilde A`.
        f: Preview gains (N,), ``f[j-1]`` multiplies :math:`p^{ref}_{k+j}`.
        P: Stationary Riccati solution (4, 4).
        iterations: Riccati iterations used.
    """

    K: np.ndarray
    f: np.ndarray
    P: np.ndarray
    iterations: int


def preview_gains(
    A_t: np.ndarray,
    b_t: np.ndarray,
    c_t: np.ndarray,
    q: float,
    r: float,
    n_preview: int,
) -> PreviewGains:
    """Riccati solution, feedback gain and preview gains of the irteus manual.

    .. math::

        P = \\tilde c^T Q \\tilde c + \\tilde A^T P \\tilde A
            - \\tilde A^T P \\tilde b (\\tilde b^T P \\tilde b + R)^{-1}
              \\tilde b^T P \\tilde A

        f_j = \\begin{cases}
          (\\tilde b^T P \\tilde b + R)^{-1} \\tilde b^T
          (\\tilde A - \\tilde b K)^{T (j-1)} \\tilde c^T Q & (j < N) \\\\
          (\\tilde b^T P \\tilde b + R)^{-1} \\tilde b^T
          (\\tilde A - \\tilde b K)^{T (N-1)} P \\tilde c^T & (j = N)
        \\end{cases}

    The j = N term sums the tail :math:`\\sum_{j \\ge N}` of the reference held
    constant, using :math:`(I - (\\tilde A - \\tilde b K)^T) P \\tilde c^T =
    \\tilde c^T Q`.

    Args:
        A_t: Extended state matrix (4, 4).
        b_t: Extended input matrix (4, 1).
        c_t: Extended output matrix (1, 4).
        q: Output error weight Q [1/m^2].
        r: Input weight R on :math:`\\Delta u^2` [s^6/m^2].
        n_preview: Preview steps N >= 1.

    Returns:
        The :class:`PreviewGains`.
    """
    q = _positive_finite("q", q)
    r = _positive_finite("r", r)
    if int(n_preview) != n_preview or n_preview < 1:
        raise InvalidInput(f"n_preview must be an integer >= 1, got {n_preview!r}")
    n_preview = int(n_preview)
    Q_x = q * (c_t.T @ c_t)
    R = np.array([[r]])
    P, iterations = solve_riccati_by_iteration(A_t, b_t, Q_x, R)
    inv_s = 1.0 / float((b_t.T @ P @ b_t + R)[0, 0])
    K = inv_s * (b_t.T @ P @ A_t)
    A_cl_T = (A_t - b_t @ K).T
    f = np.empty(n_preview)
    power = np.eye(A_t.shape[0])  # (A - bK)^{T (j-1)}
    for j in range(1, n_preview + 1):
        tail = c_t.T * q if j < n_preview else P @ c_t.T
        f[j - 1] = inv_s * (b_t.T @ power @ tail)[0, 0]
        power = A_cl_T @ power
    return PreviewGains(K=K, f=f, P=P, iterations=iterations)


@dataclass(frozen=True)
class PreviewResult:
    """CoM trajectory produced by :meth:`PreviewController.run`.

    Row k is the state at :math:`t_k = k \\Delta t`, aligned with ``zmp_ref[k]``.
    Arrays are (T,) for a 1-D reference and (T, d) for a (T, d) reference.

    Attributes:
        com: CoM position :math:`x_k` in [m].
        com_vel: CoM velocity in [m/s].
        com_acc: CoM acceleration in [m/s^2].
        zmp: Cart-table ZMP :math:`p_k = c x_k` in [m].
        zmp_ref: The reference that was tracked in [m].
    """

    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    zmp: np.ndarray
    zmp_ref: np.ndarray


class PreviewController:
    """Extended preview controller of the cart-table model, applied per axis.

    irteus manual: ``preview-control-cart-table-cog-trajectory-generator`` with
    ``extended-preview-controller`` (q = 1, r = 1e-6, delay = 1.6 s).

    Args:
        dt: Sampling time in [s].
        com_height: CoM height above the ZMP plane in [m].
        q: Weight Q of the ZMP error [1/m^2].
        r: Weight R of the jerk increment [s^6/m^2].
        preview_time: Preview horizon in [s]; :math:`N = round(preview\\_time / dt)`.
        gravity: Gravitational acceleration in [m/s^2].
    """

    def __init__(
        self,
        dt: float,
        com_height: float,
        q: float = 1.0,
        r: float = 1e-6,
        preview_time: float = 1.6,
        gravity: float = STANDARD_GRAVITY,
    ):
        self.dt = _positive_finite("dt", dt)
        self.com_height = _positive_finite("com_height", com_height)
        self.gravity = _positive_finite("gravity", gravity)
        preview_time = _positive_finite("preview_time", preview_time)
        self.n_preview = round(preview_time / self.dt)
        if self.n_preview < 1:
            raise InvalidInput(f"preview_time ({preview_time} s) must be at least one dt ({dt} s)")
        self.A, self.b, self.c = cart_table_model(dt, com_height, gravity)
        self.A_t, self.b_t, self.c_t = extended_system(self.A, self.b, self.c)
        self.gains = preview_gains(self.A_t, self.b_t, self.c_t, q, r, self.n_preview)
        self.q, self.r = float(q), float(r)
        self._x: np.ndarray | None = None  # (3, d) state [x, xd, xdd]
        self._dx: np.ndarray | None = None  # (3, d) x_k - x_{k-1}
        self._u: np.ndarray | None = None  # (d,) jerk u_{k-1}

    def __repr__(self) -> str:
        return (
            f"PreviewController(dt={self.dt}, com_height={self.com_height}, "
            f"q={self.q}, r={self.r}, N={self.n_preview})"
        )

    # -- streaming -----------------------------------------------------------
    def reset(self, com0: np.ndarray | float) -> None:
        """Start at rest: :math:`x_0 = [com0, 0, 0]`, :math:`\\Delta x_0 = 0`, u = 0.

        Args:
            com0: Initial CoM position per axis in [m], scalar or (d,).
        """
        com0 = np.atleast_1d(np.asarray(com0, dtype=float))
        if com0.ndim != 1 or not np.all(np.isfinite(com0)):
            raise InvalidInput(f"com0 must be a finite scalar or (d,) vector, got {com0}")
        d = com0.shape[0]
        self._x = np.zeros((3, d))
        self._x[0] = com0
        self._dx = np.zeros((3, d))
        self._u = np.zeros(d)

    @property
    def state(self) -> np.ndarray:
        """Current state (3, d): rows CoM position [m], velocity [m/s], acc [m/s^2]."""
        if self._x is None:
            raise PikError("PreviewController.reset(com0) must be called first")
        return self._x.copy()

    @property
    def extended_state(self) -> np.ndarray:
        """Current extended state :math:`x^*_k = [p_k, \\Delta x_k]` (4, d)."""
        if self._x is None or self._dx is None:
            raise PikError("PreviewController.reset(com0) must be called first")
        return np.vstack([self.c @ self._x, self._dx])

    def jerk_increment(self, p_future: np.ndarray) -> np.ndarray:
        """Optimal input of the current tick, without advancing.

        .. math::

            \\Delta u_k = -K x^*_k + \\sum_{j=1}^N f_j p^{ref}_{k+j}

        Args:
            p_future: References :math:`p^{ref}_{k+1} \\ldots p^{ref}_{k+N}` in [m],
                shape (N, d) (or (N,) for d = 1).

        Returns:
            :math:`\\Delta u_k` (d,) in [m/s^3].
        """
        x_star = self.extended_state
        d = x_star.shape[1]
        window = np.asarray(p_future, dtype=float)
        if window.shape == (self.n_preview,) and d == 1:
            window = window[:, None]
        if window.shape != (self.n_preview, d):
            raise InvalidInput(
                f"p_future must have shape ({self.n_preview}, {d}), got {np.shape(p_future)}"
            )
        return -(self.gains.K @ x_star)[0] + self.gains.f @ window

    def update(self, p_future: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Advance one tick, from k to k+1, given the preview window.

        .. math::

            u_k = u_{k-1} + \\Delta u_k, \\quad x_{k+1} = A x_k + b u_k

        with :math:`\\Delta u_k` from :meth:`jerk_increment`.

        Args:
            p_future: References :math:`p^{ref}_{k+1} \\ldots p^{ref}_{k+N}` in [m],
                shape (N, d) (or (N,) for d = 1).

        Returns:
            ``(com, zmp)`` at tick k+1, each (d,) in [m].
        """
        du = self.jerk_increment(p_future)
        assert self._x is not None and self._u is not None
        self._u = self._u + du
        x_next = self.A @ self._x + self.b * self._u[None, :]
        self._dx = x_next - self._x
        self._x = x_next
        return self._x[0].copy(), (self.c @ self._x)[0].copy()

    # -- batch ---------------------------------------------------------------
    def run(self, zmp_ref: np.ndarray, com0: np.ndarray | float | None = None) -> PreviewResult:
        """CoM trajectory whose cart-table ZMP tracks ``zmp_ref``.

        The reference beyond its end is held at its last value (the irteus manual's queue
        is flushed with the last reference). Row k of every output is the state at
        tick k; row 0 is the initial state at rest over ``com0``.

        Args:
            zmp_ref: ZMP reference in [m], (T,) or (T, d), T >= 1, finite.
            com0: Initial CoM in [m]; defaults to ``zmp_ref[0]``.

        Returns:
            The :class:`PreviewResult`.
        """
        ref = np.asarray(zmp_ref, dtype=float)
        if ref.ndim not in (1, 2) or ref.shape[0] < 1:
            raise InvalidInput(f"zmp_ref must be (T,) or (T, d), got shape {ref.shape}")
        if not np.all(np.isfinite(ref)):
            raise InvalidInput("zmp_ref contains NaN or inf")
        one_d = ref.ndim == 1
        ref2 = ref[:, None] if one_d else ref
        T, d = ref2.shape
        self.reset(ref2[0] if com0 is None else com0)
        if self.state.shape[1] != d:
            raise InvalidInput(f"com0 must have {d} entries, got {np.shape(com0)}")
        N = self.n_preview
        padded = np.vstack([ref2, np.repeat(ref2[-1:], N, axis=0)])
        states = np.empty((T, 3, d))
        states[0] = self.state
        for k in range(T - 1):
            self.update(padded[k + 1 : k + 1 + N])
            states[k + 1] = self._x  # type: ignore[assignment]
        zmp = states[:, 0] + self.c[0, 2] * states[:, 2]

        def shape(a: np.ndarray) -> np.ndarray:
            return a[:, 0].copy() if one_d else a.copy()

        return PreviewResult(
            com=shape(states[:, 0]),
            com_vel=shape(states[:, 1]),
            com_acc=shape(states[:, 2]),
            zmp=shape(zmp),
            zmp_ref=ref.copy(),
        )
