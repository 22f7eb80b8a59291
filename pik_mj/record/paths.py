"""The one entity-path table of pik_mj's recordings, and their timelines."""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["PATHS", "TIMELINES", "EntityPaths", "path_part"]

#: Kind of every timeline pik_mj uses: ``iteration`` counts IK solver iterations,
#: ``sim_time`` is physics time in [s]. Other timelines need an explicit ``kind``.
TIMELINES: dict[str, str] = {"iteration": "sequence", "sim_time": "duration"}


_NOT_PLAIN = re.compile(r"[^\w.\-]+")


def path_part(name: str) -> str:
    """``name`` as one readable entity-path part: every run of characters that
    rerun would escape (spaces, ``/``, ``:``, ...) becomes one ``_``, so the
    viewer shows ``target_larm_end`` rather than ``target\\:larm_end``.
    Letters and digits of any script, ``_``, ``-`` and ``.`` stay."""
    return _NOT_PLAIN.sub("_", str(name)) or "_"


@dataclass(frozen=True)
class EntityPaths:
    """Every rerun entity path pik_mj writes. Names (MJCF, task names) are
    made plain path parts by :func:`path_part`.

    Attributes:
        world: Root of the 3D scene (z up).
        robot: Parent of the robot's geometry (``world/robot/<kind>``) and body
            frames (``world/robot/bodies``).
        scene: Parent of the environment's geometry: ``world/scene/<kind>``
            (welded to the world), ``world/scene/moving/<kind>`` and
            ``world/scene/moving/bodies`` (free or mocap bodies).
        com: Centre of mass ``p_WC`` [m] (``Points3D``) and, for a floating
            base, its plumb line to the ground (``Arrows3D``, same entity: one
            chunk).
        com_target: Target of the centre of mass [m].
        support_polygon: Support polygon outline (child ``margin``: shrunk outline).
        scfr: Static centroid feasible region outline.
        zmp: Zero-moment point [m] (measured in physics; children
            ``reference`` and ``inverse_dynamics`` of a walking pattern).
        footsteps: The footstep plan of a walk: sole outlines.
        contact_points: Contact points [m].
        contact_forces: Contact forces drawn as arrows (scaled, [m/N]).
        tasks: Parent of task frames: ``world/tasks/<task>/target|current``
            (a target also carries a labelled marker at its origin).
        errors: Parent of task error series: ``errors/level_<k>/<solve>/<task>``
            (``errors/level_<k>/<task>`` when logged without a solve's label).
        errors_log10: The same series as ``log10`` of the error (a log scale):
            ``errors_log10/level_<k>/<solve>/<task>``.
        events: Text log of the run.
        hold: Parent of physics-hold metrics: ``hold/<metric>`` (e.g. ``hold/drift``).
        balance: Parent of per-iteration balance metrics of the simulated static
            check: ``balance/<metric>`` (e.g. ``balance/margin``).
        walk: Parent of walking series: ``walk/<group>/<series>`` (e.g.
            ``walk/zmp_x/reference``, ``walk/margin/inverse_dynamics``).
        motion: Parent of the series of a motion played in physics:
            ``motion/<metric>`` (e.g. ``motion/tracking_error``,
            ``motion/frame_error/<frame>``, ``motion/waypoint``).
        reference: The reference pose of a motion, drawn as a second robot:
            ``world/reference/<kind>`` geoms, ``world/reference/bodies`` frames.
        sensors: Parent of sensor readings: ``sensors/<group>/<sensor>`` (e.g.
            ``sensors/force/rleg_end``, ``sensors/imu_acceleration/imu_x``).
        cameras: Parent of the robot's cameras: ``world/cameras/<camera>`` (its
            pose) and ``world/cameras/<camera>/image`` (pinhole, image).
    """

    world: str = "world"
    robot: str = "world/robot"
    scene: str = "world/scene"
    com: str = "world/com"
    com_target: str = "world/com_target"
    support_polygon: str = "world/support_polygon"
    scfr: str = "world/scfr"
    zmp: str = "world/zmp"
    footsteps: str = "world/footsteps"
    contact_points: str = "world/contacts/points"
    contact_forces: str = "world/contacts/forces"
    tasks: str = "world/tasks"
    errors: str = "errors"
    errors_log10: str = "errors_log10"
    events: str = "log/events"
    hold: str = "hold"
    balance: str = "balance"
    walk: str = "walk"
    motion: str = "motion"
    reference: str = "world/reference"
    sensors: str = "sensors"
    cameras: str = "world/cameras"

    def geoms(self, kind: str, *, robot: bool = True, moving: bool = True) -> str:
        """Path of the geoms of one primitive ``kind`` (``boxes``, ``capsules``,
        ``cylinders``, ``ellipsoids``, ``meshes/<mesh>``, ``hfields/<hfield>``)
        of the robot, of the scene welded to the world, or of moving scene bodies."""
        if robot:
            return f"{self.robot}/{kind}"
        return f"{self.scene}/moving/{kind}" if moving else f"{self.scene}/{kind}"

    def bodies(self, *, robot: bool = True) -> str:
        """Path of the body frames ``X_WB`` of the robot or of the moving scene
        bodies (one instance per body, labelled with its MJCF name)."""
        return f"{self.robot}/bodies" if robot else f"{self.scene}/moving/bodies"

    def task_target(self, task: str) -> str:
        """Path of a task's target frame."""
        return f"{self.tasks}/{path_part(task)}/target"

    def task_current(self, task: str) -> str:
        """Path of a task's current frame."""
        return f"{self.tasks}/{path_part(task)}/current"

    def level_errors(self, level: int, *, log10: bool = False) -> str:
        """Parent path of the error series of priority level ``level`` (of their
        ``log10``)."""
        return f"{self.errors_log10 if log10 else self.errors}/level_{int(level)}"

    def task_error(
        self, level: int, task: str, *, log10: bool = False, solve: str | None = None
    ) -> str:
        """Path of the scalar error series of ``task`` on priority level ``level``
        (of its ``log10``): ``errors/level_<k>/<task>``, or
        ``errors/level_<k>/<solve>/<task>`` for a task of the solve labelled
        ``solve`` (a recording of several solves, whose stacks put the same task
        on different levels, keeps each solve's series apart)."""
        parent = self.level_errors(level, log10=log10)
        if solve is not None:
            parent = f"{parent}/{path_part(solve)}"
        return f"{parent}/{path_part(task)}"

    def hold_metric(self, name: str) -> str:
        """Path of a physics-hold metric series, e.g. ``hold/drift``."""
        return f"{self.hold}/{path_part(name)}"

    def balance_metric(self, name: str) -> str:
        """Path of a per-iteration balance metric series, e.g. ``balance/margin``."""
        return f"{self.balance}/{path_part(name)}"

    def motion_metric(self, name: str) -> str:
        """Path of a motion series, e.g. ``motion/tracking_error``."""
        return f"{self.motion}/{path_part(name)}"

    def frame_error(self, frame: str) -> str:
        """Path of a task frame's tracking error in a motion [m]."""
        return f"{self.motion}/frame_error/{path_part(frame)}"

    def sensor_series(self, group: str, name: str) -> str:
        """Path of a sensor's series, e.g. ``sensors/force/rleg_end``: one plot
        per ``group``."""
        return f"{self.sensors}/{path_part(group)}/{path_part(name)}"

    def camera(self, name: str) -> str:
        """Path of a camera's pose; its pinhole and image are at ``<path>/image``."""
        return f"{self.cameras}/{path_part(name)}"

    def walk_series(self, group: str, name: str) -> str:
        """Path of a walking series, e.g. ``walk/zmp_x/reference``: one plot per
        ``group``."""
        return f"{self.walk}/{path_part(group)}/{path_part(name)}"


#: The one entity-path table of pik_mj.
PATHS = EntityPaths()
