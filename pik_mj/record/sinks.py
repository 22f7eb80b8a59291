"""Where a recording goes, and whether it got there.

* :class:`SavedFiles`: the ``.rrd`` files a stream saves to. Each is claimed by one
  writer (:class:`pik_mj.outputs.WriterLock` on the file: a second ``Recorder`` on
  the same path is refused) and checked complete when the stream closes
  (:func:`pik_mj.record.reader.check_complete`: a full disk, which rerun only logs,
  becomes an error naming the file).
* :func:`probe_viewer`: whether a rerun viewer listens at a ``rerun+http://`` URL,
  within a few seconds (``--connect`` without a viewer would otherwise stream into
  nothing and drop the recording).
* :class:`WebViewer`: a rerun web viewer and the gRPC server it reads from
  (``rerun --serve-web``), listening on :data:`LOOPBACK` unless told another
  address; it says where it listens and stops with the process.
"""

from __future__ import annotations

import atexit
import contextlib
import ipaddress
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
from pathlib import Path

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, OptionError
from pik_mj.outputs import WriterLock
from pik_mj.record.reader import check_complete

__all__ = [
    "DEFAULT_VIEWER_URL",
    "LOOPBACK",
    "SavedFiles",
    "WebViewer",
    "check_bind",
    "free_port",
    "probe_viewer",
    "rerun_executable",
    "unreachable",
]

LOOPBACK = "127.0.0.1"
"""Where every server pik_mj starts listens unless told otherwise (this machine only)."""

DEFAULT_VIEWER_URL = "rerun+http://127.0.0.1:9876/proxy"
"""The viewer ``--connect`` streams to without ``--url`` (rerun's default)."""

PROBE_SECONDS = 3.0
"""Longest wait [s] for a viewer at ``--connect``'s address to accept a connection."""


class SavedFiles:
    """The ``.rrd`` files one recording stream saves to, held by this writer until
    :meth:`finish`."""

    def __init__(self) -> None:
        self.paths: list[Path] = []
        self._locks: list[WriterLock] = []

    def claim(self, path: str | os.PathLike[str]) -> Path:
        """``path`` as a file this stream may write: a writable file path whose
        directory exists (:func:`pik_mj.inputs.output_path`), written by no other
        writer; held until :meth:`finish`.

        Raises:
            InvalidInput: Not a writable file path, or its directory is missing.
            WriterBusy: Another writer (this process's or another's) has it open.
        """
        p = inputs.output_path(path, "recording")
        if not p.parent.is_dir():
            raise InvalidInput(f"directory of the recording {str(p)!r} does not exist")
        self._locks.append(WriterLock(p, "recording"))
        self.paths.append(p)
        return p

    def finish(self) -> list[str]:
        """Once the stream is closed: what is wrong with each file (truncated, not
        written), and let the next writer in. An empty list: every file is whole."""
        problems = []
        for p in self.paths:
            try:
                check_complete(p)
            except InvalidInput as exc:
                problems.append(str(exc))
        for lock in self._locks:
            lock.release()
        return problems

    def release(self) -> None:
        """Let the next writer in without checking (the stream never opened)."""
        for lock in self._locks:
            lock.release()


def check_bind(address: str) -> str:
    """``address`` as an IP address a server may listen on.

    Raises:
        InvalidInput: Not an IPv4 or IPv6 address.
    """
    try:
        return str(ipaddress.ip_address(address))
    except ValueError:
        raise InvalidInput(
            f"--bind {address!r} is not an IP address: give {LOOPBACK} (this machine only, "
            "the default), 0.0.0.0 (every interface) or one of this machine's addresses"
        ) from None


def probe_viewer(url: str | None, timeout: float = PROBE_SECONDS) -> str:
    """The viewer URL ``--connect`` streams to, once something accepts a connection there.

    Raises:
        OptionError: Not a rerun URL, or nothing listens there within ``timeout`` [s].
    """
    url = url or DEFAULT_VIEWER_URL
    parts = urllib.parse.urlsplit(url)
    if parts.scheme not in ("rerun", "rerun+http", "rerun+https") or not parts.hostname:
        raise OptionError(f"--url {url!r} is not a rerun viewer URL such as {DEFAULT_VIEWER_URL!r}")
    port = parts.port or (443 if parts.scheme == "rerun+https" else 9876)
    why = unreachable(parts.hostname, port, timeout)
    if why is not None:
        raise OptionError(
            f"--connect: no rerun viewer answers at {url} ({why} within {timeout:g} s); "
            "start one (`rerun`), give its address with --url, or use --save FILE.rrd"
        )
    return url


def unreachable(host: str, port: int, timeout: float) -> str | None:
    """Why nothing accepted a TCP connection at ``host:port`` within ``timeout`` [s]
    (refused, timed out, no route), or None when something did."""
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return None
    except OSError as exc:
        return "timed out" if isinstance(exc, TimeoutError) else (exc.strerror or str(exc))


def rerun_executable() -> str:
    """The ``rerun`` CLI of this Python environment (else the one on PATH).

    Raises:
        OptionError: There is none.
    """
    beside = Path(sys.executable).parent / "rerun"
    found = str(beside) if beside.is_file() else shutil.which("rerun")
    if found is None:
        raise OptionError("the rerun viewer (the `rerun` executable of rerun-sdk) is not installed")
    return found


def free_port(host: str = LOOPBACK, preferred: int = 0) -> int:
    """``preferred`` if nothing listens on it at ``host``, else a free port."""
    for port in (preferred, 0):
        with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as s:
            try:
                s.bind((host, port))
            except OSError:
                continue
            return int(s.getsockname()[1])
    raise OptionError(f"no free port to listen on at {host}")


class WebViewer:
    """A rerun web viewer and its gRPC server (``rerun --serve-web``) listening on
    ``bind``: rerun's defaults (gRPC 9876, web 9090) when free, else free ports.
    Stopped by :meth:`stop`, at the latest when the process exits.

    Args:
        bind: Address to listen on (:data:`LOOPBACK`: this machine only).
        timeout: Longest wait [s] for it to listen.

    Attributes:
        bind: Where it listens.
        grpc_url: What a logging stream connects to (``rerun+http://…/proxy``).
        web_url: What a browser opens.

    Raises:
        OptionError: It did not start (its error given).
    """

    def __init__(self, bind: str = LOOPBACK, *, timeout: float = 30.0) -> None:
        self.bind = check_bind(bind)
        wildcard = ipaddress.ip_address(self.bind).is_unspecified
        local = LOOPBACK if wildcard else self.bind
        grpc, web = free_port(self.bind, 9876), free_port(self.bind, 9090)
        command = [
            rerun_executable(),
            "--serve-web",
            "--bind",
            self.bind,
            "--port",
            str(grpc),
            "--web-viewer-port",
            str(web),
        ]
        env = dict(os.environ, RERUN_ANALYTICS="0")
        self._log = tempfile.TemporaryFile(mode="w+")  # its messages, read if it fails
        self.process = subprocess.Popen(
            command,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=self._log,
            text=True,
            env=env,
            start_new_session=True,  # its own group: stopped whole, not by the terminal's Ctrl-C
        )
        atexit.register(self.stop)
        host = socket.gethostname() if wildcard else local
        shown = f"[{host}]" if ":" in host else host
        self.grpc_url = f"rerun+http://{'[' + local + ']' if ':' in local else local}:{grpc}/proxy"
        served = f"rerun+http://{shown}:{grpc}/proxy"
        self.web_url = f"http://{shown}:{web}/?url={urllib.parse.quote(served, safe='')}"
        self.ports = (grpc, web)
        self._wait(local, (grpc, web), timeout)

    def _wait(self, host: str, ports: tuple[int, int], timeout: float) -> None:
        deadline = time.monotonic() + timeout
        for port in ports:
            while True:
                if self.process.poll() is not None:
                    self._log.seek(0)
                    err = self._log.read()
                    raise OptionError(
                        f"--serve: the rerun web viewer exited ({self.process.returncode}): "
                        f"{err[-1000:]}"
                    )
                try:
                    with socket.create_connection((host, port), timeout=1.0):
                        break
                except OSError:
                    if time.monotonic() > deadline:
                        self.stop()
                        raise OptionError(
                            f"--serve: the rerun web viewer did not listen in {timeout:g} s"
                        ) from None
                    time.sleep(0.1)

    def where(self) -> str:
        """Where it listens, for the user."""
        scope = (
            "this machine only; --bind ADDRESS to listen elsewhere"
            if ipaddress.ip_address(self.bind).is_loopback
            else f"reachable at {self.bind}"
        )
        return f"web viewer at {self.web_url}  (gRPC {self.grpc_url}; {scope})"

    def running(self) -> bool:
        return self.process.poll() is None

    def stop(self) -> None:
        """Stop its process group (idempotent)."""
        if self.process.poll() is None:
            for sig, wait in ((signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.process.pid, sig)
                try:
                    self.process.wait(timeout=wait)
                    break
                except subprocess.TimeoutExpired:
                    continue
        self._log.close()
