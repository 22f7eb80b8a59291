"""Starting or joining Ray for a sweep, with every wait bounded.

Without an address a local instance starts on this machine's cores
(``ray.init(address="local")``: never someone else's running instance). With an
address, :func:`join` first probes it (a TCP connection, at most
``connect_timeout`` seconds) and then runs ``ray.init`` for at most the rest of
that time: a dead head, a port that is not Ray's, or a cluster that refuses this
driver (Ray's token authentication) is an error naming the address instead of
Ray's endless retries.

Addresses: ``"host:port"`` (the head's GCS, default port 6379), ``"ray://host:port"``
(Ray Client, default port 10001), ``"auto"`` (the cluster ``ray start`` left on this
machine; not probed, ``ray.init`` still bounded).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from typing import Any

from pik_mj.exceptions import InvalidInput
from pik_mj.record.sinks import unreachable

OBJECT_STORE_BYTES = 128 * 2**20  # a local instance's object store: rows are small
DEFAULT_CONNECT_TIMEOUT = 10.0
"""Longest wait [s] for a Ray cluster at an address to answer (probe and ``ray.init``)."""

_QUIET = {"include_dashboard": False, "log_to_driver": False, "logging_level": logging.ERROR}
_DEFAULT_PORTS = {"ray://": 10001, "": 6379}


def start(address: str | None, num_cpus: int | None, connect_timeout: float) -> bool:
    """Start or join Ray unless this process already has it; True if we did.

    Raises:
        InvalidInput: Ray is already initialised and ``address``/``num_cpus`` are
            given; the address does not answer in time (:func:`join`).
    """
    import ray

    if ray.is_initialized():
        if address is not None or num_cpus is not None:
            raise InvalidInput(
                "Ray is already initialised in this process: address and num_cpus "
                "cannot apply (call ray.shutdown() first, or leave them out)"
            )
        return False
    if address is None:
        os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # no network from a local run
        ray.init(
            address="local", num_cpus=num_cpus, object_store_memory=OBJECT_STORE_BYTES, **_QUIET
        )
    else:
        join(address, connect_timeout)
    return True


def endpoint(address: str) -> tuple[str, int] | None:
    """``(host, port)`` that ``address`` connects to, or None (``"auto"``).

    Raises:
        InvalidInput: Not a Ray address (a bad port).
    """
    if address == "auto":
        return None
    scheme = "ray://" if address.startswith("ray://") else ""
    rest = address.removeprefix(scheme)
    host, sep, port = rest.rpartition(":")
    if not sep:
        host, port = rest, str(_DEFAULT_PORTS[scheme])
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not host or not 0 < number < 65536:
        raise InvalidInput(
            f"address {address!r} is not a Ray address: give 'host:port', 'ray://host:port' "
            "or 'auto'"
        )
    return host.strip("[]"), number


def probe(address: str, timeout: float) -> None:
    """Raise unless something accepts a TCP connection at ``address`` within ``timeout`` [s].

    Raises:
        InvalidInput: Nothing listens there (refused, unreachable, timed out).
    """
    where = endpoint(address)
    why = None if where is None else unreachable(*where, timeout)
    if why is not None:
        raise InvalidInput(
            f"no Ray cluster answers at {address!r} ({why} within {timeout:g} s): start "
            "one there (`ray start --head`), correct --address, or leave it out to run on "
            "a local instance"
        )


def join(address: str, connect_timeout: float) -> None:
    """Join the Ray cluster at ``address``: probed, then ``ray.init`` in a helper
    thread for at most the rest of ``connect_timeout`` [s]. A ``ray.init`` that
    outlives it is abandoned (and shut down if it ever returns).

    Raises:
        InvalidInput: The address does not answer, ``ray.init`` fails or does not
            return in time; the message names the address.
    """
    import ray

    deadline = time.monotonic() + connect_timeout
    probe(address, connect_timeout)
    outcome: dict[str, Any] = {}
    settled = threading.Lock()  # orders the thread's end against the caller giving up

    def init() -> None:
        try:
            ray.init(address=address, **_QUIET)
        except Exception as exc:  # reported by the caller
            with settled:
                outcome["error"] = exc
            return
        with settled:
            outcome["joined"] = True
            late = outcome.get("abandoned", False)
        if late:
            ray.shutdown()

    thread = threading.Thread(target=init, name="pik_mj-ray-init", daemon=True)
    thread.start()
    thread.join(max(0.0, deadline - time.monotonic()))
    with settled:
        if not outcome:
            outcome["abandoned"] = True
    if outcome.get("abandoned"):
        raise InvalidInput(
            f"the Ray cluster at {address!r} accepted a connection but did not let this "
            f"driver join within {connect_timeout:g} s (is it a Ray head of the same "
            "version? a cluster with token authentication needs RAY_AUTH_MODE=token and "
            "its token); raise --connect-timeout if it is only slow"
        )
    if "error" in outcome:
        exc = outcome["error"]
        raise InvalidInput(
            f"cannot join the Ray cluster at {address!r}: {type(exc).__name__}: {exc}"
        ) from exc
