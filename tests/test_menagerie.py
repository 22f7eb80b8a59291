"""Menagerie robots by name (pik_mj.robot.loading): a fake Menagerie tree and cache, then the
real robots when this machine has them (MENAGERIE_ROOT or the package's cache)."""

from __future__ import annotations

import json

import mujoco
import mujoco_menagerie
import numpy as np
import pytest
from local_menagerie import menagerie_model, requires_menagerie

from pik_mj.exceptions import InvalidInput, UnknownName
from pik_mj.robot.loading import (
    load_model,
    load_spec,
    menagerie_available,
    menagerie_models,
    model_path,
)

# Two bodies with one hinge / three bodies with two hinges: told apart by nv.
_ROBOT = """<mujoco model="{name}"><compiler angle="radian"/><worldbody>
<body name="base">{bodies}</body></worldbody></mujoco>"""
_LINK = '<body name="l{i}" pos="0 0 0.1"><joint name="j{i}"/><geom size="0.02"/>{rest}</body>'


def _write_robot(folder, file: str, links: int) -> None:
    bodies = ""
    for i in reversed(range(links)):
        bodies = _LINK.format(i=i, rest=bodies)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / file).write_text(_ROBOT.format(name=file, bodies=bodies))


@pytest.fixture
def fake_root(tmp_path, monkeypatch):
    """A Menagerie checkout holding only unitree_g1 (g1.xml and g1_with_hands.xml)."""
    _write_robot(tmp_path / "unitree_g1", "g1.xml", 1)
    _write_robot(tmp_path / "unitree_g1", "g1_with_hands.xml", 2)
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    return tmp_path


def test_name_resolves_to_default_model_under_root(fake_root):
    assert model_path("unitree_g1") == (fake_root / "unitree_g1" / "g1.xml").resolve()
    assert load_model("unitree_g1").nv == 1
    assert load_spec("unitree_g1").compile().nv == 1


def test_entry_point_after_colon(fake_root):
    path = model_path("unitree_g1:g1_with_hands")
    assert path == (fake_root / "unitree_g1" / "g1_with_hands.xml").resolve()
    assert load_model("unitree_g1:g1_with_hands").nv == 2


def test_unknown_entry_point_lists_the_robots_entry_points(fake_root):
    with pytest.raises(UnknownName) as err:
        model_path("unitree_g1:g2")
    assert set(err.value.valid) == set(mujoco_menagerie.get("unitree_g1").entry_names)
    assert "g1_with_hands" in str(err.value)


def test_robot_missing_under_root_says_where_it_looked(fake_root):
    assert not menagerie_available("booster_t1")
    assert menagerie_available("unitree_g1")
    with pytest.raises(InvalidInput) as err:
        load_model("booster_t1")
    message = str(err.value)
    assert "booster_t1" in message and str(fake_root) in message
    assert "MENAGERIE_ROOT" in message


def test_cached_robot_without_root(tmp_path, monkeypatch):
    """The package's cache layout: models/<name>-<oid16>/ published with a .complete file."""
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    monkeypatch.setenv("MENAGERIE_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("MENAGERIE_BASE_URL", (tmp_path / "no_server").as_uri())
    robot = mujoco_menagerie.get("booster_t1")
    folder = tmp_path / "cache" / "models" / f"booster_t1-{robot.oid[:16]}"
    _write_robot(folder, "t1.xml", 3)
    assert not menagerie_available("booster_t1")  # not published yet
    (folder / ".complete").write_text(json.dumps({"oid": robot.oid, "files": {}}))
    assert menagerie_available("booster_t1")
    assert model_path("booster_t1") == (folder / "t1.xml").resolve()
    assert load_model("booster_t1").nv == 3


def test_not_cached_and_no_download_is_a_clear_error(tmp_path, monkeypatch):
    """No MENAGERIE_ROOT, an empty cache and a base URL that serves nothing (no
    network is touched: the package reads file:// URLs)."""
    monkeypatch.delenv("MENAGERIE_ROOT", raising=False)
    monkeypatch.setenv("MENAGERIE_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("MENAGERIE_BASE_URL", (tmp_path / "no_server").as_uri())
    with pytest.raises(InvalidInput) as err:
        model_path("unitree_h1")
    message = str(err.value)
    assert "unitree_h1" in message and str(tmp_path / "cache") in message
    assert "MENAGERIE_ROOT" in message and "prefetch unitree_h1" in message


def test_unknown_name_suggests_menagerie_robots(fake_root):
    with pytest.raises(UnknownName) as err:
        model_path("unitree_g2")
    assert err.value.kind == "model"
    assert "unitree_g1" in err.value.valid and "sample_humanoid" in err.value.valid
    assert "menagerie_models()" in str(err.value)


def test_menagerie_names_without_io():
    humanoids = menagerie_models("humanoid")
    assert {"unitree_g1", "unitree_h1", "booster_t1", "pal_talos"} <= set(humanoids)
    assert set(humanoids) < set(menagerie_models())


@pytest.mark.parametrize(
    ("name", "nq", "nv", "nbody"),
    [("unitree_g1", 36, 35, 31), ("unitree_h1", 26, 25, 21), ("booster_t1", 30, 29, 25)],
)
def test_real_menagerie_humanoids_load(name, nq, nv, nbody):
    model = menagerie_model(name)
    assert (model.nq, model.nv, model.nbody) == (nq, nv, nbody)
    # the robot alone: no floor plane of the robot's scene.xml
    assert mujoco.mjtGeom.mjGEOM_PLANE not in set(model.geom_type)


# ------------------------------------------------ the robots end to end (issue 14)
def test_fullbody_reach_runs_on_unitree_g1(tmp_path, capsys):
    """``pik-mj run fullbody_reach --model unitree_g1``: limbs, standing keyframe and
    soles found, its own position actuators as servos; every check and the 3 s
    hold pass, with nothing written by the user."""
    requires_menagerie("unitree_g1")
    from pik_mj import cli

    js = tmp_path / "g1.json"
    args = ["run", "fullbody_reach", "--model", "unitree_g1", "--headless", "--quiet"]
    code = cli.main([*args, "--json", str(js)])
    out = capsys.readouterr().out
    assert code == 0, out
    summary = json.loads(js.read_text())
    assert summary["passed"] and summary["balance"]["hold"]["passed"]
    assert summary["balance"]["hold"]["simulated"] == pytest.approx(3.0)
    assert summary["balance"]["hold"]["drift"] < 2e-3
    assert summary["figures"]["hand_error_m"] < 1e-3


@pytest.mark.parametrize(
    ("name", "own_servos", "joint"),
    [("unitree_h1", 0, "left_elbow"), ("booster_t1", 23, "Left_Elbow_Pitch")],
)
def test_servos_of_h1_and_t1(name, own_servos, joint):
    """H1 ships motors: the scene adds servos with kp = ω² M_jj (checked against
    mj_fullM at the start pose); T1 ships position actuators: they are its servos.
    Either way an elbow bent 0.3 rad more is held there in physics."""
    requires_menagerie(name)
    from pik_mj import Robot, Scene
    from pik_mj.sim.servos import DEFAULT_BANDWIDTH

    robot = Robot.from_model(name)
    scene = Scene.from_robot(robot)
    assert len(scene.robot_servos) == own_servos
    assert set(scene.servo_joints) == set(robot.joint_names)
    if not own_servos:
        data = mujoco.MjData(robot.model)
        data.qpos[:] = robot.start_q()
        mujoco.mj_forward(robot.model, data)
        M = np.zeros((robot.model.nv, robot.model.nv))
        mujoco.mj_fullM(robot.model, data, M)
        dof = robot.model.joint(joint).dofadr[0]
        kp, kv = scene.servo_gains[joint]
        assert kp == pytest.approx(DEFAULT_BANDWIDTH**2 * M[dof, dof], rel=1e-9)
        assert kv == pytest.approx(2 * DEFAULT_BANDWIDTH * M[dof, dof], rel=1e-9)
    q = robot.configuration.q.copy()
    adr = robot.model.joint(joint).qposadr[0]
    q[adr] += 0.3
    report = scene.hold(q, 1.0)
    assert report.passed, report.failures
    assert scene.data.qpos[adr] == pytest.approx(q[adr], abs=5e-3)
