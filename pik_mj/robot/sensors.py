"""A robot's MJCF sensors (irteus manual: ``:force-sensors``, ``:imu-sensors``,
``bumper-model``) and the ZMP from foot force sensors
(``:calc-zmp-from-forces-moments``).

MuJoCo computes every reading (``data.sensordata``, after ``mj_forward`` or
``mj_step``); this module names them, groups them the way irteus does, and
turns force/torque readings into the wrench the environment applies.

* **Force sensor** (:class:`ForceSensor`): a MuJoCo ``force`` and ``torque``
  sensor on one site, a 6-axis force/torque sensor. MuJoCo reports the wrench
  ``(f_S, n_S)`` that the parent body exerts on the subtree of the site's body
  (the *distal part* ``D``: a foot, a hand), in the site frame, the moment about
  the site origin. The wrench the environment applies to ``D`` then follows
  from ``D``'s equilibrium (:meth:`ForceSensor.contact_wrench`):

  .. math::

      f_{env} = -R_{WS} f_S - m_D\\, g, \\qquad
      n_{env} = -R_{WS} n_S - (c_D - p_{WS}) \\times m_D\\, g

  with ``m_D``, ``c_D`` the mass and CoM of ``D`` and ``g`` the model's gravity
  (``model.opt.gravity``). This is exact at rest; in motion it leaves out
  ``m_D a_D`` of the distal part, as a real sensor's weight compensation does.
* **IMU** (:class:`Imu`): ``accelerometer`` (``a − g`` in the site frame
  [m/s²]: ``R_WSᵀ (−g)`` at rest), ``gyro`` (angular velocity in the site
  frame [rad/s]) and ``framequat`` (orientation ``q_WS``, w x y z) on one site.
* **Bumper** (:class:`Bumper`): a MuJoCo ``touch`` sensor, the normal force [N]
  of the contacts inside its site's volume, read on/off with a threshold (the
  irteus bumper returns 1/0; its threshold is a distance, MuJoCo's touch
  sensor measures force).
* **ZMP** (:func:`zmp_from_wrenches`, :func:`zmp_from_force_sensors`): the
  point of the floor plane ``z = h`` about which the horizontal moment of the
  summed contact wrenches vanishes. With every wrench ``(f_i, n_i)`` taken about
  a common point ``P = (0, 0, h)``:

  .. math::

      f = \\sum_i f_i, \\quad n_P = \\sum_i n_i + (p_i - P) \\times f_i, \\qquad
      p_{zmp} = P + \\left(-\\frac{n_{P,y}}{f_z},\\; \\frac{n_{P,x}}{f_z},\\; 0\\right)

  One wrench gives one foot's centre of pressure; the ZMP of double support is
  the same formula over both feet (equal to the ``f_z``-weighted mean of the
  feet's centres of pressure, as irteus computes it). A sensor whose
  ``f_z`` is below a threshold takes no part; with none left the ZMP is
  undefined (irteus returns nil, this module None).

Sensors that a robot's MJCF lacks are added to its ``MjSpec`` on the sites the
caller names with :func:`~pik_mj.robot.sensor_channels.add_sensors`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from pik_mj.dynamics import zmp_from_wrench
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.frames import names_of
from pik_mj.robot.sensor_channels import (
    FORCE_TORQUE,
    IMU,
    KINDS,
    TOUCH,
    SensorChannel,
    add_sensors,
    site_channels,
)

__all__ = [
    "DEFAULT_BUMPER_THRESHOLD",
    "DEFAULT_FZ_THRESHOLD",
    "FORCE_TORQUE",
    "IMU",
    "KINDS",
    "TOUCH",
    "Bumper",
    "ContactWrench",
    "ForceSensor",
    "Imu",
    "ImuReading",
    "RobotSensors",
    "SensorChannel",
    "SensorTrace",
    "SensorZmp",
    "add_sensors",
    "zmp_from_force_sensors",
    "zmp_from_wrenches",
]

DEFAULT_BUMPER_THRESHOLD = 1.0
"""Touch force [N] at and above which a bumper reads on."""

DEFAULT_FZ_THRESHOLD = 1.0
"""Normal force [N] below which a force sensor takes no part in the ZMP (the
irteus manual's ``fz-thre``, 1 mN there; 1 N here because a compensated swing foot
still reads its own ``m_D a_D``)."""


# ----------------------------------------------------------------------------
# sensors as irteus groups them
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class ContactWrench:
    """A wrench acting on the robot, world frame.

    Attributes:
        force: ``f`` (3,) [N].
        moment: ``n`` (3,) [N·m] about :attr:`point`.
        point: ``p_W`` (3,) [m] (the sensor site's origin).
    """

    force: np.ndarray
    moment: np.ndarray
    point: np.ndarray


@dataclass(frozen=True)
class ForceSensor:
    """A 6-axis force/torque sensor: MuJoCo ``force`` + ``torque`` sensors on one
    site (either may be missing). Named after the site.

    Attributes:
        name: The site's name.
        site_id: The site's id.
        body: The site's body (the root of the distal part ``D``).
        body_id: Its id.
        force: The ``force`` channel, or None.
        torque: The ``torque`` channel, or None.
    """

    name: str
    site_id: int
    body: str
    body_id: int
    force: SensorChannel | None
    torque: SensorChannel | None

    def reading(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """MuJoCo's reading ``(f_S [N], n_S [N·m])`` in the site frame: the wrench
        the parent body exerts on the distal part, about the site origin. A
        missing channel reads NaN."""
        f = self.force.read(data) if self.force is not None else np.full(3, np.nan)
        n = self.torque.read(data) if self.torque is not None else np.full(3, np.nan)
        return f, n

    def contact_wrench(
        self, model: mujoco.MjModel, data: mujoco.MjData, *, compensate: bool = True
    ) -> ContactWrench:
        """The wrench the environment applies to the distal part (module
        docstring), world frame, about the site origin.

        Args:
            model: The model.
            data: State after ``mj_forward``/``mj_step`` (sensors and kinematics).
            compensate: Remove the weight of the distal part. Without it the
                result is ``−R_WS (f_S, n_S)``: the wrench the distal part applies
                to the robot above the sensor.
        """
        f_S, n_S = self.reading(data)
        R_WS = data.site_xmat[self.site_id].reshape(3, 3)
        p_WS = data.site_xpos[self.site_id].copy()
        f, n = -R_WS @ f_S, -R_WS @ n_S
        if compensate:
            weight = model.body_subtreemass[self.body_id] * np.asarray(model.opt.gravity)
            f = f - weight
            n = n - np.cross(data.subtree_com[self.body_id] - p_WS, weight)
        return ContactWrench(force=f, moment=n, point=p_WS)

    def loaded(self, model: mujoco.MjModel, data: mujoco.MjData) -> bool:
        """Whether something outside the distal part pushes on it: a MuJoCo
        contact between a body of the distal part (the site's body and the
        bodies below it) and a body outside it, with a normal force > 0
        (``mj_contactForce``). A foot in the air carries no load, whatever
        the compensated reading says (in free fall the compensation alone
        makes ``f_z = m_D g``)."""
        ncon = int(data.ncon)
        if ncon == 0:
            return False
        distal = np.zeros(model.nbody, dtype=bool)
        distal[self.body_id] = True
        for b in range(self.body_id + 1, model.nbody):  # a body comes after its parent
            distal[b] = distal[model.body_parentid[b]]
        sides = distal[model.geom_bodyid[data.contact.geom[:ncon]]]
        wrench = np.zeros(6)
        for i in np.flatnonzero(sides[:, 0] != sides[:, 1]):
            mujoco.mj_contactForce(model, data, int(i), wrench)
            if wrench[0] > 0:
                return True
        return False


@dataclass(frozen=True)
class ImuReading:
    """One IMU's values (None where the IMU lacks that sensor).

    Attributes:
        acceleration: ``a − g`` in the site frame (3,) [m/s²].
        angular_velocity: ``ω`` in the site frame (3,) [rad/s].
        orientation: ``q_WS`` (4,), (w, x, y, z).
    """

    acceleration: np.ndarray | None
    angular_velocity: np.ndarray | None
    orientation: np.ndarray | None


@dataclass(frozen=True)
class Imu:
    """An IMU: ``accelerometer``, ``gyro`` and ``framequat`` sensors on one site
    (any may be missing). Named after the site.

    Attributes:
        name: The site's name.
        site_id, body, body_id: Where it sits.
        accelerometer, gyro, framequat: The channels, or None.
    """

    name: str
    site_id: int
    body: str
    body_id: int
    accelerometer: SensorChannel | None
    gyro: SensorChannel | None
    framequat: SensorChannel | None

    def read(self, data: mujoco.MjData) -> ImuReading:
        """The current :class:`ImuReading`."""

        def get(channel: SensorChannel | None) -> np.ndarray | None:
            return None if channel is None else channel.read(data)

        return ImuReading(get(self.accelerometer), get(self.gyro), get(self.framequat))


@dataclass(frozen=True)
class Bumper:
    """A touch sensor read as on/off (irteus manual: ``bumper-model``). Named after the site.

    Attributes:
        name: The site's name (its volume is the sensing zone).
        site_id, body, body_id: Where it sits.
        touch: The ``touch`` channel.
        threshold: Force [N] at and above which it reads on.
    """

    name: str
    site_id: int
    body: str
    body_id: int
    touch: SensorChannel
    threshold: float

    def force(self, data: mujoco.MjData) -> float:
        """Normal force [N] of the contacts inside the site's volume."""
        return float(self.touch.read(data)[0])

    def is_on(self, data: mujoco.MjData) -> bool:
        """irteus' reading: True (1) when the force reaches the threshold."""
        return self.force(data) >= self.threshold


@dataclass(frozen=True)
class RobotSensors:
    """A robot's force sensors, IMUs and bumpers, found in its model.

    Build with :meth:`from_model`. Readings of every channel by MJCF name come
    from :meth:`read`; :meth:`by_limb` groups the sensors by limb.

    Attributes:
        force_sensors: One per site carrying a ``force`` or ``torque`` sensor.
        imu_sensors: One per site carrying an ``accelerometer``, ``gyro`` or
            ``framequat`` sensor.
        bumpers: One per ``touch`` sensor.
        channels: Every sensor read (the union of the above).
    """

    force_sensors: tuple[ForceSensor, ...]
    imu_sensors: tuple[Imu, ...]
    bumpers: tuple[Bumper, ...]
    channels: tuple[SensorChannel, ...]

    @classmethod
    def from_model(
        cls,
        model: mujoco.MjModel,
        *,
        bodies: Iterable[str] | None = None,
        bumper_threshold: float = DEFAULT_BUMPER_THRESHOLD,
    ) -> RobotSensors:
        """The sensors of ``model`` (on sites of ``bodies`` when given, e.g. the
        robot's bodies in a scene holding other sensors too).

        Raises:
            UnknownName: A body of ``bodies`` does not exist.
            InvalidInput: ``bumper_threshold`` is not a finite number >= 0.
        """
        if not (math.isfinite(bumper_threshold) and bumper_threshold >= 0):
            raise InvalidInput(f"bumper_threshold must be >= 0 [N], got {bumper_threshold}")
        channels = site_channels(model)
        if bodies is not None:
            keep = set()
            for name in bodies:
                b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
                if b < 0:
                    raise UnknownName("body", name, names_of(model, "body"))
                keep.add(b)
            channels = [c for c in channels if c.body_id in keep]
        by_site: dict[int, dict[str, SensorChannel]] = {}
        for c in channels:
            if c.kind != "touch":
                # the first sensor of a kind on a site serves it
                by_site.setdefault(c.site_id, {}).setdefault(c.kind, c)
        force_sensors, imus = [], []
        for kinds in by_site.values():
            c = next(iter(kinds.values()))
            where = {"name": c.site, "site_id": c.site_id, "body": c.body, "body_id": c.body_id}
            if any(k in kinds for k in FORCE_TORQUE):
                force_sensors.append(
                    ForceSensor(**where, force=kinds.get("force"), torque=kinds.get("torque"))
                )
            if any(k in kinds for k in IMU):
                imus.append(
                    Imu(
                        **where,
                        accelerometer=kinds.get("accelerometer"),
                        gyro=kinds.get("gyro"),
                        framequat=kinds.get("framequat"),
                    )
                )
        bumpers = [
            Bumper(c.site, c.site_id, c.body, c.body_id, c, float(bumper_threshold))
            for c in channels
            if c.kind == "touch"
        ]
        return cls(tuple(force_sensors), tuple(imus), tuple(bumpers), tuple(channels))

    # ----------------------------------------------------------- look-ups
    def force_sensor(self, name: str) -> ForceSensor:
        """The force sensor on site ``name`` (irteus manual: ``:force-sensor``)."""
        return _by_name("force sensor", self.force_sensors, name)

    def imu_sensor(self, name: str) -> Imu:
        """The IMU on site ``name`` (irteus manual: ``:imu-sensor``)."""
        return _by_name("IMU", self.imu_sensors, name)

    def bumper(self, name: str) -> Bumper:
        """The bumper on site ``name``."""
        return _by_name("bumper", self.bumpers, name)

    def by_limb(self, limbs: Mapping[str, Iterable[str]]) -> dict[str, RobotSensors]:
        """The sensors of each limb, given as ``{limb: its body names}`` (irteus
        manual: ``(send robot :rleg :force-sensors)``). A sensor belongs to the limb
        holding its site's body; sensors of no limb are left out."""
        limb_of: dict[str, str] = {}
        for limb, bodies in limbs.items():
            for body in bodies:
                limb_of.setdefault(body, limb)

        def pick(items: Sequence, limb: str) -> tuple:
            return tuple(s for s in items if limb_of.get(s.body) == limb)

        return {
            limb: RobotSensors(
                pick(self.force_sensors, limb),
                pick(self.imu_sensors, limb),
                pick(self.bumpers, limb),
                pick(self.channels, limb),
            )
            for limb in limbs
        }

    def read(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Every channel's values by MJCF sensor name (see each channel's
        ``unit`` and ``frame``)."""
        return {c.name: c.read(data) for c in self.channels}


class SensorTrace:
    """The bumpers' readings along a hold or a motion: a callback of
    :meth:`pik_mj.sim.Scene.hold` / :meth:`~pik_mj.sim.Scene.play`, called with
    each :class:`~pik_mj.sim.HoldSample` (its ``data`` holds ``sensordata``).

    Args:
        sensors: The robot's sensors (:meth:`RobotSensors.from_model`).

    Attributes:
        time: Sample times (the physics clock) [s].
        force: Each bumper's touch force per sample [N], by site name.
        on: Each bumper's on/off reading per sample, by site name.
    """

    def __init__(self, sensors: RobotSensors):
        self.sensors = sensors
        self.time: list[float] = []
        self.force: dict[str, list[float]] = {b.name: [] for b in sensors.bumpers}
        self.on: dict[str, list[bool]] = {b.name: [] for b in sensors.bumpers}

    def __call__(self, sample: Any) -> None:
        self.time.append(float(sample.time))
        for b in self.sensors.bumpers:
            f = b.force(sample.data)
            self.force[b.name].append(f)
            self.on[b.name].append(f >= b.threshold)

    def first_on(self, bumper: str) -> float | None:
        """Time [s] of the first sample where ``bumper`` reads on, or None."""
        _by_name("bumper", self.sensors.bumpers, bumper)  # an unknown name lists the bumpers
        return next((t for t, on in zip(self.time, self.on[bumper], strict=True) if on), None)


def _by_name(kind: str, items: Sequence, name: str):
    for item in items:
        if item.name == name:
            return item
    raise UnknownName(kind, name, [i.name for i in items])


# ----------------------------------------------------------------------------
# ZMP (irteus manual: :calc-zmp-from-forces-moments)
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class SensorZmp:
    """The ZMP from force sensors.

    Attributes:
        point: ZMP ``(x, y, h)`` on the floor plane [m].
        force: Summed force of the sensors taking part (3,) [N].
        cops: Centre of pressure ``(x, y, h)`` [m] of each sensor taking part, by name.
        normal_forces: ``f_z`` [N] of every sensor, by name.
    """

    point: np.ndarray
    force: np.ndarray
    cops: dict[str, np.ndarray]
    normal_forces: dict[str, float]


def zmp_from_wrenches(wrenches: Sequence[ContactWrench], z: float = 0.0) -> np.ndarray:
    """ZMP ``(x, y, z)`` [m] of contact wrenches on the plane at height ``z``
    (module docstring).

    Raises:
        InvalidInput: No wrench, or a summed ``f_z <= 0`` (the ZMP is undefined).
    """
    if not wrenches:
        raise InvalidInput("the ZMP needs at least one contact wrench")
    f = np.sum([w.force for w in wrenches], axis=0)
    n_0 = np.sum([w.moment + np.cross(w.point, w.force) for w in wrenches], axis=0)
    if not f[2] > 0:
        raise InvalidInput(f"the contact wrenches do not push up (f_z = {f[2]:.3g} N): no ZMP")
    return np.array([*zmp_from_wrench(f, n_0, float(z)), float(z)])


def zmp_from_force_sensors(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    sensors: Sequence[ForceSensor],
    *,
    z: float = 0.0,
    fz_threshold: float = DEFAULT_FZ_THRESHOLD,
    compensate: bool = True,
) -> SensorZmp | None:
    """The ZMP from foot force sensors (irteus manual: ``:calc-zmp-from-forces-moments``).

    Each sensor whose distal part carries a load (:meth:`ForceSensor.loaded`:
    a MuJoCo contact pushes on it) and whose
    :meth:`ForceSensor.contact_wrench` ``f_z`` reaches ``fz_threshold`` takes
    part; its centre of pressure and the combined ZMP come from
    :func:`zmp_from_wrenches` on the plane ``z``.

    Args:
        model: The model.
        data: State after ``mj_forward``/``mj_step``.
        sensors: The feet's force sensors (each with force and torque).
        z: Floor height [m].
        fz_threshold: Normal force [N] below which a sensor is left out.
        compensate: Remove the distal parts' weight (see :class:`ForceSensor`).

    Returns:
        A :class:`SensorZmp`, or None when no sensor carries a load reaching
        the threshold (irteus returns nil).

    Raises:
        InvalidInput: No sensors, a sensor without force or torque channel, or a
            bad ``z``/``fz_threshold``.
    """
    if not sensors:
        raise InvalidInput("zmp_from_force_sensors needs at least one force sensor")
    if not (math.isfinite(z) and math.isfinite(fz_threshold) and fz_threshold > 0):
        raise InvalidInput(f"z must be finite and fz_threshold > 0 [N], got {z}, {fz_threshold}")
    for s in sensors:
        if s.force is None or s.torque is None:
            raise InvalidInput(
                f"force sensor {s.name!r} needs both a force and a torque sensor for a ZMP"
            )
    wrenches = {s.name: s.contact_wrench(model, data, compensate=compensate) for s in sensors}
    normal = {name: float(w.force[2]) for name, w in wrenches.items()}
    used = {
        s.name: wrenches[s.name]
        for s in sensors
        if normal[s.name] >= fz_threshold and s.loaded(model, data)
    }
    if not used:
        return None
    return SensorZmp(
        point=zmp_from_wrenches(list(used.values()), z),
        force=np.sum([w.force for w in used.values()], axis=0),
        cops={name: zmp_from_wrenches([w], z) for name, w in used.items()},
        normal_forces=normal,
    )
