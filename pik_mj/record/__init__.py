"""Rerun recordings of solves, physics holds, motions and walks.

One ``.rrd`` per run: the robot's geometry once (static), then per solver
iteration (timeline ``iteration``) or per simulation sample (``sim_time``) the
body poses, targets, CoM, support polygon, contact forces and every task's
error; one blueprint, sent when the recording closes, lays out what was
logged. Modules:

* :mod:`~pik_mj.record.paths`: the one entity-path table (:data:`PATHS`).
* :mod:`~pik_mj.record.recorder`: :class:`Recorder`, the logging calls; its
  generic half (stream, timelines, points, frames, series, text, lifetime) is
  :class:`~pik_mj.record.canvas.Canvas`.
* :mod:`~pik_mj.record.loggers`: the callbacks of a solve
  (:meth:`Recorder.solve_logger`), a physics hold (:meth:`Recorder.hold_logger`),
  a motion (:meth:`Recorder.motion_logger`) and a walk
  (:meth:`Recorder.walk_logger`).
* :mod:`~pik_mj.record.stream`: rows buffered and sent as chunks, the timelines.
* :mod:`~pik_mj.record.drawing`: what a model is drawn as; the views' framing.
* :mod:`~pik_mj.record.geometry`: MuJoCo geoms as rerun primitives.
* :mod:`~pik_mj.record.columns`: rerun 0.41's chunk API (buffered rows).
* :mod:`~pik_mj.record.blueprint`: viewer layouts.
* :mod:`~pik_mj.record.reader`: :func:`read_recording`, :func:`read_blueprint`.
* :mod:`~pik_mj.record.style`: colours and sizes of the overlays.
* :mod:`~pik_mj.record.screenshot`: pictures of a recording by rerun's
  headless viewer (``pik-mj screenshot``).

See docs/recording.md.
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
