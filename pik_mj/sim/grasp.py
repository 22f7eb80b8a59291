r"""Objects held rigidly by a robot frame: :class:`Grasp`, read from a pose or given,
and the weld that holds one in a scene's physics (:func:`add_grasp_welds`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.frames import Frame
from pik_mj.spatial import matrix_to_quat, quat_to_matrix

__all__ = ["Grasp", "GraspLike", "add_grasp_welds", "grasp_candidates", "parse_grasps"]


@dataclass(frozen=True)
class Grasp:
    r"""An object held rigidly by a robot frame (a hand).

    The object O is a top-level body with a free joint that is not the robot
    (e.g. the room's ``kettle``). In a :class:`~pik_mj.sim.Scene` with this grasp
    its pose follows the robot: for every robot configuration ``q``

    .. math::

        X_{WO}(q) = X_{WF}(q)\, X_{FO}, \qquad
        p_{WO} = p_{WF} + R_{WF}\, p_{FO}, \quad R_{WO} = R_{WF} R_{FO}

    and in the physics a MuJoCo weld equality between the frame's body and O
    keeps that relative pose (MuJoCo computes the constraint force, so the
    object's weight loads the arm and the balance). The object belongs to the
    system: its mass counts in the CoM and the equilibrium of
    :meth:`~pik_mj.sim.Scene.static_check`, its contacts with the environment
    are the system's, its contacts with the robot self-contacts; contacts
    between the frame's body and O (the grip) are excluded.

    Attributes:
        frame: Robot site or body name F (e.g. ``"rarm_end"``).
        body: Object body name O.
        p_FO: Position of O's body frame in F (3,) [m].
        R_FO: Orientation of O's body frame in F (3, 3) [-].
    """

    frame: str
    body: str
    p_FO: np.ndarray
    R_FO: np.ndarray

    def __post_init__(self) -> None:
        p = np.asarray(self.p_FO, dtype=float).reshape(-1)
        R = np.asarray(self.R_FO, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InvalidInput(f"grasp of {self.body!r}: p_FO must be 3 finite numbers [m]")
        if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-6):
            raise InvalidInput(f"grasp of {self.body!r}: R_FO must be a 3x3 rotation matrix")
        object.__setattr__(self, "p_FO", p)
        object.__setattr__(self, "R_FO", R)

    def to_dict(self) -> dict[str, Any]:
        """``{"frame", "body", "p_FO" [m], "R_FO"}``, JSON-ready."""
        return {
            "frame": self.frame,
            "body": self.body,
            "p_FO": self.p_FO.tolist(),
            "R_FO": self.R_FO.tolist(),
        }


GraspLike = Grasp | tuple[str, str] | tuple[str, str, ArrayLike, ArrayLike]
"""A :class:`Grasp`, ``(frame, body)`` (``X_FO`` read at the robot's pose) or
``(frame, body, p_FO [m], R_FO)``."""


def grasp_candidates(model: mujoco.MjModel, robot_body: np.ndarray) -> tuple[list[str], list[str]]:
    """Robot frames (sites and bodies, ``robot_body`` the mask of the robot's
    bodies) and free top-level bodies of the environment, by name."""
    sites = [
        model.site(i).name
        for i in range(model.nsite)
        if model.site(i).name and robot_body[model.site_bodyid[i]]
    ]
    bodies = [
        model.body(i).name for i in range(model.nbody) if model.body(i).name and robot_body[i]
    ]
    objects = [
        model.body(b).name
        for b in range(1, model.nbody)
        if model.body_parentid[b] == 0
        and not robot_body[b]
        and model.body_jntnum[b] == 1
        and model.jnt_type[model.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE
    ]
    return sites + bodies, objects


def _check_names(model: mujoco.MjModel, robot_body: np.ndarray, frame: str, body: str) -> None:
    frames, objects = grasp_candidates(model, robot_body)
    if frame not in frames:
        raise UnknownName("robot frame (site or body)", frame, frames)
    if body not in objects:
        raise UnknownName("free environment body", body, objects)


def parse_grasps(
    model: mujoco.MjModel, robot_body: np.ndarray, q: np.ndarray, grasps: Sequence[GraspLike]
) -> list[Grasp]:
    """:class:`Grasp`\\ es; for ``(frame, body)`` pairs ``X_FO = X_WF⁻¹ X_WO`` is
    read in ``model`` at the robot configuration ``q`` (a prefix of ``qpos``; the
    environment at ``qpos0``).

    Raises:
        InvalidInput: A grasp of another form.
        UnknownName: The frame of a pair is not the robot's, or its body is not
            a free environment body.
    """
    out: list[Grasp] = []
    d = None
    for g in grasps:
        if isinstance(g, Grasp):
            out.append(g)
            continue
        if not isinstance(g, (tuple, list)) or len(g) not in (2, 4):
            raise InvalidInput(
                f"a grasp is (frame, body), (frame, body, p_FO, R_FO) or a Grasp, got {g!r}"
            )
        if len(g) == 4:
            out.append(Grasp(*g))
            continue
        frame, body = g
        if d is None:
            d = mujoco.MjData(model)
            d.qpos[: len(q)] = q
            mujoco.mj_kinematics(model, d)
        _check_names(model, robot_body, frame, body)
        F = Frame.find(model, frame)
        b = model.body(body).id
        R_WF = F.rotation(d)
        R_WO = d.xmat[b].reshape(3, 3)
        p_FO = R_WF.T @ (d.xpos[b] - F.position(d))
        out.append(Grasp(frame, body, p_FO, R_WF.T @ R_WO))
    return out


def add_grasp_welds(
    spec: mujoco.MjSpec,
    model: mujoco.MjModel,
    robot_body: np.ndarray,
    grasps: Sequence[Grasp],
    solref: Sequence[float] | None = None,
) -> None:
    """A weld ``(frame's body B, object O)`` with ``relpose = X_BO = X_BF X_FO``
    (``solref`` when given, else MuJoCo's) and a contact exclusion of ``(B, O)``
    per grasp, added to ``spec`` (``model``: ``spec`` compiled).

    Raises:
        UnknownName: A frame that is not the robot's, or an object that is not a
            free environment body.
        InvalidInput: A body grasped twice.
    """
    seen: set[str] = set()
    for g in grasps:
        _check_names(model, robot_body, g.frame, g.body)
        if g.body in seen:
            raise InvalidInput(f"body {g.body!r} is grasped twice")
        seen.add(g.body)
        frame = Frame.find(model, g.frame)
        body = frame.body_id
        if frame.frame_type == "site":
            p_BF = np.array(model.site_pos[frame.id])
            R_BF = quat_to_matrix(model.site_quat[frame.id])
        else:
            p_BF, R_BF = np.zeros(3), np.eye(3)
        p_BO = p_BF + R_BF @ g.p_FO
        quat_BO = matrix_to_quat(R_BF @ g.R_FO)
        weld = spec.add_equality(
            name=f"grasp_{g.body}",
            type=mujoco.mjtEq.mjEQ_WELD,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            name1=model.body(body).name,
            name2=g.body,
        )
        # data: anchor (3) in O, relpose X_BO (3 + 4), torque scale.
        weld.data = np.r_[np.zeros(3), p_BO, quat_BO, 1.0, np.zeros(len(weld.data) - 11)]
        if solref is not None:
            weld.solref = list(solref)
        spec.add_exclude(bodyname1=model.body(body).name, bodyname2=g.body)
