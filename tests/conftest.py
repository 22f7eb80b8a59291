"""Fixtures shared by the test modules."""

from __future__ import annotations

import signal
from collections.abc import Iterator

import pytest


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
