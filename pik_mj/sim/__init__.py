"""Simulation of a robot's world in MuJoCo (DESIGN.md §5): the physics scene,
the static check, the physics hold, and the guard around MuJoCo's steps.

* :mod:`.environment` — environment specs (floor, boxes, walls), attaching one
  into a robot's spec, placing the robot;
* :mod:`.scene` — :class:`Scene`: the robot's world with servos and contacts;
* :mod:`.static` — :class:`StaticReport`, :class:`StaticChecks` (per iteration);
* :mod:`.hold` — :class:`HoldCriteria`, :class:`HoldSample`, :class:`HoldReport`,
  and the stepping loop a hold shares with a motion;
* :mod:`.motion` — :class:`Waypoints`, :class:`MotionReport`: a solve's iterates
  played in physics (:meth:`Scene.play`);
* :mod:`.guard` — MuJoCo's warnings routed to Python, the invalid-state check;
* :mod:`.validate` — :func:`validate_pose` (``pik-mj validate``).
"""

from pik_mj.mujoco_warnings import mujoco_warnings
from pik_mj.robot.world import add_box, add_wall, floor_environment
from pik_mj.sim.guard import StateGuard
from pik_mj.sim.hold import HoldCriteria, HoldReport, HoldSample
from pik_mj.sim.motion import MotionReport, Waypoints
from pik_mj.sim.scene import DEFAULT_CONTACT, ContactParams, Grasp, Scene
from pik_mj.sim.static import ContactInfo, StaticChecks, StaticReport
from pik_mj.sim.validate import balance_report, validate_pose

__all__ = [
    "DEFAULT_CONTACT",
    "ContactInfo",
    "ContactParams",
    "Grasp",
    "HoldCriteria",
    "HoldReport",
    "HoldSample",
    "MotionReport",
    "Scene",
    "StateGuard",
    "StaticChecks",
    "StaticReport",
    "Waypoints",
    "add_box",
    "add_wall",
    "balance_report",
    "floor_environment",
    "mujoco_warnings",
    "validate_pose",
]
