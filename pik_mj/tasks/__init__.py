"""Tasks of the cascade: the prioritized-IK manual's task library and adapters for mink.

prioritized-IK manual task → class:

* ``minmax-angle-task`` → :class:`JointLimitTask`
* ``joint-velocity-task`` → :class:`JointVelocityTask`
* ``joint-angle-task`` → :class:`JointCouplingTask`
* ``move-target-task`` → :class:`FrameTask`
* ``target-centroid-pos-task`` → :class:`CentroidTask`
* ``centroid-support-polygon-task`` → :class:`SupportPolygonTask`
* ``centroid-scfr-task`` → :class:`ScfrTask`

and from the irteus manual: :class:`CollisionAvoidanceTask`, :class:`LookAtTask`,
:class:`LinearTask` (the additional-Jacobian hook).
"""

from pik_mj.tasks.collision import CollisionAvoidanceTask
from pik_mj.tasks.com import CentroidTask
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.joint_coupling import JointCouplingTask
from pik_mj.tasks.joint_limit import JointLimitTask
from pik_mj.tasks.joint_velocity import JointVelocityTask
from pik_mj.tasks.linear import LinearTask
from pik_mj.tasks.look_at import LookAtTask
from pik_mj.tasks.mink_adapter import MinkLimit, MinkTask, as_task
from pik_mj.tasks.scfr import AttachedContact, ScfrTask
from pik_mj.tasks.support_polygon import SupportPolygonTask
from pik_mj.tasks.task import Task, TaskRows

__all__ = [
    "AttachedContact",
    "CentroidTask",
    "CollisionAvoidanceTask",
    "FrameTask",
    "JointCouplingTask",
    "JointLimitTask",
    "JointVelocityTask",
    "LinearTask",
    "LookAtTask",
    "MinkLimit",
    "MinkTask",
    "ScfrTask",
    "SupportPolygonTask",
    "Task",
    "TaskRows",
    "as_task",
]
