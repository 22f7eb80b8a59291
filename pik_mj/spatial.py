"""Small spatial helpers: the cross-product matrix, row-wise cross products,
rotations about z, quaternion <-> matrix (MuJoCo's own conversions), planar
headings, and the SO(3) logarithm and its inverse left Jacobian.

Quaternions are (w, x, y, z), as MuJoCo stores them; angles in [rad].
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "STANDARD_GRAVITY",
    "cross_rows",
    "ljacinv",
    "ljacinv_rows",
    "matrix_to_quat",
    "quat_log",
    "quat_mul",
    "quat_to_matrix",
    "rot_z",
    "rotation_vector",
    "skew",
    "yaw_of",
    "yaw_quat",
]

STANDARD_GRAVITY = 9.81
"""|g| [m/s²] of the functions that take no model (pure geometry, the cart-table
model); everything that has a model reads ``model.opt.gravity``."""


def skew(v: ArrayLike) -> np.ndarray:
    """Matrix ``[v]×`` (3, 3) with ``[v]× u = v × u``."""
    x, y, z = np.asarray(v, dtype=float).reshape(3).tolist()
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products ``a × b`` of vectors along the last axis (..., 3), broadcast
    as numpy does (rows against rows, one vector against rows, two vectors):
    ``(a_1 b_2 - a_2 b_1, a_2 b_0 - a_0 b_2, a_0 b_1 - a_1 b_0)``, the same
    products and differences as ``np.cross`` (bitwise), without its axis
    handling, which costs more than the products on a few rows."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def rot_z(yaw: float) -> np.ndarray:
    """Rotation (3, 3) by ``yaw`` [rad] about z."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def yaw_quat(yaw: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation by ``yaw`` [rad] about z:
    ``(cos(ψ/2), 0, 0, sin(ψ/2))``."""
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def yaw_of(R: ArrayLike) -> float:
    """Heading [rad] of a rotation: its x axis projected on the ground,
    ``ψ = atan2(R_10, R_00)``."""
    R = np.asarray(R, dtype=float)
    return math.atan2(float(R[1, 0]), float(R[0, 0]))


def quat_to_matrix(quat: ArrayLike) -> np.ndarray:
    """Rotation matrix (3, 3) of a quaternion (w, x, y, z) (``mju_quat2Mat``;
    the quaternion is normalized first)."""
    q = np.asarray(quat, dtype=float).reshape(4)
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, q / np.linalg.norm(q))
    return R.reshape(3, 3)


def matrix_to_quat(R: ArrayLike) -> np.ndarray:
    """Quaternion (w, x, y, z) of a rotation matrix (``mju_mat2Quat``)."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).reshape(9))
    return q


def quat_mul(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """Product ``a ⊗ b`` of two quaternions (w, x, y, z) (``mju_mulQuat``)."""
    out = np.empty(4)
    mujoco.mju_mulQuat(out, np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    return out


def rotation_vector(R: ArrayLike) -> np.ndarray:
    """``log(R)`` as a rotation vector ``θ u`` [rad], ``θ ∈ [0, π]``.

    MuJoCo's ``mju_mat2Quat`` then ``mju_quat2Vel`` (unit time step), which
    picks the shorter of the two rotations a quaternion's sign leaves open.
    """
    e = np.empty(3)
    mujoco.mju_quat2Vel(e, matrix_to_quat(R), 1.0)
    return e


def quat_log(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """The rotation vector [rad] of a unit quaternion, as MuJoCo's
    ``mju_quat2Vel`` at unit time step (the shorter of the two rotations),
    on Python floats: ``θ = 2 atan2(‖v‖, w)``, less ``2π`` above ``π``,
    times ``v / ‖v‖``."""
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-15:  # MuJoCo's mjMINVAL: no axis, no rotation
        return 0.0, 0.0, 0.0
    angle = 2.0 * math.atan2(s, w)
    if angle > math.pi:
        angle -= 2.0 * math.pi
    k = angle / s
    return k * x, k * y, k * z


def ljacinv(e: ArrayLike) -> np.ndarray:
    """Inverse left Jacobian of SO(3) at ``e`` [rad], safe at ``e = 0``.

    .. math::

        J_l^{-1}(e) = I - \\tfrac12 [e]_\\times
            + \\Big(\\frac{1}{\\theta^2} - \\frac{1 + \\cos\\theta}{2\\theta\\sin\\theta}\\Big)
              [e]_\\times^2, \\quad \\theta = \\|e\\|

    Closed form, as mink's ``SO3.ljacinv`` (which divides by zero at ``θ = 0``);
    below 1e-6 rad the series ``I - ½[e]× + [e]×²/12`` is exact to double
    precision.
    """
    x, y, z = np.asarray(e, dtype=float).reshape(3).tolist()
    return np.array(ljacinv_rows(x, y, z))


def ljacinv_rows(x: float, y: float, z: float) -> list[list[float]]:
    """The rows of :func:`ljacinv` at ``e = (x, y, z)``, as Python floats
    (written out with ``[e]×² = e eᵀ − θ² I``)."""
    theta2 = x * x + y * y + z * z
    theta = math.sqrt(theta2)
    if theta < 1e-6:
        c = 1.0 / 12.0
    else:
        c = 1.0 / theta2 - (1.0 + math.cos(theta)) / (2.0 * theta * math.sin(theta))
    a = 1.0 - c * theta2
    cxy, cxz, cyz = c * x * y, c * x * z, c * y * z
    return [
        [a + c * x * x, cxy + 0.5 * z, cxz - 0.5 * y],
        [cxy - 0.5 * z, a + c * y * y, cyz + 0.5 * x],
        [cxz + 0.5 * y, cyz - 0.5 * x, a + c * z * z],
    ]
