"""A local Ray instance for tests that run sweeps in their own process."""

from __future__ import annotations

import contextlib
import logging
import tempfile
from collections.abc import Iterator

import pytest
import ray


@contextlib.contextmanager
def local_ray(num_cpus: int, prefix: str = "pkr") -> Iterator[str]:
    """A local Ray instance of ``num_cpus`` CPUs in its own temporary directory
    (yielded: its processes carry it in their command lines), shut down on leaving."""
    tmp = tempfile.mkdtemp(prefix=prefix)  # short: Ray's socket paths live below it
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RAY_USAGE_STATS_ENABLED", "0")
        ray.init(
            address="local",
            num_cpus=num_cpus,
            include_dashboard=False,
            log_to_driver=False,
            logging_level=logging.ERROR,
            _temp_dir=tmp,
        )
        try:
            yield tmp
        finally:
            ray.shutdown()
