"""Joint position limits (prioritized-IK manual: ``minmax-angle-task``).

For a hinge or slide joint with limits ``θ_min``, ``θ_max`` and current value
``θ`` [rad or m], one inequality row on its degree of freedom:

.. math::

    \\theta_{min} - \\theta \\le x + \\omega \\le \\theta_{max} - \\theta

For a ball joint (irteus manual: ``sphere-joint``; MuJoCo's ``range="0 θ_max"``) the
rotation angle is limited: with ``r = log(q)`` the rotation vector of the joint's
quaternion (``θ = ‖r‖ ∈ [0, π]``), one linearized cone row

.. math::

    \\theta + \\hat r^T x + \\omega \\le \\theta_{max}, \\qquad \\hat r = r / \\|r\\|

on the joint's three (body-frame angular velocity) degrees of freedom. It is exact
to first order because MuJoCo integrates a ball joint as ``q ⊕ x = q ⊗ exp(x)``,
so ``ṙ = J_r^{-1}(r) x`` and ``r^T J_r^{-1}(r) = r^T``. At ``θ < 1e-9`` rad the
row is zero (the cone's apex: any direction is allowed, the next iteration
re-linearizes). Free joints are rejected. Units are SI (m, rad); unlike
:class:`mink.ConfigurationLimit` there is no gain (the prioritized-IK manual's
form) and :meth:`JointLimitTask.violations` reports each joint's violation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.tasks.task import Task, TaskRows, TaskState, diagonal_weights

JOINT_TYPES = {
    int(mujoco.mjtJoint.mjJNT_FREE): "free",
    int(mujoco.mjtJoint.mjJNT_BALL): "ball",
    int(mujoco.mjtJoint.mjJNT_SLIDE): "slide",
    int(mujoco.mjtJoint.mjJNT_HINGE): "hinge",
}
_NDOF = {"free": 6, "ball": 3, "slide": 1, "hinge": 1}

DEFAULT_CHECK_MARGIN = 1e-5
"""Stop-test tolerance of hinge/slide limits [rad or m] (prioritized-IK manual:
``check-margin``)."""

BALL_CHECK_MARGIN = 1e-3
"""Stop-test tolerance of ball-joint limits [rad] (irteus manual: ``sphere`` joints)."""


@dataclass(frozen=True)
class JointRef:
    """A joint of a model with its addresses in ``qpos`` and in the tangent space.

    Attributes:
        name: MJCF name.
        id: Joint id.
        kind: ``"hinge"``, ``"slide"``, ``"ball"`` or ``"free"``.
        qposadr: First index in ``qpos``.
        dofadr: First index in the tangent space (``qvel``, ``x``).
        ndof: Number of degrees of freedom (1, 3 or 6).
    """

    name: str
    id: int
    kind: str
    qposadr: int
    dofadr: int
    ndof: int

    @property
    def dofs(self) -> np.ndarray:
        """Tangent-space indices of the joint, shape (ndof,)."""
        return np.arange(self.dofadr, self.dofadr + self.ndof)


def joint_names(model: mujoco.MjModel) -> list[str]:
    """Names of all named joints of ``model``."""
    names = (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt))
    return [n for n in names if n]


def find_joint(
    model: mujoco.MjModel,
    name: str,
    kinds: Sequence[str] = ("hinge", "slide", "ball", "free"),
    what: str = "joint",
) -> JointRef:
    """The joint called ``name``.

    Raises:
        UnknownName: No such joint (the message lists the valid names).
        InvalidInput: ``name`` is not a string, or the joint's type is not in ``kinds``.
    """
    if not isinstance(name, str):
        raise InvalidInput(f"{what} must be a joint name (str), got {type(name).__name__}")
    j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
    if j < 0:
        raise UnknownName("joint", name, joint_names(model))
    kind = JOINT_TYPES[int(model.jnt_type[j])]
    if kind not in kinds:
        raise InvalidInput(f"{what} {name!r} is a {kind} joint; this task accepts {list(kinds)}")
    return JointRef(name, j, kind, int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), _NDOF[kind])


def joint_list(
    model: mujoco.MjModel, joints: str | Sequence[str], kinds: Sequence[str], what: str
) -> list[JointRef]:
    """Resolve one name or a sequence of distinct names."""
    names = [joints] if isinstance(joints, str) else list(joints)
    if not names:
        raise InvalidInput(f"{what}: give at least one joint name")
    refs = [find_joint(model, n, kinds, what) for n in names]
    if len({r.id for r in refs}) != len(refs):
        raise InvalidInput(f"{what}: a joint is listed twice in {names}")
    return refs


def ball_angle(quat: np.ndarray) -> tuple[float, np.ndarray]:
    """Rotation angle ``θ = ‖log(q)‖ ∈ [0, π]`` [rad] and axis of a quaternion (w, x, y, z).

    .. math::

        \\theta = 2\\,\\operatorname{atan2}(\\|v\\|, |w|), \\qquad
        \\hat r = \\operatorname{sign}(w)\\, v / \\|v\\|
    """
    q = np.asarray(quat, dtype=float)
    q = q / np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    s = float(np.linalg.norm(q[1:]))
    if s < 1e-12:
        return 0.0, np.zeros(3)
    return 2.0 * float(np.arctan2(s, q[0])), q[1:] / s


def per_entry(value, n: int, what: str, entry: str = "joint") -> np.ndarray:
    """``value`` (a float, or one per ``entry``) as ``n`` floats without NaN, or raise."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise InvalidInput(
            f"{what} must be a float or one value per {entry} ({n}), got shape {arr.shape}"
        )
    if np.any(np.isnan(arr)):
        raise InvalidInput(f"{what} contains NaN: {arr}")
    return arr


def _per_joint(value, n: int, what: str) -> np.ndarray | None:
    return None if value is None else per_entry(value, n, what)


class JointLimitTask(Task):
    """Joint position limits as inequality rows (prioritized-IK manual: ``minmax-angle-task``).

    Args:
        configuration: Robot configuration (for name lookup and model limits).
        joints: A joint name or names (hinge, slide, ball). None: every joint the
            model limits (``jnt_limited``) except free joints (no rows when the
            model limits none).
        min_angle: Lower limits [rad or m]: a float for all joints or one per
            joint (``-inf`` allowed); None reads the model's ``jnt_range``, or
            ``-inf`` for a joint without a range (``limited="false"``: unbounded).
            Ball joints take 0 (or None): their limit is the cone angle ``max_angle``.
        max_angle: Upper limits [rad or m] (``inf`` allowed); for ball joints the
            largest rotation angle [rad] (> 0). None reads ``jnt_range``, or
            ``inf`` for a joint without a range.
        w: Slack weight(s), float or one per row.
        check: Whether the solve loop's stop test looks at this task.
        check_margin: Violation tolerated by the stop test [rad or m]; default
            1e-5 for hinge/slide and 1e-3 for ball joints.
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        joints: str | Sequence[str] | None = None,
        *,
        min_angle: float | Sequence[float] | None = None,
        max_angle: float | Sequence[float] | None = None,
        w: float | Sequence[float] = 1.0,
        check: bool = True,
        check_margin: float | None = None,
        name: str | None = None,
    ):
        model = configuration.model
        kinds = ("hinge", "slide", "ball")
        if joints is None:
            ids = [
                j
                for j in range(model.njnt)
                if model.jnt_limited[j] and JOINT_TYPES[int(model.jnt_type[j])] in kinds
            ]
            names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in ids]
            if any(not n for n in names):
                raise InvalidInput("every limited joint needs a name to build a JointLimitTask")
            # A model without any range (every joint unbounded) gets a task without rows.
            self.joints = joint_list(model, names, kinds, "JointLimitTask joint") if ids else []
        else:
            self.joints = joint_list(model, joints, kinds, "JointLimitTask joint")
        n = len(self.joints)
        lo = _per_joint(min_angle, n, "min_angle")
        hi = _per_joint(max_angle, n, "max_angle")
        self.min_angle = np.zeros(n)
        self.max_angle = np.zeros(n)
        for i, jr in enumerate(self.joints):
            # A joint without a range (limited=false) is unbounded where no value is given.
            bounded = bool(model.jnt_limited[jr.id])
            m_lo = (model.jnt_range[jr.id, 0] if bounded else -np.inf) if lo is None else lo[i]
            m_hi = (model.jnt_range[jr.id, 1] if bounded else np.inf) if hi is None else hi[i]
            if jr.kind == "ball" and m_lo == -np.inf and m_hi == np.inf:
                m_lo = 0.0  # an unbounded cone
            elif jr.kind == "ball":
                if m_lo != 0.0:
                    raise InvalidInput(
                        f"ball joint {jr.name!r}: min_angle must be 0 (the limit is the "
                        f"cone angle max_angle), got {m_lo}"
                    )
                if not (np.isfinite(m_hi) and 0.0 < m_hi):
                    raise InvalidInput(
                        f"ball joint {jr.name!r}: max_angle must be a finite angle > 0 [rad], "
                        f"got {m_hi}"
                    )
            if not m_lo <= m_hi:
                raise InvalidInput(
                    f"joint {jr.name!r}: inverted limits, min_angle {m_lo} > max_angle {m_hi}"
                )
            self.min_angle[i], self.max_angle[i] = m_lo, m_hi
        self.w = diagonal_weights(w, n, "w")
        if np.any(self.w <= 0):
            raise InvalidInput(f"slack weights w must be > 0, got {self.w}")
        if check_margin is None:
            self.check_margin = np.array(
                [
                    BALL_CHECK_MARGIN if j.kind == "ball" else DEFAULT_CHECK_MARGIN
                    for j in self.joints
                ]
            )
        else:
            if not (np.isfinite(check_margin) and check_margin >= 0):
                raise InvalidInput(f"check_margin must be finite and >= 0, got {check_margin}")
            self.check_margin = np.full(n, float(check_margin))
        self.check = check
        self.name = name or (f"limits:{self.joints[0].name}" if n == 1 else f"limits:{n} joints")

    @classmethod
    def all_limited(cls, configuration: mink.Configuration, **kwargs) -> JointLimitTask:
        """One task for every limited hinge, slide and ball joint of the model."""
        return cls(configuration, None, **kwargs)

    # -- values -------------------------------------------------------------
    def _values_and_rows(self, configuration: mink.Configuration):
        q = configuration.q
        nv = configuration.model.nv
        values = np.zeros(len(self.joints))
        C = np.zeros((len(self.joints), nv))
        for i, jr in enumerate(self.joints):
            if jr.kind == "ball":
                theta, axis = ball_angle(q[jr.qposadr : jr.qposadr + 4])
                values[i] = theta
                if theta >= 1e-9:
                    C[i, jr.dofadr : jr.dofadr + 3] = axis
            else:
                values[i] = q[jr.qposadr]
                C[i, jr.dofadr] = 1.0
        return values, C

    def values(self, configuration: mink.Configuration) -> np.ndarray:
        """Limited quantity of each joint: angle/position, or a ball's rotation angle."""
        return self._values_and_rows(configuration)[0]

    def violations(self, configuration: mink.Configuration) -> dict[str, float]:
        """Violation of each joint's limits [rad or m] (0 when within)."""
        e = self.compute_error(configuration)
        return {jr.name: float(v) for jr, v in zip(self.joints, e, strict=True)}

    # -- cascade contract ---------------------------------------------------
    def compute_rows(self, configuration: mink.Configuration) -> TaskRows:
        return self._rows(*self._values_and_rows(configuration))

    def _rows(self, values: np.ndarray, C: np.ndarray) -> TaskRows:
        ball = np.array([jr.kind == "ball" for jr in self.joints])
        lower = np.where(ball, -np.inf, self.min_angle - values)
        return TaskRows.inequality(C, lower, self.max_angle - values, self.w)

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """Per-joint violation ``max(θ_min - θ, 0) + max(θ - θ_max, 0)`` [rad or m]."""
        return self._error(self.values(configuration))

    def _error(self, v: np.ndarray) -> np.ndarray:
        return np.maximum(self.min_angle - v, 0.0) + np.maximum(v - self.max_angle, 0.0)

    def is_satisfied(self, configuration: mink.Configuration) -> bool:
        return bool(np.all(self.compute_error(configuration) <= self.check_margin))

    def evaluate(self, configuration: mink.Configuration) -> TaskState:
        """Rows, error norm and stop test from one reading of the joints (the
        values of :meth:`compute_rows`, :meth:`compute_error` and
        :meth:`is_satisfied`)."""
        values, C = self._values_and_rows(configuration)
        error = self._error(values)
        return TaskState(
            self._rows(values, C),
            float(np.linalg.norm(error)),
            bool(np.all(error <= self.check_margin)),
        )

    def __repr__(self) -> str:
        shown = [j.name for j in self.joints[:4]] + (["..."] if len(self.joints) > 4 else [])
        return (
            f"JointLimitTask(name={self.name!r}, joints={shown}, n={len(self.joints)}, "
            f"check={self.check})"
        )
