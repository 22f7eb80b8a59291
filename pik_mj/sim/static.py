"""The static check of a pose in its scene: contacts, support polygon, CoM
margin and static equilibrium, per pose or per IK iteration.

:func:`static_check` (:meth:`pik_mj.sim.Scene.static_check`) runs MuJoCo's
collision detection at the pose (kinematics only, no stepping) and reports a
:class:`StaticReport`; :class:`StaticChecks` is the per-iteration callback of
:func:`pik_mj.solve` that keeps one report per iteration.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from pik_mj import balance, inputs
from pik_mj.exceptions import InvalidInput
from pik_mj.sim.physics import ContactInfo, External, Physics

__all__ = [
    "ContactInfo",
    "StaticChecks",
    "StaticReport",
    "finite_or_none",
    "point_contacts",
    "static_check",
]


def finite_or_none(x: float | None) -> float | None:
    """``x``, or None when it is None or not finite (JSON has no inf)."""
    return None if x is None or not math.isfinite(x) else float(x)


@dataclass
class StaticReport:
    """Result of :meth:`pik_mj.sim.Scene.static_check` for one configuration.

    Attributes:
        contacts: Every robot contact (environment and self) within the tolerance.
        support_polygon: Vertices (m, 3) [m] of the support polygon (convex hull
            of the ground contacts projected along gravity, counter-clockwise),
            at the mean contact height; ``(0, 3)`` without ground contacts, 1 or 2
            rows when they span no area.
        com: Centre of mass ``p_WG`` (3,) [m] of the robot and its grasped objects.
        margin: Signed distance [m] of the CoM's projection to the support polygon,
            positive inside; for a degenerate polygon (a point or a segment) minus
            the distance to it; ``-inf`` without ground contacts.
        feasible: Contact forces inside the friction cones at the environment
            contacts balance gravity and the external wrenches.
        message: Equilibrium LP message (or why it was not solved).
        forces: Contact forces (n_env, 3) [N] found by the LP (world frame, on the
            robot), one per environment contact in ``contacts`` order, or None.
        mu: Friction coefficient used in the LP (None: each contact's own).
        scfr_margin: Signed distance [m] of the CoM to the static centroid
            feasible region of the actual contacts, when requested.
        q: The robot configuration checked.
        margin_outline: The support polygon shrunk by ``margin`` (m, 3) [m]: the
            iso-margin outline through the CoM's projection; ``(0, 3)`` when the
            CoM is outside or the polygon is degenerate.
    """

    contacts: list[ContactInfo]
    support_polygon: np.ndarray
    com: np.ndarray
    margin: float
    feasible: bool
    message: str
    forces: np.ndarray | None
    mu: float | None
    scfr_margin: float | None
    q: np.ndarray
    margin_outline: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def environment_contacts(self) -> list[ContactInfo]:
        """Contacts with the environment (self contacts left out)."""
        return [c for c in self.contacts if not c.self_contact]

    @property
    def touching_geoms(self) -> list[str]:
        """Sorted names of robot geoms touching the environment."""
        return sorted({c.robot_geom for c in self.environment_contacts})

    @property
    def self_contacts(self) -> list[tuple[str, str]]:
        """Pairs of robot geoms touching each other."""
        return sorted({(c.robot_geom, c.other_geom) for c in self.contacts if c.self_contact})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (non-finite margins become None)."""
        return {
            "feasible": self.feasible,
            "margin": finite_or_none(self.margin),
            "scfr_margin": finite_or_none(self.scfr_margin),
            "com": self.com.tolist(),
            "support_polygon": self.support_polygon.tolist(),
            "touching_geoms": self.touching_geoms,
            "self_contacts": [list(p) for p in self.self_contacts],
            "contacts": [c.to_dict() for c in self.contacts],
            "forces": None if self.forces is None else self.forces.tolist(),
            "mu": self.mu,
            "message": self.message,
        }


def static_check(
    scene: Physics,
    q: ArrayLike,
    *,
    mu: float | None = None,
    external: Sequence[External] = (),
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed",
    max_ground_slope: float = math.pi / 4,
    scfr: bool = False,
) -> StaticReport:
    """Contacts, support polygon, CoM margin and static equilibrium of a pose.

    Collision detection runs on a copy of the model whose robot geoms have
    ``margin = contact_tolerance``; contacts with ``dist <= contact_tolerance``
    count. Each environment contact ``i`` is a point contact at ``p_i`` with
    normal ``n_i`` into the robot; the LP (HiGHS) asks for forces ``f_i``

    .. math::

        \\sum_i f_i + m g + \\sum_k f_k = 0, \\quad
        \\sum_i p_i \\times f_i + c \\times m g + \\sum_k (\\tau_k + p_k \\times f_k) = 0,

        f_i \\cdot n_i \\ge 0, \\quad |f_i \\cdot t_{i,j}| \\le \\mu' f_i \\cdot n_i

    (``μ' = μ/√2`` for the inscribed pyramid). The support polygon is the
    convex hull of the contacts whose normal is within ``max_ground_slope``
    of up, projected along gravity; ``margin = min_j (a_j^T c + b_j)`` [m].

    Args:
        scene: The scene (its :class:`~pik_mj.sim.physics.Physics`).
        q: Robot configuration (``robot.model.nq``).
        mu: Friction coefficient for the LP; None uses each contact's MuJoCo
            friction.
        external: Wrenches ``(frame, force, moment)`` acting on the robot.
        pyramid: Friction pyramid (see :class:`pik_mj.balance.ContactConstraint`).
        max_ground_slope: Largest angle [rad] between a contact normal and up
            for the contact to count in the support polygon.
        scfr: Also compute the margin to the static centroid feasible region
            of the actual contacts (:func:`pik_mj.balance.scfr`, one LP per
            direction of its boundary).

    Returns:
        A :class:`StaticReport`.
    """
    if mu is not None:
        mu = inputs.real(mu, "mu", low=0)
    inputs.real(max_ground_slope, "max_ground_slope", unit="rad", low=0, high=math.pi / 2)
    inputs.flag(scfr, "scfr")
    d = scene.probe(q)
    contacts = scene.contacts(d, scene.contact_tolerance)
    com = scene.com(d)
    region, margin = scene.support(contacts, com, max_ground_slope)
    wrenches = scene.external_wrenches(external, d)
    env = [c for c in contacts if not c.self_contact]
    gravity = np.asarray(scene.model.opt.gravity, dtype=float)
    forces = None
    scfr_margin = None
    if not env:
        feasible, message = False, "no contact with the environment"
    else:
        cons = point_contacts(env, mu, pyramid)
        result = balance.static_equilibrium(
            cons, scene.mass + scene.carried_mass, com, wrenches, gravity
        )
        feasible, message = result.feasible, result.message
        if result.wrenches is not None:
            forces = result.wrenches[:, :3].copy()
        if scfr:
            scfr_margin = _scfr_margin(scene, cons, com, wrenches, gravity)
    return StaticReport(
        contacts=contacts,
        support_polygon=np.zeros((0, 3)) if region is None else region.vertices_3d,
        com=com,
        margin=margin,
        feasible=feasible,
        message=message,
        forces=forces,
        mu=mu,
        scfr_margin=scfr_margin,
        q=np.array(q, dtype=float),
        margin_outline=(
            region.shrunk(margin) if region is not None and margin > 0 else np.zeros((0, 3))
        ),
    )


def point_contacts(
    contacts: Sequence[ContactInfo],
    mu: float | None = None,
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed",
) -> list[balance.ContactConstraint]:
    """Point-contact constraints (friction pyramid about each normal) of contacts,
    as :func:`pik_mj.balance.contact_from_normal` (the same contact point, normal
    and friction: the same constraint object, kept from an earlier call; the
    same normal: the same frame)."""
    return [
        _point_contact(
            *c.position.tolist(), *c.normal.tolist(), c.friction if mu is None else mu, pyramid
        )
        for c in contacts
    ]


@functools.lru_cache(maxsize=4096)
def _point_contact(
    px: float, py: float, pz: float, nx: float, ny: float, nz: float, mu: float, pyramid: str
) -> balance.ContactConstraint:
    """:func:`pik_mj.balance.contact_from_normal` of a point contact, by value."""
    return balance.ContactConstraint(
        p_WC=np.array([px, py, pz]), R_WC=_contact_frame(nx, ny, nz), mu=mu, pyramid=pyramid
    )


@functools.lru_cache(maxsize=256)
def _contact_frame(nx: float, ny: float, nz: float) -> np.ndarray:
    """:func:`pik_mj.balance.plane_basis` of a contact normal, by value (read-only)."""
    R = balance.plane_basis(np.array([nx, ny, nz]))
    R.flags.writeable = False
    return R


def _scfr_margin(
    scene: Physics,
    cons: list[balance.ContactConstraint],
    com: np.ndarray,
    external: Sequence[balance.ExternalWrench],
    gravity: np.ndarray,
) -> float:
    pts = np.array([c.p_WC for c in cons])
    lo, hi = pts[:, :2].min(axis=0) - 2.0, pts[:, :2].max(axis=0) + 2.0
    try:
        region = balance.scfr(
            cons,
            scene.mass + scene.carried_mass,
            external,
            gravity,
            com_z=float(com[2]),
            bounds=(lo[0], hi[0], lo[1], hi[1]),
        )
    except InvalidInput:  # degenerate region (a segment or a point)
        return -math.inf
    return region.signed_distance(com[:2])


class StaticChecks:
    """A :func:`pik_mj.solve` callback: :func:`static_check` of every
    iteration's configuration, kept in order.

    Make one with :meth:`pik_mj.sim.Scene.static_checker`; put it before the
    callbacks that read its last report (e.g. a recorder's solve logger).

    Attributes:
        scene: The scene checked against.
        reports: One :class:`StaticReport` per iteration, in order.
        times: Wall time of each check [s].
    """

    def __init__(
        self,
        scene: Physics,
        *,
        mu: float | None = None,
        external: Sequence[tuple[str, Any, Any]] = (),
        scfr: bool = False,
    ):
        self.scene = scene
        self.mu = mu
        self.external = list(external)
        self.scfr = scfr
        self.reports: list[StaticReport] = []
        self.times: list[float] = []

    def __call__(self, info: Any) -> None:
        t0 = time.perf_counter()
        report = static_check(
            self.scene, info.configuration.q, mu=self.mu, external=self.external, scfr=self.scfr
        )
        self.times.append(time.perf_counter() - t0)
        self.reports.append(report)

    @property
    def last(self) -> StaticReport | None:
        """The latest report, or None before the first iteration."""
        return self.reports[-1] if self.reports else None

    def to_dicts(self) -> list[dict[str, Any]]:
        """``to_dict()`` of every report."""
        return [r.to_dict() for r in self.reports]
