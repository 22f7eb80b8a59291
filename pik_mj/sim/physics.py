r"""The compiled physics of a robot's world: :class:`Physics`, what the static check,
the hold and the motion playback work with.

A :class:`Physics` holds MuJoCo's model and state of a robot's world and answers
in the robot's terms: the robot configuration ``q`` (the robot model's ``nq``) is
a prefix of the world's ``qpos`` (:meth:`Physics.qpos_of`), the robot's contacts
in a state (:meth:`Physics.contacts`, :meth:`Physics.touching`), the external
wrenches at their frames (:meth:`Physics.external_wrenches`), the servo joints
and their dofs, geom names, the grasped objects, and stepping through the state
guard (:meth:`Physics.step`). :class:`pik_mj.sim.Scene` assembles the model
(servos, contact parameters, grasp welds) and is a :class:`Physics`.

**Touching geoms.** MuJoCo reports a contact only for ``dist < margin``; feet
placed exactly on the floor have ``dist = 0``. The static check therefore runs
collision detection on a probe copy of the model whose robot geoms have
``geom_margin = contact_tolerance`` (:meth:`Physics.probe`,
:meth:`Physics.touching`) and keeps contacts with ``dist <= contact_tolerance``.
The physics model keeps the original margins (a margin there would make the
contacts push at a distance).
"""

from __future__ import annotations

import copy
import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj import balance, inputs
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.frames import Frame
from pik_mj.robot import Robot
from pik_mj.robot.ground import foot_geoms
from pik_mj.sim.falls import foot_length
from pik_mj.sim.grasp import Grasp
from pik_mj.sim.guard import StateGuard
from pik_mj.sim.servos import ServoLaw, position_feedback, rest_controls
from pik_mj.spatial import matrix_to_quat

__all__ = ["ContactInfo", "External", "Physics", "subtree_mask"]

External = tuple[str, ArrayLike, ArrayLike]
"""``(frame, force (3,) [N], moment (3,) [N·m])``: a wrench acting on the robot, the
force at the frame's origin (a site or body of the scene), world frame."""


@dataclass(frozen=True)
class ContactInfo:
    """A contact between a robot geom and another geom.

    Attributes:
        robot_geom: Name of the robot's geom.
        other_geom: Name of the other geom (environment, or robot if ``self_contact``).
        other_body: Name of the other geom's body.
        position: Contact point ``p_WC`` (3,) [m] (MuJoCo: midway between surfaces).
        normal: Unit normal (3,) pointing INTO the robot geom (the direction the
            other geom pushes it).
        dist: Signed distance between the surfaces [m] (< 0: penetration).
        friction: MuJoCo's sliding friction coefficient of the pair.
        self_contact: Both geoms belong to the robot.
    """

    robot_geom: str
    other_geom: str
    other_body: str
    position: np.ndarray
    normal: np.ndarray
    dist: float
    friction: float
    self_contact: bool

    def to_dict(self) -> dict[str, Any]:
        return {
            "robot_geom": self.robot_geom,
            "other_geom": self.other_geom,
            "other_body": self.other_body,
            "position": self.position.tolist(),
            "normal": self.normal.tolist(),
            "dist": self.dist,
            "friction": self.friction,
            "self_contact": self.self_contact,
        }


def subtree_mask(model: mujoco.MjModel, root_id: int) -> np.ndarray:
    """Mask (nbody,) of the bodies whose top-level ancestor is ``root_id`` (its tree)."""
    return np.asarray(model.body_rootid) == root_id


class Physics:
    """MuJoCo's model and state of a robot's world, read in the robot's terms.

    Args:
        robot: The robot; its joints come first in ``model``, at the same addresses.
        model: The compiled world.
        grasps: Objects held by robot frames (welded in ``model``): they follow
            their frames in :meth:`qpos_of` and count in the CoM and the contacts.
        contact_tolerance: Distance [m] within which :meth:`touching` counts two
            geoms as touching.
        allowed_contacts: Robot geoms allowed to touch the environment in a
            hold; default: the robot's feet (:attr:`foot_geoms`).

    Attributes:
        robot: The :class:`pik_mj.Robot`.
        model: The physics model.
        data: The physics state.
        root_body: Name of the robot's top-level body.
        mass: Robot mass [kg].
        carried_mass: Mass of the grasped objects [kg].
        grasps: The :class:`~pik_mj.sim.grasp.Grasp` list.
        contact_tolerance: Distance [m] within which :meth:`touching` counts two
            geoms as touching.
        servo_joints: Joints with a position servo (the robot's hinge/slide joints).
        servo_dofs: Their dof addresses (read-only array).
        servo_qposadr: Their ``qpos`` addresses (read-only array; the robot's
            coordinates come first in the world's).
        position_actuators: Ids of the actuators that pull towards a position
            (:func:`pik_mj.sim.servos.position_feedback`; read-only array).
        robot_bodies: Mask (nbody,) of the robot's bodies (read-only array).
        geom_names: Name of each geom by id (``""`` when unnamed).
        geom_ids: ``{name: id}`` of the named geoms (read-only mapping).
        foot_geoms: The robot's foot geoms (:func:`pik_mj.robot.ground.foot_geoms`,
            by name): a hold's foot slip is theirs.
        foot_length: The largest horizontal extent of one foot [m] in the
            robot's configuration when the physics was made
            (:func:`pik_mj.sim.falls.foot_length`); None without feet.
        allowed_contacts: Robot geoms allowed to touch the environment in a hold
            by default.

    Raises:
        UnknownName: A geom of ``allowed_contacts`` that is not the robot's.
    """

    def __init__(
        self,
        robot: Robot,
        model: mujoco.MjModel,
        *,
        grasps: Sequence[Grasp] = (),
        contact_tolerance: float = 2e-3,
        allowed_contacts: Sequence[str] | None = None,
    ):
        self.robot = robot
        self.model = model
        self.data = mujoco.MjData(model)
        self._guard = StateGuard(model, self.data)
        self.contact_tolerance = float(contact_tolerance)
        self.root_body = robot.root_body
        self._root_id = robot.root_body_id
        self.mass = float(model.body_subtreemass[self._root_id])
        self.robot_bodies = _frozen(subtree_mask(model, self._root_id))
        # Grasped objects are part of the system: CoM, contacts, equilibrium.
        self.grasps = list(grasps)
        self._grasp_frames = [Frame.find(model, g.frame) for g in self.grasps]
        self._grasp_bodies = np.array([model.body(g.body).id for g in self.grasps], dtype=int)
        self._grasp_qadr = [
            int(model.jnt_qposadr[model.body_jntadr[b]]) for b in self._grasp_bodies
        ]
        self.carried_mass = float(model.body_subtreemass[self._grasp_bodies].sum())
        system = self.robot_bodies.copy()
        for b in self._grasp_bodies:
            system |= subtree_mask(model, b)
        self._system_geom = system[model.geom_bodyid]
        self._system_view = _frozen(self._system_geom.copy())
        self._system_list = self._system_geom.tolist()
        self._kin_data = mujoco.MjData(model)
        self._workspace: mujoco.MjData | None = None
        self._spare: list[mujoco.MjData] = []  # datas given back (borrow_data)
        self._regions: dict[bytes, balance.SupportRegion] = {}
        rm = robot.model
        servo_ids = [int(j) for j in robot.angle_joint_ids]
        self.servo_joints = [rm.joint(j).name for j in servo_ids]
        self.servo_dofs = _frozen(np.array(rm.jnt_dofadr[servo_ids], dtype=int))
        self.servo_qposadr = _frozen(np.array(rm.jnt_qposadr[servo_ids], dtype=int))
        self.position_actuators = _frozen(np.flatnonzero(position_feedback(model)))
        # Collision-only copy whose robot geoms carry the contact tolerance.
        self._probe_model = copy.copy(model)
        self._probe_model.geom_margin[self._system_geom] = self.contact_tolerance
        pairs = self._system_geom[model.pair_geom1] | self._system_geom[model.pair_geom2]
        self._probe_model.pair_margin[pairs] = self.contact_tolerance
        self._probe_data = mujoco.MjData(self._probe_model)
        self.geom_names = tuple(model.geom(g).name for g in range(model.ngeom))
        self._body_names = [model.body(b).name for b in range(model.nbody)]
        self._geom_body_names = [self._body_names[b] for b in model.geom_bodyid.tolist()]
        self.geom_ids = MappingProxyType({n: g for g, n in enumerate(self.geom_names) if n})
        self.foot_geoms = [rm.geom(g).name for g in foot_geoms(robot)]
        self._foot_ids = np.array([self.geom_ids[n] for n in self.foot_geoms], dtype=int)
        self.foot_length = foot_length(
            model, self.kinematics(robot.configuration.q), self._foot_ids.tolist(), self.up()
        )
        self.allowed_contacts = (
            list(self.foot_geoms)
            if allowed_contacts is None
            else self.check_robot_geoms(allowed_contacts)
        )

    # ------------------------------------------------------------------ names
    def check_robot_geoms(self, names: Sequence[str]) -> list[str]:
        """``names`` as a list, each checked to be a geom of the robot or of a
        grasped object.

        Raises:
            InvalidInput: Not a list of names.
            UnknownName: A geom that is not the robot's (lists the robot's).
        """
        robot_geoms = [n for g, n in enumerate(self.geom_names) if self._system_geom[g] and n]
        names = inputs.names(names, "allowed contacts (robot geoms)")
        for name in names:
            if name not in robot_geoms:
                raise UnknownName("robot geom", name, robot_geoms)
        return list(names)

    def allowed(self, names: Sequence[str] | None = None) -> list[str]:
        """The robot geoms allowed to touch the environment: ``names``
        (:meth:`check_robot_geoms`), or :attr:`allowed_contacts` for None."""
        return list(self.allowed_contacts) if names is None else self.check_robot_geoms(names)

    @property
    def held_objects(self) -> list[tuple[Frame, int]]:
        """``(frame F, object body id)`` of each grasp, in :attr:`grasps` order."""
        return list(zip(self._grasp_frames, self._grasp_bodies.tolist(), strict=True))

    # ------------------------------------------------------------------- pose
    @property
    def robot_nq(self) -> int:
        """Length of a robot configuration (the robot model's ``nq``)."""
        return int(self.robot.model.nq)

    def qpos_of(self, q: ArrayLike, base: np.ndarray | None = None) -> np.ndarray:
        """The world's ``qpos`` (a new array): ``q`` in its first :attr:`robot_nq`
        entries, the rest from ``base`` (default ``qpos0``), grasped objects at
        ``X_WF(q) X_FO``.

        Raises:
            InvalidInput: ``q`` is not a finite configuration of the robot.
        """
        q = inputs.configuration(self.robot.model, q, "q (the robot's configuration)")
        out = (self.model.qpos0 if base is None else base).copy()
        out[: self.robot_nq] = q
        if self.grasps:
            d = self._kin_data
            d.qpos[:] = out
            mujoco.mj_kinematics(self.model, d)
            for g, frame, adr in zip(
                self.grasps, self._grasp_frames, self._grasp_qadr, strict=True
            ):
                R_WF = frame.rotation(d)
                out[adr : adr + 3] = frame.position(d) + R_WF @ g.p_FO
                out[adr + 3 : adr + 7] = matrix_to_quat(R_WF @ g.R_FO)
        return out

    def kinematics(self, q: ArrayLike, data: mujoco.MjData | None = None) -> mujoco.MjData:
        """MuJoCo's kinematics of the world at the robot configuration ``q``
        (the environment at ``qpos0``, grasped objects in their frames): the
        poses of bodies, geoms and sites (``mj_kinematics``) and the subtree
        centres of mass (``mj_comPos``), in ``data`` (default: a new
        ``MjData`` of :attr:`model`, the physics state untouched). For
        distances along a path (``mj_geomDistance``), camera views, the CoM
        (:meth:`com`).

        Raises:
            InvalidInput: ``q`` is not a finite configuration of the robot, or
                ``data`` is not of :attr:`model`.
        """
        if data is None:
            data = mujoco.MjData(self.model)
        elif not isinstance(data, mujoco.MjData) or data.qpos.shape != (self.model.nq,):
            raise InvalidInput("data must be an MjData of the scene's model (scene.model)")
        data.qpos[:] = self.qpos_of(q)
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        return data

    def workspace(self) -> mujoco.MjData:
        """A data of :attr:`model` to compute in, shared by its callers (made
        once): for a computation that writes every input it reads (``qpos``,
        ``qvel``, ``qacc`` before ``mj_inverse``), valid until the next caller's."""
        if self._workspace is None:
            self._workspace = mujoco.MjData(self.model)
        return self._workspace

    @functools.cached_property
    def servo_law(self) -> ServoLaw:
        """The controls of the scene's position actuators on the robot's hinge and
        slide joints (:class:`~pik_mj.sim.servos.ServoLaw`, made once; read only)."""
        return ServoLaw(self.model, self.position_actuators, self.robot_nq, self.robot.model.nv)

    def borrow_data(self) -> mujoco.MjData:
        """A data of :attr:`model` at its reset state (``mj_resetData``: as a new
        one is), one given back before (:meth:`give_back`) or a new one: a run's
        own data without making one each time (making an ``MjData`` costs about
        0.7 ms, its arena of the model's memory; resetting one about 7 µs)."""
        data = self._spare.pop() if self._spare else mujoco.MjData(self.model)
        mujoco.mj_resetData(self.model, data)
        return data

    def give_back(self, data: mujoco.MjData) -> None:
        """Give a data of :meth:`borrow_data` back: the caller reads it no more."""
        if len(self._spare) < _SPARE_KEPT:
            self._spare.append(data)

    def set_pose(self, q: ArrayLike) -> None:
        """Write the robot configuration ``q`` into the physics state: zero
        velocity, ``mj_forward``, and every actuator's control at rest there: the
        servos' (the scene's and the robot's own position actuators') targets at
        the pose (:func:`pik_mj.sim.servos.rest_controls`; their activations
        too), zero for the others (motors). The other joints keep their state
        (grasped objects follow their frames)."""
        m, d = self.model, self.data
        d.qpos[:] = self.qpos_of(q, base=d.qpos)
        d.qvel[:] = 0.0
        d.ctrl[:] = 0.0
        d.act[:] = 0.0
        mujoco.mj_fwdPosition(m, d)
        servos = self.position_actuators
        d.ctrl[servos] = rest_controls(m, d, servos)
        for a in servos[m.actuator_actnum[servos] > 0]:
            d.act[m.actuator_actadr[a]] = d.ctrl[a]
        mujoco.mj_forward(m, d)

    def com(self, data: mujoco.MjData | None = None) -> np.ndarray:
        r"""Centre of mass ``p_WG`` (3,) [m] of the robot and its grasped objects
        in ``data`` (default: physics):

        .. math::

            p_{WG} = \frac{m_r c_r + \sum_o m_o c_o}{m_r + \sum_o m_o}
        """
        d = self.data if data is None else data
        if not self.grasps:
            return d.subtree_com[self._root_id].copy()
        c = self.mass * d.subtree_com[self._root_id]
        for b in self._grasp_bodies:
            c = c + self.model.body_subtreemass[b] * d.subtree_com[b]
        return c / (self.mass + self.carried_mass)

    def root_height(self, data: mujoco.MjData | None = None) -> float:
        """Height [m] of the robot's root body along up in ``data`` (default: physics)."""
        d = self.data if data is None else data
        return float(d.xpos[self._root_id] @ self.up())

    def com_height(self, data: mujoco.MjData | None = None) -> float | None:
        """Height [m] of the CoM (:meth:`com`) above the mean of the foot geoms'
        centres, along up, in ``data`` (default: physics; kinematics and
        ``mj_comPos`` current); None without feet."""
        if not len(self._foot_ids):
            return None
        d = self.data if data is None else data
        return float((self.com(d) - d.geom_xpos[self._foot_ids].mean(axis=0)) @ self.up())

    # --------------------------------------------------------------- contacts
    def contacts(
        self, data: mujoco.MjData | None = None, max_dist: float = 0.0
    ) -> list[ContactInfo]:
        """Robot contacts (with the environment and self-contacts) in ``data``
        (default: physics; or :meth:`probe`'s state) with ``dist <= max_dist`` [m]
        (:meth:`robot_contact_rows`)."""
        d = self.data if data is None else data
        if not d.ncon:
            return []
        con = d.contact  # MuJoCo's contact arrays, read at once
        keep, robot, other, normal = self.robot_contact_rows(
            con.geom, con.dist, con.exclude, con.frame[:, :3], max_dist
        )
        rows = np.flatnonzero(keep)
        if not len(rows):
            return []
        position, normal = con.pos[rows], normal[rows]
        dist, friction = con.dist[rows].tolist(), con.friction[rows, 0].tolist()
        system, geoms, bodies = self._system_list, self.geom_names, self._geom_body_names
        return [
            ContactInfo(
                robot_geom=geoms[r],
                other_geom=geoms[o],
                other_body=bodies[o],
                position=position[k],
                normal=normal[k],
                dist=dist[k],
                friction=friction[k],
                self_contact=system[o],
            )
            for k, (r, o) in enumerate(zip(robot[rows].tolist(), other[rows].tolist(), strict=True))
        ]

    def robot_contact_rows(
        self,
        geom: np.ndarray,
        dist: np.ndarray,
        exclude: np.ndarray,
        frame: np.ndarray | None = None,
        max_dist: float | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """Of MuJoCo's contacts given as arrays, ``geom`` (n, 2), ``dist`` (n,)
        [m], ``exclude`` (n,) and the normals ``frame[:, :3]`` (n, 3) (of
        :meth:`probe_contacts`, rows of several stacked, or a data's
        ``contact``): which are the robot's (a geom of the robot or of a grasped
        object, not excluded) with ``dist <= max_dist`` [m] (default
        ``contact_tolerance``); and of every row, the robot's geom and the other
        geom (the robot's geom2 when both are) and, with ``frame``, the normal
        into the robot's geom (MuJoCo's ``frame[0:3]`` points from geom1 to
        geom2: it pushes geom2). The other geom is the robot's too in a
        self-contact (:attr:`system_geoms`)."""
        g = np.asarray(geom).reshape(-1, 2)
        r2 = self._system_geom[g[:, 1]]
        mine = self._system_geom[g[:, 0]] | r2
        limit = self.contact_tolerance if max_dist is None else max_dist
        keep = (dist <= limit) & ((exclude == 0) | (exclude == 1)) & mine
        robot, other = np.where(r2, g[:, 1], g[:, 0]), np.where(r2, g[:, 0], g[:, 1])
        normal = None if frame is None else np.where(r2[:, None], frame, -frame)
        return keep, robot, other, normal

    def probe(self, q: ArrayLike) -> mujoco.MjData:
        """The state of the probe model (robot geoms with ``margin =
        contact_tolerance``) at the robot configuration ``q`` at rest, after
        ``mj_forward``: its :meth:`contacts` within ``contact_tolerance`` are
        the geoms touching at ``q``. Valid until the next call.

        Raises:
            InvalidInput: ``q`` is not a finite configuration of the robot.
        """
        m, d = self._probe_model, self._probe_data
        d.qpos[:] = self.qpos_of(q)
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        return d

    def touching(self, qpos: np.ndarray) -> list[ContactInfo]:
        """Robot contacts within ``contact_tolerance`` at the world state ``qpos``
        (collision detection on the probe model, as :meth:`probe`)."""
        m, d = self._probe_model, self._probe_data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        return self.contacts(d, self.contact_tolerance)

    def contact_forces(self, data: mujoco.MjData | None = None) -> tuple[np.ndarray, np.ndarray]:
        r"""Points ``p_WC`` (n, 3) [m] and forces (n, 3) [N] on the robot (and its
        grasped objects) of the active contacts with the environment in ``data``
        (default: physics), from MuJoCo's ``mj_contactForce``.

        MuJoCo's contact frame has its normal (first row of ``frame``) from geom1
        to geom2 and gives the force of geom1 on geom2 in that frame:

        .. math::
            f_W = R_{WC} f_C, \quad R_{WC} = \text{frame}^T, \qquad
            f_{robot} = \pm f_W \;(+ \text{ if the robot geom is geom2})
        """
        d = self.data if data is None else data
        points, forces = [], []
        f6 = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            r1, r2 = bool(self._system_geom[c.geom1]), bool(self._system_geom[c.geom2])
            if r1 == r2 or c.efc_address < 0:  # not robot-environment, or inactive
                continue
            mujoco.mj_contactForce(self.model, d, i, f6)
            f_W = np.asarray(c.frame).reshape(3, 3).T @ f6[:3]
            points.append(np.array(c.pos))
            forces.append(f_W if r2 else -f_W)
        return np.array(points).reshape(-1, 3), np.array(forces).reshape(-1, 3)

    def up(self) -> np.ndarray:
        """Unit vector against gravity (z without gravity)."""
        gx, gy, gz = self.model.opt.gravity.tolist()
        n = math.sqrt(gx * gx + gy * gy + gz * gz)
        return np.array([-gx / n, -gy / n, -gz / n]) if n > 0 else np.array([0.0, 0.0, 1.0])

    def support(
        self, contacts: list[ContactInfo], com: np.ndarray, max_slope: float
    ) -> tuple[balance.SupportRegion | None, float]:
        """Support region of the ground contacts (normal within ``max_slope`` [rad]
        of up, projected along gravity) and the signed distance of ``com`` to it
        [m] (``(None, -inf)`` without ground contacts)."""
        up = self.up()
        cos_max = math.cos(max_slope)
        pts = [c.position for c in contacts if not c.self_contact and c.normal @ up >= cos_max]
        region = self.support_region(np.array(pts).reshape(-1, 3))
        return region, (-math.inf if region is None else region.signed_distance(com))

    def support_region(self, points: np.ndarray) -> balance.SupportRegion | None:
        """Convex hull (:func:`pik_mj.balance.support_polygon`, degenerate allowed)
        of ground contact points (n, 3) [m] projected along gravity; None without
        points. The region of points seen before is the one built then (read only)."""
        if not len(points):
            return None
        up = self.up()
        points = np.ascontiguousarray(points, dtype=float)
        key = up.tobytes() + points.tobytes() + repr(points.shape).encode()
        region = self._regions.get(key)
        if region is None:
            uv = points @ balance.plane_basis(up)[:, :2]
            extent = float(np.max(np.ptp(uv, axis=0))) if len(uv) > 1 else 0.0
            region = balance.support_polygon(
                [points], up, allow_degenerate=True, tol=max(1e-9, 1e-6 * extent)
            )
            if len(self._regions) >= _REGIONS_KEPT:
                self._regions.clear()
            self._regions[key] = region
        return region

    def ground_points(self, qpos: np.ndarray, max_slope: float) -> tuple[np.ndarray, bytes]:
        """The points ``p_WC`` (n, 3) [m] of :meth:`support`: the robot's (and its
        grasped objects') environment contacts within ``contact_tolerance`` at
        the world state ``qpos`` (the probe model, as :meth:`touching`) whose
        normal into the robot is within ``max_slope`` [rad] of up, read from
        MuJoCo's contact arrays at once; and their geom pairs as bytes (equal
        bytes: the same contacts)."""
        contacts = self.probe_contacts(qpos)
        keep = self.ground_contacts(contacts, max_slope)
        return contacts[4][keep], contacts[0][keep].tobytes()

    def probe_contacts(self, qpos: np.ndarray, friction: bool = False) -> tuple[np.ndarray, ...]:
        """MuJoCo's contacts of the probe model (as :meth:`touching`) at the world
        state ``qpos``, its arrays copied: ``geom`` (n, 2), ``dist`` (n,) [m],
        ``exclude`` (n,), the normal ``frame[:, :3]`` (n, 3) and ``pos`` (n, 3) [m];
        with ``friction``, the pairs' sliding friction ``friction[:, 0]`` (n,) last."""
        m, d = self._probe_model, self._probe_data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_collision(m, d)
        con = d.contact
        arrays = (
            con.geom.copy(),
            con.dist.copy(),
            con.exclude.copy(),
            con.frame[:, :3].copy(),
            con.pos.copy(),
        )
        return (*arrays, con.friction[:, 0].copy()) if friction else arrays

    def ground_contacts(self, contacts: tuple[np.ndarray, ...], max_slope: float) -> np.ndarray:
        """Which of the probe ``contacts`` (:meth:`probe_contacts`, or rows of
        several of them stacked) are ground contacts: robot (or grasped object)
        with the environment, within ``contact_tolerance``, the normal into the
        robot within ``max_slope`` [rad] of up."""
        keep, _, other, normal = self.robot_contact_rows(*contacts[:4])
        return keep & self.on_ground(normal, self._system_geom[other], max_slope)

    def on_ground(
        self, normals: np.ndarray, self_contact: np.ndarray, max_slope: float
    ) -> np.ndarray:
        """Which of the robot's contacts, their normals into the robot (n, 3) and
        whether each is a self-contact (n,), stand on the ground: with the
        environment, the normal within ``max_slope`` [rad] of up."""
        return ~self_contact & (normals @ self.up() >= math.cos(max_slope))

    @property
    def system_geoms(self) -> np.ndarray:
        """Mask (ngeom,) of the geoms of the robot and its grasped objects (read-only)."""
        return self._system_view

    def external_wrenches(
        self, external: Sequence[External], data: mujoco.MjData | None = None
    ) -> list[balance.ExternalWrench]:
        """``external`` as :class:`pik_mj.balance.ExternalWrench`\\ es at the frames'
        positions in ``data`` (default: physics).

        Raises:
            InvalidInput: Not a list of ``(frame, force, moment)``.
            UnknownName: A frame that is not a site or body of the world.
        """
        d = self.data if data is None else data
        return [
            balance.ExternalWrench(Frame.find(self.model, frame).position(d), F, M)
            for frame, F, M in inputs.wrenches(external, "external")
        ]

    # --------------------------------------------------------------- stepping
    def step(
        self, n: int = 1, *, before_step: Callable[[mujoco.MjData], None] | None = None
    ) -> None:
        """Advance the physics ``n`` steps through the state guard
        (:class:`pik_mj.sim.guard.StateGuard`), calling ``before_step`` with the
        state before each (e.g. to write ``xfrc_applied``).

        Raises:
            SimulationUnstable: A warning fired or the state is not finite.
        """
        self._guard.step(n, before_step=before_step)


_SPARE_KEPT = 8
"""Datas given back that :meth:`Physics.borrow_data` keeps for the next borrower."""

_REGIONS_KEPT = 256
"""Support regions :meth:`Physics.support_region` keeps, by their points."""


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a
