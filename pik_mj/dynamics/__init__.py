"""Statics and inverse dynamics (irteus manual: ``:torque-vector``, ``:calc-zmp``,
``:calc-static-balance-point``, ``:calc-force-from-joint-torque``).

Modules: :mod:`~pik_mj.dynamics.inverse` (joint torques of a motion under
external wrenches), :mod:`~pik_mj.dynamics.floating_base` (the base's wrench,
the ZMP), :mod:`~pik_mj.dynamics.distribution` (contact wrenches holding a
static pose), :mod:`~pik_mj.dynamics.statics` (irteus' static formulas, torque
limits).

MuJoCo does the mechanics: ``mj_inverse`` (recursive Newton–Euler, the mass
matrix with armature, passive forces), ``mj_jac*`` (Jacobians),
``mj_differentiatePos`` (finite differences on the configuration manifold).

Sign convention: every wrench passed in or returned here — an external wrench,
a contact wrench, the ground reaction — is the wrench ACTING ON the robot,
expressed in the world frame, ``w = (f, n)`` [N, N·m]. The joint torques that
hold a motion then are

.. math::

    \\tau = M(q)\\,\\ddot q + c(q, \\dot q) - \\tau_{passive}
          - \\sum_k J_k^T w_k

with ``J_k = [J_p; J_ω]`` (6, nv) the world Jacobian of the point where ``w_k``
acts (its moment ``n_k`` taken about that point). ``M q̈ + c − τ_passive`` is
MuJoCo's ``qfrc_inverse`` (computed with the constraint solver disabled, so
contacts of a scene play no part). For a static pose ``q̇ = q̈ = 0`` this is
``τ = g(q) − Σ Jᵀ w``.
"""

from pik_mj.dynamics.distribution import (
    ContactDistribution,
    SoleContact,
    StaticTorques,
    contact_wrenches,
    static_torques,
    wrench_map,
)
from pik_mj.dynamics.floating_base import (
    free_root_body,
    root_wrench,
    zmp_from_inverse_dynamics,
    zmp_from_wrench,
    zmp_of_motion,
    zmp_points,
)
from pik_mj.dynamics.inverse import (
    ExternalSpec,
    external_torques,
    frame_jacobian,
    inverse_dynamics,
    inverse_dynamics_many,
    joint_torques,
)
from pik_mj.dynamics.statics import (
    DEFAULT_MAX_TORQUE,
    force_from_joint_torque,
    static_balance_point,
    torque_limits,
    torque_ratio,
)

__all__ = [
    "DEFAULT_MAX_TORQUE",
    "ContactDistribution",
    "ExternalSpec",
    "SoleContact",
    "StaticTorques",
    "contact_wrenches",
    "external_torques",
    "force_from_joint_torque",
    "frame_jacobian",
    "free_root_body",
    "inverse_dynamics",
    "inverse_dynamics_many",
    "joint_torques",
    "root_wrench",
    "static_balance_point",
    "static_torques",
    "torque_limits",
    "torque_ratio",
    "wrench_map",
    "zmp_from_inverse_dynamics",
    "zmp_from_wrench",
    "zmp_of_motion",
    "zmp_points",
]
