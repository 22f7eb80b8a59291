"""The robot layer: a MuJoCo model as irteus' robot-model (limbs, end frames, keyframes, soles,
sensors, cameras, couplings) and the MJCF world it stands in.

* :mod:`.loading` — model names (the project's MJCF, dm_control, MuJoCo Menagerie) to specs.
* :mod:`.robot` — :class:`Robot`: a robot built from its model, standing in its world
  (:meth:`Robot.from_model`); :mod:`.robot_model` — :class:`RobotModel`, what it is
  on its compiled model: joints (:mod:`.joints`), limbs and start pose, read and set by
  name; :mod:`.assembly` — the spec steps of :meth:`Robot.from_model`.
* :mod:`.source` — :class:`RobotSource`: what builds a robot, as JSON.
* :mod:`.description` — robot description files (limbs, keyframe, soles the tree does not tell).
* :mod:`.limbs`, :mod:`.keyframes` — limbs from the kinematic tree, the start pose.
* :mod:`.floor_contact`, :mod:`.ground` — collision geometry against the floor; the
  robot's feet, sole polygons and size. :mod:`.stance` — soles turned flat.
* :mod:`.stack` — the guard and posture levels every IK stack on a robot has.
* :mod:`.sensors` (:mod:`.sensor_channels`), :mod:`.camera`, :mod:`.couplings` — MJCF
  sensors, cameras, joint couplings.
* :mod:`.world` — environments (floor, room, boxes) attached into a robot's spec.

This layer imports the core only (frames, tasks, solve, balance, dynamics); nothing here runs
physics or the irteus IK entry points.
"""

from pik_mj.robot.limbs import Limb
from pik_mj.robot.robot import GROUND_TOLERANCE, STANDING_KEYFRAME, Robot
from pik_mj.robot.robot_model import RobotModel
from pik_mj.robot.source import RobotSource

__all__ = ["GROUND_TOLERANCE", "STANDING_KEYFRAME", "Limb", "Robot", "RobotModel", "RobotSource"]
