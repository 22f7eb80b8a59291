"""A virtual 6-DoF root for fixed-base models (prioritized-IK manual: ``virtual-joint-variable``).

irteus attaches a virtual joint between the world and a robot for one solve and
removes it afterwards. MuJoCo cannot add degrees of freedom to a compiled model,
so :func:`with_virtual_root` edits the model's :class:`mujoco.MjSpec`:

* if the robot's top-level body ``B`` has no joint, a free joint is added to it
  (its initial value is ``B``'s pose);
* otherwise a new body ``virtual_root`` with a free joint (at the world origin,
  mass 1e-9 kg) becomes ``B``'s parent.

The joints of the original model keep their names; :class:`VirtualRootInfo` maps
configurations between the two models by name. :func:`solve_with_virtual_root`
solves on the floating model and maps the result back. The fixed model cannot
move its base, so the base motion found by the solve is *returned*: as the
displacement ``X_D`` (a rigid transform of the whole fixed-base robot, world
included: placing the fixed model at ``q`` and applying ``X_D`` reproduces the
solution, ``p_W = X_D · p_W^{fixed}(q)``) and as the root body's pose ``X_WB``.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import mink
import mujoco
import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.mujoco_warnings import mujoco_warnings
from pik_mj.robot.loading import load_spec
from pik_mj.robot.world import ATTACH_WARNINGS
from pik_mj.solve import SolveResult, solve
from pik_mj.tasks.com import robot_root_body

VIRTUAL_ROOT = "virtual_root"
"""Default name of the added free joint (and of the wrapper body when one is needed)."""

_WRAPPER_MASS = 1e-9  # [kg]; MuJoCo requires a mass on a body with a free joint.


def _spec_of(source: Any) -> mujoco.MjSpec:
    if isinstance(source, mujoco.MjSpec):
        return source.copy()
    if isinstance(source, (str, os.PathLike)):
        return load_spec(source)
    if isinstance(source, mujoco.MjModel):
        raise InvalidInput(
            "a compiled MjModel cannot gain degrees of freedom and MuJoCo cannot turn it "
            "back into a spec; pass the model's name, its MJCF path or its MjSpec"
        )
    raise InvalidInput(
        f"source must be a model name, an MJCF path or a mujoco.MjSpec, got {type(source).__name__}"
    )


def _compile(spec: mujoco.MjSpec, what: str) -> mujoco.MjModel:
    # Attaching with an empty prefix keeps every name; MuJoCo warns about it.
    with mujoco_warnings(expected=ATTACH_WARNINGS), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*empty prefix.*")
        try:
            return spec.compile()
        except ValueError as exc:
            raise InvalidInput(f"{what} does not compile: {exc}") from exc


def _joint_name(model: mujoco.MjModel, j: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""


def _se3(p: np.ndarray, quat: np.ndarray) -> mink.SE3:
    q = np.asarray(quat, dtype=float)
    return mink.SE3.from_rotation_and_translation(mink.SO3(q / np.linalg.norm(q)), p)


@dataclass(frozen=True)
class VirtualRootInfo:
    """How the floating model relates to the fixed one.

    Attributes:
        joint_name: Name of the added free joint.
        root_body: Name of the robot's top-level body ``B``.
        wrapped: A ``virtual_root`` body was inserted above ``B`` (``B`` had joints).
        qposadr: Index of the free joint in the floating ``qpos`` (7 values).
        dofadr: Index of the free joint in the floating tangent space (6 values).
        qpos_map: ``q_float[qpos_map] = q_fixed`` (length fixed ``nq``).
        dof_map: Same for tangent vectors (length fixed ``nv``).
        qpos0: Floating ``qpos0``; its free-joint part is the base's initial pose.
    """

    joint_name: str
    root_body: str
    wrapped: bool
    qposadr: int
    dofadr: int
    qpos_map: np.ndarray
    dof_map: np.ndarray
    qpos0: np.ndarray

    @property
    def base_q0(self) -> np.ndarray:
        """Initial free-joint value ``(p [m], quat wxyz)`` (the undisplaced base)."""
        return self.qpos0[self.qposadr : self.qposadr + 7].copy()

    def to_floating(self, q_fixed: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
        """Floating ``qpos`` from the fixed model's ``q`` (base at ``base`` or undisplaced)."""
        q_fixed = np.asarray(q_fixed, dtype=float)
        if q_fixed.shape != self.qpos_map.shape or not np.all(np.isfinite(q_fixed)):
            raise InvalidInput(
                f"q must be {self.qpos_map.size} finite numbers (the fixed model's nq), "
                f"got shape {q_fixed.shape}"
            )
        q = self.qpos0.copy()
        q[self.qpos_map] = q_fixed
        if base is not None:
            b = np.asarray(base, dtype=float)
            if b.shape != (7,) or not np.all(np.isfinite(b)) or np.linalg.norm(b[3:]) == 0:
                raise InvalidInput("base must be 7 finite numbers (position, quat wxyz)")
            q[self.qposadr : self.qposadr + 7] = b
        return q

    def to_fixed(self, q_float: np.ndarray) -> np.ndarray:
        """The fixed model's ``q`` (the base pose is dropped)."""
        return np.asarray(q_float, dtype=float)[self.qpos_map].copy()

    def displacement(self, q_float: np.ndarray) -> mink.SE3:
        """``X_D = X_free · X_free0⁻¹``: the rigid motion of the whole robot."""
        q = np.asarray(q_float, dtype=float)[self.qposadr : self.qposadr + 7]
        q0 = self.base_q0
        return _se3(q[:3], q[3:]) @ _se3(q0[:3], q0[3:]).inverse()


def with_virtual_root(
    source: Any, *, root_body: str | None = None, joint_name: str = VIRTUAL_ROOT
) -> tuple[mujoco.MjModel, VirtualRootInfo]:
    """The model with a free joint at the robot's root.

    Args:
        source: A model name (:func:`pik_mj.robot.loading.load_spec`), an MJCF path or a
            :class:`mujoco.MjSpec` (copied, never modified).
        root_body: The robot's top-level body; default as
            :func:`pik_mj.tasks.com.robot_root_body`.
        joint_name: Name of the free joint (must be unused).

    Returns:
        ``(floating_model, info)``. Keyframes are kept, mapped to the new ``qpos``.

    Raises:
        InvalidInput: The robot already has a free joint at its root, the root
            body is not top-level, a joint has no name, or ``joint_name`` is taken.
    """
    spec = _spec_of(source)
    fixed = _compile(spec, "the given model")
    b = robot_root_body(fixed, root_body)
    name = mujoco.mj_id2name(fixed, mujoco.mjtObj.mjOBJ_BODY, b)
    if fixed.body_parentid[b] != 0 or not name:
        raise InvalidInput(
            f"root body {name!r} must be a named top-level body (child of the world)"
        )
    free = int(mujoco.mjtJoint.mjJNT_FREE)
    if fixed.body_jntnum[b] and fixed.jnt_type[fixed.body_jntadr[b]] == free:
        raise InvalidInput(
            f"body {name!r} already has a free joint {_joint_name(fixed, fixed.body_jntadr[b])!r}: "
            "the model floats already, solve on it directly"
        )
    names = [_joint_name(fixed, j) for j in range(fixed.njnt)]
    if any(not n for n in names):
        raise InvalidInput("every joint needs a name to map configurations; name the joints")
    if joint_name in names:
        raise InvalidInput(f"joint_name {joint_name!r} is already a joint of the model")
    keys = [(k.name, np.array(k.qpos), np.array(k.qvel)) for k in spec.keys]
    for k in spec.keys:
        k.qpos, k.qvel = [], []
    wrapped = fixed.body_jntnum[b] > 0
    if not wrapped:
        spec.body(name).add_freejoint(name=joint_name)
    else:
        source_copy = spec.copy()
        for k in list(source_copy.keys):  # attaching would copy them (name clash)
            source_copy.delete(k)
        spec.delete(spec.body(name))
        wrapper = spec.worldbody.add_body(
            name=joint_name, mass=_WRAPPER_MASS, inertia=[_WRAPPER_MASS] * 3
        )
        wrapper.add_freejoint(name=joint_name)
        with mujoco_warnings(expected=ATTACH_WARNINGS):
            wrapper.add_frame().attach_body(source_copy.body(name), "", "")
    floating = _compile(spec, "the model with a virtual root")
    jf = mujoco.mj_name2id(floating, mujoco.mjtObj.mjOBJ_JOINT, joint_name)
    qpos_map, dof_map = [], []
    for j, n in enumerate(names):
        k = mujoco.mj_name2id(floating, mujoco.mjtObj.mjOBJ_JOINT, n)
        nq = {0: 7, 1: 4}.get(int(fixed.jnt_type[j]), 1)
        nd = {0: 6, 1: 3}.get(int(fixed.jnt_type[j]), 1)
        qa, da = fixed.jnt_qposadr[j], fixed.jnt_dofadr[j]
        qpos_map.append((qa, np.arange(floating.jnt_qposadr[k], floating.jnt_qposadr[k] + nq)))
        dof_map.append((da, np.arange(floating.jnt_dofadr[k], floating.jnt_dofadr[k] + nd)))
    qmap = np.zeros(fixed.nq, dtype=int)
    dmap = np.zeros(fixed.nv, dtype=int)
    for qa, idx in qpos_map:
        qmap[qa : qa + idx.size] = idx
    for da, idx in dof_map:
        dmap[da : da + idx.size] = idx
    info = VirtualRootInfo(
        joint_name=joint_name,
        root_body=name,
        wrapped=bool(wrapped),
        qposadr=int(floating.jnt_qposadr[jf]),
        dofadr=int(floating.jnt_dofadr[jf]),
        qpos_map=qmap,
        dof_map=dmap,
        qpos0=floating.qpos0.copy(),
    )
    if keys:
        for k, (_, qpos, qvel) in zip(spec.keys, keys, strict=True):
            if qpos.size:
                k.qpos = info.to_floating(qpos).tolist()
            if qvel.size:
                v = np.zeros(floating.nv)
                v[dmap] = qvel
                k.qvel = v.tolist()
        floating = _compile(spec, "the model with a virtual root")
    return floating, info


@dataclass
class VirtualRootResult:
    """Outcome of :func:`solve_with_virtual_root`.

    Attributes:
        q: The fixed model's configuration (``nq`` of the fixed model).
        displacement: ``X_D``, the rigid motion to apply to the whole fixed-base
            robot (see the module docstring).
        base_pose: ``X_WB``, the root body's pose in the world at the solution.
        solve: The :class:`~pik_mj.solve.SolveResult` on the floating model.
        model: The floating model.
        configuration: The floating configuration at the solution.
        info: The :class:`VirtualRootInfo`.
    """

    q: np.ndarray
    displacement: mink.SE3
    base_pose: mink.SE3
    solve: SolveResult
    model: mujoco.MjModel
    configuration: mink.Configuration
    info: VirtualRootInfo


def solve_with_virtual_root(
    source: Any,
    q: Sequence[float] | np.ndarray | None,
    levels_fn: Callable[[mink.Configuration], Sequence[Sequence[object]]],
    *,
    root_body: str | None = None,
    **solve_kwargs: Any,
) -> VirtualRootResult:
    """Solve with the robot's base free to move, then map back.

    Args:
        source: The fixed-base model (name, MJCF path or :class:`mujoco.MjSpec`).
        q: The fixed model's configuration; None for its ``qpos0``.
        levels_fn: ``f(configuration) -> levels`` building the tasks on the
            floating configuration it receives (names are those of the fixed model).
        root_body: The robot's top-level body.
        **solve_kwargs: Passed to :func:`pik_mj.solve.solve`.

    Returns:
        :class:`VirtualRootResult`; ``q`` excludes the base, whose motion is in
        ``displacement`` / ``base_pose``.
    """
    model, info = with_virtual_root(source, root_body=root_body)
    q_fixed = info.qpos0[info.qpos_map] if q is None else np.asarray(q, dtype=float)
    configuration = mink.Configuration(model)
    configuration.update(info.to_floating(q_fixed))
    result = solve(configuration, levels_fn(configuration), **solve_kwargs)
    b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, info.root_body)
    data = configuration.data
    return VirtualRootResult(
        q=info.to_fixed(configuration.q),
        displacement=info.displacement(configuration.q),
        base_pose=_se3(data.xpos[b].copy(), data.xquat[b].copy()),
        solve=result,
        model=model,
        configuration=configuration,
        info=info,
    )
