"""Walk to a pose (seed 001 ``:go-pos-params->footstep-list``): go_pos(0.5, 0.15, 45°).

Footsteps from the sample humanoid's feet to a goal 0.5 m ahead, 0.15 m left
and turned 45° left (the left leg leads, at most 0.15 m / 30° per step), the
walking pattern by preview control and whole-body IK per tick, then the same
checks as ``walk_forward``: ZMP of the inverse dynamics inside the support
polygon at every tick; in physics no fall and the feet end where planned.
"""

from __future__ import annotations

import numpy as np

from pik_mj.record import Recorder
from pik_mj.robot import Robot
from pik_mj.scenarios import ScenarioResult, main_for
from pik_mj.walking import GaitParameters
from pik_mj.walking.playback import evaluate_walk, play_walk_pattern
from pik_mj.walking.wholebody import go_pos

MODEL = "sample_humanoid"


def run(
    out=None,
    *,
    progress: bool = False,
    x: float = 0.5,  # [m]
    y: float = 0.15,  # [m]
    theta_deg: float = 45.0,  # [deg]
    dt: float = 0.01,  # [s]
) -> ScenarioResult:
    result = ScenarioResult("walk_go_pos")
    robot = Robot.load(MODEL)
    params = GaitParameters(dt=dt, step_time=1.0, step_height=0.05, double_support_ratio=0.2)
    pattern = go_pos(robot, x, y, np.deg2rad(theta_deg), params)
    if progress:
        print(pattern)
    recorder = None if out is None else Recorder.to_file(out, application_id="walk_go_pos")
    try:
        report = play_walk_pattern(pattern, MODEL, recorder=recorder)
    finally:
        if recorder is not None:
            recorder.close()
    result.recording = None if out is None else str(out)
    result.figures, checks = evaluate_walk(pattern, report)
    result.figures["sim_final_yaw_error_deg"] = float(np.rad2deg(report.final_yaw_error))
    for label, ok, detail in checks:
        result.check(label, ok, detail)
    result.check(
        "physics playback: final heading within 5 deg of the plan",
        report.final_yaw_error <= np.deg2rad(5.0),
        f"{np.rad2deg(report.final_yaw_error):.2f} deg",
    )
    return result


def main(argv=None) -> int:
    return main_for(run, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
