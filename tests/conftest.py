"""Fixtures shared by the test modules."""

from __future__ import annotations

import gc
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

SLOW_MARKS = ("long", "process")
"""Marks of the slowest tests (H1's walks take minutes): their files run first."""


def pytest_configure(config: pytest.Config) -> None:
    """``pytest-xdist`` hands the files out in collection order
    (:func:`pytest_collection_modifyitems`'s), not by their number of tests
    (``--no-loadscope-reorder``)."""
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Put the files holding a ``long`` or ``process`` test first, the rest in
    collection order: ``pytest-xdist`` (``--dist loadfile``) hands the files to
    the workers in this order, the slowest start first instead of last, and no
    worker runs a minutes-long file alone while the others have finished."""
    slow = {item.path for item in items if any(item.get_closest_marker(m) for m in SLOW_MARKS)}
    items.sort(key=lambda item: item.path not in slow)  # stable: False (slow) first


@pytest.fixture
def ctrl_c() -> Iterator[None]:
    """A SIGINT to this process raises ``KeyboardInterrupt`` during the test,
    as in an interactive shell. A job that a non-interactive shell starts in
    the background (``pytest &`` in a script) inherits SIGINT ignored, and a
    test sending itself a real SIGINT would then see nothing happen; the
    previous handler is put back afterwards."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.fixture
def small_disk() -> Iterator[Path]:
    """A 512 KiB tmpfs mounted for the test (the machine must allow it: root in a
    sandbox); the test is skipped, saying why, where it does not. A full disk is
    made by filling it."""
    mount = Path(tempfile.mkdtemp(prefix="pkdisk"))
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(mount)],
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        mount.rmdir()
        pytest.skip(f"cannot mount a small tmpfs here ({done.stderr.strip() or 'not root'})")
    try:
        yield mount
    finally:
        unmount(mount)
        mount.rmdir()


def unmount(mount: Path, tries: int = 20) -> None:
    """Unmount ``mount``; while it is busy (a file the test's libraries have not
    closed yet, e.g. a memory-mapped table awaiting collection) collect garbage and
    retry, then detach it lazily (``umount -l``: gone once the last file closes)."""
    for _ in range(tries):
        if subprocess.run(["umount", str(mount)], capture_output=True).returncode == 0:
            return
        gc.collect()
        time.sleep(0.05)
    subprocess.run(["umount", "-l", str(mount)], check=False)
