"""Small spatial helpers shared by the top layer: cross-product matrix, rotations
about z, quaternion <-> matrix (MuJoCo's own conversions), planar headings.

Quaternions are (w, x, y, z), as MuJoCo stores them; angles in [rad].
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "STANDARD_GRAVITY",
    "matrix_to_quat",
    "quat_mul",
    "quat_to_matrix",
    "rot_z",
    "skew",
    "yaw_of",
    "yaw_quat",
]

STANDARD_GRAVITY = 9.81
"""|g| [m/s²] of the functions that take no model (pure geometry, the cart-table
model); everything that has a model reads ``model.opt.gravity``."""


def skew(v: ArrayLike) -> np.ndarray:
    """Matrix ``[v]x`` (3, 3) with ``[v]x u = v x u``."""
    x, y, z = np.asarray(v, dtype=float).reshape(3)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


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
