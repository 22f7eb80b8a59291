"""Fullbody IK with the centroid over the feet (seed 001 ``fullbody-inverse-kinematics``).

Both feet stay where they are, the centroid's x-y goes to the midpoint of the feet
(z free, irteus ``:cog-translation-axis :z``), and the left hand reaches the seed's
``#f(400 100 -600)`` mm from the waist, position only (``:rotation-axis nil``);
the floating base moves within the seed's root-link bounds. The seed first bends
the waist by 10° (done where the robot has ``torso_waist_p``). dm_control's
humanoid has its root at the chest, not the waist, and cannot crouch as deep
within the root bounds: its hand target is (0.3, 0.1, -0.5) m from its root.
"""

from __future__ import annotations

import numpy as np

from pik_mj.ik import fullbody_inverse_kinematics
from pik_mj.robot import Robot
from pik_mj.scenarios import ScenarioRecorder, ScenarioResult, com_margin, main_for

HAND_OFFSETS = {  # [m] left-hand target from the root body, per model
    "sample_humanoid": (0.4, 0.1, -0.6),  # the seed's #f(400 100 -600) mm
    "dm_humanoid_cmu": (0.4, 0.1, -0.6),
    "dm_humanoid": (0.3, 0.1, -0.5),
}
OTHER_MODELS = (0.3, 0.1, -0.4)
FEET = ("rleg", "lleg")


def foot_poses(robot: Robot) -> list:
    return [robot.frame_pose(robot.limb(x).end_frame, robot.limb(x).end_frame_type) for x in FEET]


def run(out=None, *, progress: bool = False, model: str = "sample_humanoid") -> ScenarioResult:
    result = ScenarioResult("fullbody_reach")
    robot = Robot.load(model)
    if "torso_waist_p" in robot.joint_names:  # seed: (send *robot* :torso :waist-p :joint-angle 10)
        robot.set_angle_vector([np.deg2rad(10.0)], ["torso_waist_p"])
    feet0 = foot_poses(robot)
    p_mid = 0.5 * (feet0[0].translation() + feet0[1].translation())
    p_root, _ = robot.root_pose()
    target = p_root + np.array(HAND_OFFSETS.get(str(model), OTHER_MODELS))

    with ScenarioRecorder(out, robot, progress=progress, name="fullbody_reach") as rec:
        res = fullbody_inverse_kinematics(
            robot,
            [(target, np.array([1.0, 0.0, 0.0, 0.0]))],
            limbs=["larm"],
            rotation_axis=[None],
            target_centroid_pos=p_mid,
            centroid_axes="z",
            stop=100,
            callback=rec.callback("reach"),
        )
        rec.record("reach", res)

    feet1 = foot_poses(robot)
    hand = robot.frame_pose(robot.limb("larm").end_frame, robot.limb("larm").end_frame_type)
    com = robot.com()
    rec.fill(result, main="reach")
    result.figures = {
        "model": model,
        "hand_target_m": target,
        "hand_error_m": float(np.linalg.norm(hand.translation() - target)),
        "feet_moved_m": max(
            float(np.linalg.norm(a.translation() - b.translation()))
            for a, b in zip(feet0, feet1, strict=True)
        ),
        "feet_turned_rad": max(
            float(np.linalg.norm((a.rotation().inverse() @ b.rotation()).log()))
            for a, b in zip(feet0, feet1, strict=True)
        ),
        "com_m": com,
        "com_xy_error_m": float(np.linalg.norm(com[:2] - p_mid[:2])),
        "com_margin_m": com_margin(robot),
        "root_displacement_m": robot.root_pose()[0] - p_root,
        "median_iteration_ms": res.median_iteration_ms,
    }
    f = result.figures
    result.check("converged", res.converged, f"{res.iterations} iterations")
    result.check("hand on target (1 mm)", f["hand_error_m"] <= 1e-3, f"{f['hand_error_m']:.2e} m")
    result.check(
        "feet did not move (0.1 mm, 1 mrad)",
        f["feet_moved_m"] <= 1e-4 and f["feet_turned_rad"] <= 1e-3,
    )
    result.check("CoM xy over the feet midpoint (1 mm)", f["com_xy_error_m"] <= 1e-3)
    result.check(
        "CoM inside the support polygon", f["com_margin_m"] > 0, f"margin {f['com_margin_m']:.3f} m"
    )
    return result


def main(argv=None) -> int:
    return main_for(run, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
