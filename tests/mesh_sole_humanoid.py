"""A synthetic humanoid for the walking and sole tests: no sites at all, soles that
are meshes placed off the ankle (forward and outward), larger visual meshes, torque
motors with limits (as Unitree H1 ships). MuJoCo touches each mesh sole at a few of
its bottom vertices, not at all of them.
"""

from __future__ import annotations

import numpy as np

SOLE_OFFSET = (0.035, 0.012)
"""[m] Centre of each sole's bottom outline from the ankle: forward, outward."""

# bottom outline of a sole around its centre [m] (ccw): a foot, rounded toe, narrow heel
_OUTLINE = np.array(
    [
        [-0.07, -0.025],
        [-0.035, -0.035],
        [0.04, -0.04],
        [0.085, -0.03],
        [0.1, 0.0],
        [0.085, 0.03],
        [0.04, 0.04],
        [-0.035, 0.035],
        [-0.07, 0.025],
    ]
)
SOLE_THICKNESS = 0.02
"""[m] Height of the sole mesh."""
ANKLE_HEIGHT = 0.06
"""[m] Ankle axis above the floor in the standing pose."""
THIGH = SHANK = 0.24
"""[m] Thigh and shank lengths."""
STAND = {"hip_p": -0.4, "knee": 0.8, "ankle_p": -0.4}
"""[rad] Leg joints of the standing keyframe (soles flat)."""


def sole_mesh_vertices(side: float) -> np.ndarray:
    """Vertices (18, 3) [m] of a sole mesh in its foot's frame (ankle at the origin):
    the outline on the floor, a smaller copy ``SOLE_THICKNESS`` above; ``side`` +1
    for the left foot, -1 for the right (the outward offset)."""
    centre = np.array([SOLE_OFFSET[0], side * SOLE_OFFSET[1]])
    bottom = np.column_stack([_OUTLINE + centre, np.full(len(_OUTLINE), -ANKLE_HEIGHT)])
    top = np.column_stack(
        [0.9 * _OUTLINE + centre, np.full(len(_OUTLINE), -ANKLE_HEIGHT + SOLE_THICKNESS)]
    )
    return np.vstack([bottom, top])


def _vertex_attr(v: np.ndarray) -> str:
    return " ".join(f"{x:.5f}" for x in v.ravel())


def _leg(side: str, s: float) -> str:
    roll = "-0.4 0.6" if s > 0 else "-0.6 0.4"
    return f"""
      <body name="{side}_hip" pos="0 {s * 0.08:.3f} -0.06">
        <joint name="{side}_hip_yaw" axis="0 0 1" range="-0.6 0.6"/>
        <joint name="{side}_hip_roll" axis="1 0 0" range="{roll}"/>
        <joint name="{side}_hip_pitch" axis="0 1 0" range="-2.0 0.6"/>
        <geom type="capsule" fromto="0 0 0 0 0 -{THIGH}" size="0.035" mass="2.5"/>
        <geom type="capsule" fromto="0 0 0 0 0 -{THIGH}" size="0.05" contype="0"
              conaffinity="0" group="1" mass="0"/>
        <body name="{side}_shank" pos="0 0 -{THIGH}">
          <joint name="{side}_knee" axis="0 1 0" range="0 2.3"/>
          <geom type="capsule" fromto="0 0 0 0 0 -{SHANK}" size="0.03" mass="1.8"/>
          <body name="{side}_foot" pos="0 0 -{SHANK}">
            <joint name="{side}_ankle_pitch" axis="0 1 0" range="-0.9 0.6"/>
            <joint name="{side}_ankle_roll" axis="1 0 0" range="-0.4 0.4"/>
            <geom name="{side}_sole" type="mesh" mesh="{side}_sole" mass="0.6"/>
            <geom type="mesh" mesh="{side}_shoe" contype="0" conaffinity="0" group="1"
                  mass="0"/>
          </body>
        </body>
      </body>"""


def _arm(side: str, s: float) -> str:
    return f"""
      <body name="{side}_upper_arm" pos="0 {s * 0.15:.3f} 0.3">
        <joint name="{side}_shoulder_pitch" axis="0 1 0" range="-2.5 2.5"/>
        <joint name="{side}_shoulder_roll" axis="1 0 0" range="-1.5 1.5"/>
        <geom type="capsule" fromto="0 {s * 0.02:.3f} 0 0 {s * 0.02:.3f} -0.2" size="0.025"
              mass="0.8"/>
        <body name="{side}_forearm" pos="0 {s * 0.02:.3f} -0.2">
          <joint name="{side}_elbow" axis="0 1 0" range="-2.4 0"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.18" size="0.02" mass="0.5"/>
        </body>
      </body>"""


_LEG_JOINTS = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
_ARM_JOINTS = ("shoulder_pitch", "shoulder_roll", "elbow")
_LIMITS = {
    "hip_yaw": 40,
    "hip_roll": 60,
    "hip_pitch": 60,
    "knee": 80,
    "ankle_pitch": 40,
    "ankle_roll": 30,
    "shoulder_pitch": 15,
    "shoulder_roll": 15,
    "elbow": 10,
}
"""[N·m] Torque limits of the motors (their ctrlrange, gear 1)."""


def mesh_sole_humanoid(name: str = "mesh_sole_humanoid") -> str:
    """The MJCF of the humanoid (module docstring): 22 kg, 18 hinges, a keyframe
    ``stand`` with the knees bent and the soles flat on z = 0."""
    meshes = []
    for side, s in (("right", -1.0), ("left", 1.0)):
        v = sole_mesh_vertices(s)
        meshes.append(f'<mesh name="{side}_sole" vertex="{_vertex_attr(v)}"/>')
        shoe = v.copy()
        shoe[:, :2] *= 1.15
        shoe[:, 2] += 0.004
        meshes.append(f'<mesh name="{side}_shoe" vertex="{_vertex_attr(shoe)}"/>')
    motors = [
        f'<motor name="{side}_{j}" joint="{side}_{j}" ctrlrange="-{_LIMITS[j]} {_LIMITS[j]}"/>'
        for side in ("right", "left")
        for j in _LEG_JOINTS + _ARM_JOINTS
    ]
    # keyframe: legs (right, left) then arms (right, left), in body order
    leg = f"0 0 {STAND['hip_p']} {STAND['knee']} {STAND['ankle_p']} 0"
    arm = "0 0 -0.3"
    z = ANKLE_HEIGHT + (THIGH + SHANK) * np.cos(-STAND["hip_p"]) + 0.06
    qpos = f"0 0 {z:.6f} 1 0 0 0 {leg} {leg} {arm} {arm}"
    return f"""
<mujoco model="{name}">
  <compiler angle="radian"/>
  <default><joint type="hinge" damping="0.2" armature="0.01" limited="true"/></default>
  <asset>{"".join(meshes)}</asset>
  <worldbody>
    <body name="pelvis" pos="0 0 {z:.6f}">
      <freejoint name="floating_base"/>
      <geom type="box" size="0.07 0.11 0.05" mass="5"/>
      <geom type="box" size="0.08 0.13 0.16" pos="0 0 0.22" mass="7"/>
      <geom type="sphere" size="0.07" pos="0 0 0.46" mass="1.5"/>
      {_leg("right", -1.0)}{_leg("left", 1.0)}
      {_arm("right", -1.0)}{_arm("left", 1.0)}
    </body>
  </worldbody>
  <actuator>{"".join(motors)}</actuator>
  <keyframe><key name="stand" qpos="{qpos}"/></keyframe>
</mujoco>"""
