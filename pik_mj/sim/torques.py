"""The torques that hold a pose or move it along a path: :func:`holding_torques`
(inverse dynamics with the contact forces that carry the robot), and the joints
whose drive cannot give them (:func:`drive_shortfalls`)."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np
from numpy.typing import ArrayLike

from pik_mj.dynamics import ContactDistribution, joint_torques, wrench_map
from pik_mj.sim.drives import DriveShortfall, servo_bounds, shortfalls
from pik_mj.sim.physics import ContactInfo, External, Physics

__all__ = [
    "ContactSupport",
    "drive_shortfalls",
    "holding_torques",
    "root_free_dofs",
    "root_wrench_maps",
    "weight_torques",
]

_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


def holding_torques(
    scene: Physics,
    q: ArrayLike,
    external: Sequence[External] = (),
    *,
    qvel: np.ndarray | None = None,
    qacc: np.ndarray | None = None,
    data: mujoco.MjData | None = None,
    contacts: Sequence[ContactInfo] | None = None,
    support: ContactSupport | None = None,
) -> np.ndarray | None:
    r"""Generalized forces that move the robot through ``q`` at velocity ``qvel``
    and acceleration ``qacc`` (default: hold it still) under gravity, the
    contact forces and the external wrenches:

    .. math::

        \tau = \underbrace{M \ddot q + c(q, \dot q) - \tau_{passive}}_{\texttt{mj\_inverse}}
           - \sum_i J_{p}(p_i)^T f_i - \sum_e J_e^T w_e - \sum_o J_{p,F_o}(c_o)^T m_o g

    (:func:`pik_mj.dynamics.joint_torques`; ``τ_passive``: the joints' springs,
    dm_control's humanoid has them). The free joint's rows of the rest are the
    wrench the contacts must apply (:func:`pik_mj.dynamics.root_wrench`); ``f_i``
    are the least-norm forces inside the friction pyramids at the robot's
    environment contacts ``p_i`` (within the scene's ``contact_tolerance``,
    :meth:`~pik_mj.sim.physics.Physics.touching`) that apply it
    (:func:`pik_mj.dynamics.contact_wrenches`; an equilibrium LP's forces are
    any feasible point, often on a cone's edge, which would push the feet to
    slip). A grasped object's weight ``m_o g`` acts at its CoM ``c_o`` on the
    grasping frame's body (the weld carries it in the physics); its own contacts
    with the environment (a kettle still on the counter at the lift's start) are
    not among the ``p_i``: the hand carries the object, the object does not carry
    the robot. A robot
    without a free joint is held by its fixed base: no contact forces. The rows
    on the servo joints are the feed-forward of the servos; the free-joint rows
    are ~0.

    Args:
        scene: The scene.
        q: Robot configuration (``robot_nq``).
        external: Wrenches ``(frame, force, moment)`` acting on the robot.
        qvel, qacc: Robot velocity and acceleration (``robot.model.nv``) [rad/s,
            rad/s²]; None: zero.
        data: Workspace (default: a new ``MjData`` of the scene's model).
        contacts: The robot's environment contacts at ``q`` when known (default:
            ``scene.touching``'s).
        support: Their :class:`ContactSupport` at ``q`` when built already
            (``contacts`` then unused).

    Returns:
        ``(nv,)`` [N, N·m] of the scene's model, or None when no contact forces
        within the friction pyramids apply the wrench (no equilibrium).
    """
    m = scene.model
    d = mujoco.MjData(m) if data is None else data
    qpos = scene.qpos_of(q)
    v, a = np.zeros(m.nv), np.zeros(m.nv)
    nv = scene.robot.model.nv
    if qvel is not None:
        v[:nv] = qvel
    if qacc is not None:
        a[:nv] = qacc
    wrenches = [(f, np.asarray(F, float), np.asarray(M, float)) for f, F, M in external]
    tau = joint_torques(m, d, qpos, v, a, wrenches) - weight_torques(scene, d)
    if support is None:
        support = ContactSupport(scene, d, scene.touching(qpos) if contacts is None else contacts)
    return support.hold(tau)


def weight_torques(scene: Physics, data: mujoco.MjData) -> np.ndarray:
    """``Σ_o J_{p,F_o}(c_o)ᵀ m_o g`` (nv,): the weights of the grasped objects,
    each on its grasping frame's body at the object's CoM (kinematics and
    ``subtree_com`` current in ``data``; zeros without grasps)."""
    m = scene.model
    out = np.zeros(m.nv)
    jacp = np.zeros((3, m.nv))
    gravity = np.asarray(m.opt.gravity, dtype=float)
    for frame, b in scene.held_objects:
        mujoco.mj_jac(m, data, jacp, None, data.subtree_com[b], frame.body_id)
        out += jacp.T @ (m.body_subtreemass[b] * gravity)
    return out


def root_free_dofs(scene: Physics) -> slice | None:
    """The dofs (a slice of 6) of the free joint of the robot's root body in the
    scene's model, or None when the root is not on a free joint (a fixed base)."""
    m = scene.model
    j = int(m.body_jntadr[scene.robot.root_body_id])
    if j < 0 or int(m.jnt_type[j]) != _FREE:
        return None
    a = int(m.jnt_dofadr[j])
    return slice(a, a + 6)


def root_wrench_maps(J_B: np.ndarray, origin: np.ndarray) -> np.ndarray:
    r"""``T J_B^{-T}`` (k, 6, 6) at k poses: the map from the free joint's rows
    of a generalized force to the wrench ``(f, n about the world origin)``
    [N, N·m] the contacts must apply for them (:class:`ContactSupport`).
    ``J_B`` (k, 6, 6): the root body's Jacobian ``[J_p; J_ω]`` on its free
    joint's dofs (``mj_jacBody``); ``origin`` (k, 3): its position ``p_WB``
    [m]; ``T = [[I, 0], [[p_WB]_×, I]]`` takes ``(f, n about p_WB)`` to
    ``(f, n about the origin)``."""
    k = len(origin)
    shift = np.zeros((k, 6, 6))
    shift[:, :, :3] = wrench_map(origin).reshape(6, k, 3).transpose(1, 0, 2)  # [I; [p_WB]×]
    shift[:, 3:, 3:] = np.eye(3)
    return shift @ np.linalg.inv(np.transpose(J_B, (0, 2, 1)))


class ContactSupport:
    r"""The robot's environment contacts (within the scene's
    ``contact_tolerance``, self-contacts and the grasped objects' contacts left
    out: the weld carries an object's weight to the hand, :func:`weight_torques`,
    so its contacts carry nothing of the robot) at the pose current in
    ``data`` (its kinematics), as maps of generalized forces: what is left of
    ``τ`` (nv,) once the contacts apply the wrench of its free-joint rows.

    With ``J_B`` the root body's Jacobian on its free joint, the wrench about
    the world origin is ``w(τ) = T J_B^{-T} τ_{root}`` (``T`` shifts it from
    the root body's origin, :func:`pik_mj.dynamics.root_wrench`); ``A`` (6, 3n)
    maps the contact forces ``f = (f_1, …, f_n)`` at the points ``p_i`` to the
    wrench about the origin (``f_i ↦ (f_i, p_i × f_i)``) and ``J_c`` (3n, nv)
    stacks the points' Jacobians (``mj_jac``):

    * :meth:`hold`: ``τ − J_cᵀ f`` with ``f`` the least-norm forces inside the
      friction pyramids with ``A f = w(τ)``
      (:func:`pik_mj.dynamics.contact_wrenches`, :class:`~pik_mj.dynamics.ContactDistribution`);
      None without them;
    * :meth:`carry`: ``P τ = τ − J_cᵀ A⁺ w(τ)``, the least-norm forces without
      their limits, linear in ``τ`` (the product ``J_cᵀ A⁺ T J_B^{-T}`` is
      formed once).

    Without a free joint or without contacts both are the identity.

    Args:
        scene: The scene.
        data: Workspace of the scene's model, kinematics current.
        contacts: The robot's contacts at that pose (:meth:`~pik_mj.sim.physics.Physics.touching`).
    """

    def __init__(self, scene: Physics, data: mujoco.MjData, contacts: Sequence[ContactInfo]):
        bodies = scene.model.geom_bodyid
        arrays = (
            np.array([c.position for c in contacts], dtype=float).reshape(-1, 3),
            np.array([c.normal for c in contacts], dtype=float).reshape(-1, 3),
            np.array([c.friction for c in contacts], dtype=float),
            np.array([bodies[scene.geom_ids[c.robot_geom]] for c in contacts], dtype=int),
        )
        self._build(scene, data, _carrying(scene, arrays, [c.self_contact for c in contacts]))

    @classmethod
    def of_points(
        cls,
        scene: Physics,
        data: mujoco.MjData,
        points: np.ndarray,
        normals: np.ndarray,
        friction: np.ndarray,
        bodies: np.ndarray,
        self_contact: np.ndarray | None = None,
        wrench: np.ndarray | None = None,
    ) -> ContactSupport:
        """The support of the robot's contacts given as arrays: points ``p_i``
        (n, 3) [m], unit normals into the robot (n, 3), sliding friction (n,),
        the robot's body of each (n,) and, when some may be, which are
        self-contacts (n,) (None: the contacts are those that carry the robot;
        else those that do not are left out, as the class says); ``wrench``:
        the pose's ``T J_B^{-T}`` (6, 6) when formed already
        (:func:`root_wrench_maps`; default: formed here)."""
        arrays = (points, normals, friction, bodies)
        if self_contact is not None:
            arrays = _carrying(scene, arrays, self_contact)
        support = cls.__new__(cls)
        support._build(scene, data, arrays, wrench)
        return support

    def _build(
        self,
        scene: Physics,
        data: mujoco.MjData,
        contacts: tuple[np.ndarray, ...],
        wrench: np.ndarray | None = None,
    ) -> None:
        """The maps of the contacts ``(points, normals, friction, bodies)``;
        ``wrench``: ``T J_B^{-T}`` when formed already (:func:`root_wrench_maps`)."""
        points, normals, friction, bodies = contacts
        m = scene.model
        dofs = root_free_dofs(scene)
        self.active = len(points) > 0 and dofs is not None
        if not self.active:
            return
        self._dofs = dofs  # the free joint's
        if wrench is None:
            b = scene.robot.root_body_id
            J_B = np.zeros((1, 6, m.nv))
            mujoco.mj_jacBody(m, data, J_B[0, :3], J_B[0, 3:], b)
            wrench = root_wrench_maps(J_B[:, :, dofs], data.xpos[b][None])[0]
        self._wrench = wrench  # (6, 6): τ_root -> w
        J = np.zeros((len(points), 3, m.nv))
        for Ji, point, body in zip(J, points, bodies.tolist(), strict=True):
            mujoco.mj_jac(m, data, Ji, None, point, body)
        J = J.reshape(-1, m.nv)
        self._J = J
        self._distribution = _distribution(points, normals, friction)
        self._carried: np.ndarray | None = None

    def wrench(self, tau: np.ndarray) -> np.ndarray:
        """``w(τ)``: the wrench ``(f, n about the origin)`` (6,) [N, N·m] the
        contacts must apply for the free-joint rows of ``tau``."""
        return self._wrench @ tau[self._dofs]

    def hold(self, tau: np.ndarray) -> np.ndarray | None:
        """``τ − J_cᵀ f``, ``f`` within the friction pyramids (class docstring);
        None when no such forces apply ``w(τ)``."""
        if not self.active:
            return tau
        solved = self._distribution.solve_unknowns(self.wrench(tau))
        if solved is None:
            return None
        scale, x = solved  # the points' forces (3 n,) in units of scale
        return tau - self._J.T @ (scale * x)

    def carry(self, tau: np.ndarray) -> np.ndarray:
        """``P τ`` (class docstring)."""
        if not self.active:
            return tau
        if self._carried is None:
            L = self._distribution.least_norm_map  # A⁺ where A has full row rank
            if L is None:
                L = np.linalg.pinv(self._distribution.A)
            self._carried = self._J.T @ L @ self._wrench  # (nv, 6)
        return tau - self._carried @ tau[self._dofs]


def _carrying(
    scene: Physics, contacts: tuple[np.ndarray, ...], self_contact: ArrayLike
) -> tuple[np.ndarray, ...]:
    """The rows of ``contacts`` ``(points, normals, friction, bodies)`` that carry
    the robot: not self-contacts, not on a grasped object's body
    (:class:`ContactSupport`)."""
    keep = ~np.asarray(self_contact, dtype=bool)
    if scene.grasps:
        keep &= ~np.isin(contacts[3], [body for _, body in scene.held_objects])
    return contacts if keep.all() else tuple(x[keep] for x in contacts)


_DISTRIBUTIONS: dict[bytes, ContactDistribution] = {}
_DISTRIBUTIONS_KEPT = 256


def _distribution(points: np.ndarray, normals: np.ndarray, mu: np.ndarray) -> ContactDistribution:
    """:meth:`~pik_mj.dynamics.ContactDistribution.of_points` of the contacts'
    points (n, 3), normals (n, 3) and friction (n,); the one of the same values
    is kept (with its least-norm map, formed once)."""
    points, normals, mu = (np.ascontiguousarray(x, dtype=float) for x in (points, normals, mu))
    key = points.tobytes() + normals.tobytes() + mu.tobytes()
    found = _DISTRIBUTIONS.get(key)
    if found is None:
        found = ContactDistribution.of_points(points, normals, mu)
        if len(_DISTRIBUTIONS) >= _DISTRIBUTIONS_KEPT:
            _DISTRIBUTIONS.clear()
        _DISTRIBUTIONS[key] = found
    return found


def drive_shortfalls(scene: Physics, q: np.ndarray, tau: np.ndarray) -> list[DriveShortfall]:
    """The servo joints whose drive cannot give ``tau`` (nv,) at rest at ``q``, the
    joint giving way a little (:func:`pik_mj.sim.drives.servo_bounds`)."""
    actuators = np.array([scene.servo_actuators[j] for j in scene.servo_joints], dtype=int)
    lo, hi = servo_bounds(scene.model, actuators, scene.qpos_of(q))
    return shortfalls(list(scene.servo_joints), tau[scene.servo_dofs], lo, hi, ["the held pose"])
