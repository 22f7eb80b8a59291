"""Menagerie robots for tests: found through MENAGERIE_ROOT or the mujoco-menagerie
package's cache, never downloaded (tests never touch the network)."""

from __future__ import annotations

import pytest

from pik_mj.models import menagerie_available


def requires_menagerie(name: str) -> None:
    """Skip the calling test, saying why, when Menagerie robot ``name`` is not here."""
    if not menagerie_available(name):
        pytest.skip(
            f"needs the MuJoCo Menagerie robot {name!r}: set MENAGERIE_ROOT to a folder "
            f"holding Menagerie robot folders, or run `python -m mujoco_menagerie prefetch "
            f"{name}` on a machine with network (tests never download)"
        )
