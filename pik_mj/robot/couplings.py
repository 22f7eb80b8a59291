"""Couplings a model declares in MJCF, as hard equality rows of the IK (level 0).

MuJoCo's ``<equality joint>`` and ``<equality tendon>`` (fixed tendons) keep one
coordinate a quartic polynomial of another. With ``y`` the first coordinate (a
joint position or a fixed tendon's length ``L = Σ_i a_i q_i``), ``x`` the second
(zero when there is none) and ``y_0``, ``x_0`` their values at ``qpos0``:

.. math::

    e = (y - y_0) - \\sum_{k=0}^{4} c_k (x - x_0)^k, \\qquad
    \\frac{\\partial e}{\\partial q}
        = J_y - \\Big(\\sum_{k=1}^{4} k\\, c_k (x - x_0)^{k-1}\\Big) J_x

and :class:`CouplingTask` gives the equality rows ``J x = -e``: at level 0 they
hold in every level's QP, so a solve keeps the coupling (to first order each
step, exactly once the step is small). ``e`` is MuJoCo's own constraint
violation (``efc_pos`` of the equality row; tested). Equalities of other kinds
(``connect``, ``weld``, ``distance``, ``flex``, tendons that are not fixed,
joints that are not hinges or slides) are listed in
:attr:`Couplings.unsupported`, never dropped silently.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.tasks.task import Task, TaskRows

DEFAULT_CHECK_MARGIN = 1e-6
"""``|e|`` [rad or m] the solve loop's stop test tolerates (a first-order QP
solver meets equality rows to ~1e-6; an exact one such as DAQP to ~1e-12)."""

_ANGLE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@dataclass(frozen=True)
class LinearCoordinate:
    """A coordinate linear in ``qpos``: ``y = Σ_i a_i q[qposadr_i]`` (a joint, a fixed tendon).

    Attributes:
        label: What it is, e.g. ``"joint 'knee'"``.
        qposadr: Indices into ``qpos`` (k,).
        dofadr: The matching tangent-space indices (k,).
        coef: The coefficients ``a_i`` (k,).
        reference: Its value at ``qpos0`` (MuJoCo's reference of the equality).
    """

    label: str
    qposadr: np.ndarray
    dofadr: np.ndarray
    coef: np.ndarray
    reference: float

    def value(self, q: np.ndarray) -> float:
        return float(self.coef @ q[self.qposadr])

    def jacobian(self, nv: int) -> np.ndarray:
        J = np.zeros(nv)
        np.add.at(J, self.dofadr, self.coef)
        return J


@dataclass(frozen=True)
class Coupling:
    """``y - y_0 = Σ_k c_k (x - x_0)^k`` (module docstring), one MJCF equality.

    Attributes:
        name: The equality's name, or ``equality #i``.
        y: The constrained coordinate.
        x: The coordinate it follows, or None (``y - y_0 = c_0``).
        polycoef: ``c_0 .. c_4``.
    """

    name: str
    y: LinearCoordinate
    x: LinearCoordinate | None
    polycoef: np.ndarray

    def error_and_jacobian(self, q: np.ndarray, nv: int) -> tuple[float, np.ndarray]:
        """``e`` [rad or m] and ``∂e/∂q`` (nv,) at configuration ``q``."""
        c = self.polycoef
        dx = 0.0 if self.x is None else self.x.value(q) - self.x.reference
        poly = sum(c[k] * dx**k for k in range(5))
        error = self.y.value(q) - self.y.reference - poly
        J = self.y.jacobian(nv)
        if self.x is not None:
            slope = sum(k * c[k] * dx ** (k - 1) for k in range(1, 5))
            J = J - slope * self.x.jacobian(nv)
        return float(error), J


@dataclass(frozen=True)
class Couplings:
    """The model's equalities: the couplings the IK keeps, and the others, reported.

    Attributes:
        couplings: Active joint and fixed-tendon equalities.
        unsupported: One line per equality that gives no IK rows (kind, what it
            ties, why), inactive ones included.
    """

    couplings: tuple[Coupling, ...]
    unsupported: tuple[str, ...]


def _joint(model: mujoco.MjModel, j: int) -> LinearCoordinate | str:
    name = model.joint(j).name or f"#{j}"
    if int(model.jnt_type[j]) not in _ANGLE:
        kind = mujoco.mjtJoint(model.jnt_type[j]).name
        return f"joint {name!r} is a {kind} joint, not a hinge or slide"
    adr = int(model.jnt_qposadr[j])
    return LinearCoordinate(
        f"joint {name!r}",
        np.array([adr]),
        np.array([int(model.jnt_dofadr[j])]),
        np.ones(1),
        float(model.qpos0[adr]),
    )


def _tendon(model: mujoco.MjModel, t: int) -> LinearCoordinate | str:
    name = model.tendon(t).name or f"#{t}"
    wraps = range(model.tendon_adr[t], model.tendon_adr[t] + model.tendon_num[t])
    if any(model.wrap_type[w] != mujoco.mjtWrap.mjWRAP_JOINT for w in wraps):
        return f"tendon {name!r} is spatial, not fixed"
    joints = [int(model.wrap_objid[w]) for w in wraps]
    if any(int(model.jnt_type[j]) not in _ANGLE for j in joints):
        return f"tendon {name!r} runs over a ball or free joint"
    return LinearCoordinate(
        f"tendon {name!r}",
        model.jnt_qposadr[joints].astype(int),
        model.jnt_dofadr[joints].astype(int),
        np.array([model.wrap_prm[w] for w in wraps], dtype=float),
        float(model.tendon_length0[t]),
    )


def find_couplings(model: mujoco.MjModel) -> Couplings:
    """Read the model's ``<equality>`` elements (module docstring)."""
    kinds = mujoco.mjtEq
    couplings: list[Coupling] = []
    unsupported: list[str] = []
    for i in range(model.neq):
        name = model.eq(i).name or f"equality #{i}"
        kind = int(model.eq_type[i])
        label = f"{name!r} ({kinds(kind).name.removeprefix('mjEQ_').lower()})"
        if kind not in (kinds.mjEQ_JOINT, kinds.mjEQ_TENDON):
            unsupported.append(f"{label}: only joint and fixed-tendon equalities give IK rows")
            continue
        if not model.eq_active0[i]:
            unsupported.append(f"{label}: inactive in the model (active=false)")
            continue
        side = _joint if kind == kinds.mjEQ_JOINT else _tendon
        y = side(model, int(model.eq_obj1id[i]))
        x = None if model.eq_obj2id[i] < 0 else side(model, int(model.eq_obj2id[i]))
        problems = [s for s in (y, x) if isinstance(s, str)]
        if problems:
            unsupported.append(f"{label}: {'; '.join(problems)}")
            continue
        couplings.append(Coupling(name, y, x, model.eq_data[i, :5].astype(float).copy()))
    return Couplings(tuple(couplings), tuple(unsupported))


class CouplingTask(Task):
    """The couplings as equality rows ``J x = -e`` (put it at level 0: hard).

    Args:
        configuration: Robot configuration.
        couplings: The couplings; None: every one :func:`find_couplings` reads.
        w: Weight [cost/rad²] (matters only below level 0).
        check_margin: ``|e|`` the stop test tolerates [rad or m].
        name: Display name.

    Raises:
        InvalidInput: No coupling to keep, or a bad weight/margin.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        couplings: Sequence[Coupling] | None = None,
        *,
        w: float = 1.0,
        check_margin: float = DEFAULT_CHECK_MARGIN,
        name: str = "mjcf_couplings",
    ):
        found = find_couplings(configuration.model)
        self.couplings = tuple(found.couplings if couplings is None else couplings)
        if not self.couplings:
            raise InvalidInput(
                "the model declares no joint or fixed-tendon equality to keep"
                + (f"; not supported: {list(found.unsupported)}" if found.unsupported else "")
            )
        if not (np.isfinite(w) and w > 0):
            raise InvalidInput(f"w must be finite and > 0, got {w}")
        if not (np.isfinite(check_margin) and check_margin >= 0):
            raise InvalidInput(f"check_margin must be finite and >= 0, got {check_margin}")
        self.w, self.check_margin = float(w), float(check_margin)
        self.check = True
        self.name = name

    def _rows(self, configuration: mink.Configuration) -> tuple[np.ndarray, np.ndarray]:
        nv = configuration.model.nv
        pairs = [c.error_and_jacobian(configuration.q, nv) for c in self.couplings]
        return np.array([e for e, _ in pairs]), np.array([J for _, J in pairs])

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """``e`` of each coupling [rad or m]."""
        return self._rows(configuration)[0]

    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        e, J = self._rows(configuration)
        return TaskRows.equality(J, -e, self.w)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return bool(np.all(np.abs(self.compute_error(configuration)) <= self.check_margin))

    def __repr__(self) -> str:
        return f"CouplingTask(name={self.name!r}, couplings={[c.name for c in self.couplings]})"
