"""Walk forward (seed 001 ``:calc-walk-pattern-from-footstep-list``): 4 steps of 0.12 m.

The seed's first walking example on the sample humanoid: footsteps straight
ahead (left first), preview control of the cart-table model for the CoM, one
whole-body IK per tick (feet, CoM and upright pelvis, posture), then two
checks of the pattern: the ZMP of its inverse dynamics stays inside the
support polygon at every tick, and played with joint servos on a floor in
MuJoCo it walks without falling and ends where planned.
"""

from __future__ import annotations

from pik_mj.record import Recorder
from pik_mj.robot import Robot
from pik_mj.scenarios import ScenarioResult, main_for
from pik_mj.walking import GaitParameters
from pik_mj.walking.playback import evaluate_walk, play_walk_pattern
from pik_mj.walking.wholebody import straight_walk

MODEL = "sample_humanoid"


def run(
    out=None,
    *,
    progress: bool = False,
    n_steps: int = 4,
    stride: float = 0.12,  # [m]
    dt: float = 0.01,  # [s]
) -> ScenarioResult:
    result = ScenarioResult("walk_forward")
    robot = Robot.load(MODEL)
    params = GaitParameters(dt=dt, step_time=1.0, step_height=0.05, double_support_ratio=0.2)
    pattern = straight_walk(robot, n_steps, stride, params)
    if progress:
        print(pattern)
    recorder = None if out is None else Recorder.to_file(out, application_id="walk_forward")
    try:
        report = play_walk_pattern(pattern, MODEL, recorder=recorder)
    finally:
        if recorder is not None:
            recorder.close()
    result.recording = None if out is None else str(out)
    result.figures, checks = evaluate_walk(pattern, report)
    for label, ok, detail in checks:
        result.check(label, ok, detail)
    return result


def main(argv=None) -> int:
    return main_for(run, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
