"""Static-balance geometry: support polygon, contact wrench limits, equilibrium, SCFR
(prioritized-IK manual: ``centroid-support-polygon-task``, ``centroid-scfr-task``;
docs/balance.md).

Everything here is pure numpy/scipy (LPs are solved with ``scipy.optimize.linprog``,
HiGHS). One module per part:

* :mod:`~pik_mj.balance.polygon`: planar polygons and half-planes;
* :mod:`~pik_mj.balance.support`: the support polygon;
* :mod:`~pik_mj.balance.contacts`: contacts and their wrench limits;
* :mod:`~pik_mj.balance.equilibrium`: static equilibrium (an LP);
* :mod:`~pik_mj.balance.projection`: the static centroid feasible region (SCFR).

Conventions:

* A planar region is a :class:`HalfPlanes` ``(A, b)`` meaning
  ``{c : A c + b >= 0}`` with unit-norm rows of ``A``, so ``A c + b`` is the signed
  distance [m] of ``c`` to each edge line (positive inside).
* Polygons are vertex arrays ``(m, 2)`` ordered counter-clockwise.
* The robot receives the contact wrench ``w_i = (f_i, n_i)`` [N, N·m], expressed in
  the world frame, the moment taken about the contact frame origin ``p_WC``.
* Static equilibrium about the world origin (``g`` = gravity vector [m/s²]):

  .. math::

      \\sum_i \\begin{bmatrix} f_i \\\\ n_i + p_i \\times f_i \\end{bmatrix}
      + \\begin{bmatrix} m g \\\\ c \\times m g \\end{bmatrix}
      + \\sum_k \\begin{bmatrix} f_k \\\\ \\tau_k + p_k \\times f_k \\end{bmatrix} = 0
"""

from pik_mj.balance.contacts import (
    ContactConstraint,
    contact_from_normal,
    foot_contact,
    wrench_constraints,
)
from pik_mj.balance.equilibrium import (
    GRAVITY,
    EquilibriumResult,
    ExternalWrench,
    static_equilibrium,
)
from pik_mj.balance.polygon import (
    HalfPlanes,
    convex_hull_2d,
    halfplanes_from_polygon,
    hull_region,
    inset_vertices,
    polygon_area,
    polygon_from_halfplanes,
    shrink,
    signed_distance,
)
from pik_mj.balance.projection import Region, scfr
from pik_mj.balance.support import SupportRegion, plane_basis, support_polygon

__all__ = [
    "GRAVITY",
    "ContactConstraint",
    "EquilibriumResult",
    "ExternalWrench",
    "HalfPlanes",
    "Region",
    "SupportRegion",
    "contact_from_normal",
    "convex_hull_2d",
    "foot_contact",
    "halfplanes_from_polygon",
    "hull_region",
    "inset_vertices",
    "plane_basis",
    "polygon_area",
    "polygon_from_halfplanes",
    "scfr",
    "shrink",
    "signed_distance",
    "static_equilibrium",
    "support_polygon",
    "wrench_constraints",
]
