"""Menagerie robots for tests: found through MENAGERIE_ROOT or the mujoco-menagerie
package's cache, never downloaded (tests never touch the network)."""

from __future__ import annotations

import functools

import mujoco
import pytest

from pik_mj.robot.loading import load_model, menagerie_available


def requires_menagerie(name: str) -> None:
    """Skip the calling test, saying why, when Menagerie robot ``name`` is not here."""
    if not menagerie_available(name):
        pytest.skip(
            f"needs the MuJoCo Menagerie robot {name!r}: set MENAGERIE_ROOT to a folder "
            f"holding Menagerie robot folders, or run `python -m mujoco_menagerie prefetch "
            f"{name}` on a machine with network (tests never download)"
        )


@functools.cache
def menagerie_model(name: str) -> mujoco.MjModel:
    """The compiled Menagerie robot ``name``, loaded once per test session (G1's
    meshes take 1.7 s to load); skips like :func:`requires_menagerie`. Read only."""
    requires_menagerie(name)
    return load_model(name)
