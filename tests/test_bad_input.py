# ruff: noqa: E501  (the case tables keep one case a line)
"""Bad input to the top layer and the ``pik-mj`` command, answered clearly.

Every case of :data:`API_CASES` calls the Python API with one bad argument and
asserts the exception type (:class:`~pik_mj.InvalidInput` or
:class:`~pik_mj.UnknownName`), a message naming the cause (the argument, the bad
value or what is valid) and that the robots' configurations are unchanged.
Every case of :data:`CLI_CASES` runs ``pik_mj.cli.main(argv)`` in-process and
asserts exit status 2, a one-line message naming the cause on stderr, no
traceback, and that no work started (nothing written, no solve). A few CLI cases
also run as a real ``python -m pik_mj.cli`` process. The solver's own options
(``solve``'s ``stop``, ``qp_args``, ...) are tested with the solver.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import mink
import numpy as np
import pytest
from tmp_scenarios import add_scenario

from pik_mj import (
    HoldCriteria,
    InvalidInput,
    MinkTask,
    Recorder,
    Robot,
    Scene,
    UnknownName,
    cli,
    fullbody_inverse_kinematics,
    inverse_kinematics,
)
from pik_mj.ik import gaze_angle, static_balance_point
from pik_mj.robot import RobotSource
from pik_mj.robot.ground import sole_polygons
from pik_mj.scenario import ScenarioResult, jsonable
from pik_mj.sim import validate_pose
from pik_mj.sim.scene import ContactParams


@dataclass(frozen=True)
class Case:
    """One bad call: what it is, the call, the exception and the message (a regex)."""

    name: str
    call: Callable[[Any], Any]
    error: type[Exception]
    message: str


def _id(case: Case) -> str:
    return case.name


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> SimpleNamespace:
    """Files a user might pass by mistake."""
    tmp = tmp_path_factory.mktemp("bad_input")
    (tmp / "folder").mkdir()
    (tmp / "garbage.xml").write_text("this is not XML")
    (tmp / "other.xml").write_text("<html><body>not a model</body></html>")
    (tmp / "binary.json").write_bytes(bytes(range(256)) * 4)
    (tmp / "plain.txt").write_text("some notes")
    (tmp / "not_json.json").write_text("{model: sample_humanoid")
    (tmp / "no_pose.json").write_text(json.dumps({"name": "three_dof_reach", "robot": None}))
    robot = Robot.from_model("sample_humanoid")
    q = robot.configuration.q.tolist()

    def pose(name: str, **entries: Any) -> None:
        (tmp / name).write_text(json.dumps({"model": "sample_humanoid", "q": q, **entries}))

    pose("good.json")
    pose("short.json", q=q[:7])
    pose("arm_pose.json", q=[0.1, 0.2, 0.3])
    pose("strings.json", q=["a"] * len(q))
    pose("zero_quat.json", q=[*q[:3], 0, 0, 0, 0, *q[7:]])
    pose("unknown_model.json", model="no_such_robot")
    pose("site_without_room.json", at="spot_counter_front")
    pose("bad_keyframe.json", keyframe="flying")
    (tmp / "nan.json").write_text(
        json.dumps({"model": "sample_humanoid", "q": [math.nan, *q[1:]]})  # JSON's NaN
    )
    return SimpleNamespace(tmp=tmp, **{p.stem: p for p in tmp.iterdir()})


@pytest.fixture(scope="module")
def ctx(files) -> SimpleNamespace:
    robot = Robot.from_model("sample_humanoid")
    arm = Robot.from_model("three_dof_arm")
    scene = Scene.from_robot(robot)
    p_hand = robot.frame_pose("larm_end").translation()
    return SimpleNamespace(
        r=robot,
        arm=arm,
        s=scene,
        q=robot.configuration.q.copy(),
        tgt=(p_hand + np.array([0.05, 0.0, 0.0]), np.array([1.0, 0.0, 0.0, 0.0])),
        files=files,
    )


def _q_with(c: Any, index: int, value: Any) -> np.ndarray:
    q = c.q.copy()
    q[index] = value
    return q


def ik(c: Any, **kw: Any) -> Any:
    kw.setdefault("limbs", ["larm"])
    return inverse_kinematics(c.r, kw.pop("targets", [c.tgt]), **kw)


def fik(c: Any, **kw: Any) -> Any:
    kw.setdefault("limbs", ["larm"])
    return fullbody_inverse_kinematics(c.r, kw.pop("targets", [c.tgt]), **kw)


def _json_object(_c: Any) -> Any:
    result = ScenarioResult("bad")
    result.figures["robot"] = object()
    return result.to_dict()


NAN, INF = math.nan, math.inf
I, U = InvalidInput, UnknownName
Z4 = [0.0, 0.0, 0.0, 0.0]

# fmt: off
API_CASES: list[Case] = [
    # -- Robot.from_model: model, environment, placement, keyframe, root body, limbs
    Case("model None", lambda c: Robot.from_model(None), I, r"model must be a model name, an MJCF path or a mujoco.MjSpec, got None"),
    Case("model int", lambda c: Robot.from_model(5), I, r"model must be .*MjSpec, got 5"),
    Case("model unknown name", lambda c: Robot.from_model("nope"), U, r"model 'nope' does not exist.*sample_humanoid"),
    Case("model empty", lambda c: Robot.from_model(""), U, r"model '' does not exist"),
    Case("model folder", lambda c: Robot.from_model(c.files.folder), I, r"model file .*folder' is a directory"),
    Case("model missing file", lambda c: Robot.from_model(c.files.tmp / "missing.xml"), I, r"missing.xml' does not exist"),
    Case("model not XML", lambda c: Robot.from_model(c.files.garbage), I, r"cannot parse MJCF file .*garbage.xml'.*XML"),
    Case("model XML not MJCF", lambda c: Robot.from_model(c.files.other), I, r"cannot parse MJCF file .*other.xml'.*html"),
    Case("model binary file", lambda c: Robot.from_model(str(c.files.binary)), I, r"cannot parse MJCF file .*binary.json'"),
    Case("environment int", lambda c: Robot.from_model("sample_humanoid", environment=5), I, r"environment must be .*, got 5"),
    Case("environment unknown", lambda c: Robot.from_model("sample_humanoid", environment="nope"), U, r"model 'nope' does not exist"),
    Case("environment clashing names", lambda c: Robot.from_model("sample_humanoid", environment="sample_humanoid"), I, r"cannot attach environment 'sample_humanoid'.*repeated name"),
    Case("keyframe float", lambda c: Robot.from_model("sample_humanoid", keyframe=5.0), I, r"keyframe must be a keyframe name \(a string\) or an index, got 5.0"),
    Case("keyframe index out of range", lambda c: Robot.from_model("sample_humanoid", keyframe=5), I, r"keyframe index 5 is out of range: the model has 1 keyframes \['reset_pose'\]"),
    Case("keyframe unknown", lambda c: Robot.from_model("sample_humanoid", keyframe="flying"), U, r"keyframe 'flying' does not exist. Valid keyframe names: \['reset_pose'\]"),
    Case("at NaN", lambda c: Robot.from_model("sample_humanoid", at=(NAN, 0, 0)), I, r"at must be a site name, or 3 or 4 finite numbers.*got \(nan, 0, 0\)"),
    Case("at two numbers", lambda c: Robot.from_model("sample_humanoid", at=(1, 2)), I, r"at must be .*3 or 4 finite numbers.*got \(1, 2\)"),
    Case("at overflow", lambda c: Robot.from_model("sample_humanoid", at=(1e300, 0, 0)), I, r"at must be .*within ±1e\+06, got \(1e\+300"),
    Case("at string numbers", lambda c: Robot.from_model("sample_humanoid", at=(0, 0, "a")), I, r"at must be a site name, \(x, y, yaw\).*'a'"),
    Case("at site without environment", lambda c: Robot.from_model("sample_humanoid", at="spot"), I, r"at='spot' names a site of an environment, but no environment is given"),
    Case("at unknown site", lambda c: Robot.from_model("sample_humanoid", environment="room", at="nosite"), U, r"site of the environment 'nosite' does not exist.*spot_counter_front"),
    Case("root_body int", lambda c: Robot.from_model("sample_humanoid", root_body=5), I, r"root_body must be a body name, got int"),
    Case("root_body unknown", lambda c: Robot.from_model("sample_humanoid", root_body="nope"), U, r"body 'nope' does not exist"),
    Case("limbs int", lambda c: Robot.from_model("sample_humanoid", limbs=5), I, r"limbs must be a mapping of names to Limb, got 5"),
    Case("source without model", lambda c: RobotSource.from_dict({"q": [0]}), I, r'a robot source needs "model"'),
    Case("source bad at", lambda c: RobotSource.from_dict({"model": "sample_humanoid", "at": [1, "x"]}), I, r'robot source "at" must be a site name or numbers'),
    # -- Robot state
    Case("angle vector NaN", lambda c: c.r.set_angle_vector([NAN] * 30), I, r"angle vector .* must be 30 finite numbers, got NaN or inf"),
    Case("angle vector text", lambda c: c.r.set_angle_vector("abc"), I, r"angle vector .* must be 30 finite numbers, got 'abc'"),
    Case("angle vector None", lambda c: c.r.set_angle_vector(None), I, r"angle vector .* got None"),
    Case("angle vector too short", lambda c: c.r.set_angle_vector([0.1, 0.2]), I, r"must be 30 finite numbers, got shape \(2,\)"),
    Case("angle vector overflow", lambda c: c.r.set_angle_vector([1e200], ["larm_elbow_p"]), I, r"joint 'larm_elbow_p' at 1e\+200 is beyond 1e\+06"),
    Case("angle vector names int", lambda c: c.r.set_angle_vector([0.1], 5), I, r"names \(of joints\) must be a list of names, got 5"),
    Case("angle vector names one string", lambda c: c.r.set_angle_vector([0.1], "larm_elbow_p"), I, r"names \(of joints\) must be a list of names, got 'larm_elbow_p'"),
    Case("angle vector unknown joint", lambda c: c.r.set_angle_vector([0.1], ["elbow"]), U, r"joint 'elbow' does not exist.*larm_elbow_p"),
    Case("angle vector free joint", lambda c: c.r.set_angle_vector([0.1], ["root"]), I, r"joint 'root' is a .*FREE joint; angle vectors hold only hinge and slide"),
    Case("angle vector names of ints", lambda c: c.r.angle_vector([3]), I, r"names \(of joints\)\[0\] must be a name \(a string\), got 3"),
    Case("root pose zero quaternion", lambda c: c.r.set_root_pose([0, 0, 1], Z4), I, r"quat_WB is a zero quaternion"),
    Case("root pose NaN", lambda c: c.r.set_root_pose([0, 0, NAN], [1, 0, 0, 0]), I, r"p_WB .* must be 3 finite numbers \[m\], got NaN"),
    Case("root pose quaternion of 3", lambda c: c.r.set_root_pose([0, 0, 1], [1, 0, 0]), I, r"quat_WB .* must be 4 finite numbers, got shape \(3,\)"),
    Case("root pose overflow", lambda c: c.r.set_root_pose([1e7, 0, 1], [1, 0, 0, 0]), I, r"p_WB .* is beyond 1e\+06 m"),
    Case("root pose of a fixed base", lambda c: c.arm.set_root_pose([0, 0, 1], [1, 0, 0, 0]), I, r"root body 'l1' has no free joint"),
    Case("frame unknown", lambda c: c.r.frame_pose("hand"), U, r"site 'hand' does not exist.*larm_end"),
    Case("frame not a string", lambda c: c.r.frame_pose(5), I, r"a frame name must be a string, got 5"),
    Case("frame type unknown", lambda c: c.r.frame_pose("larm_end", "joint"), I, r"frame_type 'joint' is not one of \['site', 'body', 'geom'\]"),
    Case("limb unknown", lambda c: c.r.limb("arm"), U, r"limb 'arm' does not exist.*'larm'"),
    Case("joint limits one string", lambda c: c.r.joint_limits("larm_elbow_p"), I, r"names \(of joints\) must be a list of names"),
    # -- Scene.from_robot and its options
    Case("scene of a non-robot", lambda c: Scene.from_robot(5), I, r"Scene.from_robot takes a pik_mj.Robot, got int"),
    Case("scene of a bare model", lambda c: Scene.from_robot(Robot(c.r.model)), I, r"made from a compiled MjModel and does not know its world"),
    Case("scene unknown option", lambda c: Scene.from_robot(c.r, timestamp=0.001), U, r"Scene option 'timestamp' does not exist.*'timestep'"),
    Case("scene timestep 0", lambda c: Scene.from_robot(c.r, timestep=0), I, r"timestep must be a finite number > 0 \[s\], got 0"),
    Case("scene timestep text", lambda c: Scene.from_robot(c.r, timestep="2ms"), I, r"timestep must be a finite number > 0 \[s\], got '2ms'"),
    Case("scene kp negative", lambda c: Scene.from_robot(c.r, kp=-1.0), I, r"kp of joint '\w+' must be a finite number > 0 \[N·m/rad\], got -1.0"),
    Case("scene kp text", lambda c: Scene.from_robot(c.r, kp="stiff"), I, r"kp of joint '\w+' must be a finite number > 0.*got 'stiff'"),
    Case("scene kp unknown joint", lambda c: Scene.from_robot(c.r, kp={"knee": 10.0}), U, r"joint 'knee' does not exist"),
    Case("scene kv NaN", lambda c: Scene.from_robot(c.r, kv=NAN), I, r"kv of joint '\w+' must be a finite number >= 0 \[N·m·s/rad\], got nan"),
    Case("scene allowed one string", lambda c: Scene.from_robot(c.r, allowed_contacts="lleg_sole"), I, r"allowed contacts \(robot geoms\) must be a list of names, got 'lleg_sole'"),
    Case("scene allowed unknown geom", lambda c: Scene.from_robot(c.r, allowed_contacts=["sole"]), U, r"robot geom 'sole' does not exist.*lleg_sole"),
    Case("scene impratio below 1", lambda c: Scene.from_robot(c.r, impratio=0.5), I, r"impratio must be a finite number >= 1, got 0.5"),
    Case("scene noslip bool", lambda c: Scene.from_robot(c.r, noslip_iterations=True), I, r"noslip_iterations must be an integer >= 0, got True"),
    Case("scene noslip negative", lambda c: Scene.from_robot(c.r, noslip_iterations=-1), I, r"noslip_iterations must be an integer >= 0, got -1"),
    Case("scene contact int", lambda c: Scene.from_robot(c.r, contact=5), I, r"contact must be a ContactParams or None, got 5"),
    Case("scene contact tolerance negative", lambda c: Scene.from_robot(c.r, contact_tolerance=-1e-3), I, r"contact_tolerance must be a finite number >= 0 \[m\], got -0.001"),
    Case("scene grasps int", lambda c: Scene.from_robot(c.r, grasps=5), I, r"grasps must be a list of grasps, got 5"),
    Case("scene grasp unknown body", lambda c: Scene.from_robot(c.r, grasps=[("larm_end", "kettle")]), U, r"free environment body 'kettle' does not exist"),
    Case("scene environment unknown", lambda c: Scene.from_robot(c.r, environment="nope"), U, r"model 'nope' does not exist"),
    Case("contact friction negative", lambda c: ContactParams(friction=-1.0), I, r"friction must be a finite number >= 0, got -1.0"),
    Case("contact condim 2", lambda c: ContactParams(condim=2), I, r"condim must be 1, 3, 4 or 6, got 2"),
    Case("contact solref of 1", lambda c: ContactParams(solref=(0.02,)), I, r"solref .* must be 2 finite numbers, got shape \(1,\)"),
    # -- HoldCriteria
    Case("criteria drift 0", lambda c: HoldCriteria(max_drift=0), I, r"max_drift must be a finite number > 0 \[m\], got 0"),
    Case("criteria drift text", lambda c: HoldCriteria(max_drift="1cm"), I, r"max_drift must be a finite number > 0 \[m\], got '1cm'"),
    Case("criteria slip None", lambda c: HoldCriteria(max_slip=None), I, r"max_slip must be a finite number > 0 \[m\], got None"),
    Case("criteria fall ratio 1.5", lambda c: HoldCriteria(fall_ratio=1.5), I, r"fall_ratio must be a finite number > 0 and < 1, got 1.5"),
    Case("criteria fall ratio NaN", lambda c: HoldCriteria(fall_ratio=NAN), I, r"fall_ratio must be .*got nan"),
    Case("criteria allowed int", lambda c: HoldCriteria(allowed=5), I, r"allowed \(robot geoms\) must be a list of names, got 5"),
    Case("criteria feet of ints", lambda c: HoldCriteria(feet=[5]), I, r"feet \(robot geoms\)\[0\] must be a name \(a string\), got 5"),
    Case("criteria slope negative", lambda c: HoldCriteria(max_ground_slope=-0.1), I, r"max_ground_slope must be a finite number >= 0 and <= 1.5708 \[rad\], got -0.1"),
    Case("criteria self contact text", lambda c: HoldCriteria(allow_self_contact="no"), I, r"allow_self_contact must be True or False, got 'no'"),
    Case("criteria stop on fall None", lambda c: HoldCriteria(stop_on_fall=None), I, r"stop_on_fall must be True or False, got None"),
    # -- Scene.hold
    Case("hold duration 0", lambda c: c.s.hold(c.q, 0), I, r"duration must be a finite number > 0 \[s\], got 0"),
    Case("hold duration text", lambda c: c.s.hold(c.q, "3 s"), I, r"duration must be a finite number > 0 \[s\], got '3 s'"),
    Case("hold duration inf", lambda c: c.s.hold(c.q, INF), I, r"duration must be a finite number > 0 \[s\], got inf"),
    Case("hold q of another robot", lambda c: c.s.hold(c.arm.configuration.q, 0.1), I, r"q \(the robot's configuration\) has shape \(3,\), but this model's configuration has 37 numbers: a pose of another model"),
    Case("hold q NaN", lambda c: c.s.hold(_q_with(c, 10, NAN), 0.1), I, r"joint '\w+' holds NaN or inf"),
    Case("hold q zero quaternion", lambda c: c.s.hold(np.r_[c.q[:3], Z4, c.q[7:]], 0.1), I, r"joint 'root' has a zero quaternion"),
    Case("hold q None", lambda c: c.s.hold(None, 0.1), I, r"q \(the robot's configuration\) must be 37 numbers \(the model's nq\), got None"),
    Case("hold criteria int", lambda c: c.s.hold(c.q, 0.1, criteria=5), I, r"criteria must be a HoldCriteria, got int"),
    Case("hold criteria unknown geom", lambda c: c.s.hold(c.q, 0.1, criteria=HoldCriteria(allowed=["sole"])), U, r"robot geom 'sole' does not exist"),
    Case("hold callback int", lambda c: c.s.hold(c.q, 0.1, callback=5), I, r"callback must be a callable or a list of callables .*got 5 \(int\)"),
    Case("hold external int", lambda c: c.s.hold(c.q, 0.1, external=5), I, r"external must be a list of \(frame, force \(3,\) \[N\], moment \(3,\) \[N·m\]\), got 5"),
    Case("hold external unknown frame", lambda c: c.s.hold(c.q, 0.1, external=[("hand", [0, 0, 1], [0, 0, 0])]), U, r"frame 'hand' does not exist"),
    Case("hold external NaN force", lambda c: c.s.hold(c.q, 0.1, external=[("larm_end", [NAN, 0, 0], [0, 0, 0])]), I, r"external\[0\] force at 'larm_end' must be 3 finite numbers \[N\], got NaN"),
    Case("hold external pair", lambda c: c.s.hold(c.q, 0.1, external=[("larm_end", [0, 0, 1])]), I, r"external\[0\] must be \(frame, force \(3,\) \[N\], moment \(3,\) \[N·m\]\), got \('larm_end', \[0, 0, 1\]\)"),
    Case("hold every 0", lambda c: c.s.hold(c.q, 0.1, every=0), I, r"every must be an integer >= 1, got 0"),
    Case("hold margin_every float", lambda c: c.s.hold(c.q, 0.1, margin_every=1.5), I, r"margin_every must be an integer >= 1, got 1.5"),
    # -- static check
    Case("static q too short", lambda c: c.s.static_check(c.q[:5]), I, r"has shape \(5,\), but this model's configuration has 37 numbers"),
    Case("static q overflow", lambda c: c.s.static_check(_q_with(c, 20, 1e200)), I, r"joint '\w+' is at \[1e\+200\], beyond 1e\+06"),
    Case("static mu negative", lambda c: c.s.static_check(c.q, mu=-0.5), I, r"mu must be a finite number >= 0, got -0.5"),
    Case("static mu text", lambda c: c.s.static_check(c.q, mu="high"), I, r"mu must be a finite number >= 0, got 'high'"),
    Case("static unknown option", lambda c: c.s.static_check(c.q, friction=1.0), U, r"static_check option 'friction' does not exist.*'mu'"),
    Case("static pyramid", lambda c: c.s.static_check(c.q, pyramid="square"), I, r"pyramid must be 'inscribed' or 'circumscribed', got 'square'"),
    Case("static external int", lambda c: c.s.static_check(c.q, external=5), I, r"external must be a list of \(frame, force"),
    Case("static slope NaN", lambda c: c.s.static_check(c.q, max_ground_slope=NAN), I, r"max_ground_slope must be .*got nan"),
    Case("static scfr text", lambda c: c.s.static_check(c.q, scfr="yes"), I, r"scfr must be True or False, got 'yes'"),
    Case("static checker mu", lambda c: c.s.static_checker(mu=-1.0), I, r"mu must be a finite number >= 0, got -1.0"),
    Case("set_pose text", lambda c: c.s.set_pose("standing"), I, r"q \(the robot's configuration\) must be 37 numbers .*got 'standing'"),
    # -- inverse_kinematics' own arguments
    Case("ik thre with unit", lambda c: ik(c, thre="1mm"), I, r"thre must be a finite number > 0 \[m\], got '1mm'"),
    Case("ik thre NaN", lambda c: ik(c, thre=NAN), I, r"thre must be a finite number > 0 \[m\], got nan"),
    Case("ik thre 0", lambda c: ik(c, thre=0.0), I, r"thre must be a finite number > 0 \[m\], got 0.0"),
    Case("ik rthre inf", lambda c: ik(c, rthre=INF), I, r"rthre must be a finite number > 0 \[rad\], got inf"),
    Case("ik thre per target", lambda c: ik(c, thre=[1e-3, NAN], targets=[c.tgt, c.tgt], limbs=["larm", "rarm"]), I, r"thre\[1\] must be a finite number > 0 \[m\], got nan"),
    Case("ik thre list too long", lambda c: ik(c, thre=[1e-3, 1e-3]), I, r"thre must be one value or a list of 1 \(one per target\)"),
    Case("ik zero quaternion", lambda c: ik(c, targets=[(c.tgt[0], Z4)]), I, r"targets\[0\] orientation is a zero quaternion"),
    Case("ik NaN position", lambda c: ik(c, targets=[([NAN, 0, 0], [1, 0, 0, 0])]), I, r"targets\[0\]: position must be 3 finite numbers"),
    Case("ik target text", lambda c: ik(c, targets="hand"), I, r"targets must be a pose .*got str"),
    Case("ik limbs int", lambda c: ik(c, limbs=5), I, r"limbs must be a list of names, got 5"),
    Case("ik limbs unknown", lambda c: ik(c, limbs=["arm"]), U, r"limb 'arm' does not exist.*'larm'"),
    Case("ik no limbs", lambda c: ik(c, limbs=None), I, r"give limbs=\[...\] or move_targets=\[...\].*'larm'"),
    Case("ik two limbs one target", lambda c: ik(c, limbs=["larm", "rarm"]), I, r"2 limbs \['larm', 'rarm'\] for 1 targets"),
    Case("ik move target unknown", lambda c: ik(c, limbs=None, move_targets=["hand"]), U, r"frame 'hand' does not exist"),
    Case("ik rotation axis", lambda c: ik(c, rotation_axis="w"), I, r"rotation_axis 'w' is not valid; use True/'t', None, 'x'"),
    Case("ik joints int", lambda c: ik(c, joints=5), I, r"joints must be a list of names, got 5"),
    Case("ik joints word", lambda c: ik(c, joints="some"), I, r"joints 'some': use None, 'chain', 'all' or a list of names"),
    Case("ik posture weight text", lambda c: ik(c, posture_weight="low"), I, r"posture_weight must be a finite number >= 0 \[cost/rad²\], got 'low'"),
    Case("ik posture task of another model", lambda c: ik(c, extra_levels=[[mink.PostureTask(c.arm.model, cost=1.0)]]), I, r"extra_levels\[0\]\[0\]: PostureTask was made for a model with nq=3, nv=3, but the robot has nq=37, nv=36"),
    Case("ik wrapped posture of another model", lambda c: ik(c, extra_levels=[[MinkTask(mink.PostureTask(c.arm.model, cost=1.0))]]), I, r"PostureTask was made for a model with nq=3"),
    Case("ik limit of another model", lambda c: ik(c, extra_levels=[[mink.ConfigurationLimit(c.arm.model)]]), I, r"ConfigurationLimit was made for a model with nq=3"),
    Case("ik extra levels int", lambda c: ik(c, extra_levels=5), I, r"extra_levels must be a list of lists of tasks"),
    Case("ik robot is a model", lambda c: inverse_kinematics(c.r.model, [c.tgt], limbs=["larm"]), I, r"robot must be a pik_mj.robot.Robot, got MjModel"),
    Case("ik unknown option", lambda c: ik(c, threshold=1e-3), U, r"inverse_kinematics option 'threshold' does not exist.*'thre'"),
    Case("ik look_at NaN", lambda c: ik(c, look_at=[NAN, 0, 1]), I, r"finite point \(3,\) \[m\], got \[nan, 0, 1\]"),
    Case("ik gaze axis zero", lambda c: ik(c, look_at=[1, 0, 1], gaze_axis=[0, 0, 0]), I, r"axis must be a non-zero 3-vector"),
    # -- fullbody_inverse_kinematics' own arguments
    Case("fik root bounds int", lambda c: fik(c, root_bounds=5), I, r"root_bounds must be \(lo \(6,\), hi \(6,\)\) or None, got 5"),
    Case("fik root bounds NaN", lambda c: fik(c, root_bounds=([NAN] * 6, [1] * 6)), I, r"root_bounds lo must be 6 finite numbers \[m, rad\], got NaN"),
    Case("fik root bounds inverted", lambda c: fik(c, root_bounds=([1] * 6, [0] * 6)), I, r"root_bounds must have lo <= hi"),
    Case("fik root weight zero", lambda c: fik(c, root_weight=[0] * 6), I, r"root_weight must be 6 positive numbers"),
    Case("fik centroid axes", lambda c: fik(c, centroid_axes="w"), I, r"centroid_axes 'w' is not valid"),
    Case("fik centroid target of 2", lambda c: fik(c, target_centroid_pos=[0.1, 0.2]), I, r"target_centroid_pos must be 3 finite numbers \[m\], got shape \(2,\)"),
    Case("fik centroid thre with unit", lambda c: fik(c, centroid_thre="1mm"), I, r"centroid_thre must be a finite number > 0 \[m\], got '1mm'"),
    Case("fik fix_feet int", lambda c: fik(c, fix_feet=5), I, r"fix_feet must be a list of names, got 5"),
    Case("fik fix_feet unknown", lambda c: fik(c, fix_feet=["foot"]), U, r"limb 'foot' does not exist"),
    Case("fik balance word", lambda c: fik(c, balance="zmp"), I, r"balance 'zmp': use 'centroid', 'support_polygon' or a list of tasks"),
    Case("fik balance int", lambda c: fik(c, balance=5), I, r"balance must be a task or a list of tasks, got 5"),
    Case("fik external forces int", lambda c: fik(c, external_forces=5), I, r"external_forces must be a list of \(frame, force \(3,\) \[N\], moment \(3,\) \[N·m\]\), got 5"),
    Case("fik centroid offset int", lambda c: fik(c, centroid_offset=5), I, r"centroid_offset must be a callable returning a point \[m\], got 5"),
    Case("fik both offsets", lambda c: fik(c, centroid_offset=lambda r: r.com(), external_forces=[]), I, r"give centroid_offset or external_forces, not both"),
    Case("fik fixed base", lambda c: fullbody_inverse_kinematics(c.arm, [c.tgt]), I, r"needs a floating base; root body 'l1' has no free joint"),
    Case("fik rthre NaN", lambda c: fik(c, rthre=NAN), I, r"rthre must be a finite number > 0 \[rad\], got nan"),
    Case("fik unknown option", lambda c: fik(c, stop_after=3), U, r"fullbody_inverse_kinematics option 'stop_after' does not exist.*'stop'"),
    Case("balance point height NaN", lambda c: static_balance_point(c.r, [], NAN), I, r"height must be a finite number \[m\], got nan"),
    Case("gaze angle zero axis", lambda c: gaze_angle(c.r, [1, 0, 1], [0, 0, 0]), I, r"axis must be a non-zero 3-vector"),
    Case("sole polygons unknown leg", lambda c: sole_polygons(c.r, ["leg"]), U, r"limb 'leg' does not exist"),
    # -- validate_pose (the API of pik-mj validate)
    Case("validate q NaN", lambda c: validate_pose("sample_humanoid", _q_with(c, 12, NAN), 0.1), I, r"q \(a pose of 'sample_humanoid'\): joint '\w+' holds NaN or inf"),
    Case("validate q of another model", lambda c: validate_pose("sample_humanoid", [0.1, 0.2, 0.3], 0.1), I, r"has shape \(3,\), but this model's configuration has 37 numbers: a pose of another model"),
    Case("validate zero quaternion", lambda c: validate_pose("sample_humanoid", np.r_[c.q[:3], Z4, c.q[7:]], 0.1), I, r"joint 'root' has a zero quaternion"),
    Case("validate q text", lambda c: validate_pose("sample_humanoid", ["a"] * 37, 0.1), I, r"q \(a pose of 'sample_humanoid'\) must be 37 numbers"),
    Case("validate unknown keyframe", lambda c: validate_pose("sample_humanoid", "flying", 0.1), U, r"keyframe 'flying' does not exist"),
    Case("validate source int", lambda c: validate_pose(5, None, 0.1), I, r'a robot source needs "model"'),
    Case("validate duration 0", lambda c: validate_pose("sample_humanoid", None, 0.0), I, r"duration must be a finite number > 0 \[s\], got 0.0"),
    # -- recordings and results written to files
    Case("recording to a folder", lambda c: Recorder.to_file(c.files.folder), I, r"recording '.*folder' is a directory"),
    Case("recording below a file", lambda c: Recorder.to_file(c.files.plain / "x.rrd"), I, r"recording '.*plain.txt/x.rrd' cannot be written"),
    Case("recording path int", lambda c: Recorder.to_file(5), I, r"recording must be a file path, got 5"),
    Case("recording path empty", lambda c: Recorder.to_file(""), I, r"recording must be a file path, got ''"),
    Case("result name int", lambda c: ScenarioResult(5), I, r"a scenario's name must be a non-empty string, got 5"),
    Case("result json to a folder", lambda c: ScenarioResult("x").to_json(c.files.folder), I, r"JSON summary '.*folder' is a directory"),
    Case("result json below a file", lambda c: ScenarioResult("x").to_json(c.files.plain / "x.json"), I, r"JSON summary '.*plain.txt/x.json' cannot be written"),
    Case("result figure not JSON", _json_object, I, r"ScenarioResult\['figures'\]\['robot'\] is a object, which JSON cannot hold"),
    Case("result check of an array", lambda c: ScenarioResult("x").check("feet", np.array([True, False])), I, r"check 'feet': ok must be True or False"),
    Case("jsonable of a function", lambda c: jsonable({"f": print}), I, r"value\['f'\] is a builtin_function_or_method, which JSON cannot hold"),
]
# fmt: on


def test_there_are_at_least_100_cases():
    assert len(API_CASES) + len(CLI_CASES) >= 100
    assert len(API_CASES) >= 100  # the API alone
    for names in ([c.name for c in API_CASES], [c[0] for c in CLI_CASES]):
        assert len(set(names)) == len(names)


@pytest.mark.parametrize("case", API_CASES, ids=_id)
def test_api_bad_input(case: Case, ctx):
    q_robot, q_arm = ctx.r.configuration.q.copy(), ctx.arm.configuration.q.copy()
    with pytest.raises(case.error) as raised:
        case.call(ctx)
    message = str(raised.value)
    assert type(raised.value) is case.error, f"{type(raised.value).__name__}: {message}"
    assert re.search(case.message, message), message
    assert "\n" not in message  # one line
    assert np.array_equal(ctx.r.configuration.q, q_robot)  # unchanged
    assert np.array_equal(ctx.arm.configuration.q, q_arm)


# (name, argv, message on stderr (regex)); "{tmp}" and "{<file>}" name the files
# of the `files` fixture, "{out}" a fresh folder that must stay empty.
# fmt: off
CLI_CASES: list[tuple[str, list[str], str]] = [
    # pik-mj itself
    ("no command", [], r"required: command"),
    ("unknown command", ["frobnicate"], r"invalid choice: 'frobnicate' \(choose from 'list', 'run', 'validate', 'screenshot', 'sweep'\)"),
    ("list with arguments", ["list", "all"], r"unrecognized arguments: all"),
    ("unknown scenario", ["run", "walking"], r"scenario 'walking' does not exist. Valid scenario names: \[.*'walk_forward'"),
    ("unknown option", ["run", "three_dof_reach", "--frob"], r"unrecognized arguments: --frob"),
    ("option of another scenario", ["run", "three_dof_reach", "--hold", "1"], r"unrecognized arguments: --hold 1"),
    # --model
    ("model unknown", ["run", "--model", "nope"], r"argument --model: model 'nope' does not exist. Models for this scenario \(a left arm, two legs, a floating base\): \['sample_humanoid', 'dm_humanoid', 'dm_humanoid_cmu'\], the MuJoCo Menagerie humanoids \[.*'unitree_g1'.*\], or an MJCF path$"),
    ("model misspelt", ["run", "kettle", "--model", "unitree_g"], r"model 'unitree_g' does not exist \(did you mean 'unitree_g1'"),
    ("arm model unknown", ["run", "three_dof_reach", "--model", "nope"], r"Models for this scenario \(an arm, a fixed base\): \['three_dof_arm'\], the MuJoCo Menagerie arms \[.*'franka_emika_panda'"),
    ("model missing value", ["run", "--model"], r"argument --model: expected one argument"),
    ("model not XML", ["run", "--model", "{garbage}"], r"argument --model: cannot parse MJCF file '.*garbage.xml': XML parse error"),
    ("model XML not MJCF", ["run", "--model", "{other}"], r"argument --model: cannot parse MJCF file .*other.xml"),
    ("model missing file", ["run", "--model", "{tmp}/missing.xml"], r"argument --model: model file '.*missing.xml' does not exist"),
    ("model folder", ["run", "--model", "{folder}/"], r"argument --model: model file '.*folder' is a directory"),
    ("model without the limbs", ["run", "--model", "three_dof_arm"], r"argument --model: model 'three_dof_arm' has no limb rleg, lleg, larm, which this scenario moves \(its limbs: arm\)"),
    # output files, checked before any work
    ("json to a folder", ["run", "three_dof_reach", "--json", "{folder}"], r"argument --json: '.*folder' is a directory"),
    ("json below a file", ["run", "three_dof_reach", "--json", "{plain}/x.json"], r"argument --json: '.*plain.txt/x.json' cannot be written: '.*plain.txt' is a file"),
    ("save to a folder", ["run", "three_dof_reach", "--save", "{folder}"], r"argument --save: '.*folder' is a directory"),
    ("save below a file", ["run", "three_dof_reach", "--save", "{plain}/x.rrd"], r"argument --save: '.*plain.txt/x.rrd' cannot be written: '.*plain.txt' is a file"),
    ("save empty", ["run", "three_dof_reach", "--save", ""], r"argument --save: must be a file path, got ''"),
    ("json and save the same", ["run", "three_dof_reach", "--save", "{out}/r.rrd", "--json", "{out}/r.rrd"], r"--save and --json name the same file"),
    ("json below a file, model run", ["run", "--json", "{plain}/x.json", "--save", "{out}/r.rrd"], r"argument --json: .*cannot be written"),
    # numbers
    ("hold negative", ["run", "--hold", "-1"], r"argument --hold: a duration must be a finite number >= 0 \[s\], got -1.0"),
    ("hold NaN", ["run", "--hold", "nan"], r"argument --hold: a duration must be a finite number >= 0 \[s\], got nan"),
    ("hold word", ["run", "--hold", "long"], r"argument --hold: a duration must be .*got 'long'"),
    ("steps 0", ["run", "walk_forward", "--steps", "0"], r"argument --steps: a count must be an integer >= 1, got 0"),
    ("steps fraction", ["run", "cocktail_shaker", "--steps", "1.5"], r"argument --steps: a count must be an integer >= 1, got '1.5'"),
    ("dt NaN", ["run", "walk_forward", "--dt", "nan"], r"argument --dt: a value must be a finite number > 0, got nan"),
    ("dt negative", ["run", "walk_go_pos", "--dt", "-0.01"], r"argument --dt: a value must be a finite number > 0, got -0.01"),
    ("goal inf", ["run", "walk_go_pos", "--x", "inf"], r"argument --x: a value must be a finite number, got inf"),
    # recording destination
    ("viewer address", ["run", "--connect", "--url", "nope"], r"--url 'nope' is not a rerun viewer URL"),
    # validate
    ("validate without file", ["validate"], r"the following arguments are required: file"),
    ("validate missing file", ["validate", "{tmp}/missing.json"], r"pose file '.*missing.json' does not exist"),
    ("validate folder", ["validate", "{folder}"], r"pose file '.*folder' is a directory; give a JSON file"),
    ("validate binary file", ["validate", "{binary}"], r"pose file '.*binary.json' is not text \(a binary file\?\)"),
    ("validate not JSON", ["validate", "{not_json}"], r"pose file '.*not_json.json' is not JSON"),
    ("validate no pose", ["validate", "{no_pose}"], r"pose file '.*no_pose.json' holds no pose"),
    ("validate pose too short", ["validate", "{short}"], r"q \(a pose of 'sample_humanoid'\) has shape \(7,\), but this model's configuration has 37 numbers: a pose of another model"),
    ("validate pose of another robot", ["validate", "{arm_pose}"], r"has shape \(3,\), but this model's configuration has 37 numbers: a pose of another model"),
    ("validate NaN", ["validate", "{nan}"], r"joint 'root' holds NaN or inf"),
    ("validate strings", ["validate", "{strings}"], r'pose file .*strings.json\': "q" must be a list of numbers'),
    ("validate zero quaternion", ["validate", "{zero_quat}"], r"joint 'root' has a zero quaternion"),
    ("validate unknown model", ["validate", "{unknown_model}"], r"model 'no_such_robot' does not exist"),
    ("validate site without room", ["validate", "{site_without_room}"], r"at='spot_counter_front' names a site of an environment"),
    ("validate unknown keyframe", ["validate", "{bad_keyframe}"], r"keyframe 'flying' does not exist"),
    ("validate duration 0", ["validate", "{good}", "--duration", "0"], r"--duration \[s\]: a value must be a finite number > 0, got 0.0"),
    ("validate duration NaN", ["validate", "{good}", "--duration", "nan"], r"--duration \[s\]: a value must be a finite number > 0, got nan"),
    ("validate json to a folder", ["validate", "{good}", "--json", "{folder}"], r"--json '.*folder' is a directory"),
    ("validate save below a file", ["validate", "{good}", "--save", "{plain}/x.rrd"], r"--save '.*plain.txt/x.rrd' cannot be written: '.*plain.txt' is a file"),
    ("validate unknown environment", ["validate", "{good}", "--environment", "kitchen"], r"model 'kitchen' does not exist"),
    # sweep: checked before Ray starts or the sweep directory is made
    ("sweep without directory", ["sweep"], r"the following arguments are required: out"),
    ("sweep grid count", ["sweep", "{out}/s", "--grid", "x=0.1:0.5", "y=0", "z=1"], r"--grid 'x=0.1:0.5': A:B:N needs a whole count N >= 1"),
    ("sweep grid word", ["sweep", "{out}/s", "--grid", "x=a,b", "y=0", "z=1"], r"--grid 'x=a,b': each value must be a finite number, got 'a'"),
    ("sweep grid NaN", ["sweep", "{out}/s", "--grid", "x=nan", "y=0", "z=1"], r"--grid 'x=nan': each value must be a finite number, got nan"),
    ("sweep grid no values", ["sweep", "{out}/s", "--grid", "x", "y=0", "z=1"], r"--grid 'x': expected NAME=VALUES"),
    ("sweep grid axis twice", ["sweep", "{out}/s", "--grid", "x=0.3", "x=0.4", "y=0", "z=1"], r"--grid names 'x' twice"),
    ("sweep unknown parameter", ["sweep", "{out}/s", "--grid", "w=1", "x=0.3", "y=0", "z=1"], r"unknown sweep parameter 'w'; valid parameters: x \(hand target x \[m\]"),
    ("sweep target incomplete", ["sweep", "{out}/s", "--grid", "x=0.3", "y=0"], r"the sweep's space must set \['z'\]"),
    ("sweep grid and random", ["sweep", "{out}/s", "--grid", "x=0.3", "--random", "5"], r"argument --random: not allowed with argument --grid"),
    ("sweep range without random", ["sweep", "{out}/s", "--range", "x=0:1"], r"--range goes with --random"),
    ("sweep range inverted", ["sweep", "{out}/s", "--random", "5", "--range", "x=0.7:0.2", "y=0", "z=1"], r"range of 'x' is inverted: low 0.7 > high 0.2"),
    ("sweep random 0", ["sweep", "{out}/s", "--random", "0"], r"argument --random: a count must be an integer >= 1, got 0"),
    ("sweep hold 0", ["sweep", "{out}/s", "--hold", "0"], r"argument --hold: a value must be a finite number > 0, got 0.0"),
    ("sweep seed negative", ["sweep", "{out}/s", "--seed", "-1"], r"argument --seed: a seed must be an integer >= 0, got -1"),
    ("sweep workers fraction", ["sweep", "{out}/s", "--workers", "1.5"], r"argument --workers: a count must be an integer >= 1, got '1.5'"),
    ("sweep batch size 0", ["sweep", "{out}/s", "--batch-size", "0"], r"argument --batch-size: a count must be an integer >= 1, got 0"),
    ("sweep unknown stack", ["sweep", "{out}/s", "--stack", "tiptoe"], r"argument --stack: invalid choice: 'tiptoe' \(choose from 'balanced', 'unbalanced'\)"),
    ("sweep unknown axis", ["sweep", "{out}/s", "--across", "w"], r"argument --across: invalid choice: 'w'"),
    ("sweep unknown robot", ["sweep", "{out}/s", "--robot", "nope"], r"model 'nope' does not exist. Valid model names:"),
    ("sweep robot without feet", ["sweep", "{out}/s", "--robot", "three_dof_arm"], r"model 'three_dof_arm' has no floating base"),
    ("sweep unknown hand", ["sweep", "{out}/s", "--hand", "rhand"], r"limb 'rhand' does not exist. Valid limb names: \[.*'rarm'"),
    ("sweep directory is a file", ["sweep", "{plain}"], r"'.*plain.txt' exists and is not an empty directory"),
    ("sweep directory below a file", ["sweep", "{plain}/s"], r"'.*plain.txt/s' cannot be made: '.*plain.txt' is a file"),
    ("sweep resume of nothing", ["sweep", "{out}/s", "--resume"], r"'.*s' holds no sweep to resume \(sweep.json is missing\)"),
    ("sweep png to a folder", ["sweep", "{out}/s", "--png", "{folder}"], r"argument --png: '.*folder' is a directory"),
    ("sweep rrd below a file", ["sweep", "{out}/s", "--rrd", "{plain}/m.rrd"], r"argument --rrd: '.*plain.txt/m.rrd' cannot be written: '.*plain.txt' is a file"),
    ("sweep workers above CPUs", ["sweep", "{out}/s", "--workers", "3", "--num-cpus", "2"], r"--workers 3 but --num-cpus 2: each worker takes a CPU"),
    ("sweep CPUs of a cluster", ["sweep", "{out}/s", "--num-cpus", "2", "--address", "head:6379"], r"--num-cpus sizes a local Ray instance; leave it out with --address"),
]
# fmt: on


def _argv(argv: list[str], files: SimpleNamespace, out: Path) -> list[str]:
    names = {k: str(v) for k, v in vars(files).items()} | {"out": str(out)}
    return [a.format(**names) for a in argv]


@pytest.mark.parametrize(("name", "argv", "message"), CLI_CASES, ids=[c[0] for c in CLI_CASES])
def test_cli_usage_error(name, argv, message, files, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # `run` would record into ./out
    out = tmp_path / "outputs"
    out.mkdir()
    assert cli.main(_argv(argv, files, out)) == 2
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    errors = [line for line in captured.err.splitlines() if "error:" in line]
    assert len(errors) == 1, captured.err  # one line says what was wrong
    assert re.search(message, errors[0]), errors[0]
    assert "iteration" not in captured.err  # no solve started
    assert not any(out.iterdir()) and not (tmp_path / "out").exists()  # nothing written
    assert sorted(p.name for p in files.folder.iterdir()) == []


def test_cli_usage_errors_in_a_real_process(files, tmp_path):
    """The same answers from ``python -m pik_mj.cli`` (the console script's code)."""
    cases = {
        "model unknown": ["run", "--model", "nope"],
        "validate folder": ["validate", str(files.folder)],
        "json to a folder": ["run", "three_dof_reach", "--json", str(files.folder)],
    }
    procs = {
        name: subprocess.Popen(
            [sys.executable, "-m", "pik_mj.cli", *argv],
            cwd=tmp_path,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for name, argv in cases.items()
    }
    expected = {c[0]: c[2] for c in CLI_CASES}
    for name, proc in procs.items():
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 2, err
        assert "Traceback" not in err
        assert re.search(expected[name], err), err
    assert not (tmp_path / "out").exists()


def test_validate_names_the_joints_outside_their_range(tmp_path, capsys):
    """Elbows at +0.5 rad where the range is [-2.5, 0]: FAILED (exit 1, not a usage
    error), each joint named with its excess; the API says the same."""
    robot = Robot.from_model("sample_humanoid")
    assert [float(x[0]) for x in robot.joint_limits(["larm_elbow_p"])] == [-2.5, 0.0]
    robot.set_angle_vector([0.5, -2.6], ["larm_elbow_p", "rarm_elbow_p"])
    pose = tmp_path / "elbows.json"
    pose.write_text(json.dumps({"model": "sample_humanoid", "q": robot.configuration.q.tolist()}))
    assert cli.main(["validate", str(pose), "--duration", "0.2"]) == 1
    out = capsys.readouterr().out
    assert "joint 'larm_elbow_p' at 0.5 rad is 0.5 rad above its range [-2.5, 0] rad" in out
    assert "joint 'rarm_elbow_p' at -2.6 rad is 0.1 rad below its range [-2.5, 0] rad" in out
    assert out.rstrip().splitlines()[-1].startswith("FAILED")
    report = validate_pose("sample_humanoid", robot.configuration.q, 0.2)
    assert not report["passed"]
    assert [(v["joint"], v["unit"]) for v in report["joint_limits"]] == [
        ("rarm_elbow_p", "rad"),
        ("larm_elbow_p", "rad"),
    ]
    excess = {v["joint"]: v["excess"] for v in report["joint_limits"]}
    assert excess == pytest.approx({"larm_elbow_p": 0.5, "rarm_elbow_p": 0.1}, abs=1e-12)
    # the same pose within its range passes the limit check (and the hold)
    robot.set_angle_vector([-0.5, -0.5], ["larm_elbow_p", "rarm_elbow_p"])
    report = validate_pose("sample_humanoid", robot.configuration.q, 0.2)
    assert report["joint_limits"] == [] and report["passed"]


BUGGY = '''
    """A scenario whose own code passes pik_mj a bad argument."""
    from pik_mj import Robot
    from pik_mj.scenario import ScenarioResult, open_recorder, parser, report


    def run(recorder):
        Robot.from_model("sample_humanoid").limb("tail")  # the script's bug, not the user's
        return ScenarioResult("buggy")


    def main(argv=None):
        args = parser(__doc__, hold=False).parse_args(argv)
        with open_recorder(args, "buggy") as recorder:
            result = run(recorder)
        return report(result, args)
'''


def test_a_scenario_that_raises_is_not_a_usage_error(tmp_path, monkeypatch, capsys):
    """Bad input from the scenario's own code (not from the command line) is the
    scenario's failure: its traceback and exit 1, the recording up to the error."""
    add_scenario(monkeypatch, tmp_path, "buggy", BUGGY)
    rrd = tmp_path / "buggy.rrd"
    assert cli.main(["run", "buggy", "--save", str(rrd)]) == 1
    captured = capsys.readouterr()
    assert "Traceback (most recent call last)" in captured.err
    assert "pik-mj: scenario buggy raised UnknownName: limb 'tail' does not exist" in captured.err
    assert f"recording (up to the error): {rrd}" in captured.out
