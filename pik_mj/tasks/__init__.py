"""Tasks of the cascade: the seed's task library and adapters for mink.

Seed 000 task → class:

* ``minmax-angle-task`` → :class:`JointLimitTask`
* ``joint-velocity-task`` → :class:`JointVelocityTask`
* ``joint-angle-task`` → :class:`JointCouplingTask`
* ``move-target-task`` → :class:`FrameTask`
* ``target-centroid-pos-task`` → :class:`CentroidTask`
* ``centroid-support-polygon-task`` → :class:`SupportPolygonTask`
* ``centroid-scfr-task`` → :class:`ScfrTask`

and from irteus (seed 001): :class:`CollisionAvoidanceTask`, :class:`LookAtTask`,
:class:`LinearTask` (the additional-Jacobian hook).
"""

from .collision import CollisionAvoidanceTask
from .com import CentroidTask
from .frame import FrameTask
from .joint_coupling import JointCouplingTask
from .joint_limit import JointLimitTask
from .joint_velocity import JointVelocityTask
from .linear import LinearTask
from .look_at import LookAtTask
from .mink_adapter import MinkLimit, MinkTask, as_task
from .scfr import AttachedContact, ScfrTask
from .support_polygon import SupportPolygonTask
from .task import Task, TaskRows

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
