"""The logger catalogue: callbacks that record a solve, a physics hold, a motion
and a walk, each built on the Recorder's public methods
(:class:`~pik_mj.record.loggers.surface.RecorderSurface`).

* :mod:`~pik_mj.record.loggers.solve`: :class:`SolveLogger` (``iteration``).
* :mod:`~pik_mj.record.loggers.physics`: :class:`HoldLogger`,
  :class:`MotionLogger` and the robot's sensors (``sim_time``).
* :mod:`~pik_mj.record.loggers.walk`: :class:`WalkLogger` and the walk's series.
"""

from pik_mj.record.loggers.physics import HoldLogger, MotionLogger, log_sensors
from pik_mj.record.loggers.solve import SolveLogger, margin_outline
from pik_mj.record.loggers.surface import RecorderSurface
from pik_mj.record.loggers.walk import WalkLogger, log_walk

__all__ = [
    "HoldLogger",
    "MotionLogger",
    "RecorderSurface",
    "SolveLogger",
    "WalkLogger",
    "log_sensors",
    "log_walk",
    "margin_outline",
]
