"""Named frames of a MuJoCo model: pose and world Jacobians from MuJoCo.

A frame is a body, site or geom of the MJCF. Its pose is read from
``mjData`` (``xpos``/``xmat``, ``site_xpos``/``site_xmat``,
``geom_xpos``/``geom_xmat``) and its Jacobians come from ``mj_jacBody``,
``mj_jacSite`` or ``mj_jacGeom``. The configuration must be current
(``mink.Configuration.update`` runs ``mj_kinematics`` and ``mj_comPos``).

:func:`robot_root_body` says which top-level body of a model is the robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName

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


def _body_name(model: mujoco.MjModel, b: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or ""


def robot_root_body(model: mujoco.MjModel, root_body: int | str | None = None) -> int:
    """Id of the robot's top-level body: the one choice every part of pik_mj makes.

    Args:
        model: The model (a robot alone, or with an environment).
        root_body: A body name or id (any body but the world; its subtree is the
            robot). None picks among the top-level bodies (children of the
            world): those with a free joint if any, then the one with the most
            degrees of freedom in its subtree.

    Raises:
        UnknownName: No body ``root_body``.
        InvalidInput: ``root_body`` is the world, or the default is ambiguous.
    """
    top = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
    names = [_body_name(model, b) or f"#{b}" for b in top]
    if root_body is not None:
        if isinstance(root_body, (int, np.integer)) and not isinstance(root_body, bool):
            b = int(root_body)
            if not 0 <= b < model.nbody:
                raise InvalidInput(f"body id {b} is out of range [0, {model.nbody})")
        elif isinstance(root_body, str):
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, root_body)
            if b < 0:
                all_names = [_body_name(model, i) for i in range(model.nbody)]
                raise UnknownName("body", root_body, [n for n in all_names if n])
        else:
            raise InvalidInput(f"root_body must be a body name, got {type(root_body).__name__}")
        if b == 0:
            raise InvalidInput(
                f"root_body {root_body!r} is the world body, whose subtree holds the "
                f"environment too; give the robot's top-level body, one of {names}"
            )
        return int(b)
    if not top:
        raise InvalidInput("the model has no body besides the world")
    free = int(mujoco.mjtJoint.mjJNT_FREE)
    floating = [
        b for b in top if model.body_jntnum[b] > 0 and model.jnt_type[model.body_jntadr[b]] == free
    ]
    candidates = floating or top
    dofs = [int(model.body_dofnum[model.body_rootid == b].sum()) for b in candidates]
    best = max(dofs)
    if dofs.count(best) > 1:
        tied = [
            _body_name(model, b) or f"#{b}"
            for b, n in zip(candidates, dofs, strict=True)
            if n == best
        ]
        raise InvalidInput(
            f"cannot tell which top-level body is the robot: {tied} have {best} degrees of "
            f"freedom each (top-level bodies: {names}); name the robot's root body"
        )
    return int(candidates[dofs.index(best)])
