"""A sweep's rows checked again from what they carry: :func:`replay`
(``pik-mj validate OUT#CASE``).

A row holds its case's final configuration (``qpos``) and the iterates of its
solve (``path``). Replaying it rebuilds the case's robot standing on the floor
(:func:`pik_mj.sweep.case.standing_robot`) and its scene, and runs the checks of
:meth:`pik_mj.sweep.case.Worker.check_many` on them (the static check, the motion,
the hold; the holds of all replayed rows stepped together): no solve. The
verdict is the dataset's (:func:`pik_mj.sweep.dataset.verdict`), the solve's
convergence taken from the row.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from pik_mj.exceptions import InvalidInput
from pik_mj.sweep.case import Worker
from pik_mj.sweep.dataset import Dataset, read_rows, verdict

__all__ = ["FIGURES", "parse_target", "replay"]

FIGURES = (
    "static_feasible",
    "static_margin",
    "motion_passed",
    "hold_passed",
    "drift",
    "slip",
    "hold_min_margin",
    "fell",
)
"""The columns a replay recomputes (with the verdict)."""


def parse_target(target: str) -> tuple[str, list[int] | None]:
    """``OUT#3`` -> ``("OUT", [3])``; ``OUT#3,7`` -> two cases; ``OUT#all`` -> every row.

    Raises:
        InvalidInput: No ``#``, or cases that are not integers.
    """
    path, sep, cases = target.rpartition("#")
    if not sep or not path:
        raise InvalidInput(f"a sweep row is OUT#CASE (e.g. out/sweep#12), got {target!r}")
    if cases == "all":
        return path, None
    try:
        return path, [int(c) for c in cases.split(",")]
    except ValueError:
        raise InvalidInput(
            f"cases of {target!r} must be integers (OUT#3 or OUT#3,7) or 'all', got {cases!r}"
        ) from None


def replay(
    path: str | os.PathLike[str], cases: Sequence[int] | None = None
) -> list[dict[str, Any]]:
    """The rows ``cases`` (default: every row) of the sweep in ``path`` checked
    again from their ``qpos`` and ``path`` (module docstring).

    Returns:
        Per row: ``case``, ``robot``, ``stored`` (its verdict and :data:`FIGURES`
        as stored) and ``replayed`` (the same, recomputed).

    Raises:
        InvalidInput: No sweep in ``path``, a case without a row, or a row
            without a pose (a case that raised, or a sweep of an older version).
    """
    rows = read_rows(path).to_pylist()
    sweep = Dataset.stored_sweep(path)
    by_case = {r["case"]: r for r in rows}
    wanted = [r["case"] for r in rows] if cases is None else list(cases)
    missing = [c for c in wanted if c not in by_case]
    if missing:
        raise InvalidInput(f"sweep {str(path)!r} has no rows for the cases {missing}")
    chosen = [by_case[c] for c in wanted]
    bare = [r["case"] for r in chosen if not r.get("qpos") or not r.get("path")]
    if bare:
        raise InvalidInput(
            f"the rows of cases {bare} carry no pose (qpos, path): nothing to replay"
        )
    out = []
    for robot in dict.fromkeys(r["robot"] for r in chosen):
        mine = [r for r in chosen if r["robot"] == robot]
        worker = Worker(robot, hand=sweep.hand, hold=sweep.hold)
        checked = worker.check_many(
            [np.array(r["qpos"]) for r in mine], [np.array(r["path"]) for r in mine]
        )
        for row, again in zip(mine, checked, strict=True):
            again = {**again, "converged": row["converged"]}
            out.append(
                {
                    "case": row["case"],
                    "robot": robot,
                    "stored": {"verdict": row["verdict"], **{k: row[k] for k in FIGURES}},
                    "replayed": {"verdict": verdict(again), **{k: again[k] for k in FIGURES}},
                }
            )
    return sorted(out, key=lambda r: wanted.index(r["case"]))
