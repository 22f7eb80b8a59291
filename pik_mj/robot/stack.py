"""The tasks a robot's priority stack opens and closes with, for :func:`pik_mj.solve.solve`.

* The **guard level** (level 0, hard): every limited joint within its range
  (prioritized-IK manual: ``minmax-angle-task``), the model's MJCF couplings
  (:class:`~pik_mj.robot.couplings.CouplingTask`, when it has any), and every
  degree of freedom the solve may not move frozen (``x_i = 0``).
* The **posture level** (last, not checked): a cost on moving away from the
  configuration the solve starts from.

The irteus entry points (:mod:`pik_mj.ik`) and the robot's flat stance
(:mod:`pik_mj.robot.stance`) build their stacks between these two.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

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


def freeze_task(nv: int, moving: np.ndarray) -> LinearTask | None:
    """Rows ``x_i = 0`` for every dof ``i`` of ``range(nv)`` not in ``moving``, or None
    when every dof moves."""
    frozen = np.setdiff1d(np.arange(nv), moving)
    if frozen.size == 0:
        return None
    A = np.zeros((frozen.size, nv))
    A[np.arange(frozen.size), frozen] = 1.0
    return LinearTask(A, np.zeros(frozen.size), name="frozen_dofs")


def guard_level(
    configuration: mink.Configuration,
    joints: Iterable[str],
    free_dofs: Iterable[int] = (),
) -> list[Task]:
    """Level 0 of a stack: joint limits, the MJCF couplings, and every dof frozen but
    those of ``joints`` (grown by :func:`coupled_joints`) and ``free_dofs`` (e.g. a
    floating base's six).

    Args:
        configuration: The robot's configuration (its model's joints and couplings).
        joints: Hinge/slide joint names the solve may move.
        free_dofs: Further tangent-space indices the solve may move.
    """
    model = configuration.model
    couplings = find_couplings(model).couplings
    level: list[Task] = [JointLimitTask.all_limited(configuration)]
    if couplings:
        level.append(CouplingTask(configuration, couplings))
    used = coupled_joints(model, joints, couplings)
    moving = np.union1d(joint_dofs(model, used), np.asarray(list(free_dofs), dtype=int))
    freeze = freeze_task(model.nv, moving)
    if freeze is not None:
        level.append(freeze)
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
