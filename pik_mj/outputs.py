"""Writing results so that nothing is lost silently: one writer per output, whole files.

* :class:`WriterLock`: an exclusive writer of a path (an advisory ``flock`` held
  while it writes, released by the operating system when the process ends, also
  when it is killed). A second writer is refused with the holder's process and host
  (:class:`~pik_mj.exceptions.WriterBusy`).
* :func:`write_atomic`: a file written under a hidden name and renamed into place,
  so that a reader sees the old file or the whole new one; a failed write (a full
  disk) leaves nothing behind and raises :class:`~pik_mj.exceptions.OutputError`
  naming the file.

Checking an output path before any work starts is :func:`pik_mj.inputs.output_path`.
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import time
from pathlib import Path

from pik_mj.exceptions import OutputError, WriterBusy

__all__ = ["WriterLock", "write_atomic"]


class WriterLock:
    """An exclusive writer of ``path``, held until :meth:`release`.

    The lock is an advisory ``flock`` on ``lock_file`` (``path`` itself, or a
    dedicated file beside it). A dedicated lock file (``records_holder``) also
    holds who has it (``{"pid", "host", "since"}``), for the message a second
    writer gets; on ``path`` itself (e.g. an ``.rrd`` another library writes)
    the holder's process is looked up in ``/proc/locks`` where there is one.

    Args:
        lock_file: The file locked (created if missing, never truncated unless
            ``records_holder``).
        what: What is written, for messages (``"recording"``, ``"sweep directory"``).
        path: What is written (default ``lock_file``), for messages.
        records_holder: Write this process's pid and host into ``lock_file``.

    Raises:
        WriterBusy: Another writer holds the lock.
        OutputError: ``lock_file`` cannot be opened.
    """

    def __init__(
        self,
        lock_file: str | os.PathLike[str],
        what: str,
        *,
        path: str | os.PathLike[str] | None = None,
        records_holder: bool = False,
    ) -> None:
        self._fd: int | None = None
        self.lock_file = Path(lock_file)
        self.path = Path(path) if path is not None else self.lock_file
        self.what = what
        try:
            self._fd = os.open(self.lock_file, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise OutputError(
                f"{what} {str(self.path)!r} cannot be written: {exc.strerror or exc}"
            ) from None
        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _recorded_holder(self._fd) if records_holder else _proc_locks_holder(self._fd)
            os.close(self._fd)
            self._fd = None
            raise WriterBusy(what, str(self.path), holder) from None
        if records_holder:
            me = {"pid": os.getpid(), "host": socket.gethostname(), "since": _now()}
            try:
                os.ftruncate(self._fd, 0)
                os.pwrite(self._fd, json.dumps(me).encode(), 0)
            except OSError:  # a full disk: the lock holds, the message will lack the holder
                pass

    @property
    def held(self) -> bool:
        """Whether this writer still holds the lock."""
        return self._fd is not None

    def release(self) -> None:
        """Let the next writer in (idempotent)."""
        if self._fd is not None:
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> WriterLock:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __del__(self) -> None:
        self.release()


def write_atomic(path: str | os.PathLike[str], data: bytes | str, what: str) -> Path:
    """Write ``data`` to ``path`` whole or not at all: into ``.tmp-<name>`` beside it,
    flushed to disk, then renamed over ``path``.

    Raises:
        OutputError: The write failed (a full disk, an I/O error); the hidden file
            is removed and ``path`` is left as it was.
    """
    p = Path(path)
    tmp = p.with_name(f".tmp-{p.name}")
    raw = data.encode() if isinstance(data, str) else data
    try:
        with open(tmp, "wb") as f:
            f.write(raw)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, p)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(
            f"{what} {str(p)!r} could not be written: {exc.strerror or exc}; nothing was "
            "written there"
        ) from None
    return p


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


def _recorded_holder(fd: int) -> str | None:
    """The holder a dedicated lock file records, as ``"pid P on host H (since T)"``."""
    try:
        info = json.loads(os.pread(fd, 4096, 0).decode() or "null")
        return f"pid {info['pid']} on host {info['host']} (since {info['since']})"
    except (OSError, ValueError, TypeError, KeyError):
        return None


def _proc_locks_holder(fd: int) -> str | None:
    """The process holding an ``flock`` on the file of ``fd`` (Linux ``/proc/locks``)."""
    st = os.fstat(fd)
    inode = f"{os.major(st.st_dev):02x}:{os.minor(st.st_dev):02x}:{st.st_ino}"
    try:
        lines = Path("/proc/locks").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        fields = line.split()
        if len(fields) > 5 and fields[1] == "FLOCK" and fields[5] == inode:
            return f"pid {fields[4]} on host {socket.gethostname()}"
    return None
