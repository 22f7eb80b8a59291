"""CoM inside the static centroid feasible region (prioritized-IK manual:
``centroid-scfr-task``).

The region of CoM positions ``(c_x, c_y)`` that contact wrenches within their
limits (:class:`pik_mj.balance.ContactConstraint`) can hold against gravity and
optional external wrenches is computed by :func:`pik_mj.balance.scfr` as
half-planes ``A c + b ≥ 0`` with unit-norm rows (so ``A c + b`` are distances
[m]). Each iteration gives the rows

.. math::

    A (c + J_{c,xy}\\, x) + \\omega \\ge -b + \\text{margin}

The region itself is not differentiated (as in the prioritized-IK manual: the
contacts are not moved to change it). Contacts are fixed, or attached to robot
frames and re-posed from the current configuration each iteration; the region
is recomputed only when a contact pose, an external wrench or gravity changed by
more than ``cache_tol`` since the last computation (an SCFR costs tens of LPs).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import mink
import numpy as np

from pik_mj.balance import ContactConstraint, ExternalWrench, Region, scfr
from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.frames import Frame
from pik_mj.tasks.com import com_jacobian, com_position, robot_root_body, vector3
from pik_mj.tasks.task import Task, TaskRows, TaskState

ExternalSpec = Sequence[ExternalWrench] | Callable[[mink.Configuration], Sequence[ExternalWrench]]


@dataclasses.dataclass(frozen=True)
class AttachedContact:
    """A contact that moves with a robot frame ``F``.

    Attributes:
        frame: Name of the robot frame (site, body or geom).
        contact: The contact with its pose read IN ``F``: ``p_WC`` is ``p_FC`` and
            ``R_WC`` is ``R_FC`` (z = normal into the robot); sizes and friction
            as given.
        frame_type: ``"site"``, ``"body"``, ``"geom"`` or None (search).
    """

    frame: str
    contact: ContactConstraint
    frame_type: str | None = None


class ScfrTask(Task):
    """Keep the CoM inside the static centroid feasible region.

    Args:
        configuration: Robot configuration.
        contacts: Contacts: :class:`~pik_mj.balance.ContactConstraint` (fixed in
            the world), :class:`AttachedContact`, or tuples
            ``(frame_name, ContactConstraint[, frame_type])`` (attached).
        external: External wrenches (:class:`~pik_mj.balance.ExternalWrench`), or
            a callable ``f(configuration) -> [ExternalWrench, ...]``.
        gravity: Gravity ``(3,)`` [m/s²]; default the model's ``opt.gravity``.
        margin: ``margin`` [m] (prioritized-IK manual): the CoM is kept this
            far inside.
        w: Slack weight (float > 0).
        centroid_thre: Stop test: ``min(A c + b) >= margin − centroid_thre`` [m].
        root_body: The robot's top-level body (its subtree mass is the mass).
        tol: Accuracy of the region [m] (:func:`pik_mj.balance.scfr`; plays the
            prioritized-IK manual's ``epsilon``).
        bounds: Optional box ``(x_min, x_max, y_min, y_max)`` [m] for regions
            that would be unbounded.
        cache_tol: The previous region is reused while every entry of the
            contact poses (positions [m], rotation-matrix entries) and external
            wrenches (entries in [m], [N], [N·m]) changed by at most this.
        max_iter: Largest number of LPs per region.
        check: Whether the solve loop's stop test looks at this task.
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        contacts: Sequence[Any],
        *,
        external: ExternalSpec = (),
        gravity: Sequence[float] | None = None,
        margin: float = 0.0,
        w: float = 1.0,
        centroid_thre: float = 1e-3,
        root_body: str | None = None,
        tol: float = 1e-4,
        bounds: tuple[float, float, float, float] | None = None,
        cache_tol: float = 1e-4,
        max_iter: int = 500,
        check: bool = True,
        name: str | None = None,
    ):
        model = configuration.model
        self.root_body = robot_root_body(model, root_body)
        self.mass = float(model.body_subtreemass[self.root_body])
        if isinstance(contacts, (ContactConstraint, AttachedContact)):
            contacts = [contacts]
        items = list(contacts)
        if not items:
            raise InvalidInput("contacts is empty: give at least one contact")
        self.contacts: list[tuple[Frame | None, ContactConstraint]] = []
        for i, c in enumerate(items):
            if isinstance(c, tuple) and len(c) in (2, 3) and isinstance(c[0], str):
                c = AttachedContact(c[0], c[1], c[2] if len(c) == 3 else None)
            if isinstance(c, AttachedContact):
                if not isinstance(c.contact, ContactConstraint):
                    raise InvalidInput(
                        f"contacts[{i}].contact must be a ContactConstraint, "
                        f"got {type(c.contact).__name__}"
                    )
                self.contacts.append((Frame.find(model, c.frame, c.frame_type), c.contact))
            elif isinstance(c, ContactConstraint):
                self.contacts.append((None, c))
            else:
                raise InvalidInput(
                    f"contacts[{i}] must be a ContactConstraint, an AttachedContact or "
                    f"(frame_name, ContactConstraint); got {type(c).__name__}"
                )
        if callable(external):
            self.external_fn, self.external = external, ()
        else:
            self.external_fn, self.external = None, self._check_external(external)
        g = model.opt.gravity if gravity is None else gravity
        self.gravity = vector3(g, "gravity")
        if not np.linalg.norm(self.gravity) > 0:
            raise InvalidInput("gravity is zero (the model's opt.gravity?); pass gravity=")
        for label, v in (
            ("margin", margin),
            ("w", w),
            ("centroid_thre", centroid_thre),
            ("tol", tol),
            ("cache_tol", cache_tol),
        ):
            if not np.isfinite(v):
                raise InvalidInput(f"{label} must be finite, got {v}")
        if w <= 0 or tol <= 0 or centroid_thre < 0 or cache_tol < 0:
            raise InvalidInput(
                f"need w > 0, tol > 0, centroid_thre >= 0, cache_tol >= 0; got w={w}, "
                f"tol={tol}, centroid_thre={centroid_thre}, cache_tol={cache_tol}"
            )
        self.margin, self.w = float(margin), float(w)
        self.centroid_thre, self.tol, self.cache_tol = (
            float(centroid_thre),
            float(tol),
            float(cache_tol),
        )
        self.bounds = bounds
        self.max_iter = int(max_iter)
        self.check = check
        self.name = name or "scfr"
        self.region_computations = 0
        """Number of SCFRs computed so far (the rest came from the cache)."""
        self._cache_key: np.ndarray | None = None
        self._cache_region: Region | None = None

    @staticmethod
    def _check_external(external: Any) -> tuple[ExternalWrench, ...]:
        items = tuple(external)
        for i, e in enumerate(items):
            if not isinstance(e, ExternalWrench):
                raise InvalidInput(
                    f"external[{i}] must be an ExternalWrench, got {type(e).__name__}"
                )
        return items

    # -- region ---------------------------------------------------------------
    def contacts_now(self, configuration: mink.Configuration) -> list[ContactConstraint]:
        """The contacts posed at the current configuration (world frame)."""
        data = configuration.data
        out = []
        for frame, c in self.contacts:
            if frame is None:
                out.append(c)
                continue
            R_WF = frame.rotation(data)
            out.append(
                dataclasses.replace(
                    c, p_WC=frame.position(data) + R_WF @ c.p_WC, R_WC=R_WF @ c.R_WC
                )
            )
        return out

    def external_now(self, configuration: mink.Configuration) -> tuple[ExternalWrench, ...]:
        """External wrenches at the current configuration."""
        if self.external_fn is None:
            return self.external
        return self._check_external(self.external_fn(configuration))

    def region(self, configuration: mink.Configuration) -> Region:
        """The SCFR at the current configuration (cached, see ``cache_tol``)."""
        contacts = self.contacts_now(configuration)
        external = self.external_now(configuration)
        vertical = np.allclose(self.gravity[:2], 0.0)
        com_z = 0.0 if vertical else float(com_position(configuration, self.root_body)[2])
        key = np.concatenate(
            [np.concatenate([c.p_WC, c.R_WC.ravel()]) for c in contacts]
            + [
                np.concatenate([np.ravel(e.p_W), np.ravel(e.force), np.ravel(e.moment)])
                for e in external
            ]
            + [self.gravity, [com_z]]
        ).astype(float)
        if (
            self._cache_region is not None
            and self._cache_key is not None
            and self._cache_key.shape == key.shape
            and float(np.max(np.abs(self._cache_key - key))) <= self.cache_tol
        ):
            return self._cache_region
        region = scfr(
            contacts,
            self.mass,
            external,
            self.gravity,
            com_z=com_z,
            tol=self.tol,
            max_iter=self.max_iter,
            bounds=self.bounds,
        )
        self.region_computations += 1
        self._cache_key, self._cache_region = key, region
        return region

    def distances(
        self, configuration: mink.Configuration, region: Region | None = None
    ) -> np.ndarray:
        """``A c_xy + b`` [m]: the CoM's signed distance to each region edge.

        Args:
            configuration: Robot configuration.
            region: A region to use instead of the current one (e.g. frozen).
        """
        region = self._nonempty(self.region(configuration) if region is None else region)
        c = com_position(configuration, self.root_body)[:2]
        return region.halfplanes.A @ c + region.halfplanes.b

    def _nonempty(self, region: Region) -> Region:
        if region.empty:
            raise PikError(
                f"task {self.name}: the static centroid feasible region is empty — no CoM "
                "position can be balanced by these contacts (check friction, force "
                "limits, contact normals and external wrenches)"
            )
        return region

    # -- cascade contract ---------------------------------------------------
    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        region = self._nonempty(self.region(configuration))
        return self._rows(configuration, region, self.distances(configuration, region))

    def _rows(self, configuration: mink.Configuration, region: Region, d: np.ndarray) -> TaskRows:
        J = region.halfplanes.A @ com_jacobian(configuration, self.root_body)[:2]
        return TaskRows.inequality(J, self.margin - d, np.inf, self.w)

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """Per-edge violation ``max(margin − (A c + b), 0)`` [m]."""
        return np.maximum(self.margin - self.distances(configuration), 0.0)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return bool(np.max(self.compute_error(configuration)) <= self.centroid_thre)

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, error norm and stop test from one region and one evaluation of
        the edge distances (the values of :meth:`compute_rows`,
        :meth:`compute_error` and :meth:`is_satisfied`)."""
        region = self._nonempty(self.region(configuration))
        d = self.distances(configuration, region)
        error = np.maximum(self.margin - d, 0.0)
        return TaskState(
            self._rows(configuration, region, d),
            float(np.linalg.norm(error)),
            bool(np.max(error) <= self.centroid_thre),
        )

    def __repr__(self) -> str:
        kinds = [str(f) if f is not None else "fixed" for f, _ in self.contacts]
        external = "callable" if self.external_fn else len(self.external)
        return (
            f"ScfrTask(name={self.name!r}, contacts={kinds}, mass={self.mass:.3f} kg, "
            f"margin={self.margin}, external={external})"
        )
