"""Tasks of the cascade: the seed's task library and adapters for mink."""

from .frame import FrameTask
from .linear import LinearTask
from .mink_adapter import MinkLimit, MinkTask, as_task
from .task import Task, TaskRows

__all__ = [
    "FrameTask",
    "LinearTask",
    "MinkLimit",
    "MinkTask",
    "Task",
    "TaskRows",
    "as_task",
]
