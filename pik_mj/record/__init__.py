"""Rerun recordings of solves, physics holds and walks (DESIGN.md §6).

One ``.rrd`` per run: the robot's geometry once (static), then per solver
iteration (timeline ``iteration``) or per simulation sample (``sim_time``) the
body poses, targets, CoM, support polygon, contact forces and every task's
error; one blueprint, sent when the recording closes, lays out what was
logged. Modules:

* :mod:`~pik_mj.record.paths`: the one entity-path table (:data:`PATHS`).
* :mod:`~pik_mj.record.recorder`: :class:`Recorder`, the logging calls.
* :mod:`~pik_mj.record.loggers`: per-iteration callbacks of a solve
  (:meth:`Recorder.solve_logger`) and of a physics hold
  (:meth:`Recorder.hold_logger`); a walk's series (:meth:`Recorder.log_walk`).
* :mod:`~pik_mj.record.geometry`: MuJoCo geoms as rerun primitives.
* :mod:`~pik_mj.record.columns`: rerun 0.41's chunk API (buffered rows).
* :mod:`~pik_mj.record.blueprint`: viewer layouts.
* :mod:`~pik_mj.record.reader`: :func:`read_recording`, :func:`read_blueprint`.
* :mod:`~pik_mj.record.style`: colours and sizes of the overlays.
* :mod:`~pik_mj.record.screenshot`: pictures of a recording by rerun's
  headless viewer (``pik-mj screenshot``).
"""

from pik_mj.record.blueprint import blueprint
from pik_mj.record.paths import PATHS, TIMELINES, EntityPaths
from pik_mj.record.reader import (
    BlueprintLayout,
    EntityData,
    ViewLayout,
    read_blueprint,
    read_recording,
)
from pik_mj.record.recorder import Recorder

__all__ = [
    "PATHS",
    "TIMELINES",
    "BlueprintLayout",
    "EntityData",
    "EntityPaths",
    "Recorder",
    "ViewLayout",
    "blueprint",
    "read_blueprint",
    "read_recording",
]
