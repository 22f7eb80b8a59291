"""MJCF joint and fixed-tendon equalities as level-0 rows (pik_mj.robot.couplings),
against MuJoCo's own equality constraint rows (efc_pos, efc_J)."""

from __future__ import annotations

import mink
import mujoco
import numpy as np
import pytest
from fd import fd_jacobian

from pik_mj.exceptions import InvalidInput
from pik_mj.robot.couplings import CouplingTask, find_couplings
from pik_mj.solve import CORRECT_ABOVE, TrustRegion, solve
from pik_mj.tasks.frame import FrameTask

# A planar 4-link arm: c follows b by a quartic, the fixed tendon a - 2 d is held
# at its qpos0 length + 0.05 (a's reference angle 0.1 makes qpos0 non-zero), and
# two equalities that give no IK rows.
ARM = """
<mujoco><compiler angle="radian"/><option><flag gravity="disable"/></option><worldbody>
<body name="l1"><joint name="a" axis="0 0 1" ref="0.1"/>
 <geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/>
 <body name="l2" pos=".2 0 0"><joint name="b" axis="0 0 1"/>
  <geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/>
  <body name="l3" pos=".2 0 0"><joint name="c" axis="0 0 1"/>
   <geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/>
   <body name="l4" pos=".2 0 0"><joint name="d" axis="0 0 1"/>
    <geom type="capsule" fromto="0 0 0 .1 0 0" size=".02"/>
    <site name="tip" pos=".1 0 0"/></body></body></body></body>
</worldbody>
<tendon><fixed name="td"><joint joint="a" coef="1"/><joint joint="d" coef="-2"/></fixed></tendon>
<equality>
  <joint name="c_of_b" joint1="c" joint2="b" polycoef="0 0.5 0.2 0.05 0.01"/>
  <tendon name="td_fixed" tendon1="td" polycoef="0.05 0 0 0 0"/>
  <connect name="pin" body1="l4" body2="world" anchor="0 0 0" active="false"/>
  <joint name="off" joint1="d" polycoef="0 0 0 0 0" active="false"/>
</equality>
</mujoco>
"""


def _mujoco_rows(model: mujoco.MjModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's equality rows at q: efc_pos (violation) and the dense efc_J."""
    model.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    rows = np.flatnonzero(data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY)
    order = np.argsort(data.efc_id[rows])
    J = data.efc_J[: data.nefc * model.nv].reshape(data.nefc, model.nv)
    return data.efc_pos[rows][order], J[rows][order]


def test_error_and_jacobian_are_mujocos_equality_rows():
    model = mujoco.MjModel.from_xml_string(ARM)
    cfg = mink.Configuration(model)
    task = CouplingTask(cfg)
    assert [c.name for c in task.couplings] == ["c_of_b", "td_fixed"]
    rng = np.random.default_rng(7)
    for _ in range(10):
        q = rng.uniform(-1.5, 1.5, model.nq)
        cfg.update(q)
        efc_pos, efc_J = _mujoco_rows(model, q)
        rows = task.compute_rows(cfg)
        assert np.allclose(task.compute_error(cfg), efc_pos, atol=1e-12)
        assert np.allclose(rows.A, efc_J, atol=1e-12)
        assert np.allclose(rows.b, -efc_pos, atol=1e-12)
        J_fd = fd_jacobian(model, q, task.compute_error)
        assert np.allclose(rows.A, J_fd, atol=1e-6)


def test_other_equalities_are_reported():
    found = find_couplings(mujoco.MjModel.from_xml_string(ARM))
    assert len(found.unsupported) == 2
    assert "'pin' (connect): only joint and fixed-tendon equalities" in found.unsupported[0]
    assert "'off' (joint): inactive" in found.unsupported[1]
    no_eq = mujoco.MjModel.from_xml_string(ARM.split("<tendon>")[0] + "</mujoco>")
    with pytest.raises(InvalidInput, match="no joint or fixed-tendon equality"):
        CouplingTask(mink.Configuration(no_eq))


def _reach(cfg: mink.Configuration, task: CouplingTask, qp_solver: str, **kwargs):
    """Move the tip 16 cm from a coupled start; per iteration, the largest coupling
    error and the step of joint b (the driving coordinate of c's polynomial)."""
    q = cfg.model.qpos0.copy()
    q[0] += 0.05  # a - 2 d = L0 + 0.05
    cfg.update(q)
    assert np.max(np.abs(task.compute_error(cfg))) < 1e-15
    start = cfg.q.copy()
    target = (cfg.data.site("tip").xpos + np.array([-0.1, 0.12, 0.0]), np.eye(3))
    reach = FrameTask(cfg, "tip", target, rotation_axis=None)
    errors, b = [], [start[1]]

    def record(info) -> None:
        errors.append(np.max(np.abs(task.compute_error(info.configuration))))
        b.append(info.configuration.q[1])

    result = solve(cfg, [[task], [reach]], stop=100, qp_solver=qp_solver, callback=record, **kwargs)
    assert result.converged
    assert np.linalg.norm(cfg.data.site("tip").xpos - target[0]) < 1e-3
    assert np.max(np.abs(cfg.q - start)) > 0.3  # the chain really moved
    return np.array(errors), np.diff(b)


@pytest.mark.parametrize(("qp_solver", "bound"), [("daqp", 1e-9), ("osqp", 2e-6)])
def test_linear_couplings_hold_at_every_iteration(qp_solver, bound):
    """A gear ratio (c = 0.5 b) and the fixed tendon: their rows are exact, so they
    hold at every iteration to 1e-9 with the exact solver DAQP, to OSQP's
    tolerance with OSQP."""
    model = mujoco.MjModel.from_xml_string(ARM.replace("0 0.5 0.2 0.05 0.01", "0 0.5 0 0 0"))
    cfg = mink.Configuration(model)
    errors, _ = _reach(cfg, CouplingTask(cfg), qp_solver)
    assert errors.max() <= bound


def test_polynomial_coupling_error_is_second_order_and_vanishes():
    """The quartic coupling is met to first order each step: after a step Δb the
    error is at most ½ max|p''| Δb² (Taylor); the solve's correction projects the
    step back onto it (level 0's rows), so it stays within the trust region's
    CORRECT_ABOVE · drift at every iteration and vanishes once the steps do."""
    model = mujoco.MjModel.from_xml_string(ARM)
    cfg = mink.Configuration(model)
    task = CouplingTask(cfg, check_margin=1e-10)
    errors, steps = _reach(cfg, task, "daqp")
    c = task.couplings[0].polycoef
    xi = np.linspace(-2.0, 2.0, 401)
    curvature = np.max(np.abs(2 * c[2] + 6 * c[3] * xi + 12 * c[4] * xi**2))
    assert np.all(errors <= 0.5 * curvature * steps**2 + 1e-9)
    assert errors.max() <= CORRECT_ABOVE * TrustRegion().drift  # projected back every iteration
    assert errors[-1] <= 1e-10


def test_violated_start_is_corrected():
    """Starting 0.2 rad off the joint coupling, the level-0 rows close the gap."""
    model = mujoco.MjModel.from_xml_string(ARM)
    cfg = mink.Configuration(model)
    q = model.qpos0.copy()
    q[0] += 0.05
    q[2] = 0.2
    cfg.update(q)
    task = CouplingTask(cfg, check_margin=1e-10)
    assert task.compute_error(cfg)[0] == pytest.approx(0.2)
    reach = FrameTask(cfg, "tip", (cfg.data.site("tip").xpos.copy(), np.eye(3)), rotation_axis=None)
    result = solve(cfg, [[task], [reach]], stop=50, qp_solver="daqp")
    assert result.converged
    assert np.max(np.abs(task.compute_error(cfg))) <= 1e-10
