"""Unitree H1 goes to (0.5 m, 0.2 m, 30°) on rolling soles, in physics: 13 steps
(its rolling-sole gait's short steps). A file of its own so that it runs beside
``test_walking_h1.py``'s forward walk; ~160 s on a 2-core machine, unloaded.
"""

from __future__ import annotations

import pytest
from test_walking_h1 import GO_POS, h1, walks_on_rolling_soles  # noqa: F401 (a fixture)

from pik_mj.walking.walk import walk
from pik_mj.walking.wholebody import feet_from_robot


@pytest.mark.long
def test_unitree_h1_goes_to_a_pose_on_rolling_soles(h1):  # noqa: F811
    """The go-pos's checks of the forward walk, and both feet end turned by 30°."""
    robot, soles, gait = h1
    robot.reset_pose()
    start = feet_from_robot(robot, soles)
    steps = gait.go_pos(*GO_POS, start)
    walks_on_rolling_soles(walk(robot, steps, gait, soles=soles), soles, 13)
    for leg, foot in feet_from_robot(robot, soles).items():
        assert foot.yaw - start[leg].yaw == pytest.approx(GO_POS[2], abs=2e-3)
