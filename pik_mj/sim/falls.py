r"""Falls: the trunk tilted, the root left its footprint, or the root sank.

A robot held or moved in physics has fallen at the first time ``t`` when one of

.. math::

    \theta(t) = \angle\big(R_{WB}(t)\, R^{ref}_{WB}(t)^T u,\; u\big) > \theta_{max}
    \qquad \text{(trunk tilt)}

    d(t) = \|P_h\,(p_{WB}(t) - p^{ref}_{WB}(t))\| > d_{max}
    \qquad \text{(root drift, horizontal)}

    u^T p_{WB}(t) < r \; u^T p^{ref}_{WB}(t)
    \qquad \text{(root height)}

holds, with ``B`` the robot's root body (its trunk: pelvis or torso), ``u`` the
unit vector against gravity, ``P_h = I - u u^T`` and ``ref`` the reference at
the same time (the start of a hold; a motion's reference pose). The tilt is
the angle by which the body axis that points up in the reference has turned
away from up: a turn about the vertical (yaw) is no tilt.

The thresholds (:class:`FallLimits`, from :class:`~pik_mj.sim.criteria.HoldCriteria`'s
``fall_tilt``, ``fall_drift``, ``fall_ratio``) default to sizes of the robot
(:func:`fall_limits`): with ``L`` its foot length (the largest horizontal extent
of a foot's collision geoms, :func:`foot_length`) and ``h`` the height of its
CoM above its feet at the start,

.. math::

    \theta_{max} = \arctan(L / h), \qquad d_{max} = L, \qquad r = 0.8

A rigid robot pivoting about the edge of its feet has its CoM half a foot
length beyond the footprint's centre, at its edge, at ``atan(L / 2h)``: the
tilt threshold is the angle at which the CoM is a whole foot length away,
well past the point of no return. A root a foot length from where it should
be has left its footprint. Without feet (a fixed-base arm) the tilt threshold
is :data:`FALLBACK_TILT` and the drift threshold a quarter of the root's
start height.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

__all__ = [
    "FALLBACK_TILT",
    "FALL_RATIO",
    "Fall",
    "FallLimits",
    "fall_limits",
    "fall_measures",
    "first_fall",
    "foot_length",
]

FALL_RATIO = 0.8
"""Default ratio of the root's reference height below which the robot fell [-]."""

FALLBACK_TILT = math.pi / 6
"""Tilt threshold [rad] of a robot without feet (30°)."""


@dataclass(frozen=True)
class FallLimits:
    """The thresholds of a fall, resolved for one robot and run (module docstring).

    Attributes:
        tilt: Largest trunk tilt from the reference [rad].
        drift: Largest horizontal root distance to the reference [m].
        ratio: Smallest root height over the reference's [-].
        foot_length: The robot's foot length ``L`` [m] (None without feet).
        com_height: CoM height above the feet at the start ``h`` [m] (None without feet).
    """

    tilt: float
    drift: float
    ratio: float
    foot_length: float | None = None
    com_height: float | None = None

    def thresholds(self) -> dict[str, float]:
        """``{"fall_tilt", "fall_drift", "fall_ratio"}`` [rad, m, -]."""
        return {"fall_tilt": self.tilt, "fall_drift": self.drift, "fall_ratio": self.ratio}


@dataclass(frozen=True)
class Fall:
    """The first sign of a fall.

    Attributes:
        kind: ``"tilt"``, ``"drift"`` or ``"height"``.
        time: Physics time [s] when it was first seen.
        value: The trunk tilt [rad], the root's horizontal drift [m] or its height [m].
        limit: The threshold it passed (for ``"height"``: ``ratio ×`` the
            reference height) [rad or m].
    """

    kind: str
    time: float
    value: float
    limit: float

    def describe(self) -> str:
        """The fall in words with its figure and time."""
        if self.kind == "tilt":
            what = (
                f"trunk tilted {math.degrees(self.value):.1f}° ({self.value:.3f} rad) from its "
                f"reference, beyond {math.degrees(self.limit):.1f}°"
            )
        elif self.kind == "drift":
            what = (
                f"root {self.value * 1e3:.0f} mm (horizontally) from its reference, beyond "
                f"{self.limit * 1e3:.0f} mm"
            )
        else:
            what = f"root at {self.value:.3f} m, below {self.limit:.3f} m"
        return f"fell at {self.time:.3f} s: {what}"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "time": self.time, "value": self.value, "limit": self.limit}


def foot_length(
    model: mujoco.MjModel, data: mujoco.MjData, geoms: list[int], up: np.ndarray
) -> float | None:
    """The largest horizontal extent [m] of one foot: the corners of the
    axis-aligned boxes (``geom_aabb``) of the foot ``geoms`` (ids), grouped by
    body, at the kinematics in ``data``, projected on the plane normal to ``up``;
    the largest distance between two corners of one body's geoms. None without geoms."""
    if not geoms:
        return None
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    P_h = np.eye(3) - np.outer(up, up)
    by_body: dict[int, list[np.ndarray]] = {}
    for g in geoms:
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        local = centre + signs * half
        corners = data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T
        by_body.setdefault(int(model.geom_bodyid[g]), []).append(corners @ P_h)
    length = 0.0
    for corners in by_body.values():
        pts = np.concatenate(corners)
        length = max(length, float(np.max(np.linalg.norm(pts[:, None] - pts[None], axis=-1))))
    return length


def fall_limits(
    tilt: float | None,
    drift: float | None,
    ratio: float,
    *,
    foot: float | None,
    com_height: float | None,
    root_height: float,
) -> FallLimits:
    """The thresholds of a fall: the given ones, the others from the robot's
    foot length ``foot`` [m], its CoM height above the feet ``com_height`` [m]
    and its root's start height ``root_height`` [m] (module docstring)."""
    feet = foot is not None and foot > 0 and com_height is not None and com_height > 0
    if tilt is None:
        tilt = math.atan2(foot, com_height) if feet else FALLBACK_TILT
    if drift is None:
        drift = foot if feet else 0.25 * abs(root_height)
    return FallLimits(
        tilt=float(tilt),
        drift=float(drift),
        ratio=float(ratio),
        foot_length=foot if feet else None,
        com_height=com_height if feet else None,
    )


def fall_measures(
    p_WB: np.ndarray,
    R_WB: np.ndarray,
    p_ref: np.ndarray,
    R_ref: np.ndarray,
    up: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Trunk tilt [rad], horizontal root drift [m], root height and reference
    root height [m] of ``n`` samples (module docstring).

    Args:
        p_WB: Root positions (n, 3) [m].
        R_WB: Root orientations (n, 3, 3) (or MuJoCo's ``xmat`` rows, (n, 9)).
        p_ref: Reference root positions (n, 3) or (3,) [m].
        R_ref: Reference root orientations (n, 3, 3), (3, 3) or (9,).
        up: Unit vector against gravity (3,).

    Returns:
        ``(tilt (n,), drift (n,), height (n,), reference height (n,))``.
    """
    p_WB, R_WB = np.asarray(p_WB, float).reshape(-1, 3), np.asarray(R_WB, float).reshape(-1, 3, 3)
    p_ref = np.broadcast_to(np.asarray(p_ref, float).reshape(-1, 3), p_WB.shape)
    R_ref = np.broadcast_to(np.asarray(R_ref, float).reshape(-1, 3, 3), R_WB.shape)
    axis_B = np.einsum("nji,j->ni", R_ref, up)  # the body axis pointing up in the reference
    cos = np.einsum("nij,nj,i->n", R_WB, axis_B, up)
    tilt = np.arccos(np.minimum(np.maximum(cos, -1.0), 1.0))
    dp = p_WB - p_ref
    across = dp - np.outer(dp @ up, up)
    drift = np.sqrt(np.add.reduce(across * across, axis=1))  # np.linalg.norm(across, axis=1)
    return tilt, drift, p_WB @ up, p_ref @ up


def first_fall(
    times: np.ndarray,
    tilt: np.ndarray,
    drift: np.ndarray,
    height: np.ndarray,
    ref_height: np.ndarray,
    limits: FallLimits,
) -> Fall | None:
    """The first sample past a threshold of ``limits`` (tilt checked first, then
    drift, then height at that sample), or None."""
    low = limits.ratio * np.asarray(ref_height)
    past = (tilt > limits.tilt) | (drift > limits.drift) | (height < low)
    hits = np.flatnonzero(past)
    if not len(hits):
        return None
    k = int(hits[0])
    t = float(times[k])
    if tilt[k] > limits.tilt:
        return Fall("tilt", t, float(tilt[k]), limits.tilt)
    if drift[k] > limits.drift:
        return Fall("drift", t, float(drift[k]), limits.drift)
    return Fall("height", t, float(height[k]), float(low[k]))
