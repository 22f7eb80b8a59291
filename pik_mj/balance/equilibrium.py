"""Static equilibrium: whether contact wrenches within their limits balance
gravity and external wrenches (an LP, HiGHS)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import linprog

from pik_mj.balance.contacts import ContactConstraint, wrench_constraints
from pik_mj.balance.values import finite_array, real
from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.spatial import STANDARD_GRAVITY, skew

GRAVITY = (0.0, 0.0, -STANDARD_GRAVITY)
"""Gravity vector [m/s²] (world frame, z up) of the functions here, which take no
model; pass ``model.opt.gravity`` when there is one."""


class ExternalWrench(NamedTuple):
    """A wrench applied to the robot by something other than the contacts.

    Attributes:
        p_W: Application point ``(3,)`` [m] (world).
        force: Force ``(3,)`` [N] (world).
        moment: Additional pure moment ``(3,)`` [N·m] (world).
    """

    p_W: ArrayLike
    force: ArrayLike
    moment: ArrayLike = (0.0, 0.0, 0.0)


class EquilibriumResult(NamedTuple):
    """Result of :func:`static_equilibrium`.

    Attributes:
        feasible: Balancing contact wrenches exist.
        wrenches: One wrench per contact ``(n, 6)`` = ``(f, n)`` [N, N·m] (world,
            about ``p_WC``), or None if infeasible.
        message: Solver message.
    """

    feasible: bool
    wrenches: np.ndarray | None
    message: str


def checked_contacts(contacts: Sequence[ContactConstraint]) -> list[ContactConstraint]:
    cs = list(contacts)
    if not cs:
        raise InvalidInput("contacts is empty: give at least one ContactConstraint")
    for i, c in enumerate(cs):
        if not isinstance(c, ContactConstraint):
            raise InvalidInput(f"contacts[{i}] must be a ContactConstraint, got {type(c).__name__}")
    return cs


def external_total(external: Sequence[ExternalWrench]) -> np.ndarray:
    """Sum of the external wrenches about the world origin ``(6,)``."""
    total = np.zeros(6)
    for i, e in enumerate(external):
        if not isinstance(e, ExternalWrench):
            raise InvalidInput(f"external[{i}] must be an ExternalWrench, got {type(e).__name__}")
        p = finite_array(e.p_W, (3,), f"external[{i}].p_W")
        f = finite_array(e.force, (3,), f"external[{i}].force")
        m = finite_array(e.moment, (3,), f"external[{i}].moment")
        total += np.concatenate([f, m + np.cross(p, f)])
    return total


@dataclass
class WrenchLP:
    """Shared rows: ``G w = h`` (equilibrium) and ``C w + d >= 0`` (limits)."""

    G: np.ndarray  # (6, 6n) maps contact wrenches to the total wrench at the origin
    C: np.ndarray  # (r, 6n) block diagonal
    d: np.ndarray  # (r,)
    n: int


def wrench_lp(contacts: list[ContactConstraint]) -> WrenchLP:
    n = len(contacts)
    G = np.zeros((6, 6 * n))
    blocks = [wrench_constraints(c) for c in contacts]
    C = np.zeros((sum(len(b[1]) for b in blocks), 6 * n))
    r = 0
    for i, (c, (Ci, _)) in enumerate(zip(contacts, blocks, strict=True)):
        G[:3, 6 * i : 6 * i + 3] = np.eye(3)
        G[3:, 6 * i : 6 * i + 3] = skew(c.p_WC)
        G[3:, 6 * i + 3 : 6 * i + 6] = np.eye(3)
        C[r : r + len(Ci), 6 * i : 6 * i + 6] = Ci
        r += len(Ci)
    return WrenchLP(G=G, C=C, d=np.concatenate([b[1] for b in blocks]), n=n)


def gravity_vector(gravity: object) -> np.ndarray:
    return finite_array(gravity, (3,), "gravity")


def static_equilibrium(
    contacts: Sequence[ContactConstraint],
    mass: float,
    com: np.ndarray,
    external: Sequence[ExternalWrench] = (),
    gravity: np.ndarray = GRAVITY,
) -> EquilibriumResult:
    """Whether contact wrenches within their limits balance gravity and ``external``.

    Solves the LP feasibility problem (HiGHS)

    .. math::

        \\text{find } w \\;\\text{s.t.}\\; G w + \\begin{bmatrix} m g \\\\
        c \\times m g\\end{bmatrix} + w_{ext} = 0, \\quad C w + d \\ge 0

    Args:
        contacts: The contacts.
        mass: Total mass [kg] (> 0).
        com: Centre of mass ``(3,)`` [m].
        external: External wrenches.
        gravity: Gravity vector ``(3,)`` [m/s²].

    Returns:
        :class:`EquilibriumResult`.
    """
    cs = checked_contacts(contacts)
    m = real(mass, "mass")
    if m <= 0.0:
        raise InvalidInput(f"mass must be > 0 [kg], got {m}")
    c = finite_array(com, (3,), "com")
    g = gravity_vector(gravity)
    lp = wrench_lp(cs)
    w_gravity = np.concatenate([m * g, np.cross(c, m * g)])
    h = -(w_gravity + external_total(external))
    # Wrenches in units of the weight m|g| keep the LP O(1); HiGHS can otherwise
    # end "unknown" (status 4) on nearly-infeasible poses. The default method
    # is tried first, then dual simplex, then interior point.
    scale = m * float(np.linalg.norm(g)) or 1.0
    for method in ("highs", "highs-ds", "highs-ipm"):
        res = linprog(
            c=np.zeros(6 * lp.n),
            A_ub=-lp.C,
            b_ub=lp.d / scale,
            A_eq=lp.G,
            b_eq=h / scale,
            bounds=(None, None),
            method=method,
        )
        if res.status == 0:
            return EquilibriumResult(True, scale * res.x.reshape(lp.n, 6), res.message)
        if res.status == 2:
            return EquilibriumResult(False, None, res.message)
    raise PikError(f"static-equilibrium LP failed (status {res.status}): {res.message}")
