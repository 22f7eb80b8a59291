"""One MuJoCo sensor as pik_mj reads it: the sensor kinds (:data:`KINDS`), a
:class:`SensorChannel` (a sensor on a site, its ``sensordata`` slice, frame and
unit), every channel of a model (:func:`site_channels`), and adding sensors to a
spec (:func:`add_sensors`). :mod:`pik_mj.robot.sensors` groups channels into a
robot's force sensors, IMUs and bumpers.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName

KINDS: dict[str, mujoco.mjtSensor] = {
    "force": mujoco.mjtSensor.mjSENS_FORCE,
    "torque": mujoco.mjtSensor.mjSENS_TORQUE,
    "accelerometer": mujoco.mjtSensor.mjSENS_ACCELEROMETER,
    "gyro": mujoco.mjtSensor.mjSENS_GYRO,
    "framequat": mujoco.mjtSensor.mjSENS_FRAMEQUAT,
    "touch": mujoco.mjtSensor.mjSENS_TOUCH,
}
"""The MuJoCo sensor types this module reads, by their MJCF element name."""

_UNITS = {
    "force": "N",
    "torque": "N·m",
    "accelerometer": "m/s²",
    "gyro": "rad/s",
    "framequat": "1",
    "touch": "N",
}

FORCE_TORQUE = ("force", "torque")
"""Kinds of a 6-axis force/torque sensor."""
IMU = ("accelerometer", "gyro", "framequat")
"""Kinds of an IMU."""
TOUCH = ("touch",)
"""Kind of a bumper."""


# ----------------------------------------------------------------------------
# one MuJoCo sensor
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class SensorChannel:
    """One MuJoCo sensor of a kind in :data:`KINDS`, on a site.

    Attributes:
        name: MJCF sensor name.
        kind: ``"force"``, ``"torque"``, ``"accelerometer"``, ``"gyro"``,
            ``"framequat"`` or ``"touch"``.
        id: Sensor id.
        adr: First index in ``data.sensordata``.
        dim: Number of values.
        site: The site it sits on.
        site_id: Its id.
        body: The site's body.
        body_id: Its id.
        frame: What the values are expressed in: ``"site"`` (the site frame), or
            ``"world"`` for ``framequat`` (the orientation ``q_WS`` of the site).
        unit: SI unit of the values.
    """

    name: str
    kind: str
    id: int
    adr: int
    dim: int
    site: str
    site_id: int
    body: str
    body_id: int
    frame: str
    unit: str

    def read(self, data: mujoco.MjData) -> np.ndarray:
        """The values ``(dim,)`` in :attr:`unit` (a copy of ``data.sensordata``)."""
        return data.sensordata[self.adr : self.adr + self.dim].copy()


def site_channels(model: mujoco.MjModel) -> list[SensorChannel]:
    """Every sensor of a kind in :data:`KINDS` attached to a site (framequat: of a
    site, with no reference frame)."""
    kind_of = {int(t): k for k, t in KINDS.items()}
    out = []
    for i in range(model.nsensor):
        kind = kind_of.get(int(model.sensor_type[i]))
        if kind is None or int(model.sensor_objtype[i]) != int(mujoco.mjtObj.mjOBJ_SITE):
            continue
        if kind == "framequat" and int(model.sensor_refid[i]) >= 0:
            continue
        site = int(model.sensor_objid[i])
        body = int(model.site_bodyid[site])
        out.append(
            SensorChannel(
                name=mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i) or f"sensor {i}",
                kind=kind,
                id=i,
                adr=int(model.sensor_adr[i]),
                dim=int(model.sensor_dim[i]),
                site=mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, site) or f"site {site}",
                site_id=site,
                body=mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}",
                body_id=body,
                frame="world" if kind == "framequat" else "site",
                unit=_UNITS[kind],
            )
        )
    return out


# ----------------------------------------------------------------------------
# adding sensors to a model
# ----------------------------------------------------------------------------


def add_sensors(
    spec: mujoco.MjSpec, sites: Iterable[str], kinds: Iterable[str] = FORCE_TORQUE
) -> list[str]:
    """Add MuJoCo sensors of ``kinds`` on each named site of ``spec``, named
    ``<site>_<kind>`` (the naming of ``models/sample_humanoid.xml``).

    E.g. ``add_sensors(spec, ["rleg_end", "lleg_end"])`` gives a robot
    without force sensors 6-axis sensors at its soles, and
    ``add_sensors(spec, ["imu"], IMU)`` an IMU. A touch sensor senses the
    contacts inside its site's volume: give it a site enclosing the part.

    Args:
        spec: The robot's spec (edited in place).
        sites: Names of existing sites.
        kinds: Sensor kinds from :data:`KINDS`.

    Returns:
        The names of the added sensors.

    Raises:
        UnknownName: A site or kind that does not exist.
        InvalidInput: A sensor of that name exists already (nothing is added).
    """
    kinds = list(kinds)
    sites = list(sites)
    for kind in kinds:
        if kind not in KINDS:
            raise UnknownName("sensor kind", kind, KINDS)
    valid = [s.name for s in spec.sites]
    for site in sites:
        if site not in valid:
            raise UnknownName("site", site, valid)
    existing = {s.name for s in spec.sensors}
    names = [f"{site}_{kind}" for site in sites for kind in kinds]
    clash = [n for n in names if n in existing]
    if clash:
        raise InvalidInput(f"the spec already has sensors named {clash}")
    for site in sites:
        for kind in kinds:
            spec.add_sensor(
                name=f"{site}_{kind}",
                type=KINDS[kind],
                objtype=mujoco.mjtObj.mjOBJ_SITE,
                objname=site,
            )
    return names
