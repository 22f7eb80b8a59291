"""Limbs found from the kinematic tree of a robot standing on the floor.

In the standing configuration (:func:`pik_mj.robot.keyframes.standing_pose`):

* **legs** end in the bodies whose collision geoms touch the floor: those within
  3 mm (:data:`pik_mj.robot.floor_contact.DEFAULT_TOLERANCE`) of the robot's lowest point, or
  within :data:`FOOT_TOLERANCE` when they turn a line or a face to the floor (a
  heel or a toe lying flat, not the rounded end of a shank). The touching bodies hang
  off one branching body ``L`` (the pelvis; Booster T1's waist); each branch of
  ``L`` holding touching bodies is a leg, ending at the deepest body common to
  its touching bodies (dm_control's CMU humanoid: foot and toes touch, the leg
  ends at the foot);
* **left and right** come from the lateral axis: of the root body's three axes,
  the one closest to the line between the two feet (``y`` for Menagerie robots;
  ``x`` for the CMU humanoid, whose root frame is turned); left is its positive
  side;
* **arms** are the other chains off the trunk lying wholly on one side: the
  highest body whose leaves (legs left out) all lie more than :data:`LATERAL`
  to the left (or right) starts an arm; the arm follows its chain down through
  **side bodies** (:meth:`_Tree.chain_end`: a gear welded to a link, a drive gear
  whose joint an MJCF coupling drives) and ends where the chain branches into
  parts of its own (the wrist, not one of the fingers), or at the deepest body
  common to its leaves when nothing jointed hangs below;
* **torso**: the joints between ``L`` and the arms' branching body ``A``, ending
  at the lower of the two; **head**: a chain with joints hanging off ``A`` that
  is neither arm nor leg and lies on the middle line;
* a robot with a **fixed base** whose tree is one chain (the irteus manual's 3-DoF arm)
  is one limb, ``arm``, from its first joint to its leaf.

A limb holds the hinge and slide joints from its first body to its end body and
an end frame: the site named like the end body, else the end body's only point
site that is not a touch sensor's zone (volume sites are sensing zones), else
the end body itself. These rules reproduce pik_mj's naming of ``sample_humanoid``
(``rleg_*`` joints, ``rleg_end`` sites) and the limb tables of dm_control's two
humanoids (tested against them).

When the tree does not give the limbs asked for, :func:`find_limbs` raises
:class:`LimbsNotFound` before any solve, naming what it found and how to
describe the limbs instead (:mod:`pik_mj.robot.description`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, LimbsNotFound, NoCollisionGeometry
from pik_mj.frames import Frame, robot_root_body
from pik_mj.robot.couplings import find_couplings
from pik_mj.robot.floor_contact import (
    DEFAULT_TOLERANCE,
    bottom_points,
    geom_heights,
    subtree_bodies,
)
from pik_mj.robot.keyframes import standing_pose
from pik_mj.tasks.joint_limit import find_joint

LIMB_NAMES = ("rarm", "larm", "rleg", "lleg", "torso", "head", "arm")
"""Names :func:`find_limbs` gives, in the order a robot lists its limbs."""

FOOT_TOLERANCE = 0.02
"""Height above the robot's lowest point [m] under which a collision geom lying
flat touches the floor for leg finding: above the CMU humanoid's heels (capsules
lying along the foot, 12.6 mm above its toes in its zero pose: part of the sole),
below G1's ankle pitch link (28 mm above its soles: not)."""

LATERAL = 0.02
"""Distance [m] from the middle plane beyond which a leaf lies on a side."""

HUMANOID_LIMBS = ("rleg", "lleg", "rarm", "larm")
"""The limbs :func:`find_limbs` requires by default."""

_ANGLE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@dataclass(frozen=True)
class Limb:
    """A kinematic chain of the robot (irteus ``:rarm``, ``:lleg``, ...).

    Attributes:
        name: Limb name, e.g. ``"rarm"``.
        joints: Joint names from the limb's root towards its end.
        end_frame: Name of the end-effector frame (irteus ``:end-coords``).
        end_frame_type: ``"site"`` or ``"body"``.
        root_body: The limb's first link: the body moved by ``joints[0]``
            (irteus ``:root-link``).
    """

    name: str
    joints: tuple[str, ...]
    end_frame: str
    end_frame_type: str
    root_body: str


@dataclass
class _Tree:
    """The robot's bodies in one configuration."""

    model: mujoco.MjModel
    data: mujoco.MjData
    root: int
    bodies: np.ndarray
    children: dict[int, list[int]] = field(default_factory=dict)
    partners: dict[int, set[int]] = field(default_factory=dict)
    """Joint id -> the joints an MJCF coupling ties it to (:func:`coupling_partners`)."""

    def name(self, b: int) -> str:
        return self.model.body(b).name or f"#{b}"

    def path(self, b: int) -> list[int]:
        """Bodies from the root down to ``b``."""
        chain = [b]
        while chain[-1] != self.root:
            chain.append(int(self.model.body_parentid[chain[-1]]))
        return chain[::-1]

    def common(self, bodies: Sequence[int]) -> int:
        """The deepest body that is an ancestor of (or equal to) all ``bodies``."""
        paths = [self.path(b) for b in bodies]
        out = self.root
        for level in zip(*paths, strict=False):
            if len(set(level)) > 1:
                break
            out = level[0]
        return out

    def is_ancestor(self, a: int, b: int) -> bool:
        return a in self.path(b)

    def leaves(self, b: int, without: set[int]) -> list[int]:
        out, stack = [], [b]
        while stack:
            x = stack.pop()
            kids = [c for c in self.children[x] if c not in without]
            if kids:
                stack.extend(kids)
            else:
                out.append(x)
        return out

    def subtree_joints(self, b: int) -> set[int]:
        """Hinge/slide joint ids on ``b`` and the bodies below it."""
        m = self.model
        return {
            j
            for x in subtree_bodies(m, b)
            for j in range(m.body_jntadr[x], m.body_jntadr[x] + m.body_jntnum[x])
            if int(m.jnt_type[j]) in _ANGLE
        }

    def chain_end(self, start: int, without: set[int]) -> int:
        """The end of the chain from ``start`` down (bodies in ``without`` left out).

        At each body the children are weighed by the joints below them: a child
        holding none is a side body (a gear welded to the link), and so is one
        whose joints are all coupled to joints outside it (:attr:`partners`: a
        drive gear that the elbow's coupling turns) and fewer than those below
        the child holding the most. The chain goes on into the one child left; it
        ends at a body where several are left (a hand with fingers, a gripper's
        two jaws) or none, and where no child holds a joint at all, at the
        deepest body common to the leaves (an end body welded below the last
        joint).
        """
        body = start
        while True:
            kids = [c for c in self.children[body] if c not in without]
            below = {c: self.subtree_joints(c) for c in kids}
            jointed = [c for c in kids if below[c]]
            if not jointed:
                return self.common(self.leaves(body, without)) if kids else body
            most = max(len(below[c]) for c in jointed)
            chain = [c for c in jointed if len(below[c]) == most or not self._driven(below[c])]
            if len(chain) != 1:
                return body
            body = chain[0]

    def _driven(self, joints: set[int]) -> bool:
        """Whether every joint of ``joints`` is coupled to a joint outside them."""
        return all(self.partners.get(j, set()) - joints for j in joints)

    def joints(self, start: int, end: int) -> list[int]:
        """Hinge/slide joint ids on the bodies from ``start`` down to ``end``."""
        chain = self.path(end)
        chain = chain[chain.index(start) :]
        m = self.model
        return [
            j
            for b in chain
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])
            if int(m.jnt_type[j]) in _ANGLE
        ]


def coupling_partners(model: mujoco.MjModel) -> dict[int, set[int]]:
    """Joint id -> the joints one of the model's couplings
    (:func:`~pik_mj.robot.couplings.find_couplings`) ties it to."""
    partners: dict[int, set[int]] = {}
    for coupling in find_couplings(model).couplings:
        sides = (coupling.y, coupling.x) if coupling.x is not None else (coupling.y,)
        group = {int(model.dof_jntid[d]) for c in sides for d in c.dofadr}
        for j in group:
            partners.setdefault(j, set()).update(group - {j})
    return partners


def _tree(model: mujoco.MjModel, qpos: np.ndarray, root: int) -> _Tree:
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    bodies = subtree_bodies(model, root)
    children = {int(b): [] for b in bodies}
    for b in bodies[1:]:
        children[int(model.body_parentid[b])].append(int(b))
    return _Tree(model, data, root, bodies, children, coupling_partners(model))


def end_frame(model: mujoco.MjModel, body: int) -> tuple[str, str]:
    """``(name, "site" | "body")`` of the end frame of a limb ending at ``body``.

    The site named like the body; else the body's only point site (a sphere,
    MuJoCo's default site type) that is not a touch sensor's zone; else the
    body. Box, capsule, cylinder and ellipsoid sites are volumes (dm_control's
    touch and force zones, bumpers), not frames; a point site carrying a
    force/torque sensor or an IMU is a frame like any other.
    """
    name = model.body(body).name
    sites = [s for s in range(model.nsite) if model.site_bodyid[s] == body]
    names = [model.site(s).name for s in sites]
    if name and name in names:
        return name, "site"
    touch = model.sensor_type == mujoco.mjtSensor.mjSENS_TOUCH
    zones = set(model.sensor_objid[touch].tolist())
    point = model.site_type == int(mujoco.mjtGeom.mjGEOM_SPHERE)
    free = [s for s in sites if point[s] and s not in zones and model.site(s).name]
    if len(free) == 1:
        return model.site(free[0]).name, "site"
    return name, "body"


def make_limb(model: mujoco.MjModel, name: str, joints: Sequence[int], end: int) -> Limb:
    """A :class:`~pik_mj.robot.Limb` from joint ids and its end body.

    Raises:
        InvalidInput: No joint, or an unnamed joint (a limb names its joints).
    """
    if not joints:
        raise InvalidInput(f"limb {name!r} has no hinge or slide joint")
    unnamed = [j for j in joints if not model.joint(j).name]
    if unnamed:
        raise InvalidInput(f"limb {name!r}: joints {unnamed} have no name")
    frame, kind = end_frame(model, end)
    first = model.body(int(model.jnt_bodyid[joints[0]])).name
    return Limb(name, tuple(model.joint(j).name for j in joints), frame, kind, first)


def find_limbs(
    model: mujoco.MjModel,
    qpos: np.ndarray | None = None,
    *,
    root_body: int | str | None = None,
    required: Sequence[str] = HUMANOID_LIMBS,
) -> dict[str, Limb]:
    """Legs, arms, torso and head of a robot from its kinematic tree (module docstring).

    Args:
        model: The robot's model.
        qpos: A configuration standing on the floor (nq,); default
            :func:`pik_mj.robot.keyframes.standing_pose`.
        root_body: The robot's top-level body (name or id); default
            :func:`pik_mj.frames.robot_root_body`.
        required: Limb names that must be found (the others are found if they can be).

    Returns:
        ``{name: Limb}``, names among :data:`LIMB_NAMES` in that order.

    Raises:
        LimbsNotFound: A required limb is not found (message: what was found and
            how to describe the limbs instead).
    """
    root = robot_root_body(model, root_body)
    if qpos is None:
        pose = standing_pose(model, root_body=root)
        qpos, where = pose.qpos, pose.describe()
    else:
        qpos = np.asarray(qpos, dtype=float)
        if qpos.shape != (model.nq,):
            raise InvalidInput(f"qpos has shape {qpos.shape}, expected ({model.nq},)")
        where = "the given configuration"
    tree = _tree(model, qpos, root)
    details = [f"standing configuration: {where}"]
    limbs: dict[str, Limb] = {}
    problem = _search(tree, limbs, details)
    limbs = {n: limbs[n] for n in LIMB_NAMES if n in limbs}
    missing = [n for n in required if n not in limbs]
    if missing:
        raise LimbsNotFound(
            f"cannot find the limbs {missing} of the robot with root body "
            f"{tree.name(root)!r}: {problem or 'not in the tree'}",
            limbs,
            details,
        )
    return limbs


def _search(tree: _Tree, limbs: dict[str, Limb], details: list[str]) -> str | None:
    """Fill ``limbs`` (and ``details``) by the rules of the module docstring;
    returns why the search stopped early, or None."""
    model, root = tree.model, tree.root
    try:
        heights = geom_heights(model, tree.data, tree.bodies)
    except NoCollisionGeometry as err:
        return str(err)
    if _fixed_base(model, root):
        leaves = tree.leaves(root, set())
        joints = tree.joints(root, leaves[0]) if len(leaves) == 1 else []
        if joints:  # a fixed-base serial chain: a manipulator arm
            limbs["arm"] = make_limb(model, "arm", joints, leaves[0])
            details.append(f"a fixed-base serial chain ending at {tree.name(leaves[0])!r}: an arm")
            return None
    lowest = min(heights.values())
    touching = sorted(
        {
            int(model.geom_bodyid[g])
            for g, h in heights.items()
            if h <= lowest + DEFAULT_TOLERANCE
            or (h <= lowest + FOOT_TOLERANCE and _lies_flat(model, tree.data, g))
        }
    )
    details.append(
        f"bodies touching the floor (within {DEFAULT_TOLERANCE} m of the lowest point, or "
        f"{FOOT_TOLERANCE} m lying flat): {[tree.name(b) for b in touching]}"
    )
    hip = tree.common(touching)
    branches: dict[int, list[int]] = {}
    if hip not in touching:  # else the touching bodies lie on one chain: one leg
        for b in touching:
            path = tree.path(b)
            branches.setdefault(path[path.index(hip) + 1], []).append(b)
    n_legs = len(branches) or 1
    details.append(
        f"they make {n_legs} leg(s), hanging off {tree.name(hip)!r}"
        + (f" in the branches {[tree.name(b) for b in branches]}" if branches else "")
    )
    if n_legs != 2:
        return f"the floor is touched by {n_legs} leg(s), not 2"
    (start_a, feet_a), (start_b, feet_b) = branches.items()
    foot_a, foot_b = tree.common(feet_a), tree.common(feet_b)

    R_WB = tree.data.xmat[root].reshape(3, 3)
    p_WB = tree.data.xpos[root]
    between = tree.data.xpos[foot_a] - tree.data.xpos[foot_b]
    between[2] = 0.0
    if np.linalg.norm(between) < LATERAL:
        return "the two feet are not apart sideways: no left and right"
    axis = int(np.argmax(np.abs(R_WB.T @ between)))

    def side(b: int) -> float:
        """Lateral coordinate of body ``b`` in the root frame [m] (+ is left)."""
        return float((R_WB.T @ (tree.data.xpos[b] - p_WB))[axis])

    left_first = side(foot_a) > side(foot_b)
    for name, start, foot in (
        ("lleg", *((start_a, foot_a) if left_first else (start_b, foot_b))),
        ("rleg", *((start_b, foot_b) if left_first else (start_a, foot_a))),
    ):
        limbs[name] = make_limb(model, name, tree.joints(start, foot), foot)

    leg_bodies = {int(b) for s in (start_a, start_b) for b in subtree_bodies(model, s)}
    arms = _arms(tree, leg_bodies, side)
    for name, (start, end) in arms.items():
        limbs[name] = make_limb(model, name, tree.joints(start, end), end)
    details.append(f"lateral axis: root-frame {'xyz'[axis]}; arm chains: {len(arms)}")
    if arms:
        shoulders = tree.common([int(model.body_parentid[s]) for s, _ in arms.values()])
        _add_torso_and_head(tree, limbs, hip, shoulders, leg_bodies, arms, side)
    return None


def _lies_flat(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> bool:
    """Whether ``geom`` turns a line or a face to the floor, not a point: a box or
    a cylinder; a capsule lying within 45° of horizontal (the CMU humanoid's heel
    capsules, tilted 10°), not an upright one (the rounded end of a shank); a
    mesh whose parts within :data:`FOOT_TOLERANCE` of its lowest point lie more
    than 1 cm apart; never a sphere or an ellipsoid."""
    kind = int(model.geom_type[geom])
    if kind in (mujoco.mjtGeom.mjGEOM_BOX, mujoco.mjtGeom.mjGEOM_CYLINDER):
        return True
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return abs(float(data.geom_xmat[geom][8])) < math.sqrt(0.5)  # |cos| of axis to z
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        pts = bottom_points(model, data, geom, FOOT_TOLERANCE)
        return float(np.max(np.ptp(pts[:, :2], axis=0))) > 0.01
    return False


def _fixed_base(model: mujoco.MjModel, root: int) -> bool:
    j = int(model.body_jntadr[root])
    return j < 0 or int(model.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_FREE)


def _arms(tree: _Tree, leg_bodies: set[int], side) -> dict[str, tuple[int, int]]:
    """``{"larm" | "rarm": (first body, end body)}``: per side, the chain with the
    most joints among the highest bodies whose leaves all lie on that side."""
    found: dict[str, tuple[int, int]] = {}
    for name, sign in (("larm", 1.0), ("rarm", -1.0)):
        candidates = []
        for b in tree.bodies:
            b = int(b)
            if b in leg_bodies or b == tree.root:
                continue
            leaves = tree.leaves(b, leg_bodies)
            if not all(sign * side(x) > LATERAL for x in leaves):
                continue
            parent = int(tree.model.body_parentid[b])
            if parent != tree.root and all(
                sign * side(x) > LATERAL for x in tree.leaves(parent, leg_bodies)
            ):
                continue  # not the highest such body
            end = tree.chain_end(b, leg_bodies)
            if tree.joints(b, end):
                candidates.append((len(tree.joints(b, end)), b, end))
        if candidates:
            _, start, end = max(candidates)
            found[name] = (start, end)
    return found


def _add_torso_and_head(
    tree: _Tree,
    limbs: dict[str, Limb],
    hip: int,
    shoulders: int,
    leg_bodies: set[int],
    arms: dict[str, tuple[int, int]],
    side,
) -> None:
    model = tree.model
    if tree.is_ancestor(hip, shoulders) and hip != shoulders:
        upper, lower = hip, shoulders
    elif tree.is_ancestor(shoulders, hip) and hip != shoulders:
        upper, lower = shoulders, hip
    else:
        upper = lower = hip
    if upper != lower:
        path = tree.path(lower)
        joints = tree.joints(path[path.index(upper) + 1], lower)
        if joints:
            limbs["torso"] = make_limb(model, "torso", joints, lower)
    arm_starts = {s for s, _ in arms.values()}
    heads = []
    for c in tree.children[shoulders]:
        if c in arm_starts or c in leg_bodies or tree.is_ancestor(c, hip):
            continue
        leaves = tree.leaves(c, leg_bodies)
        end = tree.common(leaves)
        joints = tree.joints(c, end)
        up = tree.data.xpos[end][2] > tree.data.xpos[shoulders][2]
        if joints and up and all(abs(side(x)) <= LATERAL for x in leaves):
            heads.append((c, end, joints))
    if len(heads) == 1:
        _, end, joints = heads[0]
        limbs["head"] = make_limb(model, "head", joints, end)


def limb_from_end(
    model: mujoco.MjModel,
    name: str,
    end: str,
    *,
    joints: Sequence[str] = (),
    start: str | None = None,
) -> Limb:
    """A limb described by its end frame and, optionally, its joints or first body.

    Args:
        model: The robot's model.
        name: Limb name (``rarm``, ...).
        end: End frame: a site name, else a body name.
        joints: The limb's hinge/slide joints, root first. Default: those on the
            bodies from ``start`` down to the end body.
        start: First body of the chain. Default: walking up from the end body
            while the parent has no other child (the chain below the nearest
            branching body: a shoulder, a hip).

    Raises:
        UnknownName: ``end``, ``start`` or a joint does not exist.
        InvalidInput: ``start`` is not above ``end``, or no joint.
    """
    frame = Frame.find(model, end)
    if frame.frame_type == "geom":
        raise InvalidInput(f"limb {name!r}: end {end!r} must be a site or a body, not a geom")
    if joints:
        ids = [find_joint(model, j, ("hinge", "slide"), f"limb {name!r} joint").id for j in joints]
        return Limb(name, tuple(joints), frame.name, frame.frame_type, _body_of(model, ids[0]))
    body = frame.body_id
    if start is None:
        first = body
        while True:
            parent = int(model.body_parentid[first])
            if parent == 0 or np.count_nonzero(model.body_parentid[1:] == parent) != 1:
                break
            first = parent
    else:
        first = Frame.find(model, start, "body").body_id
    tree = _tree(model, model.qpos0, int(model.body_rootid[body]))
    if not tree.is_ancestor(first, body):
        raise InvalidInput(f"limb {name!r}: body {start!r} is not above the end frame {end!r}")
    limb = make_limb(model, name, tree.joints(first, body), body)
    return Limb(name, limb.joints, frame.name, frame.frame_type, limb.root_body)


def _body_of(model: mujoco.MjModel, joint: int) -> str:
    return model.body(int(model.jnt_bodyid[joint])).name
