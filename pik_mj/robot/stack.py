"""The tasks a robot's priority stack opens and closes with, for :func:`pik_mj.solve.solve`.

* The **guard level** (level 0, hard): every limited joint within its range
  (prioritized-IK manual: ``minmax-angle-task``), the model's MJCF couplings
  (:class:`~pik_mj.robot.couplings.CouplingTask`, when it has any), and every
  degree of freedom the solve may not move held (:func:`hold_task`).
* **Held joints that break level 0** at the start (a keyframe as shipped with
  an arm joint outside its range, or gripper fingers off their coupling) are
  projected onto its rows in the first step instead of making it infeasible: a
  held joint outside its range steps back to its nearest bound, and a coupling
  whose joints are all held gets its followed side (the ``joint1``/``tendon1``
  of the MJCF equality) freed, so the coupling row moves it onto the coupling. A
  warning names each joint and by how much (:func:`held_breaches`).
* The **posture level** (last, not checked): a cost on moving away from the
  configuration the solve starts from.

The irteus entry points (:mod:`pik_mj.ik`) and the robot's flat stance
(:mod:`pik_mj.robot.stance`) build their stacks between these two.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Sequence

import mink
import mujoco
import numpy as np

from pik_mj import inputs
from pik_mj.robot.couplings import Coupling, CouplingTask, find_couplings
from pik_mj.tasks.joint_limit import JointLimitTask
from pik_mj.tasks.linear import LinearTask
from pik_mj.tasks.mink_adapter import MinkTask
from pik_mj.tasks.task import Task


def coupled_joints(
    model: mujoco.MjModel,
    joints: Iterable[str],
    couplings: Sequence[Coupling] | None = None,
) -> set[str]:
    """``joints`` grown by every joint an MJCF coupling (``couplings``, default: the
    model's, :func:`~pik_mj.robot.couplings.find_couplings`) ties to one of them: a
    coupled joint moves with its partner, so it is not frozen."""
    if couplings is None:
        couplings = find_couplings(model).couplings
    used = set(joints)
    groups = [
        {
            model.joint(int(model.dof_jntid[d])).name
            for c in (coupling.y, coupling.x)
            if c is not None
            for d in c.dofadr
        }
        for coupling in couplings
    ]
    grown = True
    while grown:
        grown = False
        for group in groups:
            if group & used and not group <= used:
                used |= group
                grown = True
    return used


def joint_dofs(model: mujoco.MjModel, joints: Iterable[str]) -> np.ndarray:
    """Tangent-space indices (sorted) of the hinge/slide ``joints``, one each."""
    return np.array(sorted(int(model.jnt_dofadr[model.joint(j).id]) for j in joints), dtype=int)


def moving_dofs(
    model: mujoco.MjModel,
    joints: Iterable[str],
    free_dofs: Iterable[int] = (),
    couplings: Sequence[Coupling] | None = None,
) -> np.ndarray:
    """Tangent-space indices (sorted) a solve moves: those of ``joints`` grown by the
    couplings (:func:`coupled_joints`), and ``free_dofs`` (a floating base's six)."""
    used = coupled_joints(model, joints, couplings)
    return np.union1d(joint_dofs(model, used), np.asarray(list(free_dofs), dtype=int))


_ANGLE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def _range_gap(model: mujoco.MjModel, dofs: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The function of ``q`` giving ``clip(q_j, lo, hi) - q_j`` [rad or m] of each dof
    of ``dofs`` (0 for a dof that is not a limited hinge or slide), the model's
    ranges read once."""
    joints = model.dof_jntid[dofs]
    ranged = model.jnt_limited[joints].astype(bool) & np.isin(model.jnt_type[joints], _ANGLE)
    qposadr = model.jnt_qposadr[joints]
    lo, hi = model.jnt_range[joints].T.copy()

    def gap(q: np.ndarray) -> np.ndarray:
        value = q[qposadr]
        return np.where(ranged, np.clip(value, lo, hi) - value, 0.0)

    return gap


def hold_task(model: mujoco.MjModel, moving: np.ndarray) -> LinearTask | None:
    """Rows holding every dof ``i`` not in ``moving`` (tangent-space indices): still,
    ``x_i = 0``, or, for a hinge or slide outside its range, one step to its
    nearest bound, ``x_i = clip(θ_i, θ_min, θ_max) - θ_i``. None when every dof
    moves."""
    held = np.setdiff1d(np.arange(model.nv), moving)
    if held.size == 0:
        return None
    A = np.zeros((held.size, model.nv))
    A[np.arange(held.size), held] = 1.0
    gap = _range_gap(model, held)
    return LinearTask(A, lambda c: gap(c.q), name="frozen_dofs")


def _joint_name(model: mujoco.MjModel, dof: int) -> str:
    return model.joint(int(model.dof_jntid[dof])).name or f"joint#{int(model.dof_jntid[dof])}"


def held_breaches(
    configuration: mink.Configuration, moving: np.ndarray, couplings: Sequence[Coupling]
) -> tuple[list[str], np.ndarray]:
    """The level-0 rows the held dofs (those not in ``moving``) break at the current
    configuration, and the dofs freed to repair them (module docstring).

    A coupling of held dofs is broken when it is off by more than 1e-12, or when the
    side it follows moves (a held joint stepping into its range, a freed joint):
    its followed side (``y``) is freed, repeatedly until nothing more changes.

    Returns:
        ``(what, freed)``: one line per held joint outside its range and per broken
        coupling, with by how much; the freed dofs (tangent-space indices).
    """
    model, q = configuration.model, configuration.q
    held = np.setdiff1d(np.arange(model.nv), moving)
    gap = _range_gap(model, held)(q)
    what = [
        f"{_joint_name(model, d)} outside its range by {abs(g):.4g} (steps to its bound)"
        for d, g in zip(held.tolist(), gap.tolist(), strict=True)
        if g != 0.0
    ]
    changing = set(held[gap != 0.0].tolist())
    freed: set[int] = set()
    pending = list(couplings)
    grown = True
    while grown:
        grown = False
        for c in list(pending):
            x = [] if c.x is None else c.x.dofadr.tolist()
            if not set(c.y.dofadr.tolist() + x) <= set(held.tolist()):
                pending.remove(c)
                continue
            error = c.error_and_jacobian(q, model.nv)[0]
            if abs(error) > 1e-12 or set(x) & (changing | freed):
                pending.remove(c)
                freed |= set(c.y.dofadr.tolist())
                follower = ", ".join(_joint_name(model, d) for d in c.y.dofadr)
                why = f"off by {abs(error):.4g}" if abs(error) > 1e-12 else "its leader moves"
                what.append(f"coupling {c.name!r} {why} ({follower} follows)")
                grown = True
    return what, np.array(sorted(freed), dtype=int)


def guard_level(
    configuration: mink.Configuration,
    joints: Iterable[str],
    free_dofs: Iterable[int] = (),
) -> list[Task]:
    """Level 0 of a stack: joint limits, the MJCF couplings, and every dof held
    (:func:`hold_task`) but those of ``joints`` (grown by :func:`coupled_joints`)
    and ``free_dofs`` (e.g. a floating base's six); held joints that break these
    rows at the current configuration are put on them by the first step
    (:func:`held_breaches`).

    Args:
        configuration: The robot's configuration (its model's joints and couplings).
        joints: Hinge/slide joint names the solve may move.
        free_dofs: Further tangent-space indices the solve may move.

    Warns:
        RuntimeWarning: Held joints break level 0: each named, with by how much.
    """
    model = configuration.model
    couplings = find_couplings(model).couplings
    level: list[Task] = [JointLimitTask.all_limited(configuration)]
    if couplings:
        level.append(CouplingTask(configuration, couplings))
    moving = moving_dofs(model, joints, free_dofs, couplings)
    breaches, freed = held_breaches(configuration, moving, couplings)
    if breaches:
        warnings.warn(
            "held joints break level 0 at the start; the first step puts them on its rows: "
            + "; ".join(breaches),
            RuntimeWarning,
            stacklevel=2,
        )
        moving = np.union1d(moving, freed)
    hold = hold_task(model, moving)
    if hold is not None:
        level.append(hold)
    return level


def posture_task(configuration: mink.Configuration, weight: float) -> MinkTask:
    """Cost ``weight`` [cost/rad²] on moving away from the current configuration
    (:class:`mink.PostureTask`), not checked by the stop test.

    Raises:
        InvalidInput: ``weight`` is not a finite number >= 0.
    """
    weight = inputs.real(weight, "posture_weight", unit="cost/rad²", low=0)
    posture = mink.PostureTask(configuration.model, cost=weight)
    posture.set_target_from_configuration(configuration)
    return MinkTask(posture, name="posture", check=False)
