"""Hinges without a range are unbounded: JointLimitTask and the IK accept them."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from pik_mj.ik import inverse_kinematics
from pik_mj.robot import Limb, Robot
from pik_mj.solve import solve
from pik_mj.tasks.frame import FrameTask
from pik_mj.tasks.joint_limit import JointLimitTask

# A planar two-link arm; "shoulder" has no range, "elbow" is limited to ±1 rad.
_ARM = """
<mujoco><compiler angle="radian"/><worldbody>
<body name="upper"><joint name="shoulder" axis="0 0 1"/>
  <geom type="capsule" fromto="0 0 0 .3 0 0" size=".02"/>
  <body name="lower" pos=".3 0 0"><joint name="elbow" axis="0 0 1" range="-1 1"/>
    <geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/>
    <site name="tip" pos=".2 0 0"/></body></body>
</worldbody></mujoco>
"""


def test_unbounded_hinge_has_infinite_bounds():
    model = mujoco.MjModel.from_xml_string(_ARM)
    cfg = Robot(model).configuration
    task = JointLimitTask(cfg, ["shoulder", "elbow"])
    assert task.min_angle.tolist() == [-np.inf, -1.0]
    assert task.max_angle.tolist() == [np.inf, 1.0]
    rows = task.compute_rows(cfg)
    assert rows.d_lower.tolist() == [-np.inf, -1.0] and rows.d_upper.tolist() == [np.inf, 1.0]
    q = cfg.q.copy()
    q[0] = 7.0  # far past any range: no violation
    cfg.update(q)
    assert task.violations(cfg) == {"shoulder": 0.0, "elbow": 0.0}
    # a value given for one side only bounds that side
    half = JointLimitTask(cfg, "shoulder", max_angle=3.0)
    assert (half.min_angle[0], half.max_angle[0]) == (-np.inf, 3.0)
    assert half.violations(cfg) == {"shoulder": pytest.approx(4.0)}


def test_model_without_ranges_solves():
    """No joint limited: all_limited gives a task without rows, and the IK turns
    the shoulder through more than π to reach a target behind the arm."""
    model = mujoco.MjModel.from_xml_string(_ARM.replace(' range="-1 1"', ""))
    robot = Robot(model, limbs={"arm": Limb("arm", ("shoulder", "elbow"), "tip", "site", "upper")})
    task = JointLimitTask.all_limited(robot.configuration)
    assert task.joints == [] and task.compute_rows(robot.configuration).C.shape == (0, 2)
    q = robot.configuration.q.copy()
    q[:] = [2.8, 0.3]
    robot.configuration.update(q)
    target = (np.array([-0.35, -0.2, 0.0]), np.eye(3))
    result = inverse_kinematics(robot, target, limbs="arm", rotation_axis=None, stop=100)
    assert result.converged
    tip = robot.data.site("tip").xpos
    assert np.linalg.norm(tip - target[0]) < 1e-3
    assert robot.configuration.q[0] > np.pi  # past +π, where a ±π range would stop it


def test_unbounded_and_limited_together_in_a_solve():
    """The elbow's ±1 rad holds while the unbounded shoulder moves freely."""
    model = mujoco.MjModel.from_xml_string(_ARM)
    cfg = Robot(model).configuration
    reach = FrameTask(cfg, "tip", (np.array([0.0, 0.45, 0.0]), np.eye(3)), rotation_axis=None)
    result = solve(cfg, [[JointLimitTask(cfg, ["shoulder", "elbow"])], [reach]], stop=100)
    assert result.converged
    assert -1.0 - 1e-5 <= cfg.q[1] <= 1.0 + 1e-5
