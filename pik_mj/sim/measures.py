"""What a hold or a motion is measured against and what it measured: the
:class:`Reference` the servos track, the :class:`HoldSample` a callback gets,
the :class:`Tracked` figures of a run (:mod:`pik_mj.sim.tracking` runs it,
:mod:`pik_mj.sim.figures` computes them)."""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import mujoco
import numpy as np

from pik_mj.frames import Frame
from pik_mj.sim.criteria import HoldCriteria
from pik_mj.sim.falls import Fall, FallLimits
from pik_mj.sim.physics import Physics

__all__ = ["HoldSample", "Reference", "Tracked", "describe_contacts"]


@dataclass(eq=False)
class HoldSample:
    """The physics state a hold callback receives (valid during the call).

    Attributes:
        time: Simulated time [s].
        step: Physics steps taken.
        model: The physics model.
        data: The physics state now (do not modify).
        com: CoM ``p_WG`` (3,) [m] of the robot and its grasped objects.
        drift: Largest root displacement so far [m].
        slip: Largest foot slip so far [m].
        support_polygon: Support polygon of the touching ground contacts (m, 3) [m]
            (computed on first access).
        margin: CoM margin to it [m] (``-inf`` without ground contact).
        contact_points: Active contact points with the environment (n, 3) [m].
        contact_forces: MuJoCo's contact forces on the robot there (n, 3) [N].
        reference: Kinematics of the reference pose now (a motion's; None in a
            hold, whose reference is its start).
        waypoint: Index of the last waypoint the reference passed (a motion's),
            or None.
        tracking_error: Largest servo joint error ``|q - q_ref|`` now [rad or m].
        frame_errors: Distance [m] of each tracked task frame to its reference
            position, by frame name (computed on first access; empty in a hold).
    """

    time: float
    step: int
    model: mujoco.MjModel
    data: mujoco.MjData
    com: np.ndarray
    drift: float
    slip: float
    _scene: Physics = field(repr=False)
    reference: mujoco.MjData | None = field(default=None, repr=False)
    waypoint: int | None = None
    tracking_error: float = 0.0
    _frames: Sequence[Frame] = field(default=(), repr=False)
    _max_slope: float = field(default=math.pi / 4, repr=False)
    _support: tuple[np.ndarray, float] | None = field(default=None, repr=False)

    def _region(self) -> tuple[np.ndarray, float]:
        if self._support is None:
            contacts = self._scene.touching(self.data.qpos)
            region, margin = self._scene.support(contacts, self.com, self._max_slope)
            polygon = np.zeros((0, 3)) if region is None else region.vertices_3d
            self._support = (polygon, margin)
        return self._support

    @property
    def support_polygon(self) -> np.ndarray:
        return self._region()[0]

    @property
    def margin(self) -> float:
        return self._region()[1]

    @functools.cached_property
    def _contact_forces(self) -> tuple[np.ndarray, np.ndarray]:
        return self._scene.contact_forces(self.data)

    @property
    def contact_points(self) -> np.ndarray:
        return self._contact_forces[0]

    @property
    def contact_forces(self) -> np.ndarray:
        return self._contact_forces[1]

    @functools.cached_property
    def frame_errors(self) -> dict[str, float]:
        if self.reference is None:
            return {}
        return {
            f.name: float(np.linalg.norm(f.position(self.data) - f.position(self.reference)))
            for f in self._frames
        }


class Reference(Protocol):
    """What :func:`pik_mj.sim.tracking.track` steps the physics along.

    Attributes:
        moving: False for a constant reference (its kinematics never change).
        data: Kinematics of the reference pose at the last :meth:`update` (an
            ``MjData`` of the scene's model: body, site and geom poses).
        waypoint: Index of the last waypoint passed, or None.
        load: Scale of the external wrenches at the last :meth:`update` [-].
    """

    moving: bool
    data: mujoco.MjData
    waypoint: int | None
    load: float

    def begin(self, data: mujoco.MjData | None = None) -> None:
        """Put the physics (the scene's data) at the reference's start, its
        controls of time 0 written; the reference's kinematics (:attr:`data`)
        in ``data`` from now on (a data of the scene's model at its reset
        state; default: a new one)."""

    def update(self, t: float) -> None:
        """Move the reference to time ``t`` [s] from its start: :attr:`data`,
        :attr:`waypoint`, :attr:`load`."""

    def updates(self, times: np.ndarray) -> Iterator[None]:
        """Move the reference to each of ``times`` [s] in turn (as :meth:`update`),
        yielding after each: the stepping loop reads the rows of a chunk."""

    def controls(self, t: np.ndarray) -> np.ndarray:
        """The actuators' controls (len(t), nu) of the steps that start at times
        ``t`` [s] from the reference's start."""

    def loads(self, t: np.ndarray) -> np.ndarray:
        """The scale (len(t),) of the external wrenches in those steps [-]."""


@dataclass
class Tracked:
    """What :func:`pik_mj.sim.tracking.track` measured (see :class:`pik_mj.sim.hold.HoldReport` for
    the metrics).

    Attributes:
        drift: Largest root-body distance to its reference position [m].
        drift_horizontal: Its largest horizontal part [m].
        drift_vertical: Its largest vertical part [m].
        final_displacement: Root body minus its reference position at the end (3,) [m].
        slip_per_geom: Largest slip of each allowed geom that touched [m].
        foot_slip: Largest slip of a foot geom [m].
        min_margin: Smallest CoM margin to the support polygon [m].
        fell: The robot fell (:mod:`pik_mj.sim.falls`).
        fall: The first sign of the fall (None: no fall).
        tilt: Largest trunk tilt from the reference [rad].
        limits: The fall thresholds used.
        unexpected: ``(robot geom, other geom) -> first time [s]``.
        steps: Physics steps taken.
        simulated: Simulated time [s].
        end_time: Physics time at the end [s].
        root_height: Root height at the start and at the end [m].
        tracking_error: Largest servo joint error ``|q - q_ref|`` [rad or m].
        tracking_joint: The joint where it was reached (None without servos).
        frame_errors: Largest distance of each tracked frame to its reference [m].
        series: ``time`` [s], ``margin`` [m], ``tracking_error`` and ``waypoint``
            at the samples whose margin was evaluated.
        wall_time: Wall-clock time [s].
        settled: The physics state (``mjSTATE_INTEGRATION``) :data:`SETTLE` after
            the start, what :func:`pik_mj.sim.stability.unstable_mode` linearizes
            about (None if the run ended before).
    """

    drift: float
    drift_horizontal: float
    drift_vertical: float
    final_displacement: np.ndarray
    slip_per_geom: dict[str, float]
    foot_slip: float
    min_margin: float
    fell: bool
    fall: Fall | None
    tilt: float
    limits: FallLimits
    unexpected: dict[tuple[str, str], float]
    steps: int
    simulated: float
    end_time: float
    root_height: tuple[float, float]
    tracking_error: float
    tracking_joint: str | None
    frame_errors: dict[str, float]
    series: dict[str, np.ndarray]
    wall_time: float
    settled: np.ndarray | None = None

    def failures(self, criteria: HoldCriteria, drift: str = "base drift") -> list[str]:
        """One line per failed criterion of ``criteria``; ``drift`` names the drift."""
        out = []
        if self.drift >= criteria.max_drift:
            out.append(f"{drift} {self.drift * 1e3:.1f} mm >= {criteria.max_drift * 1e3:.1f} mm")
        if self.foot_slip >= criteria.max_slip:
            out.append(
                f"foot slip {self.foot_slip * 1e3:.2f} mm >= {criteria.max_slip * 1e3:.2f} mm"
            )
        if self.fall is not None:
            out.append(self.fall.describe())
        if self.unexpected:
            out.append(describe_contacts(self.unexpected))
        return out


def describe_contacts(unexpected: dict[tuple[str, str], float]) -> str:
    """``unexpected contacts: a-b at 0.512 s, ...``: each pair with the time it began."""
    pairs = ", ".join(f"{a}-{b} at {t:.3f} s" for (a, b), t in unexpected.items())
    return f"unexpected contacts: {pairs}"
