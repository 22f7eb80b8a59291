"""Viewer layouts (rerun blueprints) of pik_mj's recordings."""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

from .paths import PATHS, EntityPaths

__all__ = ["blueprint"]


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
