r"""The figures of a hold or a motion, computed over its :class:`~pik_mj.sim.sampling.Record`
at once (:func:`figures`).

With ``p_B`` the root body position, ``p_g`` a watched geom's centre and
``ref`` the reference's value at the same sample ``t``:

.. math::

    \text{drift} = \max_t \|p_B(t) - p_B^{ref}(t)\|, \qquad
    \text{slip}_g = \max_{t \text{ touching}} \|P_h(Δ_g(t) - Δ_g(t_g))\|, \quad
    Δ_g = p_g - p_g^{ref}

``t_g`` the first sample of the run of samples in which ``g`` touches (its
touch-down); the tracking error ``max_t |q - q_ref|`` over the servo joints;
each task frame's largest distance to its reference; the falls of
:mod:`pik_mj.sim.falls`. The CoM margin is the signed distance of the CoM to
the convex hull of the ground contact points at every ``margin_every``-th
sample. A hull is computed once for consecutive samples with the same contacts
whose points moved less than :data:`HULL_TOLERANCE` from the first's (a held
pose's feet barely move), and the margins of those samples come from its
half-planes at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from pik_mj.sim.falls import FallLimits, fall_measures, first_fall
from pik_mj.sim.measures import Tracked
from pik_mj.sim.physics import Physics
from pik_mj.sim.sampling import Record

__all__ = ["HULL_TOLERANCE", "RunningFigures", "figures", "margins", "slips"]

HULL_TOLERANCE = 1e-4
"""Largest move [m] of a ground contact point for which a support hull is reused."""


def slips(delta: np.ndarray, touching: np.ndarray) -> np.ndarray:
    """Largest slip (g,) [m] of each geom: ``delta`` (n, g, 3) its horizontal
    displacement from the reference per sample, ``touching`` (n, g) whether it
    touches; its slip is the distance to its displacement at the touch-down
    that began the current run of touching samples (0 if it never touched)."""
    n, g = touching.shape
    if not n or not g:
        return np.zeros(g)
    before = np.vstack([np.zeros((1, g), bool), touching[:-1]])
    start = touching & ~before
    index = np.where(start, np.arange(n)[:, None], 0)
    anchor = np.maximum.accumulate(index, axis=0)  # the last touch-down at or before t
    moved = np.linalg.norm(delta - delta[anchor, np.arange(g)], axis=2)
    return np.max(np.where(touching, moved, 0.0), axis=0)


class RunningFigures:
    """The drift and the largest slip of a run so far, row by row: what
    :func:`figures` computes over the whole record (the same definitions), for a
    callback at every sample without going over the record again.

    Args:
        scene: The scene (its up direction).
        watched: Number of watched geoms (record columns).
    """

    def __init__(self, scene: Physics, watched: int):
        up = scene.up()
        self.P_h = np.eye(3) - np.outer(up, up)
        self.rows = 0
        self.drift = 0.0
        self.anchor = np.zeros((watched, 3))
        self.touching = np.zeros(watched, dtype=bool)
        self.slip_per_geom = np.zeros(watched)

    @property
    def slip(self) -> float:
        """Largest slip of a watched geom so far [m]."""
        return float(np.max(self.slip_per_geom, initial=0.0))

    def update(self, record: Record) -> None:
        """Take in the rows of ``record`` not seen yet."""
        for i in range(self.rows, len(record)):
            dp = record.root_pos[i] - record.ref_root_pos[i]
            self.drift = max(self.drift, float(np.linalg.norm(dp)))
            delta = (record.geoms[i] - record.ref_geoms[i]) @ self.P_h
            touch = record.touching[i]
            down = touch & ~self.touching  # a touch-down: the slip's new anchor
            self.anchor[down] = delta[down]
            moved = np.linalg.norm(delta - self.anchor, axis=1)
            self.slip_per_geom = np.maximum(self.slip_per_geom, np.where(touch, moved, 0.0))
            self.touching = touch
        self.rows = len(record)


def margins(
    scene: Physics, ground: Sequence[tuple[np.ndarray, bytes]], com: np.ndarray
) -> np.ndarray:
    """CoM margins [m] (len(ground),) to the hulls of the ground contact points
    (module docstring); ``-inf`` without ground contact."""
    out = np.full(len(ground), -math.inf)
    k = 0
    while k < len(ground):
        points, key = ground[k]
        j = k + 1
        while (
            j < len(ground)
            and ground[j][1] == key
            and np.max(np.abs(ground[j][0] - points), initial=0.0) < HULL_TOLERANCE
        ):
            j += 1
        region = scene.support_region(points)
        if region is not None and region.halfplanes is not None:
            A, b = region.halfplanes
            uv = com[k:j] @ region.R[:, :2]
            out[k:j] = np.min(uv @ A.T + b, axis=1)
        elif region is not None:
            out[k:j] = [region.signed_distance(c) for c in com[k:j]]
        k = j
    return out


def figures(
    scene: Physics,
    record: Record,
    watched: Sequence[str],
    feet: set[str],
    limits: FallLimits,
    steps: int,
    t_start: float,
    wall_time: float,
    frames: Sequence[str] = (),
) -> Tracked:
    """The measures of a run (module docstring) as a :class:`~pik_mj.sim.tracking.Tracked`."""
    up = scene.up()
    P_h = np.eye(3) - np.outer(up, up)
    t = np.array(record.time)
    root, ref_root = np.array(record.root_pos), np.array(record.ref_root_pos)
    dp = root - ref_root
    tilt, drift_h, height, ref_height = fall_measures(
        root, np.array(record.root_mat), ref_root, np.array(record.ref_root_mat), up
    )
    q_err = np.abs(np.array(record.q) - np.array(record.ref_q)).reshape(len(t), -1)
    worst = np.max(q_err, axis=1, initial=0.0)
    joint = int(np.argmax(np.max(q_err, axis=0))) if q_err.size else -1
    delta = (np.array(record.geoms) - np.array(record.ref_geoms)) @ P_h
    slip = slips(
        delta.reshape(len(t), len(watched), 3), np.array(record.touching).reshape(len(t), -1)
    )
    touched = np.any(np.array(record.touching).reshape(len(t), -1), axis=0)
    slip_per_geom = {n: float(s) for n, s, hit in zip(watched, slip, touched, strict=True) if hit}
    rows = np.array(record.margin_rows, dtype=int)
    margin = margins(scene, record.ground, np.array(record.com)[rows].reshape(-1, 3))
    frame_err = (
        np.linalg.norm(np.array(record.frames) - np.array(record.ref_frames), axis=2)
        if frames
        else np.zeros((len(t), 0))
    )
    fall = first_fall(t, tilt, drift_h, height, ref_height, limits)
    return Tracked(
        drift=float(np.max(np.linalg.norm(dp, axis=1))),
        drift_horizontal=float(np.max(drift_h)),
        drift_vertical=float(np.max(np.abs(dp @ up))),
        final_displacement=dp[-1].copy(),
        slip_per_geom=slip_per_geom,
        foot_slip=max((v for n, v in slip_per_geom.items() if n in feet), default=0.0),
        min_margin=float(np.min(margin, initial=math.inf)),
        fell=fall is not None,
        fall=fall,
        tilt=float(np.max(tilt)),
        limits=limits,
        unexpected=dict(record.unexpected),
        steps=steps,
        simulated=float(t[-1] - t_start),
        end_time=float(t[-1]),
        root_height=(float(height[0]), float(height[-1])),
        tracking_error=float(np.max(worst)),
        tracking_joint=scene.servo_joints[joint] if joint >= 0 else None,
        frame_errors={name: float(np.max(frame_err[:, i])) for i, name in enumerate(frames)},
        series={
            "time": t[rows],
            "margin": margin,
            "tracking_error": worst[rows],
            "waypoint": np.array(record.waypoint)[rows],
        },
        wall_time=wall_time,
    )
