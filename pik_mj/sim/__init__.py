"""Simulation of a robot's world in MuJoCo: the physics scene, the static check,
the physics hold, the motion playback, and the guard around MuJoCo's steps.

Modules, lowest first (each imports only those above it):

* :mod:`.servos`, :mod:`.guard` — the joint servos' gains and controls; MuJoCo's
  invalid-state check around each step;
* :mod:`.grasp` — :class:`Grasp`: an object held by a robot frame, and its weld;
* :mod:`.falls` — what a fall is (:class:`Fall`, :class:`FallLimits`);
* :mod:`.stabilizer` — the stance ankles' targets turned against the body's
  inclination error (a balance controller through the robot's own servos);
* :mod:`.physics` — :class:`Physics`: the compiled world in the robot's terms
  (contacts, wrenches, servo joints, stepping);
* :mod:`.static` — :class:`StaticReport`, :class:`StaticChecks` (per iteration);
* :mod:`.criteria` — what a hold or motion must show (:class:`HoldCriteria`);
* :mod:`.drives`, :mod:`.torques` — what each servo joint's drive delivers; the
  torques that hold a pose or move it (inverse dynamics with the contacts);
* :mod:`.stepping`, :mod:`.sampling`, :mod:`.measures`, :mod:`.figures`,
  :mod:`.stability` — the physics stepped in C (``mujoco.rollout``), the samples
  a run records, what it is measured against (:class:`HoldSample`), its figures
  computed over the record, and why a robot under its servos drifts away;
* :mod:`.tracking` — the stepping loop a hold shares with a motion (one run or
  many at once);
* :mod:`.hold` — :class:`HoldReport`: a pose held in physics (``hold``,
  ``hold_many``);
* :mod:`.path`, :mod:`.timing`, :mod:`.effort`, :mod:`.reference`,
  :mod:`.clearance` — :class:`Waypoints`, their timing, the torques the timed
  path needs (slowed down for the drives), the timed reference the servos track,
  the clearance along a motion;
* :mod:`.motion` — :class:`MotionReport`: a solve's iterates played in physics;
* :mod:`.assembly` — what a scene adds to the robot's spec (:class:`ContactParams`,
  servos, exclusions);
* :mod:`.scene` — :class:`Scene`: the robot's world with servos and contacts, a
  :class:`Physics` that runs the static check, the hold and the playback;
* :mod:`.validate` — :func:`validate_pose` (``pik-mj validate``).

Environments (floor, boxes, walls) are built in :mod:`pik_mj.robot.world`.
"""

from pik_mj.mujoco_warnings import mujoco_warnings
from pik_mj.robot.world import add_box, add_wall, floor_environment
from pik_mj.sim.assembly import DEFAULT_CONTACT, ContactParams
from pik_mj.sim.criteria import HoldCriteria
from pik_mj.sim.falls import Fall, FallLimits
from pik_mj.sim.grasp import Grasp
from pik_mj.sim.guard import StateGuard
from pik_mj.sim.hold import HoldReport
from pik_mj.sim.measures import HoldSample
from pik_mj.sim.motion import MotionReport
from pik_mj.sim.path import Waypoints
from pik_mj.sim.physics import ContactInfo, Physics
from pik_mj.sim.scene import Scene
from pik_mj.sim.static import StaticChecks, StaticReport
from pik_mj.sim.validate import balance_report, validate_pose

__all__ = [
    "DEFAULT_CONTACT",
    "ContactInfo",
    "ContactParams",
    "Fall",
    "FallLimits",
    "Grasp",
    "HoldCriteria",
    "HoldReport",
    "HoldSample",
    "MotionReport",
    "Physics",
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
