"""Contacts and their wrench limits: a rectangular (or point) contact with
Coulomb friction, and the linear limits ``C w + d >= 0`` on its wrench."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from pik_mj.balance.support import plane_basis
from pik_mj.balance.values import finite_array, real
from pik_mj.exceptions import InvalidInput
from pik_mj.spatial import rot_z

_ROTATION_TOL = 1e-6


@dataclass(frozen=True, eq=False)
class ContactConstraint:
    """A rectangular (or point) contact with Coulomb friction.

    Attributes:
        p_WC: Contact frame origin in the world ``(3,)`` [m] (rectangle centre).
        R_WC: Contact frame rotation ``(3, 3)``; its z-axis is the contact normal
            pointing INTO the robot (the direction the environment pushes).
        half_x: Half-size of the rectangle along the contact x-axis [m] (0: point).
        half_y: Half-size along the contact y-axis [m] (0: point).
        mu: Friction coefficient (>= 0).
        fz_min: Lower bound of the normal force [N] (>= 0).
        fz_max: Upper bound of the normal force [N] (> fz_min, may be inf).
        torsion: Bound the yaw moment by the exact rectangular-contact wrench cone
            (Caron et al. 2015). If False the moment about the normal is free.
        pyramid: ``"inscribed"`` (default, conservative): ``|fx|, |fy| <= mu fz/√2``,
            a pyramid inside the circular cone. ``"circumscribed"``:
            ``|fx|, |fy| <= mu fz``, which contains the cone (allows up to √2·mu
            along the diagonals).
    """

    p_WC: np.ndarray
    R_WC: np.ndarray
    half_x: float = 0.0
    half_y: float = 0.0
    mu: float = 0.5
    fz_min: float = 0.0
    fz_max: float = math.inf
    torsion: bool = True
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed"

    def __post_init__(self) -> None:
        p = finite_array(self.p_WC, (3,), "ContactConstraint.p_WC")
        R = finite_array(self.R_WC, (3, 3), "ContactConstraint.R_WC")
        err = float(np.max(np.abs(R.T @ R - np.eye(3))))
        if err > _ROTATION_TOL or np.linalg.det(R) < 0.0:
            raise InvalidInput(
                f"ContactConstraint.R_WC must be a rotation (orthonormal, det +1); "
                f"|R^T R - I| = {err:.2e}, det = {np.linalg.det(R):.3f}"
            )
        hx = real(self.half_x, "ContactConstraint.half_x")
        hy = real(self.half_y, "ContactConstraint.half_y")
        if hx < 0.0 or hy < 0.0:
            raise InvalidInput(f"half_x, half_y must be >= 0 [m], got {hx}, {hy}")
        mu = real(self.mu, "ContactConstraint.mu")
        if mu < 0.0:
            raise InvalidInput(f"friction coefficient mu must be >= 0, got {mu}")
        lo = real(self.fz_min, "ContactConstraint.fz_min")
        hi = real(self.fz_max, "ContactConstraint.fz_max", allow_inf=True)
        if lo < 0.0:
            raise InvalidInput(f"fz_min must be >= 0 [N], got {lo}")
        if not hi > lo:
            raise InvalidInput(f"fz_max must be > fz_min = {lo} [N], got {hi}")
        if self.pyramid not in ("inscribed", "circumscribed"):
            raise InvalidInput(
                f"pyramid must be 'inscribed' or 'circumscribed', got {self.pyramid!r}"
            )
        for name, val in (
            ("p_WC", p),
            ("R_WC", R),
            ("half_x", hx),
            ("half_y", hy),
            ("mu", mu),
            ("fz_min", lo),
            ("fz_max", hi),
            ("torsion", bool(self.torsion)),
        ):
            if isinstance(val, np.ndarray):
                val.flags.writeable = False
            object.__setattr__(self, name, val)

    @property
    def mu_pyramid(self) -> float:
        """Pyramid coefficient: ``mu/√2`` (inscribed) or ``mu`` (circumscribed)."""
        return self.mu / math.sqrt(2.0) if self.pyramid == "inscribed" else self.mu

    def corners(self) -> np.ndarray:
        """World corners of the contact rectangle ``(4, 3)`` [m], ccw about z_C."""
        s = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], dtype=float)
        local = np.column_stack([s[:, 0] * self.half_x, s[:, 1] * self.half_y, np.zeros(4)])
        return self.p_WC + local @ self.R_WC.T

    def __repr__(self) -> str:
        return (
            f"ContactConstraint(p_WC={np.round(self.p_WC, 4).tolist()}, "
            f"normal={np.round(self.R_WC[:, 2], 4).tolist()}, half_x={self.half_x}, "
            f"half_y={self.half_y}, mu={self.mu}, fz=[{self.fz_min}, {self.fz_max}], "
            f"torsion={self.torsion}, pyramid={self.pyramid!r})"
        )


def foot_contact(
    p_W: np.ndarray,
    yaw: float,
    half_x: float,
    half_y: float,
    mu: float,
    fz_max: float = math.inf,
    *,
    fz_min: float = 0.0,
    torsion: bool = True,
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed",
) -> ContactConstraint:
    """A sole on horizontal ground: normal +z, rectangle yawed by ``yaw`` [rad].

    Args:
        p_W: Sole centre ``(3,)`` [m].
        yaw: Rotation about world z [rad].
        half_x: Half length [m].
        half_y: Half width [m].
        mu: Friction coefficient.
        fz_max: Normal force bound [N].
        fz_min: Minimum normal force [N].
        torsion: See :class:`ContactConstraint`.
        pyramid: See :class:`ContactConstraint`.
    """
    return ContactConstraint(
        p_WC=p_W,
        R_WC=rot_z(real(yaw, "yaw")),
        half_x=half_x,
        half_y=half_y,
        mu=mu,
        fz_min=fz_min,
        fz_max=fz_max,
        torsion=torsion,
        pyramid=pyramid,
    )


def contact_from_normal(
    p_W: np.ndarray,
    normal: np.ndarray,
    half_x: float = 0.0,
    half_y: float = 0.0,
    mu: float = 0.5,
    fz_max: float = math.inf,
    *,
    fz_min: float = 0.0,
    torsion: bool = True,
    pyramid: Literal["inscribed", "circumscribed"] = "inscribed",
) -> ContactConstraint:
    """A contact whose normal (into the robot) is ``normal``.

    The contact x-axis is the world x-axis projected on the contact plane (world y
    when x is nearly parallel to the normal), as in :func:`plane_basis`.

    Args:
        p_W: Contact centre ``(3,)`` [m].
        normal: Direction the environment pushes the robot ``(3,)``.
        half_x: Half-size along the contact x-axis [m].
        half_y: Half-size along the contact y-axis [m].
        mu: Friction coefficient.
        fz_max: Normal force bound [N].
        fz_min: Minimum normal force [N].
        torsion: See :class:`ContactConstraint`.
        pyramid: See :class:`ContactConstraint`.
    """
    return ContactConstraint(
        p_WC=p_W,
        R_WC=plane_basis(normal),
        half_x=half_x,
        half_y=half_y,
        mu=mu,
        fz_min=fz_min,
        fz_max=fz_max,
        torsion=torsion,
        pyramid=pyramid,
    )


def wrench_constraints(contact: ContactConstraint) -> tuple[np.ndarray, np.ndarray]:
    """Linear limits ``C w + d >= 0`` on the world contact wrench ``w = (f, n)``.

    In the contact frame, ``w_C = (f_x, f_y, f_z, n_x, n_y, n_z)`` (moment about
    ``p_WC``), with ``X = half_x``, ``Y = half_y``, ``μ'`` the pyramid coefficient
    (:attr:`ContactConstraint.mu_pyramid`):

    .. math::

        f_{z,min} \\le f_z \\le f_{z,max}, \\quad
        |f_x| \\le \\mu' f_z, \\quad |f_y| \\le \\mu' f_z, \\quad
        |n_x| \\le Y f_z, \\quad |n_y| \\le X f_z,

    and, with ``torsion`` (Caron, Pham, Nakamura 2015, the exact wrench cone of
    four corner forces inside the pyramid),

    .. math::

        -\\mu'(X+Y) f_z + |Y f_x - \\mu' n_x| + |X f_y - \\mu' n_y| \\le n_z
        \\le \\mu'(X+Y) f_z - |Y f_x + \\mu' n_x| - |X f_y + \\mu' n_y|

    (each ``|a| + |b| <= e`` expands to 4 rows). The rows are rotated to the world:
    ``C = C_C \\operatorname{diag}(R_{WC}^T, R_{WC}^T)``.

    Args:
        contact: The contact.

    Returns:
        ``C`` ``(r, 6)`` and ``d`` ``(r,)`` [N].
    """
    if not isinstance(contact, ContactConstraint):
        raise InvalidInput(f"expected a ContactConstraint, got {type(contact).__name__}")
    X, Y, mu = contact.half_x, contact.half_y, contact.mu_pyramid
    rows: list[list[float]] = []
    d: list[float] = []

    def row(
        fx: float = 0.0,
        fy: float = 0.0,
        fz: float = 0.0,
        nx: float = 0.0,
        ny: float = 0.0,
        nz: float = 0.0,
        const: float = 0.0,
    ) -> None:
        rows.append([fx, fy, fz, nx, ny, nz])
        d.append(const)

    row(fz=1.0, const=-contact.fz_min)
    if math.isfinite(contact.fz_max):
        row(fz=-1.0, const=contact.fz_max)
    for s in (1.0, -1.0):
        row(fx=s, fz=mu)
        row(fy=s, fz=mu)
        row(nx=s, fz=Y)
        row(ny=s, fz=X)
    if contact.torsion:
        for s1 in (1.0, -1.0):
            for s2 in (1.0, -1.0):
                # n_z - tau_min >= 0
                row(
                    nz=1.0,
                    fz=mu * (X + Y),
                    fx=-s1 * Y,
                    nx=s1 * mu,
                    fy=-s2 * X,
                    ny=s2 * mu,
                )
                # tau_max - n_z >= 0
                row(
                    nz=-1.0,
                    fz=mu * (X + Y),
                    fx=-s1 * Y,
                    nx=-s1 * mu,
                    fy=-s2 * X,
                    ny=-s2 * mu,
                )
    C_C = np.array(rows)
    R = contact.R_WC
    C = np.hstack([C_C[:, :3] @ R.T, C_C[:, 3:] @ R.T])
    return C, np.array(d)
