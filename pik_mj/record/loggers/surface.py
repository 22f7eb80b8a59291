"""What the loggers use of a :class:`~pik_mj.record.recorder.Recorder`.

The loggers are written against this surface, not against the Recorder's
class: the Recorder builds its loggers (:meth:`Recorder.solve_logger
<pik_mj.record.recorder.Recorder.solve_logger>`, ...), and a logger needs only
the public methods listed here, each documented on the Recorder.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from pik_mj.record.paths import EntityPaths
from pik_mj.robot.camera import Camera

__all__ = ["RecorderSurface"]


class RecorderSurface(Protocol):
    """The Recorder as its loggers see it (see
    :class:`~pik_mj.record.recorder.Recorder` for each member)."""

    paths: EntityPaths
    robot_root_body: str | None

    @property
    def model(self) -> mujoco.MjModel | None: ...
    @property
    def lift(self) -> float: ...
    @property
    def com_target(self) -> np.ndarray | None: ...

    # runs and time
    def begin_solve(self) -> int: ...
    def next_tick(self) -> int: ...
    def begin_sim(self, model: mujoco.MjModel, data: mujoco.MjData, time: float) -> None: ...
    def sim_clock(self, time: float) -> float: ...
    def set_time(self, timeline: str, value: float, *, kind: str | None = None) -> None: ...
    def disable_timeline(self, timeline: str) -> None: ...

    # geometry and poses
    def log_model_geometry(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData | None = None,
        *,
        robot_root_body: str | None = None,
    ) -> None: ...
    def log_body_poses(
        self, data: mujoco.MjData, *, timeline: str = "iteration", time: float
    ) -> None: ...
    def log_reference_geometry(self, model: mujoco.MjModel) -> None: ...
    def log_reference_poses(self, data: mujoco.MjData) -> None: ...
    def log_camera(
        self, camera: Camera, data: mujoco.MjData, image: np.ndarray | None = None
    ) -> str: ...

    # overlays
    def log_point(
        self,
        path: str,
        p: npt.ArrayLike,
        *,
        radius: float = 0.02,
        color: Sequence[int] = (255, 200, 0),
        label: str | None = None,
    ) -> None: ...
    def log_com(self, p_WC: npt.ArrayLike, target: npt.ArrayLike | None = None) -> None: ...
    def log_com_target(self, target: npt.ArrayLike) -> None: ...
    def log_polygon(
        self,
        vertices: npt.ArrayLike,
        margin_vertices: npt.ArrayLike | None = None,
        *,
        path: str | None = None,
        color: Sequence[int] = ...,
        lift: float | None = None,
    ) -> None: ...
    def log_contacts(
        self, points: npt.ArrayLike, forces: npt.ArrayLike, scale: float | None = None
    ) -> None: ...
    def log_frames(
        self,
        paths: Sequence[str],
        positions: npt.ArrayLike,
        quats_wxyz: npt.ArrayLike,
        axis_length: float = ...,
    ) -> None: ...
    def hide_frames(self, paths: Iterable[str]) -> None: ...
    def log_target(
        self, task: str, p: npt.ArrayLike, quat_wxyz: npt.ArrayLike, *, fixed: object = None
    ) -> None: ...
    def shows_target(self, task: str, fixed: object) -> bool: ...

    # series, static data, text
    def log_scalar(self, path: str, value: float) -> None: ...
    def log_task_errors(
        self, errors: Mapping[tuple[int, str], float], *, solve: str | None = None
    ) -> None: ...
    def log_series_style(self, path: str, color: tuple[int, ...], name: str) -> None: ...
    def log_static(self, path: str, *archetypes: Any) -> None: ...
    def log_text(self, message: str, level: str = "INFO") -> None: ...
