"""What a scenario reads of its robot: where it stands and faces, and its sizes.

A scenario states its targets and builds its scene in the **robot's frame** R, read
from the robot standing in its start pose:

* origin: the midpoint of the feet's end frames, on the floor (z of the lowest sole
  point); for a robot without legs, its root body's origin;
* y (left): the horizontal direction from the right foot to the left one (a robot
  without legs: its root body's y); z up; x (forward) = y × z;

and scales them by the robot's sizes: each arm's **shoulder** (the arm's first
link) and **length** ``L`` (along the chain: from the shoulder through the arm's
joint anchors to its hand, so a bent arm measures as a straight one), the
**sole** size (the extent of the sole polygons along the foot, and across it).

A point ``p_R`` in the robot's frame is ``p_W = p_WR + R_WR p_R`` in the world
(:meth:`Stature.to_world`). A **hand** (:class:`Hand`) is a frame in it (the arm's end
frame, or the hand's geometry past it) and that frame's axes nearest to the robot's
directions at the start pose: of the two axes across the forearm, the grip axis (a bar
held in the fist: forward for a forearm hanging down, up for one held forward) and
the palm's normal, signed inwards (towards the body's middle plane).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.frames import Frame
from pik_mj.robot import Robot
from pik_mj.robot.ground import collision_geoms, sole_polygons

AXES = ("x", "y", "z")
FOREARM = 0.25
"""The shortest forearm, as a share of the shoulder–hand distance (:func:`forearm`)."""


@dataclass(frozen=True)
class Hand:
    """An arm's hand: the frame that grasps and touches, its body, and its axes
    (each a unit axis of the frame, signed, ``(index, sign)``).

    The frame is the arm's end frame when it is a site (placed by the model's author);
    else, the end body's collision geom farthest from the body's origin (the hand at
    the end of a forearm link, the rubber hand past a wrist): a frame inside the hand,
    which a grasp closes around and a palm pushes with.

    Attributes:
        arm: The arm's limb name.
        frame: The hand frame's name.
        frame_type: ``"site"``, ``"geom"`` or ``"body"``.
        body: The body carrying it (what a grasp welds an object to).
        grip: The axis along a bar held in the hand, e.g. ``(0, +1)`` for +x.
        palm: The axis out of the palm (towards the robot's middle plane).
        radius: Radius [m] of the ball about the hand frame that holds the hand's
            collision geometry (the hand frame's geom, else the hand body's geoms):
            ``max_g |p_g - p_H| + r_g`` (``r_g`` MuJoCo's bounding radius
            ``geom_rbound``).
    """

    arm: str
    frame: str
    frame_type: str
    body: str
    grip: tuple[int, int]
    palm: tuple[int, int]
    radius: float

    @staticmethod
    def vector(axis: tuple[int, int]) -> np.ndarray:
        """The axis ``(index, sign)`` as a 3-vector of the hand frame."""
        v = np.zeros(3)
        v[axis[0]] = axis[1]
        return v

    @staticmethod
    def name(axis: tuple[int, int]) -> str:
        """The axis' name without its sign (``"x"``, ``"y"``, ``"z"``): the free or
        matched axis of an IK target's ``rotation_axis``."""
        return AXES[axis[0]]

    def pose(self, robot: Robot) -> mink.SE3:
        """``X_WH``: the hand frame in the world."""
        return robot.frame_pose(self.frame, self.frame_type)

    def geoms(self, model: mujoco.MjModel) -> list[int]:
        """Ids of the hand's collision geoms in ``model``: the hand frame's geom, else
        the hand body's."""
        return hand_geoms(model, self.frame, self.frame_type, self.body)

    def axis(self, X_WH: mink.SE3, axis: tuple[int, int]) -> np.ndarray:
        """``axis`` of the hand frame at pose ``X_WH``, in the world."""
        return X_WH.rotation().as_matrix() @ self.vector(axis)

    def rotation(self, grip: np.ndarray, palm: np.ndarray) -> np.ndarray:
        """An orientation ``R_WH`` with the grip axis along ``grip`` and the palm's
        normal along ``palm`` (unit vectors, orthogonal)."""
        g, p = self.grip, self.palm
        R = np.zeros((3, 3))
        R[:, g[0]] = g[1] * np.asarray(grip, dtype=float)
        R[:, p[0]] = p[1] * np.asarray(palm, dtype=float)
        k = 3 - g[0] - p[0]
        R[:, k] = np.cross(R[:, (k + 1) % 3], R[:, (k + 2) % 3])
        return R


@dataclass(frozen=True)
class Stature:
    """A robot's frame and sizes at its start pose (module docstring).

    Attributes:
        p_WR: Origin of the robot's frame [m] in the world.
        R_WR: Its orientation (columns: forward, left, up).
        shoulders: Per arm, its shoulder (the origin of its first link) [m], world.
        arm_lengths: Per arm, its length ``L`` along the chain to the hand [m].
        hands: Per arm, its hand (:class:`Hand`).
        sole: Length and width [m] of the sole polygons (the larger of the two
            feet's), or None for a robot without legs.
        mass: The robot's mass [kg].
    """

    p_WR: np.ndarray
    R_WR: np.ndarray
    shoulders: dict[str, np.ndarray]
    arm_lengths: dict[str, float]
    hands: dict[str, Hand]
    sole: tuple[float, float] | None
    mass: float

    @classmethod
    def of(cls, robot: Robot) -> Stature:
        """The stature of ``robot`` in its current configuration (its start pose)."""
        legs = [leg for leg in ("rleg", "lleg") if leg in robot.limbs]
        if len(legs) == 2:
            feet = [end_position(robot, leg) for leg in legs]
            polygons = sole_polygons(robot, legs)
            left = feet[1] - feet[0]
            left[2] = 0.0
            y = left / np.linalg.norm(left)
            p_WR = 0.5 * (feet[0] + feet[1])
            p_WR[2] = min(float(p[:, 2].min()) for p in polygons)
        else:
            p_root = robot.root_pose()[0]
            R = robot.frame_pose(robot.root_body, "body").rotation().as_matrix()
            y = np.array([R[0, 1], R[1, 1], 0.0])
            y /= np.linalg.norm(y)
            p_WR, polygons = p_root.copy(), []
        z = np.array([0.0, 0.0, 1.0])
        R_WR = np.column_stack([np.cross(y, z), y, z])
        arms = [a for a in ("rarm", "larm", "arm") if a in robot.limbs]
        hands = {a: hand(robot, a, R_WR) for a in arms}
        return cls(
            p_WR=p_WR,
            R_WR=R_WR,
            shoulders={a: shoulder(robot, a) for a in arms},
            arm_lengths={a: arm_length(robot, hands[a]) for a in arms},
            hands=hands,
            sole=sole_extent(polygons, R_WR) if polygons else None,
            mass=robot.mass,
        )

    def to_world(self, p_R: Sequence[float]) -> np.ndarray:
        """A point ``p_R`` [m] of the robot's frame in the world: ``p_WR + R_WR p_R``."""
        return self.p_WR + self.R_WR @ np.asarray(p_R, dtype=float)

    def to_robot(self, p_W: Sequence[float]) -> np.ndarray:
        """A world point ``p_W`` [m] in the robot's frame: ``R_WR^T (p_W - p_WR)``."""
        return self.R_WR.T @ (np.asarray(p_W, dtype=float) - self.p_WR)

    def direction(self, d_R: Sequence[float]) -> np.ndarray:
        """A direction of the robot's frame in the world: ``R_WR d_R``."""
        return self.R_WR @ np.asarray(d_R, dtype=float)

    def from_shoulder(self, arm: str, offset: Sequence[float]) -> np.ndarray:
        """The world point ``offset`` arm lengths from ``arm``'s shoulder, ``offset``
        in the robot's frame (x forward, y left, z up): ``s + L R_WR offset``.

        Raises:
            InvalidInput: The robot has no such arm.
        """
        if arm not in self.shoulders:
            raise InvalidInput(f"the robot has no arm {arm!r} (its arms: {list(self.shoulders)})")
        return self.shoulders[arm] + self.arm_lengths[arm] * self.direction(offset)

    def outward(self, arm: str) -> float:
        """+1 for an arm on the robot's left, -1 on its right (the sign of its
        shoulder's y in the robot's frame)."""
        return 1.0 if self.to_robot(self.shoulders[arm])[1] >= 0 else -1.0


def end_position(robot: Robot, limb: str) -> np.ndarray:
    """Position [m] of ``limb``'s end frame in the world."""
    end = robot.limb(limb)
    return robot.frame_pose(end.end_frame, end.end_frame_type).translation()


def shoulder(robot: Robot, arm: str) -> np.ndarray:
    """Origin [m] of ``arm``'s first link (its shoulder) in the world."""
    return robot.frame_pose(robot.limb(arm).root_body, "body").translation()


def arm_length(robot: Robot, hand: Hand) -> float:
    """Length [m] of ``hand``'s arm along its chain: the shoulder, the anchors of its
    joints and the hand frame, ``Σ_k |p_{k+1} - p_k|`` (MuJoCo's joint anchors
    ``xanchor``)."""
    anchors = [robot.data.joint(j).xanchor.copy() for j in robot.limb(hand.arm).joints]
    points = [shoulder(robot, hand.arm), *anchors, hand.pose(robot).translation()]
    return float(sum(np.linalg.norm(b - a) for a, b in itertools.pairwise(points)))


def hand_frame(robot: Robot, arm: str) -> tuple[str, str, int]:
    """``(name, type, body id)`` of ``arm``'s hand frame (:class:`Hand`)."""
    limb = robot.limb(arm)
    frame = Frame.find(robot.model, limb.end_frame, limb.end_frame_type)
    if limb.end_frame_type == "site":
        return limb.end_frame, "site", frame.body_id
    geoms = collision_geoms(robot.model, [frame.body_id])
    if len(geoms) == 0:
        return limb.end_frame, limb.end_frame_type, frame.body_id
    d = robot.data
    g = max(geoms, key=lambda k: np.linalg.norm(d.geom_xpos[k] - d.xpos[frame.body_id]))
    return robot.model.geom(int(g)).name, "geom", frame.body_id


def hand_geoms(model: mujoco.MjModel, frame: str, frame_type: str, body: str) -> list[int]:
    """Ids of a hand's collision geoms: its frame's geom, else its body's."""
    if frame_type == "geom":
        return [model.geom(frame).id]
    return collision_geoms(model, [model.body(body).id]).tolist()


def forearm(robot: Robot, arm: str, p_hand: np.ndarray) -> np.ndarray:
    """The forearm's direction [world] at the current pose: from the last of ``arm``'s
    joint anchors at least :data:`FOREARM` of the shoulder–hand distance from the hand
    frame at ``p_hand`` [m] to it. Wrist joints next to the hand frame (a wrist of
    three joints, a hand frame on the wrist) are passed over: their offsets say
    nothing of where the forearm points."""
    reach = np.linalg.norm(p_hand - shoulder(robot, arm))
    for joint in reversed(robot.limb(arm).joints):
        f = p_hand - robot.data.joint(joint).xanchor
        if np.linalg.norm(f) >= FOREARM * reach:
            return f
    return p_hand - shoulder(robot, arm)


def hand(robot: Robot, arm: str, R_WR: np.ndarray) -> Hand:
    """``arm``'s hand (:class:`Hand`) at the robot's current pose, ``R_WR`` the robot's
    frame. The forearm ``f`` (:func:`forearm`) runs to the hand frame; a bar held in
    the fist runs along ``f × y_R`` (``y_R`` the robot's left: forward for a hanging
    forearm, up for one held forward). Of the hand frame's axes, the one nearest ``f``
    is neither grip nor palm; of the other two, the one nearest ``f × y_R`` grips, the
    other is the palm's normal, signed inwards."""
    name, kind, body = hand_frame(robot, arm)
    X_WH = robot.frame_pose(name, kind)
    R_WH = X_WH.rotation().as_matrix()
    f_W = forearm(robot, arm, X_WH.translation())
    side = 1.0 if (R_WR.T @ (X_WH.translation() - robot.root_pose()[0]))[1] >= 0 else -1.0
    f_H, bar = R_WH.T @ f_W, R_WH.T @ np.cross(f_W, R_WR[:, 1])
    inward = R_WH.T @ (-side * R_WR[:, 1])
    rest = [k for k in range(3) if k != int(np.argmax(np.abs(f_H)))]
    grip = rest[int(np.argmax(np.abs(bar[rest])))]
    palm = next(k for k in rest if k != grip)
    m, d = robot.model, robot.data
    geoms = hand_geoms(m, name, kind, m.body(body).name)
    radius = max(
        (np.linalg.norm(d.geom_xpos[g] - X_WH.translation()) + m.geom_rbound[g] for g in geoms),
        default=0.0,
    )
    return Hand(
        arm=arm,
        frame=name,
        frame_type=kind,
        body=m.body(body).name,
        grip=(grip, int(np.sign(bar[grip]) or 1)),
        palm=(palm, int(np.sign(inward[palm]) or 1)),
        radius=float(radius),
    )


def sole_extent(polygons: Sequence[np.ndarray], R_WR: np.ndarray) -> tuple[float, float]:
    """Length and width [m] of the largest of the sole polygons: their extents along
    the robot's forward and left axes (``R_WR``'s first two columns)."""
    sizes = [np.ptp(points @ R_WR[:, :2], axis=0) for points in polygons]
    length, width = np.max(sizes, axis=0)
    return float(length), float(width)
