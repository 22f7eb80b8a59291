"""irteus' inverse-kinematics entry points on the priority cascade.

* :func:`inverse_kinematics` (:mod:`.limb`), :func:`fullbody_inverse_kinematics`
  (:mod:`.fullbody`) — irteus ``:inverse-kinematics`` and
  ``:fullbody-inverse-kinematics``: a stack of levels for :func:`pik_mj.solve.solve`,
  built from a :class:`~pik_mj.robot.Robot`'s limbs; their arguments are read by
  :mod:`.arguments`.
* :func:`static_balance_point`, :func:`gaze_angle` (:mod:`.measures`) — irteus
  ``:calc-static-balance-point`` and the head's gaze error.
* :class:`WorldAvoidance` (:mod:`.world`) — how those entry points keep the robot
  clear of its world (on by default: ``avoid_world``).
* :func:`classic_inverse_kinematics` — irteus' SR-inverse iteration, for comparison.
* :func:`with_virtual_root` — a virtual 6-DoF root for fixed-base models.

This layer imports the robot layer and the core.
"""

from pik_mj.ik.classic import classic_inverse_kinematics
from pik_mj.ik.fullbody import fullbody_inverse_kinematics
from pik_mj.ik.limb import inverse_kinematics
from pik_mj.ik.measures import gaze_angle, static_balance_point
from pik_mj.ik.virtual_root import with_virtual_root
from pik_mj.ik.world import WorldAvoidance

__all__ = [
    "WorldAvoidance",
    "classic_inverse_kinematics",
    "fullbody_inverse_kinematics",
    "gaze_angle",
    "inverse_kinematics",
    "static_balance_point",
    "with_virtual_root",
]
