"""pik_mj: prioritized inverse kinematics on MuJoCo, validated in simulation."""

from .cascade import DEFAULT_RELAXATION, Regularization, solve_cascade
from .exceptions import (
    InfeasibleHardConstraints,
    InvalidInput,
    PikError,
    QPFailure,
    SimulationUnstable,
    UnknownName,
)
from .ik import fullbody_inverse_kinematics, inverse_kinematics
from .qp import LevelProblem, OSQPBackend, make_backend
from .robot import Robot
from .solve import SolveResult, TaskReport, solve
from .tasks import (
    AttachedContact,
    CentroidTask,
    CollisionAvoidanceTask,
    FrameTask,
    JointCouplingTask,
    JointLimitTask,
    JointVelocityTask,
    LinearTask,
    LookAtTask,
    MinkLimit,
    MinkTask,
    ScfrTask,
    SupportPolygonTask,
    Task,
    TaskRows,
)
from .virtual_root import solve_with_virtual_root, with_virtual_root

__all__ = [
    "DEFAULT_RELAXATION",
    "AttachedContact",
    "CentroidTask",
    "CollisionAvoidanceTask",
    "FrameTask",
    "InfeasibleHardConstraints",
    "InvalidInput",
    "JointCouplingTask",
    "JointLimitTask",
    "JointVelocityTask",
    "LevelProblem",
    "LinearTask",
    "LookAtTask",
    "MinkLimit",
    "MinkTask",
    "OSQPBackend",
    "PikError",
    "QPFailure",
    "Regularization",
    "Robot",
    "ScfrTask",
    "SimulationUnstable",
    "SolveResult",
    "SupportPolygonTask",
    "Task",
    "TaskReport",
    "TaskRows",
    "UnknownName",
    "fullbody_inverse_kinematics",
    "inverse_kinematics",
    "make_backend",
    "solve",
    "solve_cascade",
    "solve_with_virtual_root",
    "with_virtual_root",
]
