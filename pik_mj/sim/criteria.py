"""What a physics hold or motion must show to pass: :class:`HoldCriteria`.

The verdict of a hold (:mod:`pik_mj.sim.hold`) and of a motion
(:mod:`pik_mj.sim.motion`) is: root drift below ``max_drift``, foot slip below
``max_slip``, no fall (:mod:`pik_mj.sim.falls`: trunk tilt, root drift off the
footprint, root height) and no unexpected contact.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.sim.falls import FALL_RATIO, FallLimits, fall_limits
from pik_mj.sim.physics import Physics

__all__ = ["HoldCriteria", "check_options", "slip_verdict_geoms"]


@dataclass(frozen=True)
class HoldCriteria:
    """What a physics hold (or motion) must show to pass.

    Attributes:
        max_drift: Largest root-body displacement [m] (drift < max_drift).
        max_slip: Largest horizontal slip [m] of a foot geom while in contact.
        fall_ratio: The robot fell when its root height drops below this ratio of
            its reference's [-].
        fall_tilt: The robot fell when its trunk (root body) tilts more than this
            from its reference [rad]; None: ``atan(L / h)`` from its foot length
            ``L`` and CoM height ``h`` (:mod:`pik_mj.sim.falls`).
        fall_drift: The robot fell when its root is farther than this
            horizontally from its reference [m]; None: its foot length ``L``.
        allowed: Robot geoms allowed to touch the environment (default: the
            scene's ``allowed_contacts``, its soles); repeated names count once.
        feet: Geoms whose slip is the verdict's foot slip (default: the allowed
            geoms among the scene's ``foot_geoms``, else all allowed geoms;
            :func:`slip_verdict_geoms`). A hand on a wall or a handle still
            appears in ``slip_per_geom``.
        allow_self_contact: Do not count robot self-contacts as unexpected.
        stop_on_fall: End the simulation as soon as the robot fell.
        max_ground_slope: Largest angle [rad] between a contact normal and up for
            the contact to count in the support polygon.
    """

    max_drift: float = 0.01
    max_slip: float = 0.002
    fall_ratio: float = FALL_RATIO
    fall_tilt: float | None = None
    fall_drift: float | None = None
    allowed: Sequence[str] | None = None
    feet: Sequence[str] | None = None
    allow_self_contact: bool = False
    stop_on_fall: bool = True
    max_ground_slope: float = math.pi / 4

    def __post_init__(self) -> None:
        for label in ("max_drift", "max_slip"):
            inputs.real(getattr(self, label), label, unit="m", low=0, low_open=True)
        inputs.real(self.fall_ratio, "fall_ratio", low=0, high=1, low_open=True, high_open=True)
        if self.fall_tilt is not None:
            inputs.real(self.fall_tilt, "fall_tilt", unit="rad", low=0, high=math.pi, low_open=True)
        if self.fall_drift is not None:
            inputs.real(self.fall_drift, "fall_drift", unit="m", low=0, low_open=True)
        inputs.real(self.max_ground_slope, "max_ground_slope", unit="rad", low=0, high=math.pi / 2)
        inputs.flag(self.allow_self_contact, "allow_self_contact")
        inputs.flag(self.stop_on_fall, "stop_on_fall")
        for label, names in (("allowed", self.allowed), ("feet", self.feet)):
            if names is not None:
                names = inputs.names(names, f"{label} (robot geoms)")
                object.__setattr__(self, label, tuple(dict.fromkeys(names)))

    def thresholds(self) -> dict[str, float]:
        """``{"max_drift", "max_slip", "fall_ratio"}``: the pass/fail thresholds
        (the fall's tilt and drift, resolved for a robot, are
        :meth:`FallLimits.thresholds <pik_mj.sim.falls.FallLimits.thresholds>`)."""
        return {
            "max_drift": self.max_drift,
            "max_slip": self.max_slip,
            "fall_ratio": self.fall_ratio,
        }

    def fall_limits(
        self, scene: Physics, com_height: float | None, root_height: float
    ) -> FallLimits:
        """The fall thresholds for ``scene``'s robot: this criteria's, the
        unset ones from the robot's foot length
        (:attr:`~pik_mj.sim.physics.Physics.foot_length`), ``com_height`` (CoM
        above the feet at the start [m]) and ``root_height`` [m]
        (:func:`pik_mj.sim.falls.fall_limits`)."""
        return fall_limits(
            self.fall_tilt,
            self.fall_drift,
            self.fall_ratio,
            foot=scene.foot_length,
            com_height=com_height,
            root_height=root_height,
        )


def check_options(criteria: HoldCriteria | None, duration: float, **counts: int) -> HoldCriteria:
    """``criteria`` (default :class:`HoldCriteria`) after checking it, a duration
    > 0 [s] and positive integer ``counts`` (``every=...``)."""
    criteria = HoldCriteria() if criteria is None else criteria
    if not isinstance(criteria, HoldCriteria):
        raise InvalidInput(f"criteria must be a HoldCriteria, got {type(criteria).__name__}")
    inputs.real(duration, "duration", unit="s", low=0, low_open=True)
    for label, v in counts.items():
        inputs.integer(v, label, low=1)
    return criteria


def slip_verdict_geoms(scene: Physics, allowed: Sequence[str], criteria: HoldCriteria) -> set[str]:
    """The geoms whose slip is the verdict's foot slip (:attr:`HoldCriteria.feet`;
    by default the ``allowed`` geoms among the robot's foot geoms
    (:attr:`~pik_mj.sim.physics.Physics.foot_geoms`), else all ``allowed``).

    Raises:
        UnknownName: A geom of ``criteria.feet`` that is not the robot's.
    """
    feet = criteria.feet
    if feet is None:
        feet = [n for n in allowed if n in scene.foot_geoms] or list(allowed)
    return set(scene.check_robot_geoms(feet))
