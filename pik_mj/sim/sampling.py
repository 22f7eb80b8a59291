"""What the checks of a hold or a motion read from the physics, sample by sample:
:class:`Sampler` writes one :class:`Record` row per physics state.

A sample is a state of a rollout's trajectory (:mod:`pik_mj.sim.stepping`),
its kinematics, centre of mass and contacts recomputed on the sampler's own
``MjData`` (``mj_kinematics``, ``mj_comPos``, ``mj_collision``): the same figures
whatever ``MjData`` stepped it (one of a rollout pool's threads, or the
scene's). :meth:`Sampler.read` keeps a row's contact arrays and
:meth:`Sampler.flush` classifies those of all the rows since the last flush in
one vectorized pass (a run's rows at once). A row holds the time, the root
body's pose, the CoM, the servo joints' positions, the positions of the
watched geoms (the allowed and planned contacts' robot geoms, whose slip is
measured) and which of them touch, the reference's values at the same time,
the task frames' positions, and the unexpected contacts by the time they
began (a contact with ``dist <= 0`` of a robot geom). Every
``margin_every``-th row also keeps the ground contact points within the
scene's contact tolerance (:meth:`~pik_mj.sim.physics.Physics.ground_contacts`)
for the CoM margin.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from pik_mj.frames import Frame
from pik_mj.sim.physics import Physics

__all__ = ["Record", "Sampler"]


@dataclass
class Record:
    """The samples of one run (rows appended by :meth:`Sampler.read`).

    Attributes:
        time: Physics time [s] per row.
        root_pos, root_mat: Root body position (3,) [m] and ``xmat`` (9,) per row.
        com: CoM (3,) [m] per row.
        q: Servo joint positions per row [rad or m].
        geoms: Watched geoms' centres (g, 3) [m] per row.
        touching: Which watched geoms touch (g,) per row.
        ref_root_pos, ref_root_mat, ref_q, ref_geoms: The reference's values per row.
        frames, ref_frames: Task frames' origins (f, 3) [m] per row, and the
            reference's (no rows without frames).
        waypoint: Last waypoint the reference passed per row (-1: none).
        margin_rows: Rows whose ground contacts were read.
        ground: Their ground contact points (n, 3) [m] and the contacts' key.
        unexpected: ``(robot geom, other geom) -> first time [s]``.
    """

    time: list[float] = field(default_factory=list)
    root_pos: list[np.ndarray] = field(default_factory=list)
    root_mat: list[np.ndarray] = field(default_factory=list)
    com: list[np.ndarray] = field(default_factory=list)
    q: list[np.ndarray] = field(default_factory=list)
    geoms: list[np.ndarray] = field(default_factory=list)
    touching: list[np.ndarray] = field(default_factory=list)
    ref_root_pos: list[np.ndarray] = field(default_factory=list)
    ref_root_mat: list[np.ndarray] = field(default_factory=list)
    ref_q: list[np.ndarray] = field(default_factory=list)
    ref_geoms: list[np.ndarray] = field(default_factory=list)
    frames: list[np.ndarray] = field(default_factory=list)
    ref_frames: list[np.ndarray] = field(default_factory=list)
    waypoint: list[int] = field(default_factory=list)
    margin_rows: list[int] = field(default_factory=list)
    ground: list[tuple[np.ndarray, bytes]] = field(default_factory=list)
    unexpected: dict[tuple[str, str], float] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.time)


class Sampler:
    """Reads a scene's physics states into :class:`Record` rows (module docstring).

    Args:
        scene: The scene.
        allowed: Robot geoms allowed to touch the environment anywhere.
        planned_pairs: Geom pairs allowed to touch each other.
        allow_self_contact: Robot self-contacts are not unexpected.
        watch: Robot geoms whose positions and touching are recorded (default:
            ``allowed`` and the robot geoms of ``planned_pairs``).
        frames: Task frames whose distance to the reference is recorded.
        max_slope: Largest angle [rad] of a ground contact's normal to up.
    """

    def __init__(
        self,
        scene: Physics,
        *,
        allowed: Sequence[str],
        planned_pairs: Sequence[frozenset[str]] = (),
        allow_self_contact: bool = False,
        frames: Sequence[Frame] = (),
        max_slope: float = np.pi / 4,
    ):
        m = scene.model
        self.scene, self.model = scene, m
        self.data = scene.borrow_data()  # given back by close()
        self.system = scene.system_geoms
        ids = scene.geom_ids
        self.allowed = np.zeros(m.ngeom, dtype=bool)
        self.allowed[[ids[n] for n in allowed]] = True
        self.planned = np.zeros((m.ngeom, m.ngeom), dtype=bool)
        watched = {ids[n] for n in allowed}
        for pair in planned_pairs:
            names = sorted(pair) * (3 - len(pair))  # a geom with itself: twice
            if any(n not in ids for n in names[:2]):
                continue  # an unnamed geom: no pair to plan
            a, b = ids[names[0]], ids[names[1]]
            self.planned[a, b] = self.planned[b, a] = True
            watched |= {g for g in (a, b) if self.system[g]}
        self.watch = np.array(sorted(watched), dtype=int)
        self.column = np.full(m.ngeom, -1, dtype=int)
        self.column[self.watch] = np.arange(len(self.watch))
        self.allow_self = bool(allow_self_contact)
        self.frames = list(frames)
        self.max_slope = float(max_slope)
        self.root = scene.robot.root_body_id
        self.qadr = scene.servo_qposadr
        self.names = scene.geom_names
        self._contacts: list[tuple[int, float, np.ndarray, np.ndarray, np.ndarray]] = []
        self._ground: list[tuple[np.ndarray, ...]] = []

    def close(self) -> None:
        """Give the sampler's data back to the scene (no more reads)."""
        self.scene.give_back(self.data)

    @property
    def watched(self) -> list[str]:
        """Names of the watched geoms, in record column order."""
        return [self.names[g] for g in self.watch]

    def read(
        self,
        record: Record,
        qpos: np.ndarray,
        time: float,
        ref: mujoco.MjData,
        waypoint: int | None = None,
        ground: bool = False,
        moving: bool = True,
    ) -> mujoco.MjData:
        """Append the row of the state ``qpos`` at ``time`` [s], the reference's
        kinematics ``ref`` (an ``MjData`` of the scene's model; not ``moving``:
        the same as in the first row); with ``ground``, its ground contacts too.
        Returns the sampler's data (kinematics, CoM and contacts of ``qpos``;
        valid until the next read). The row's contacts (``touching``,
        ``unexpected``, ``ground``) are read into ``record`` by :meth:`flush`."""
        m, d = self.model, self.data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_collision(m, d)
        root = self.root
        record.time.append(float(time))
        record.root_pos.append(d.xpos[root].copy())
        record.root_mat.append(d.xmat[root].copy())
        record.com.append(self.scene.com(d))
        record.q.append(qpos[self.qadr])  # indexing copies
        record.geoms.append(d.geom_xpos[self.watch])
        if moving or not record.ref_q:
            record.ref_root_pos.append(ref.xpos[root].copy())
            record.ref_root_mat.append(ref.xmat[root].copy())
            record.ref_q.append(ref.qpos[self.qadr])
            record.ref_geoms.append(ref.geom_xpos[self.watch])
        else:  # a constant reference: the same rows
            record.ref_root_pos.append(record.ref_root_pos[-1])
            record.ref_root_mat.append(record.ref_root_mat[-1])
            record.ref_q.append(record.ref_q[-1])
            record.ref_geoms.append(record.ref_geoms[-1])
        if self.frames:
            record.frames.append(np.array([f.position(d) for f in self.frames]))
            record.ref_frames.append(np.array([f.position(ref) for f in self.frames]))
        record.waypoint.append(-1 if waypoint is None else int(waypoint))
        con = d.contact
        row = len(record.time) - 1
        self._contacts.append(
            (row, float(time), con.geom.copy(), con.dist.copy(), con.exclude.copy())
        )
        if ground:
            record.margin_rows.append(row)
            self._ground.append(self.scene.probe_contacts(qpos))
        return d

    def flush(self, record: Record) -> None:
        """Read the contacts of the rows since the last flush into ``record``, all
        rows at once: which watched geoms touch (allowed, or in a planned pair
        with what they touch; ``touching``), the new unexpected contacts, and
        the ground contacts of the margin rows (``ground``)."""
        if self._contacts:
            rows = self._contacts
            self._contacts = []
            counts = [len(r[3]) for r in rows]
            touching = np.zeros((len(rows), len(self.watch)), dtype=bool)
            if sum(counts):
                self._touching(record, rows, counts, touching)
            record.touching.extend(touching)
        if self._ground:
            found = self._ground
            self._ground = []
            stacked = [np.concatenate([f[i] for f in found]) for i in range(5)]
            keep = np.split(
                self.scene.ground_contacts(stacked, self.max_slope),
                np.cumsum([len(f[1]) for f in found])[:-1],
            )
            for (g, *_, pos), k in zip(found, keep, strict=True):
                record.ground.append((pos[k], g[k].tobytes()))

    def _touching(
        self, record: Record, rows: list, counts: list[int], touching: np.ndarray
    ) -> None:
        """``touching`` (rows, watched) and the unexpected contacts of ``rows``."""
        index = np.repeat(np.arange(len(rows)), counts)
        geom = np.concatenate([r[2] for r in rows])
        dist = np.concatenate([r[3] for r in rows])
        exclude = np.concatenate([r[4] for r in rows])
        keep, robot, other, _ = self.scene.robot_contact_rows(geom, dist, exclude, max_dist=0.0)
        index, robot, other = index[keep], robot[keep], other[keep]
        self_contact = self.system[other]
        planned = self.planned[robot, other]
        fine = planned | (~self_contact & self.allowed[robot]) | (self_contact & self.allow_self)
        touch = ~self_contact & (self.allowed[robot] | planned)
        touching[index[touch], self.column[robot[touch]]] = True
        bad = ~fine
        for i, a, b in zip(index[bad], robot[bad], other[bad], strict=True):
            record.unexpected.setdefault((self.names[a], self.names[b]), rows[i][1])
