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
from .qp import LevelProblem, OSQPBackend, make_backend
from .solve import SolveResult, TaskReport, solve
from .tasks import FrameTask, LinearTask, MinkLimit, MinkTask, Task, TaskRows

__all__ = [
    "DEFAULT_RELAXATION",
    "FrameTask",
    "InfeasibleHardConstraints",
    "InvalidInput",
    "LevelProblem",
    "LinearTask",
    "MinkLimit",
    "MinkTask",
    "OSQPBackend",
    "PikError",
    "QPFailure",
    "Regularization",
    "SimulationUnstable",
    "SolveResult",
    "Task",
    "TaskReport",
    "TaskRows",
    "UnknownName",
    "make_backend",
    "solve",
    "solve_cascade",
]
