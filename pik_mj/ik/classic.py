"""irteus' classic inverse kinematics, for comparison with the cascade (irteus manual).

One iteration of irteus ``:inverse-kinematics`` (``:move-joints``) with the
frame tasks' Jacobian ``J`` and requested motion ``ẋ`` (each task's clamped
``-e``):

.. math::

    \\dot\\theta = J^{*}_W \\dot x + (I - J^{*}_W J)\\, z, \\qquad
    J^{*}_W = W^{-1} J^T (J W^{-1} J^T + k I)^{-1}

* SR-inverse (Nakamura & Hanafusa): ``k`` grows as the manipulability
  ``κ = \\sqrt{\\det(J W^{-1} J^T)}`` falls below ``κ_0`` (irteus
  ``manipulability-limit`` 0.1, ``manipulability-gain`` 0.001):
  ``k = k_0 (1 − κ/κ_0)²`` if ``κ < κ_0`` else 0.
* Weighted least norm for joint-limit avoidance (Chan & Dubey 1995):
  ``W = diag(w_i)``, ``w_i = 1 + |∂H/∂θ_i|`` while ``|∂H/∂θ_i|`` grows, else 1,
  with the performance criterion

  .. math::

      H(\\theta) = \\sum_i \\frac{(\\theta_{i,max} - \\theta_{i,min})^2}
                 {4 (\\theta_{i,max} - \\theta_i)(\\theta_i - \\theta_{i,min})},
      \\quad
      \\frac{\\partial H}{\\partial \\theta_i} =
      \\frac{(\\theta_{i,max} - \\theta_{i,min})^2 (2\\theta_i - \\theta_{i,max}
      - \\theta_{i,min})}{4 (\\theta_{i,max} - \\theta_i)^2 (\\theta_i - \\theta_{i,min})^2}

* null-space joint-limit avoidance (irteus ``avoid-nspace-gain``): ``z`` pulls each
  joint towards the middle of its range, scaled by the inverse weight,
  ``z_i = −g_n w_i^{-1} \\operatorname{sign}(r_i) r_i^2``,
  ``r_i = (θ_i − θ_{i,mid}) / (θ_{i,max} − θ_{i,mid})``: the weighted
  negative gradient of ``V = g_n Σ_i h_i |r_i|³ / 3`` (``h_i`` the half range).

After the step the joints are clamped to their ranges (irteus ``:joint-angle``).
Interlocking joint pairs (irteus ``:interlocking-joint-pairs``) add rows
``θ̇_a − θ̇_b = −(θ_a − θ_b)`` to ``J`` and ``ẋ``: the pair moves together and an
initial mismatch is removed (irteus ``:calc-jacobian-for-interlocking-joints``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.callbacks import Callback, as_callbacks
from pik_mj.checks import check_configuration
from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.solve import IterationInfo, SolveResult, evaluate_levels, revert_unless_converged
from pik_mj.tasks.frame import ONE_DEGREE, FrameTask

METHODS = ("sr-inverse", "pseudo-inverse")

_ANGLE_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def manipulability(J: np.ndarray, winv: np.ndarray | None = None) -> float:
    """Yoshikawa's manipulability ``κ = \\sqrt{\\det(J W^{-1} J^T)}``.

    Args:
        J: Jacobian (m, n).
        winv: Diagonal of ``W⁻¹`` (n,), ones if None.
    """
    JW = J if winv is None else J * winv
    return float(np.sqrt(max(np.linalg.det(JW @ J.T), 0.0)))


def sr_damping(kappa: float, limit: float = 0.1, gain: float = 0.001) -> float:
    """SR-inverse damping ``k = k_0 (1 − κ/κ_0)²`` below the limit ``κ_0``, else 0."""
    return gain * (1.0 - kappa / limit) ** 2 if kappa < limit else 0.0


def sr_inverse(J: np.ndarray, k: float, winv: np.ndarray | None = None) -> np.ndarray:
    """``J^*_W = W^{-1} J^T (J W^{-1} J^T + k I)^{-1}`` (n, m); ``k = 0`` is the
    weighted pseudo-inverse (least squares if ``J W⁻¹ Jᵀ`` is singular)."""
    WJt = J.T if winv is None else winv[:, None] * J.T
    G = J @ WJt + k * np.eye(J.shape[0])
    if k > 0:
        return WJt @ np.linalg.solve(G, np.eye(J.shape[0]))
    return WJt @ np.linalg.pinv(G)


def joint_limit_gradient(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """``∂H/∂θ_i`` of Chan & Dubey's criterion; 0 for unlimited joints.

    A joint at (or beyond) a limit is evaluated ``10⁻⁶`` of its range inside,
    so the gradient stays finite (large).
    """
    grad = np.zeros_like(q)
    lim = np.isfinite(lower) & np.isfinite(upper)
    lo, hi = lower[lim], upper[lim]
    eps = 1e-6 * (hi - lo)
    th = np.clip(q[lim], lo + eps, hi - eps)
    grad[lim] = (hi - lo) ** 2 * (2 * th - hi - lo) / (4 * (hi - th) ** 2 * (th - lo) ** 2)
    return grad


def joint_limit_weights(
    grad: np.ndarray, previous: np.ndarray | None, gain: float = 1.0
) -> np.ndarray:
    """Chan & Dubey weights ``w_i = 1 + g |∂H/∂θ_i|`` while ``|∂H/∂θ_i|`` grows, else 1.

    "Grows" is strict, so a joint held at a limit (by the clamp) is unweighted
    and free to leave it; on the first iteration (``previous`` None) every joint
    is weighted.
    """
    mag = np.abs(grad)
    growing = np.ones_like(mag, dtype=bool) if previous is None else mag > np.abs(previous)
    return np.where(growing, 1.0 + gain * mag, 1.0)


def joint_limit_nspace(
    q: np.ndarray, lower: np.ndarray, upper: np.ndarray, gain: float = 0.01
) -> np.ndarray:
    """Null-space velocity towards the middle of each range (irteus ``avoid-nspace-gain``)."""
    z = np.zeros_like(q)
    lim = np.isfinite(lower) & np.isfinite(upper)
    mid = 0.5 * (lower[lim] + upper[lim])
    r = (q[lim] - mid) / (upper[lim] - mid)
    z[lim] = -gain * np.sign(r) * r**2
    return z


def _dofs(model: mujoco.MjModel, joints: Sequence[str] | None):
    """Dof indices, lower/upper limits and qpos addresses of the moved joints."""
    if joints is None:
        ids = list(range(model.njnt))
    else:
        if isinstance(joints, str):
            raise InvalidInput(f"joints must be a list of joint names, got {joints!r}")
        ids = []
        for name in joints:
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if j < 0:
                valid = [model.joint(i).name for i in range(model.njnt)]
                raise UnknownName("joint", name, valid)
            ids.append(int(j))
    dofs, lower, upper, qadr = [], [], [], []
    for j in ids:
        n = {0: 6, 1: 3}.get(int(model.jnt_type[j]), 1)
        start = int(model.jnt_dofadr[j])
        dofs += list(range(start, start + n))
        angle = int(model.jnt_type[j]) in _ANGLE_JOINTS and bool(model.jnt_limited[j])
        lower += [model.jnt_range[j, 0] if angle else -np.inf] * n
        upper += [model.jnt_range[j, 1] if angle else np.inf] * n
        qadr += [int(model.jnt_qposadr[j]) if angle else -1] * n
    return np.array(dofs), np.array(lower), np.array(upper), np.array(qadr)


def _interlocking_rows(
    model: mujoco.MjModel, pairs: Sequence[tuple[str, str]]
) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``e_a − e_b`` (k, nv) and qpos addresses (k, 2) of interlocking pairs."""
    if isinstance(pairs, str):
        raise InvalidInput("interlocking_pairs must be a list of (joint_a, joint_b) tuples")
    J = np.zeros((len(pairs), model.nv))
    adr = np.zeros((len(pairs), 2), dtype=int)
    valid = [model.joint(i).name for i in range(model.njnt)]
    for i, pair in enumerate(pairs):
        if not isinstance(pair, (tuple, list)) or len(pair) != 2:
            raise InvalidInput(f"interlocking_pairs[{i}] must be (joint_a, joint_b), got {pair!r}")
        for side, name in enumerate(pair):
            j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if j < 0:
                raise UnknownName("joint", name, valid)
            if int(model.jnt_type[j]) not in _ANGLE_JOINTS:
                raise InvalidInput(f"interlocking joint {name!r} must be a hinge or slide joint")
            J[i, model.jnt_dofadr[j]] += 1.0 if side == 0 else -1.0
            adr[i, side] = model.jnt_qposadr[j]
    return J, adr


def _as_tasks(
    configuration: mink.Configuration, targets: Sequence[Any], thre: float, rthre: float
) -> list[FrameTask]:
    if isinstance(targets, (FrameTask, str)) or not isinstance(targets, Sequence) or not targets:
        raise InvalidInput(
            "targets must be a non-empty list of FrameTasks or (move_target, pose) tuples"
        )
    tasks = []
    for i, t in enumerate(targets):
        if isinstance(t, FrameTask):
            tasks.append(t)
        elif isinstance(t, (tuple, list)) and len(t) == 2 and isinstance(t[0], str):
            tasks.append(
                FrameTask(
                    configuration,
                    t[0],
                    t[1],
                    thre=thre,
                    rthre=rthre,
                    p_limit=0.1,
                    r_limit=0.5,
                    error_type="split",  # irteus's difference-pos and difference-rot
                )
            )
        else:
            raise InvalidInput(f"targets[{i}] must be a FrameTask or (move_target, pose)")
    return tasks


def classic_inverse_kinematics(
    configuration: mink.Configuration,
    targets: Sequence[Any],
    *,
    method: str = "sr-inverse",
    stop: int = 50,
    min_loop: int = 0,
    thre: float = 1e-3,
    rthre: float = ONE_DEGREE,
    joints: Sequence[str] | None = None,
    manipulability_limit: float = 0.1,
    manipulability_gain: float = 0.001,
    avoid_weight_gain: float = 1.0,
    avoid_nspace_gain: float = 0.01,
    interlocking_pairs: Sequence[tuple[str, str]] = (),
    revert_if_fail: bool = True,
    callback: Callback | Sequence[Callback] | None = None,
) -> SolveResult:
    """Solve frame targets the irteus way (SR-inverse, weighted least norm, null space).

    Args:
        configuration: Robot state, updated in place.
        targets: :class:`FrameTask`s (their own axes, tolerances and step limits:
            the SR-inverse has no trust region, so give them ``p_limit`` and
            ``r_limit``), or ``(move_target, pose)`` tuples made into full 6-D
            FrameTasks with irteus' limits (0.1 m, 0.5 rad) and error
            (``error_type="split"``).
        method: ``"sr-inverse"`` (irteus' default) or ``"pseudo-inverse"`` (``k = 0``).
        stop: Maximum iterations (irteus ``stop``).
        min_loop: Iterations before the stop test may end the loop.
        thre: Translation tolerance [m] for targets given as tuples.
        rthre: Rotation tolerance [rad] for targets given as tuples.
        joints: Joints moved (all of the model's if None).
        manipulability_limit: ``κ_0`` (irteus ``manipulability-limit``).
        manipulability_gain: ``k_0`` (irteus ``manipulability-gain``).
        avoid_weight_gain: Gain of the Chan–Dubey weights (0: unweighted).
        avoid_nspace_gain: Gain ``g_n`` of the null-space joint-limit term (0: off).
        interlocking_pairs: ``[(joint_a, joint_b), ...]`` hinge/slide joints kept
            at equal angles.
        revert_if_fail: Restore the initial configuration if not converged.
        callback: One callable or a list of callables, each called in order
            after every iteration with the same :class:`IterationInfo`
            (``step`` is None here).

    Returns:
        A :class:`pik_mj.solve.SolveResult` (``qp_times`` empty: no QP).
    """
    check_configuration(configuration)
    if method not in METHODS:
        raise InvalidInput(f"method {method!r} is not one of {METHODS}")
    stop = inputs.integer(stop, "stop", low=1)
    min_loop = inputs.integer(min_loop, "min_loop", low=0)
    callbacks = as_callbacks(callback)
    for label, v in (
        ("manipulability_limit", manipulability_limit),
        ("manipulability_gain", manipulability_gain),
        ("avoid_weight_gain", avoid_weight_gain),
        ("avoid_nspace_gain", avoid_nspace_gain),
    ):
        if not (np.isfinite(v) and v >= 0):
            raise InvalidInput(f"{label} must be finite and >= 0, got {v}")
    model = configuration.model
    tasks = _as_tasks(configuration, targets, thre, rthre)
    dofs, lower, upper, qadr = _dofs(model, joints)
    clamp = qadr >= 0
    J_lock, lock_qadr = _interlocking_rows(model, interlocking_pairs)
    q0 = configuration.q.copy()
    times: list[float] = []
    history: list[list[float]] = []
    previous_grad: np.ndarray | None = None
    converged = False
    iteration = 0
    levels = [[], tasks]
    try:
        rows, reports = evaluate_levels(configuration, levels)
        while iteration < stop:
            t0 = time.perf_counter()
            q_all = configuration.q
            J = np.vstack([rows[1].A, J_lock])[:, dofs]
            dx = np.concatenate([rows[1].b, q_all[lock_qadr[:, 1]] - q_all[lock_qadr[:, 0]]])
            history.append([float(dx @ dx)])
            q = configuration.q[np.where(clamp, qadr, 0)]
            grad = joint_limit_gradient(q, lower, upper)
            winv = 1.0 / joint_limit_weights(grad, previous_grad, avoid_weight_gain)
            previous_grad = grad
            k = 0.0
            if method == "sr-inverse":
                k = sr_damping(manipulability(J, winv), manipulability_limit, manipulability_gain)
            J_sharp = sr_inverse(J, k, winv)
            dtheta = J_sharp @ dx
            if avoid_nspace_gain > 0:
                z = winv * joint_limit_nspace(q, lower, upper, avoid_nspace_gain)
                dtheta += z - J_sharp @ (J @ z)
            step = np.zeros(model.nv)
            step[dofs] = dtheta
            configuration.integrate_inplace(step, 1.0)
            qnew = configuration.q
            qnew[qadr[clamp]] = np.clip(qnew[qadr[clamp]], lower[clamp], upper[clamp])
            configuration.update(qnew)
            iteration += 1
            # the stop test's evaluation is also the next iteration's linearization
            rows, reports = evaluate_levels(configuration, levels)
            converged = iteration >= min_loop and all(r.satisfied for r in reports if r.checked)
            times.append(time.perf_counter() - t0)
            info = IterationInfo(iteration, configuration, levels, None, times[-1], reports)
            for c in callbacks:
                c(info)
            if converged:
                break
    except BaseException:
        configuration.update(q0)
        raise
    level_errors = [float(sum(r.error**2 for r in reports))]
    reverted = revert_unless_converged(configuration, q0, converged, revert_if_fail)
    return SolveResult(
        converged=converged,
        iterations=iteration,
        reverted=reverted,
        tasks=reports,
        level_errors=level_errors,
        history=history,
        iteration_times=times,
        q=configuration.q.copy(),
    )
