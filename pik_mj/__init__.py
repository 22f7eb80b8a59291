"""pik_mj: prioritized inverse kinematics on MuJoCo, validated in simulation.

What a script needs is here::

    robot = Robot.from_model("sample_humanoid")           # owns its world
    scene = Scene.from_robot(robot)                       # floor, servos, contacts
    checks = scene.static_checker()
    path = Waypoints(robot)                               # the start pose, then the iterates
    result = fullbody_inverse_kinematics(robot, targets, callback=[checks, path, Progress("reach")])
    motion = scene.play(path)                             # the iterates in physics
    hold = scene.hold(robot.configuration.q, criteria=HoldCriteria())

Internals (the cascade's QP problems and backends, the virtual root) are one
import deeper: :mod:`pik_mj.cascade`, :mod:`pik_mj.qp`, :mod:`pik_mj.ik.virtual_root`.
"""

from pik_mj.exceptions import (
    InfeasibleHardConstraints,
    InvalidInput,
    LimbsNotFound,
    NoCollisionGeometry,
    OptionError,
    OutputError,
    PikError,
    QPFailure,
    RenderingUnavailable,
    ScenarioWaiting,
    SimulationUnstable,
    UnknownName,
    WriterBusy,
)
from pik_mj.ik import WorldAvoidance, fullbody_inverse_kinematics, inverse_kinematics
from pik_mj.progress import Progress
from pik_mj.record import Recorder, read_recording
from pik_mj.robot import Limb, Robot, RobotSource
from pik_mj.robot.loading import load_model
from pik_mj.sim import (
    ContactParams,
    HoldCriteria,
    HoldReport,
    HoldSample,
    MotionReport,
    Scene,
    StaticChecks,
    StaticReport,
    Waypoints,
    add_box,
    add_wall,
    floor_environment,
    validate_pose,
)
from pik_mj.solve import IterationInfo, SolveResult, TaskReport, solve
from pik_mj.tasks import (
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

__all__ = [
    "AttachedContact",
    "CentroidTask",
    "CollisionAvoidanceTask",
    "ContactParams",
    "FrameTask",
    "HoldCriteria",
    "HoldReport",
    "HoldSample",
    "InfeasibleHardConstraints",
    "InvalidInput",
    "IterationInfo",
    "JointCouplingTask",
    "JointLimitTask",
    "JointVelocityTask",
    "Limb",
    "LimbsNotFound",
    "LinearTask",
    "LookAtTask",
    "MinkLimit",
    "MinkTask",
    "MotionReport",
    "NoCollisionGeometry",
    "OptionError",
    "OutputError",
    "PikError",
    "Progress",
    "QPFailure",
    "Recorder",
    "RenderingUnavailable",
    "Robot",
    "RobotSource",
    "ScenarioWaiting",
    "Scene",
    "ScfrTask",
    "SimulationUnstable",
    "SolveResult",
    "StaticChecks",
    "StaticReport",
    "SupportPolygonTask",
    "Task",
    "TaskReport",
    "TaskRows",
    "UnknownName",
    "Waypoints",
    "WorldAvoidance",
    "WriterBusy",
    "add_box",
    "add_wall",
    "floor_environment",
    "fullbody_inverse_kinematics",
    "inverse_kinematics",
    "load_model",
    "read_recording",
    "solve",
    "validate_pose",
]
