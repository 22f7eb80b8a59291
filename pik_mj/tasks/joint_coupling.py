"""Two joint angles kept equal (prioritized-IK manual: ``joint-angle-task``).

With ``θ_1``, ``θ_2`` the joints' values [rad or m] (either may be a constant
value instead of a joint), the error and its equality rows are

.. math::

    e = \\theta_2 - (r\\,\\theta_1 + o), \\qquad
    x_{j2} - r\\, x_{j1} = -e

with ratio ``r = 1`` and offset ``o = 0`` by default (the prioritized-IK manual's:
``x_j2 − x_j1 = −(θ_2 − θ_1)``). ``r`` and ``o`` express irteus' interlocking
joints ``θ_2 = r θ_1 + o``.
"""

from __future__ import annotations

import mink
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.tasks.joint_limit import DEFAULT_CHECK_MARGIN, JointRef, find_joint
from pik_mj.tasks.task import EqualityTask, diagonal_weights

JointOrValue = str | float


class JointCouplingTask(EqualityTask):
    """Make ``joint2`` follow ``ratio · joint1 + offset`` (prioritized-IK manual:
    ``joint-angle-task``).

    Args:
        configuration: Robot configuration (for name lookup).
        joint1: A hinge/slide joint name, or a constant value [rad or m].
        joint2: A hinge/slide joint name, or a constant value [rad or m].
        ratio: ``r`` of ``θ_2 = r θ_1 + o`` (finite).
        offset: ``o`` [rad or m] (finite).
        w: Weight [cost/rad²].
        check: Whether the solve loop's stop test looks at this task.
        check_margin: ``|e|`` tolerated by the stop test [rad or m].
        name: Display name.
    """

    def __init__(
        self,
        configuration: mink.Configuration,
        joint1: JointOrValue,
        joint2: JointOrValue,
        *,
        ratio: float = 1.0,
        offset: float = 0.0,
        w: float = 1.0,
        check: bool = True,
        check_margin: float = DEFAULT_CHECK_MARGIN,
        name: str | None = None,
    ):
        model = configuration.model
        self.joint1, self.value1 = self._side(model, joint1, "joint1")
        self.joint2, self.value2 = self._side(model, joint2, "joint2")
        if self.joint1 is None and self.joint2 is None:
            raise InvalidInput("joint1 and joint2 are both values; at least one must be a joint")
        for label, v in (("ratio", ratio), ("offset", offset)):
            if not np.isfinite(v):
                raise InvalidInput(f"{label} must be finite, got {v}")
        self.ratio, self.offset = float(ratio), float(offset)
        if self.joint1 is not None and self.joint2 is not None:
            if self.joint1.id == self.joint2.id and self.ratio == 1.0:
                raise InvalidInput(
                    f"joint1 and joint2 are the same joint {self.joint1.name!r} with ratio 1: "
                    "the task has no effect"
                )
        self.w = diagonal_weights(w, 1, "w")
        self.k, self.weights = 1, self.w
        if not (np.isfinite(check_margin) and check_margin >= 0):
            raise InvalidInput(f"check_margin must be finite and >= 0, got {check_margin}")
        self.check_margin = float(check_margin)
        self.check = check
        label = [
            j.name if j is not None else f"{v:g}"
            for j, v in ((self.joint1, self.value1), (self.joint2, self.value2))
        ]
        self.name = name or f"coupling:{label[1]}={label[0]}"

    @staticmethod
    def _side(model, value: JointOrValue, what: str) -> tuple[JointRef | None, float]:
        if isinstance(value, str):
            return find_joint(model, value, ("hinge", "slide"), what), 0.0
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise InvalidInput(
                f"{what} must be a hinge/slide joint name or a number, got {value!r}"
            ) from None
        if not np.isfinite(v):
            raise InvalidInput(f"{what} value must be finite, got {v}")
        return None, v

    def _theta(self, configuration: mink.Configuration, joint: JointRef | None, v: float) -> float:
        return v if joint is None else float(configuration.q[joint.qposadr])

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        """``[θ_2 − (r θ_1 + o)]`` [rad or m]."""
        t1 = self._theta(configuration, self.joint1, self.value1)
        t2 = self._theta(configuration, self.joint2, self.value2)
        return np.array([t2 - (self.ratio * t1 + self.offset)])

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        """``d e / d q``, shape (1, nv)."""
        J = np.zeros((1, configuration.model.nv))
        if self.joint2 is not None:
            J[0, self.joint2.dofadr] += 1.0
        if self.joint1 is not None:
            J[0, self.joint1.dofadr] -= self.ratio
        return J

    def satisfied_by(self, e: np.ndarray) -> bool:
        return bool(abs(e[0]) <= self.check_margin)

    def __repr__(self) -> str:
        j1 = self.joint1.name if self.joint1 is not None else self.value1
        j2 = self.joint2.name if self.joint2 is not None else self.value2
        return (
            f"JointCouplingTask(name={self.name!r}, joint1={j1!r}, joint2={j2!r}, "
            f"ratio={self.ratio}, offset={self.offset})"
        )
