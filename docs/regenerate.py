"""Regenerate the documentation's scenario figures and pictures from current runs.

For each scenario: ``pik-mj run NAME --json out/runs/NAME.json --save
out/runs/NAME.rrd``, then

* ``docs/scenarios/figures/NAME.md``: the run's figures as a table (the JSON
  summary's checks, solves, motion, hold and the scenario's own figures),
  included by the scenario's page;
* ``docs/images/*.png``: pictures of the recording by rerun's headless viewer
  (:mod:`pik_mj.record.screenshot`). They need a Vulkan driver (without a GPU,
  Debian's ``mesa-vulkan-drivers libvulkan1``); without one the figures are still
  written and the command says what to install, exit 1.

::

    python docs/regenerate.py                     # every scenario: figures and pictures
    python docs/regenerate.py kettle walk_forward # some
    python docs/regenerate.py --no-images         # figures only
    python docs/regenerate.py --reuse             # from the runs in out/runs (pictures)
    MENAGERIE_ROOT=... python docs/regenerate.py --menagerie  # and Menagerie robots' pictures

The sweep picture (``docs/images/sweep_reach.png``) takes about ten minutes on two
cores: ``python docs/regenerate.py --sweep`` runs the sweep of
``docs/sweeps.md`` and copies its ``map.png``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pik_mj.scenarios import SCENARIOS

from pik_mj.record import screenshot

DOCS = Path(__file__).resolve().parent
IMAGES = DOCS / "images"
FIGURES = DOCS / "scenarios" / "figures"
PIK_MJ = [sys.executable, "-m", "pik_mj.cli"]

#: The sweep behind docs/images/sweep_reach.png (docs/sweeps.md shows the command).
SWEEP = ["--grid", "x=0.1:0.8:8", "y=-0.4,-0.2,0,0.2", "z=0.1:1.5:15", "--workers", "2"]


@dataclass(frozen=True)
class Picture:
    """A picture of a scenario's recording: :class:`pik_mj.record.screenshot.Shot`
    options, the time possibly a fraction of the motion's duration."""

    file: str
    time: float | str | Callable[[dict[str, Any]], float] = "last"
    timeline: str | None = None
    tab: str | None = None
    view: str | None = None
    size: tuple[int, int] = (1400, 800)


def _motion_fraction(fraction: float) -> Callable[[dict[str, Any]], float]:
    """A time [s] on ``sim_time``: ``fraction`` of the run's motion."""
    return lambda summary: fraction * float(summary["motion"]["duration"])


PICTURES: dict[str, list[Picture]] = {
    "three_dof_reach": [Picture("three_dof_reach.png", size=(1000, 700))],
    "cocktail_shaker": [Picture("cocktail_shaker.png", "last", "sim_time", tab="motion")],
    "fullbody_reach": [
        Picture("fullbody_reach.png"),
        Picture("fullbody_reach_errors.png", view="level 2", size=(1000, 450)),
    ],
    "fullbody_external_force": [Picture("fullbody_external_force.png")],
    "kettle": [Picture("kettle_motion.png", "last", "sim_time", tab="motion")],
    "wall_contact": [Picture("wall_contact.png", "last", "sim_time", tab="motion")],
    "obstacle_reach": [
        Picture("obstacle_reach_motion.png", _motion_fraction(0.6), "sim_time", tab="motion")
    ],
    "walk_forward": [Picture("walk_forward.png", _motion_fraction(0.33), "sim_time")],
    "walk_go_pos": [Picture("walk_go_pos.png", "last", "sim_time")],
}

#: Pictures of scenarios run on MuJoCo Menagerie robots (``--menagerie``; the robots
#: are found through MENAGERIE_ROOT): (scenario, model) -> pictures.
MENAGERIE_PICTURES: dict[tuple[str, str], list[Picture]] = {
    ("walk_forward", "unitree_g1"): [
        Picture("walk_forward_unitree_g1.png", _motion_fraction(0.4), "sim_time")
    ],
    ("walk_go_pos", "booster_t1"): [Picture("walk_go_pos_booster_t1.png", "last", "sim_time")],
}


def run_scenario(name: str, out: Path, model: str | None = None) -> dict[str, Any]:
    """``pik-mj run NAME [--model MODEL]`` with its JSON summary and recording in
    ``out`` (``NAME.json``, ``NAME.rrd``; ``NAME-MODEL.*`` with a model); the summary."""
    stem = name if model is None else f"{name}-{model}"
    json_path, rrd = out / f"{stem}.json", out / f"{stem}.rrd"
    command = [*PIK_MJ, "run", name, "--json", str(json_path), "--save", str(rrd), "--quiet"]
    command += [] if model is None else ["--model", model]
    print("+", " ".join(command[2:]), flush=True)
    done = subprocess.run(command, check=False, capture_output=True, text=True)
    if not json_path.is_file():
        raise SystemExit(f"{name}: no JSON summary (exit {done.returncode}):\n{done.stderr}")
    return json.loads(json_path.read_text())


def _number(value: float, unit: str) -> str:
    scale = {"mm": 1e3, "mrad": 1e3}.get(unit, 1.0)
    v = value * scale
    text = f"{v:.3g}" if abs(v) < 1000 else f"{v:.0f}"
    return f"{text} {unit}".strip()


_UNITS = {"_m": "mm", "_rad": "mrad", "_n": "N", "_s": "s", "_ms": "ms", "_kg": "kg", "_deg": "°"}


def _value(key: str, value: Any) -> str:
    """A figure of the JSON summary as text: numbers with the unit their key's
    suffix names (metres shown in mm, radians in mrad), lists element-wise."""
    unit = next((u for s, u in _UNITS.items() if key.lower().endswith(s)), "")
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return str(value)
    if isinstance(value, (int, float)):
        return _number(float(value), unit)
    if isinstance(value, list) and all(isinstance(v, (int, float)) for v in value):
        scale = 1e3 if unit in ("mm", "mrad") else 1.0
        return "(" + ", ".join(f"{v * scale:.3g}" for v in value) + f") {unit}".rstrip()
    return f"`{json.dumps(value)[:120]}`"


def _motion_rows(motion: dict[str, Any]) -> list[tuple[str, str]]:
    tracking = motion.get("max_tracking_error") or {}
    rows = [
        ("motion", "PASSED" if motion.get("passed") else "FAILED"),
        ("motion duration (simulated)", f"{motion['duration']:.2f} s"),
        ("largest tracking error", ", ".join(_value(k, v) for k, v in tracking.items())),
        ("largest root drift", _value("_m", motion.get("max_drift"))),
        ("largest foot slip", _value("_m", motion.get("max_slip"))),
    ]
    if motion.get("min_com_margin") is not None:
        rows.append(("smallest CoM margin", _value("_m", motion["min_com_margin"])))
    if motion.get("min_zmp_margin") is not None:
        rows.append(("smallest ZMP margin", _value("_m", motion["min_zmp_margin"])))
    unexpected = (motion.get("contacts") or {}).get("unexpected") or []
    rows.append(("fell / unexpected contacts", f"{motion.get('fell')} / {len(unexpected)}"))
    return rows


def _hold_rows(balance: dict[str, Any]) -> list[tuple[str, str]]:
    hold, static = balance.get("hold") or {}, balance.get("static") or {}
    rows = [("final pose held", "PASSED" if balance.get("passed") else "FAILED")]
    if static:
        rows.append(
            (
                "static equilibrium, CoM margin",
                f"{static.get('feasible')}, {_value('_m', static.get('margin'))}",
            )
        )
    if hold:
        rows.append(
            (
                f"hold {hold.get('duration')} s: drift, slip",
                f"{_value('_m', hold.get('drift'))}, {_value('_m', hold.get('slip'))}",
            )
        )
    return rows


#: Figures that time the machine, not the robot: left out of the pages.
MACHINE_TIMES = ("_ms", "_time_s", "wall_time")


def figures_page(summary: dict[str, Any]) -> str:
    """The Markdown table of a scenario's JSON summary."""
    rows = [("verdict", "PASSED" if summary.get("passed") else "FAILED")]
    model = (summary.get("figures") or {}).get("model") or (summary.get("robot") or {}).get("model")
    if model:
        rows.append(("robot", f"`{model}`"))
    for label, solve in (summary.get("solves") or {}).items():
        state = "converged" if solve.get("converged") else "not converged"
        rows.append((f"solve `{label}`", f"{state}, {solve.get('iterations')} iterations"))
    if summary.get("motion"):
        rows += _motion_rows(summary["motion"])
    if summary.get("balance"):
        rows += _hold_rows(summary["balance"])
    for key, value in (summary.get("figures") or {}).items():
        if key != "model" and not key.endswith(MACHINE_TIMES):
            rows.append((f"`{key}`", _value(key, value)))
    lines = ["| figure | value |", "| --- | --- |"]
    lines += [f"| {a} | {b.replace('|', '/')} |" for a, b in rows]
    checks = [m for m in summary.get("messages", []) if m.startswith("[")]
    text = "\n".join(lines) + "\n"
    if checks:
        text += "\nIts checks:\n\n" + "\n".join(f"* `{m}`" for m in checks) + "\n"
    return text


def take_pictures(pictures: list[Picture], summary: dict[str, Any], rrd: Path) -> list[Path]:
    """``pictures`` of a run's recording ``rrd`` (its JSON ``summary`` times them)."""
    written = []
    for p in pictures:
        t = p.time(summary) if callable(p.time) else p.time
        shot = screenshot.Shot(IMAGES / p.file, p.timeline, t, view=p.view, tab=p.tab)
        written += screenshot.screenshots(rrd, [shot], size=p.size)
    return written


def run_sweep_picture(out: Path) -> None:
    """The sweep of docs/sweeps.md; its map.png copied to docs/images/sweep_reach.png."""
    sweep = out / "reach"
    if sweep.exists():
        shutil.rmtree(sweep)
    subprocess.run([*PIK_MJ, "sweep", str(sweep), *SWEEP], check=True)
    shutil.copyfile(sweep / "map.png", IMAGES / "sweep_reach.png")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help=f"scenarios (default: all of {SCENARIOS})")
    parser.add_argument("--no-images", action="store_true", help="figures only")
    parser.add_argument(
        "--reuse", action="store_true", help="use the runs already in --out (pictures again)"
    )
    parser.add_argument("--sweep", action="store_true", help="also the sweep picture (~10 min)")
    parser.add_argument(
        "--menagerie",
        action="store_true",
        help="also the pictures of Menagerie robots (MENAGERIE_ROOT must name their folder)",
    )
    parser.add_argument("--out", default="out/runs", help="where runs go (default out/runs)")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.names) - set(SCENARIOS))
    if unknown:
        parser.error(f"unknown scenarios {unknown}; there are {SCENARIOS}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    problem = None if args.no_images else screenshot.viewer_problem()
    if problem:
        print(f"pictures left as they are: {problem}", file=sys.stderr)
    for name in args.names or SCENARIOS:
        saved = out / f"{name}.json"
        summary = json.loads(saved.read_text()) if args.reuse else run_scenario(name, out)
        (FIGURES / f"{name}.md").write_text(figures_page(summary))
        print(f"  {FIGURES / name}.md", flush=True)
        if not args.no_images and not problem:
            for png in take_pictures(PICTURES.get(name, []), summary, out / f"{name}.rrd"):
                print(f"  {png}", flush=True)
    if args.menagerie and not problem:
        for (name, model), pictures in MENAGERIE_PICTURES.items():
            summary = run_scenario(name, out, model)
            for png in take_pictures(pictures, summary, out / f"{name}-{model}.rrd"):
                print(f"  {png}", flush=True)
    if args.sweep and not problem:
        run_sweep_picture(out)
    return 1 if problem else 0


if __name__ == "__main__":
    raise SystemExit(main())
