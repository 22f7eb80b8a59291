"""Named frames of a MuJoCo model: pose and world Jacobians from MuJoCo.

A frame is a body, site or geom of the MJCF. Its pose is read from
``mjData`` (``xpos``/``xmat``, ``site_xpos``/``site_xmat``,
``geom_xpos``/``geom_xmat``) and its Jacobians come from ``mj_jacBody``,
``mj_jacSite`` or ``mj_jacGeom``. The configuration must be current
(``mink.Configuration.update`` runs ``mj_kinematics`` and ``mj_comPos``).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from .exceptions import InvalidInput, UnknownName

FRAME_TYPES = ("site", "body", "geom")

_OBJ = {
    "body": mujoco.mjtObj.mjOBJ_BODY,
    "site": mujoco.mjtObj.mjOBJ_SITE,
    "geom": mujoco.mjtObj.mjOBJ_GEOM,
}


def names_of(model: mujoco.MjModel, frame_type: str) -> list[str]:
    """All names of one kind of frame in ``model``."""
    count = {"body": model.nbody, "site": model.nsite, "geom": model.ngeom}[frame_type]
    names = (mujoco.mj_id2name(model, _OBJ[frame_type], i) for i in range(count))
    return [n for n in names if n]


@dataclass(frozen=True)
class Frame:
    """A body, site or geom of a model, by name.

    Args:
        model: The model.
        name: The MJCF name.
        frame_type: ``"site"``, ``"body"`` or ``"geom"``; None finds the name among
            sites, then bodies, then geoms.
    """

    model: mujoco.MjModel
    name: str
    frame_type: str
    id: int

    @staticmethod
    def find(model: mujoco.MjModel, name: str, frame_type: str | None = None) -> Frame:
        if not isinstance(name, str):
            raise InvalidInput(f"frame name must be a string, got {type(name).__name__}")
        if frame_type is not None and frame_type not in FRAME_TYPES:
            raise InvalidInput(f"frame_type {frame_type!r} is not one of {FRAME_TYPES}")
        kinds = (frame_type,) if frame_type else FRAME_TYPES
        for kind in kinds:
            i = mujoco.mj_name2id(model, _OBJ[kind], name)
            if i >= 0:
                return Frame(model, name, kind, i)
        valid = [n for kind in kinds for n in names_of(model, kind)]
        raise UnknownName(frame_type or "frame", name, valid)

    @property
    def body_id(self) -> int:
        if self.frame_type == "body":
            return self.id
        if self.frame_type == "site":
            return int(self.model.site_bodyid[self.id])
        return int(self.model.geom_bodyid[self.id])

    def position(self, data: mujoco.MjData) -> np.ndarray:
        """``p_WF`` [m], shape (3,)."""
        if self.frame_type == "body":
            return data.xpos[self.id].copy()
        if self.frame_type == "site":
            return data.site_xpos[self.id].copy()
        return data.geom_xpos[self.id].copy()

    def rotation(self, data: mujoco.MjData) -> np.ndarray:
        """``R_WF``, shape (3, 3)."""
        if self.frame_type == "body":
            return data.xmat[self.id].reshape(3, 3).copy()
        if self.frame_type == "site":
            return data.site_xmat[self.id].reshape(3, 3).copy()
        return data.geom_xmat[self.id].reshape(3, 3).copy()

    def jacobians(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """World-frame ``(J_p, J_ω)`` of the frame origin, each (3, nv).

        ``ṗ_WF = J_p q̇`` and ``ω_WF = J_ω q̇``.
        """
        jacp = np.zeros((3, self.model.nv))
        jacr = np.zeros((3, self.model.nv))
        if self.frame_type == "body":
            mujoco.mj_jacBody(self.model, data, jacp, jacr, self.id)
        elif self.frame_type == "site":
            mujoco.mj_jacSite(self.model, data, jacp, jacr, self.id)
        else:
            mujoco.mj_jacGeom(self.model, data, jacp, jacr, self.id)
        return jacp, jacr

    def __repr__(self) -> str:
        return f"Frame({self.frame_type} {self.name!r})"
