"""The issue-18 scenarios' figures: motion sections, the bumper, the obstacle, the camera."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from pik_mj.scenarios import (
    cocktail_shaker,
    fullbody_external_force,
    kettle,
    obstacle_reach,
    wall_contact,
)

from pik_mj import Recorder
from pik_mj.scenario import jsonable

MOTION_KEYS = {"duration", "max_tracking_error", "min_com_margin", "max_slip", "contacts", "fell"}


def run(module, tmp_path, **options) -> dict:
    """The scenario's JSON summary (as ``pik-mj run NAME --json``)."""
    with Recorder.to_file(tmp_path / f"{module.NAME}.rrd", module.NAME) as rec:
        result = module.run(rec, hold=0.5, **options)
    out = json.loads(json.dumps(jsonable(result.to_dict())))
    assert out["passed"], result.summary()
    return out


def check_motion(out: dict) -> dict:
    """Every full-body scenario's motion section: played, passed, no fall, the
    feet still (slip < 2 mm), no unexpected contact."""
    motion = out["motion"]
    assert MOTION_KEYS <= set(motion)
    assert motion["passed"] and not motion["fell"]
    assert motion["duration"] > 0.5
    assert motion["max_slip"] < 2e-3
    assert motion["contacts"]["unexpected"] == []
    return motion


def test_wall_contact_bumper_off_then_on(tmp_path):
    """The wall pushes on the hand (MuJoCo's contact forces) in no sample where the
    hand is more than 1 mm from it, and does at the end; the hand's touch sensor
    reads off while the hand is away, on (> 1 N) at the end with the palm on it,
    first on within 20 ms of the palm reaching the wall, and reads the force the
    contacts give (the sensor sums the same contact forces, within 1 %)."""
    out = run(wall_contact, tmp_path)
    motion = check_motion(out)
    assert motion["min_com_margin"] < 0  # the lean takes the CoM past the toes
    f = out["figures"]
    assert f["samples_away_from_wall"] > 100
    assert f["wall_push_while_away"] == 0
    assert f["rarm_bumper_force_end_N"] > 1.0
    assert f["wall_push_end_N"] == pytest.approx(f["rarm_bumper_force_end_N"], rel=0.01)
    assert abs(f["rarm_bumper_first_on_s"] - f["hand_reaches_wall_s"]) < 0.02


def test_obstacle_distances_with_and_without_avoidance(tmp_path):
    """With avoidance: the iterates, the reference between them and the physical
    arm at least the orange distance (2 cm; 1 mm of linearization slack in
    physics) from the box; without: the iterates 4 cm inside it, the physical
    hand against it (distance < 0)."""
    out = run(obstacle_reach, tmp_path)
    check_motion(out)
    f = out["figures"]
    orange = obstacle_reach.ORANGE
    assert f["min_distance_iterates_with_m"] >= orange
    assert f["min_distance_reference_with_m"] >= orange - 1e-3
    assert f["min_distance_physics_with_m"] >= orange - 1e-3
    assert f["min_distance_iterates_without_m"] < -0.04
    assert f["min_distance_physics_without_m"] < 0
    # a contact the path plans (the hand touching the box at a waypoint) is not
    # unexpected; any other is the hand's against the box
    assert all(c[:2] == ["rarm_hand", "obstacle"] for c in f["unexpected_contacts_without"])
    assert f["hand_error_with_m"] < 1e-3 and f["hand_error_without_m"] < 1e-3


def test_external_force_motion_takes_up_the_load(tmp_path):
    out = run(fullbody_external_force, tmp_path)
    motion = check_motion(out)
    assert motion["min_com_margin"] > 0.02
    assert motion["max_drift"] < 0.02


@pytest.fixture(scope="module")
def kettle_out(tmp_path_factory) -> dict:
    """The kettle's JSON summary (a 0.5 s hold), run once for the tests below."""
    return run(kettle, tmp_path_factory.mktemp("kettle"))


def test_kettle_handle_centred_in_the_head_camera(kettle_out):
    """After the look-at, the handle projects within 5 % of the image width of
    the centre of the head camera's image (its pinhole: MuJoCo's fovy, 320 x
    240) and no geom occludes it (MuJoCo's ray cast)."""
    f = kettle_out["figures"]
    assert f["image_width_px"] == 320
    assert f["handle_offset_from_image_centre_px"] <= 0.05 * 320
    assert f["handle_visible_after_look"] is True
    assert 0.1 < f["handle_depth_m"] < 1.0
    u, v = f["handle_pixel_after_look_px"]
    assert 0 <= u <= 320 and 0 <= v <= 240


def test_kettle_reach_grasp_lift_played_in_physics(kettle_out):
    """Look and pre-grasp in the room, the approach with the hand's contacts with
    the kettle excluded, the lift with the kettle welded in the hand: three parts,
    each from the state the last ended in; no unexpected contact (the counter,
    the kettle, the robot itself), the hand and forearm at least the orange
    distance from the counter in the reference and clear of it in physics, the
    kettle still until the grasp and lifted 0.1 m by the physical hand."""
    motion = check_motion(kettle_out)
    parts = motion["parts"]
    assert list(parts) == ["look, pre-grasp", "approach (open hand)", "lift (kettle in the hand)"]
    assert list(parts["look, pre-grasp"]["segments"]) == ["look", "pre-grasp"]
    spans = [span for p in parts.values() for span in p["segments"].values()]
    assert all(a[1] < b[0] for a, b in itertools.pairwise(spans))  # one clock
    assert all(p["passed"] and p["contacts"]["unexpected"] == [] for p in parts.values())
    assert ["kettle_pot", "counter"] in parts["lift (kettle in the hand)"]["contacts"][
        "planned_pairs"
    ]
    assert motion["max_tracking_error"]["frames_m"] < 0.03
    assert motion["max_drift"] < 0.02 and motion["min_com_margin"] > 0.03
    f = kettle_out["figures"]
    assert f["min_distance_arm_counter_reference_m"] >= kettle.ORANGE - 1e-3
    assert f["min_distance_arm_counter_physics_m"] > 0.01
    assert f["kettle_moved_before_the_grasp_physics_m"] < 1e-3
    lifted = np.array(f["kettle_lift_physics_m"])
    assert (
        abs(lifted[2] - kettle.LIFT * f["kettle_scale"]) < 0.01
        and np.linalg.norm(lifted[:2]) < 0.01
    )


def test_cocktail_shaker_played_without_the_arms_meeting(tmp_path):
    """The shake is one segment (no stop between steps); the right hand's first
    move to the shaker passes the left hand (arm avoidance: without it the
    forearm sweeps through the left hand and knocks its wrist 0.34 rad off)."""
    out = run(cocktail_shaker, tmp_path, steps=8)
    motion = check_motion(out)
    (part,) = motion["parts"].values()
    assert list(part["segments"]) == ["left hand to start", "shake"]
    assert motion["max_tracking_error"]["joints_rad"] < 0.05


@pytest.mark.parametrize("module", [wall_contact, obstacle_reach, kettle, cocktail_shaker])
def test_motion_not_played_at_speed_zero(module, tmp_path):
    with Recorder.to_file(tmp_path / "x.rrd", "x") as rec:
        result = module.run(rec, hold=0.0, speed=0.0)
    assert result.to_dict()["motion"] is None
