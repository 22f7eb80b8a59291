"""Viewer layouts (rerun blueprints) of pik_mj's recordings."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import rerun.blueprint as rrb

from .paths import PATHS, EntityPaths

__all__ = ["blueprint", "blueprint_for"]


def blueprint(
    levels: Sequence[int],
    paths: EntityPaths = PATHS,
    *,
    extra: Sequence[tuple[str, str]] = (),
) -> rrb.Blueprint:
    """Viewer layout: the 3D ``world`` view beside one time series per level.

    Args:
        levels: Priority levels whose error series get a view.
        paths: Entity-path table.
        extra: More time-series views ``(origin, name)`` below the level views
            (e.g. ``(paths.balance, "balance")``).
    """
    view3d = rrb.Spatial3DView(origin=paths.world, name="world")
    series = [
        rrb.TimeSeriesView(origin=paths.level_errors(k), name=f"level {int(k)} errors")
        for k in levels
    ] + [rrb.TimeSeriesView(origin=origin, name=name) for origin, name in extra]
    if not series:
        return rrb.Blueprint(view3d)
    return rrb.Blueprint(rrb.Horizontal(view3d, rrb.Vertical(*series), column_shares=[2, 1]))


def _under(logged: Mapping[str, set[str]], parent: str) -> bool:
    return any(path.startswith(f"{parent}/") for path in logged)


def blueprint_for(logged: Mapping[str, set[str]], paths: EntityPaths = PATHS) -> rrb.Blueprint:
    """The layout of everything ``logged`` (entity path -> its timelines): a
    plot per priority level of every solve, the simulation's series when they
    were logged.

    Args:
        logged: What a :class:`~pik_mj.record.recorder.Recorder` logged
            (:meth:`~pik_mj.record.recorder.Recorder.logged`).
        paths: Entity-path table.
    """
    prefix = f"{paths.errors}/level_"
    levels = sorted({int(p[len(prefix) :].split("/")[0]) for p in logged if p.startswith(prefix)})
    extra = [(paths.balance, "balance (simulation)")] if _under(logged, paths.balance) else []
    if _under(logged, paths.hold):
        extra.append((paths.hold, "physics hold"))
    return blueprint(levels, paths, extra=extra)
