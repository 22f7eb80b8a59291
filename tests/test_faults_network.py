"""Every server pik_mj starts listens on 127.0.0.1 unless ``--bind`` says otherwise,
and says where it listens; ``--serve`` prints its URL and exits 130 on Ctrl-C.

Before: ``pik-mj run NAME --serve`` listened on ``0.0.0.0:9090`` (every interface),
blocked without printing a URL and exited 0 on Ctrl-C; ``pik-mj screenshot``'s headless
viewer listened for gRPC on ``0.0.0.0``.

The listening sockets are read from ``/proc/net/tcp{,6}`` and matched to the server's
processes through their file descriptors (Linux).
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from pik_mj.record import Recorder, screenshot
from pik_mj.record.reader import verify

pytestmark = [
    pytest.mark.process,  # sockets and signals, not MuJoCo's version
    pytest.mark.skipif(
        not Path("/proc/net/tcp").is_file(), reason="reads listening sockets from Linux's /proc"
    ),
]

TINY = '''
"""A tiny scenario: a few points."""
from pik_mj.scenario import ScenarioResult, open_recorder, parser, report


def run(recorder):
    for k in range(20):
        recorder.set_time("iteration", k)
        recorder.log_point("world/p", [0.01 * k, 0.0, 1.0])
    return ScenarioResult("tiny")


def main(argv=None):
    args = parser(__doc__, hold=False).parse_args(argv)
    with open_recorder(args, "tiny") as recorder:
        result = run(recorder)
    return report(result, args)
'''


def descendants(pid: int) -> set[int]:
    """``pid`` and every process below it."""
    children: dict[int, list[int]] = {}
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit():
            try:
                ppid = int((proc / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(ppid, []).append(int(proc.name))
    found, todo = set(), [pid]
    while todo:
        p = todo.pop()
        found.add(p)
        todo += children.get(p, [])
    return found


def listening(pids: set[int]) -> set[tuple[str, int]]:
    """``(address, port)`` of every TCP socket in LISTEN state held by ``pids``."""
    inodes = set()
    for pid in pids:
        try:
            for fd in Path(f"/proc/{pid}/fd").iterdir():
                target = os.readlink(fd)
                if target.startswith("socket:["):
                    inodes.add(target[8:-1])
        except OSError:
            continue
    found = set()
    for table, width in (("/proc/net/tcp", 4), ("/proc/net/tcp6", 16)):
        for line in Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] != "0A" or fields[9] not in inodes:  # 0A: LISTEN
                continue
            hex_ip, hex_port = fields[1].split(":")
            raw = bytes.fromhex(hex_ip)
            if width == 4:
                ip = socket.inet_ntop(socket.AF_INET, raw[::-1])
            else:
                words = b"".join(raw[i : i + 4][::-1] for i in range(0, 16, 4))
                ip = socket.inet_ntop(socket.AF_INET6, words)
            found.add((ip, int(hex_port, 16)))
    return found


def alive(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie, ended but not yet reaped, does not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def start_serving(tmp_path: Path, *args: str) -> subprocess.Popen:
    (tmp_path / "tiny.py").write_text(TINY)
    bootstrap = (
        "import sys; import pik_mj.scenarios as s; "
        f"s.__path__.append({str(tmp_path)!r}); s.SCENARIOS.append('tiny'); "
        "from pik_mj import cli; sys.exit(cli.main(sys.argv[1:]))"
    )
    return subprocess.Popen(
        [sys.executable, "-c", bootstrap, "run", "tiny", "--serve", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


def wait_for(process: subprocess.Popen, text: str, timeout: float = 240.0) -> list[str]:
    """Lines of ``process``'s stdout up to the one holding ``text``."""
    lines: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        lines.append(line)
        if text in line:
            return lines
    raise AssertionError(f"no {text!r} in {lines}; stderr: {process.stderr.read()}")


@pytest.mark.parametrize(
    ("bind", "expected"), [(None, "127.0.0.1"), ("0.0.0.0", "0.0.0.0"), ("::1", "::1")]
)
def test_serve_listens_on_loopback_unless_bind_says_and_exits_130(tmp_path, bind, expected):
    rrd = tmp_path / "served.rrd"
    served = start_serving(tmp_path, "--save", str(rrd), *(["--bind", bind] if bind else []))
    try:
        lines = wait_for(served, "serving until Ctrl-C")
        url = next(x for x in lines if x.startswith("serving the recording: web viewer at "))
        host = f"[{expected}]" if ":" in expected else expected
        if expected == "0.0.0.0":
            host = socket.gethostname()
        assert f"web viewer at http://{host}:" in url
        sockets = listening(descendants(served.pid))
        assert len(sockets) >= 2  # the web viewer and its gRPC server
        assert {ip for ip, _ in sockets} == {expected}, sockets
        if expected == "127.0.0.1":
            assert "this machine only; --bind ADDRESS to listen elsewhere" in url
        # the recording was written beside the served one
        verify(rrd)
        servers = descendants(served.pid) - {served.pid}
        served.send_signal(signal.SIGINT)
        assert served.wait(timeout=60) == 130
        assert "pik-mj: interrupted" in served.stderr.read()
        deadline = time.monotonic() + 15.0
        while any(alive(p) for p in servers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(alive(p) for p in servers)  # stopped with it
    finally:
        if served.poll() is None:
            os.killpg(served.pid, signal.SIGKILL)
            served.wait()


def test_the_screenshot_viewer_listens_on_loopback_and_says_where(tmp_path, capfd):
    """Read while the headless viewer runs (it may stop soon after listening on a
    machine without a graphics adapter: its gRPC server listens first)."""
    rrd = tmp_path / "run.rrd"
    with Recorder.to_file(rrd) as recorder:
        recorder.set_time("iteration", 0)
        recorder.log_point("world/p", [0.0, 0.0, 1.0])
    seen: set[tuple[str, int]] = set()
    stop = threading.Event()

    def watch() -> None:
        while not stop.is_set():
            seen.update(listening(descendants(os.getpid()) - {os.getpid()}))
            time.sleep(0.01)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        screenshot.main([str(rrd), "--out", str(tmp_path / "a.png"), "--size", "320x200"])
    except Exception:  # no renderer here: the viewer stops; its sockets were seen
        pass
    finally:
        stop.set()
        watcher.join()
    err = capfd.readouterr().err
    assert "screenshot: a headless rerun viewer listens on 127.0.0.1:" in err
    port = int(err.split("listens on 127.0.0.1:")[1].split()[0])
    if not seen:
        pytest.skip("the headless viewer stopped before it listened (no graphics adapter)")
    assert seen == {("127.0.0.1", port)}, seen
