"""Screenshots of a recording, rendered by rerun's own headless viewer.

``pik-mj screenshot FILE.rrd --out PNG`` (or ``python -m
pik_mj.record.screenshot``) starts ``rerun --headless`` on a free port, opens
the file (with the blueprint it was recorded with), moves the time cursor,
waits until the picture stops changing (the viewer loads chunks on demand),
and saves a PNG of the whole viewer or of one view::

    pik-mj screenshot out/fullbody_reach.rrd --out reach.png --time last \\
        --view "solve:" --size 1280x800

The viewer renders with Vulkan (wgpu): a GPU's driver, or without a GPU Mesa's
software rasterizer lavapipe (Debian and Ubuntu: ``apt-get install
mesa-vulkan-drivers libvulkan1``). Without a Vulkan driver it falls back to
OpenGL and stops (``Failed to get render context``, exit 102);
:func:`viewer_problem` finds out once per process whether it can render here and
says what to install when it cannot.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes.util
import functools
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from pik_mj import inputs
from pik_mj.exceptions import InvalidInput, PikError
from pik_mj.record.reader import check_complete
from pik_mj.record.sinks import LOOPBACK, free_port, rerun_executable

__all__ = ["Shot", "main", "screenshots", "viewer_problem"]


@dataclass(frozen=True)
class Shot:
    """One picture of a recording.

    Attributes:
        out: PNG file to write.
        timeline: Timeline to put the cursor on (None: the one the recording
            opens on).
        time: Time on it: an iteration number, seconds on ``sim_time``, or
            ``"last"`` (the end of the timeline).
        view: Name (or the start of the name) of a view to show maximized, or
            None for the whole layout.
        tab: Name (or its start) of the blueprint tab to show first, or None.
        panels: Keep the viewer's side panels and full time panel.
    """

    out: Path
    timeline: str | None = None
    time: float | str = "last"
    view: str | None = None
    tab: str | None = None
    panels: bool = False


#: Seconds the headless viewer shows its start notice (kept off the pictures).
NOTICE_SECONDS = 7.0

#: Debian's and Ubuntu's packages of a software Vulkan driver (Mesa's lavapipe)
#: and the Vulkan loader: what the headless viewer needs on a machine without a GPU.
VULKAN_PACKAGES = ("mesa-vulkan-drivers", "libvulkan1")

#: Where the Vulkan loader looks for driver manifests (ICD files) by default.
ICD_FOLDERS = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d", "/usr/local/share/vulkan/icd.d")


def vulkan_hint() -> str:
    """What keeps the Vulkan loader from finding a driver here, and what to install.

    The loader is ``libvulkan.so.1``; it reads the driver manifests named by
    ``VK_DRIVER_FILES`` or ``VK_ICD_FILENAMES`` (``:``-separated) when one is set,
    else those in :data:`ICD_FOLDERS`.
    """
    install = f"apt-get install {' '.join(VULKAN_PACKAGES)}"
    if ctypes.util.find_library("vulkan") is None:
        return f"no Vulkan loader (libvulkan.so.1) is installed: {install}"
    for variable in ("VK_DRIVER_FILES", "VK_ICD_FILENAMES"):
        named = os.environ.get(variable)
        if named:
            if not any(Path(f).is_file() for f in named.split(os.pathsep) if f):
                return f"{variable}={named} names no driver manifest: unset it, or {install}"
            return f"{variable}={named} names the Vulkan driver; is it the right one?"
    if not any(Path(d).is_dir() and any(Path(d).glob("*.json")) for d in ICD_FOLDERS):
        return f"no Vulkan driver is installed (no manifest in {', '.join(ICD_FOLDERS)}): {install}"
    return f"a Vulkan driver is installed but gave no adapter; without a GPU: {install}"


_rerun_executable = rerun_executable  # the `rerun` CLI beside this interpreter


def _exit_message(process: subprocess.Popen, log: IO[str]) -> str:
    """Why the viewer ``process`` (exited) stopped, from its stderr ``log``: its
    panic, and a hint when it found no renderer."""
    log.seek(0)
    err = re.sub(r"\x1b\[[0-9;]*m", "", log.read())
    panic = re.search(r"panicked at '([^']*)'|panicked at [^\n]*\n([^\n]+)", err)
    reason = next(g for g in panic.groups() if g) if panic else err.strip()[-1000:]
    message = f"the headless rerun viewer exited ({process.returncode}): {reason}"
    if re.search(r"render context|adapter|vulkan", err, re.IGNORECASE):
        message += f" -- it renders with Vulkan; {vulkan_hint()}"
    return message


@contextlib.contextmanager
def headless_viewer(size: tuple[int, int] = (1600, 900), *, notice: bool = True) -> Iterator[Any]:
    """A ``rerun --headless`` viewer of ``size`` (points) on a free port of
    :data:`~pik_mj.record.sinks.LOOPBACK` (this machine only), as a
    :class:`rerun.experimental.ViewerClient`; stopped on leaving the block.

    Args:
        size: Viewer size [points].
        notice: Wait until the viewer's start notice has faded
            (:data:`NOTICE_SECONDS`), so that pictures do not show it.

    Raises:
        PikError: The viewer exited (no renderer: the message says what to
            install) or did not start within 30 s.
    """
    from rerun.experimental import ViewerClient

    port = free_port(LOOPBACK)
    # its stderr in a file: a pipe left unread would fill and stall it
    with tempfile.TemporaryFile("w+") as log:
        process = _launch(port, size, log)
        print(f"screenshot: a headless rerun viewer listens on {LOOPBACK}:{port}", file=sys.stderr)
        started = time.monotonic()
        try:
            client = None
            deadline = time.monotonic() + 30.0
            while client is None:
                if process.poll() is not None:
                    raise PikError(_exit_message(process, log))
                try:
                    candidate = ViewerClient(f"rerun+http://{LOOPBACK}:{port}/proxy")
                    candidate.get_state()
                    client = candidate
                except Exception:  # not listening yet
                    if time.monotonic() > deadline:
                        raise PikError("the headless rerun viewer did not start in 30 s") from None
                    time.sleep(0.2)
            # the viewer's "running headless" notice fades out after a few seconds
            if notice:
                time.sleep(max(0.0, started + NOTICE_SECONDS - time.monotonic()))
            try:
                yield client
            except Exception as exc:  # the viewer may be stopping under the client
                try:
                    process.wait(timeout=5.0)
                except subprocess.TimeoutExpired:
                    raise exc from None
                raise PikError(_exit_message(process, log)) from exc
        finally:
            _stop(process)


def _launch(port: int, size: tuple[int, int], log: IO[str]) -> subprocess.Popen:
    """Start ``rerun --headless`` on ``port``, its stderr to ``log``, in its own
    process group (the ``rerun`` script starts the viewer binary as a child,
    which must stop with it)."""
    command = [
        _rerun_executable(),
        "--headless",
        "--bind",
        LOOPBACK,
        "--port",
        str(port),
        "--window-size",
        f"{size[0]}x{size[1]}",
        "--hide-welcome-screen",
    ]
    return subprocess.Popen(
        command,
        stdout=subprocess.DEVNULL,
        stderr=log,
        text=True,
        env=dict(os.environ, RERUN_ANALYTICS="0"),
        start_new_session=True,
    )


@functools.cache
def viewer_problem() -> str | None:
    """Why rerun's headless viewer cannot render on this machine, or None when it can.

    Starts the viewer and takes one picture, once per process (the answer is
    cached). A viewer that exits (no Vulkan driver: the reason says what to
    install) or does not start in time is a problem; any other error is raised.
    """
    try:
        with headless_viewer((160, 120), notice=False) as client:
            client.take_screenshot()
    except PikError as exc:
        return str(exc)
    return None


def _stop(process: subprocess.Popen) -> None:
    """Stop the viewer's process group (the script and the viewer binary)."""
    for sig, wait in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 5.0)):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, sig)
        try:
            process.wait(timeout=wait)
            break
        except subprocess.TimeoutExpired:
            continue


def _settled_png(client: Any, *, tries: int = 12) -> bytes:
    """A screenshot of the viewer once two in a row are the same (chunks still
    arriving or the first frames after a change differ)."""
    last = b""
    time.sleep(1.0)
    for _ in range(tries):
        png = client.take_screenshot()
        if png == last:
            return png
        last = png
        time.sleep(0.5)
    return last


def _find(names: dict[str, str], wanted: str, what: str) -> str:
    hits = [key for key, name in names.items() if name.startswith(wanted)]
    if not hits:
        raise InvalidInput(f"no {what} named {wanted!r}; there are {sorted(names.values())}")
    return hits[0]


def _open(client: Any, path: Path) -> Any:
    """Open ``path`` and wait until its timelines are loaded; its recording's state."""
    client.open(str(path.resolve()))
    deadline = time.monotonic() + 60.0
    while True:
        state = client.get_state()
        recordings = [r for r in state.recordings if r.store_id == state.active_recording]
        if recordings and recordings[0].timelines and not state.loading:
            return recordings[0]
        if time.monotonic() > deadline:
            raise PikError(f"the viewer did not finish loading {str(path)!r} in 60 s")
        time.sleep(0.3)


def _arrange(client: Any, tab: str | None, view: str | None, panels: bool) -> str | None:
    """Show the blueprint tab whose name starts with ``tab``, maximize the view
    whose name starts with ``view``; without ``panels``, hide the side and top
    panels and collapse the time panel (the picture is the recording's
    layout). Returns the id of the maximized view."""
    layout = client.get_blueprint(of="recording").blueprint
    view_id = None
    if view is not None:
        names = {
            key.rsplit("/", 1)[1]: str(v["ViewBlueprint"].get("display_name", key))
            for key, v in layout.items()
            if "ViewBlueprint" in v
        }
        view_id = _find(names, view, "view")
        # the viewport (absent from what the viewer reads out) keeps its root
        root = next(iter(_roots(_containers(layout))))
        layout["/viewport"] = {
            "ViewportBlueprint": {"root_container": root.rsplit("/", 1)[1], "maximized": view_id}
        }
    if tab is not None:
        _show_tab(layout, tab)
    if not panels:
        for panel in ("blueprint_panel", "selection_panel", "top_panel"):
            layout[f"/{panel}"] = {"PanelBlueprint": {"state": "Hidden"}}
        time_panel = layout.setdefault("/time_panel", {}).setdefault("TimePanelBlueprint", {})
        time_panel["state"] = "Collapsed"
    client.set_blueprint(layout, of="recording")
    return view_id


def _containers(layout: dict) -> dict[str, dict]:
    """The layout's containers by the id their parents list (``container/<id>``)."""
    return {
        key.lstrip("/"): v["ContainerBlueprint"]
        for key, v in layout.items()
        if "ContainerBlueprint" in v
    }


def _roots(containers: dict[str, dict]) -> dict[str, str]:
    """The containers no container holds (the layout's root), with their names."""
    children = {child for c in containers.values() for child in c.get("contents", [])}
    return {
        key: str(c.get("display_name", key)) for key, c in containers.items() if key not in children
    }


def _show_tab(layout: dict, tab: str) -> None:
    """Make the tab whose name starts with ``tab`` the active one. A layout of
    one tab has no tab container (:func:`pik_mj.record.blueprint.blueprint_for`):
    its root's name must match, and there is nothing to switch."""
    containers = _containers(layout)
    tabs = [c for c in containers.values() if c.get("container_kind") == "Tabs"]
    if not tabs:
        _find(_roots(containers), tab, "tab")
        return
    names = {
        child: str(containers.get(child, {}).get("display_name", child))
        for child in tabs[0].get("contents", [])
    }
    tabs[0]["active_tab"] = _find(names, tab, "tab")


def screenshots(recording: str | Path, shots: Sequence[Shot], *, size=(1600, 900)) -> list[Path]:
    """Render ``shots`` of ``recording`` with one headless viewer; the PNGs written.

    Raises:
        InvalidInput: No such file, a file that is not a whole ``.rrd``
            (truncated: named so), a PNG that cannot be written, a bad size
            (all before the viewer starts); no such timeline, view or tab.
        PikError: The viewer did not start or load the file.
    """
    path = check_complete(recording)
    for shot in shots:
        inputs.output_path(shot.out, "--out")
    _check_size(size)
    written = []
    with headless_viewer(size) as client:
        rec = _open(client, path)
        timelines = {t.name: t for t in rec.timelines}
        for shot in shots:
            _arrange(client, shot.tab, shot.view, shot.panels)
            name = shot.timeline or rec.current_timeline
            if name not in timelines:
                raise InvalidInput(f"no timeline {name!r}; the recording has {sorted(timelines)}")
            tl = timelines[name]
            if tl.time_type == "sequence":
                t = tl.end if shot.time == "last" else int(shot.time)
                client.set_time(name, sequence=int(t), play_state="paused")
            else:
                seconds = tl.end * 1e-9 if shot.time == "last" else float(shot.time)
                client.set_time(name, duration=seconds, play_state="paused")
            png = _settled_png(client)
            out = Path(shot.out)
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_bytes(png)
            written.append(out)
    return written


MAX_SIZE = 8192
"""Largest viewer width or height [points] of a screenshot."""


def _check_size(size: Any) -> tuple[int, int]:
    """``size`` as ``(width, height)`` [points], each in ``1..MAX_SIZE``.

    Raises:
        InvalidInput: Anything else.
    """
    if (
        not isinstance(size, (tuple, list))
        or len(size) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) for v in size)
        or not all(1 <= v <= MAX_SIZE for v in size)
    ):
        raise InvalidInput(
            f"size must be (width, height) in points, each 1..{MAX_SIZE}, got {size!r}"
        )
    return int(size[0]), int(size[1])


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        return _check_size((w, h))
    except (ValueError, InvalidInput):
        raise argparse.ArgumentTypeError(
            f"size must be WIDTHxHEIGHT in points, each 1..{MAX_SIZE} (e.g. 1600x900), got {text!r}"
        ) from None


def _time(text: str) -> float | str:
    if text == "last":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"time must be a number or 'last', got {text!r}") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The screenshot options (shared by ``pik-mj screenshot``)."""
    parser.add_argument("recording", help="the .rrd file")
    parser.add_argument("--out", required=True, help="PNG file to write")
    parser.add_argument("--timeline", help="timeline (default: the one the recording opens on)")
    parser.add_argument(
        "--time", type=_time, default="last", help="iteration, seconds, or 'last' (default)"
    )
    parser.add_argument("--view", help="show only the view whose name starts with this, maximized")
    parser.add_argument("--tab", help="show the blueprint tab whose name starts with this")
    parser.add_argument(
        "--size", type=_size, default=(1600, 900), help="viewer size in points (1600x900)"
    )
    parser.add_argument(
        "--panels", action="store_true", help="keep the viewer's side panels and time panel"
    )


def run(args: argparse.Namespace) -> int:
    """Take the screenshot ``args`` describe; 0 on success."""
    shot = Shot(Path(args.out), args.timeline, args.time, args.view, args.tab, args.panels)
    (out,) = screenshots(args.recording, [shot], size=args.size)
    print(f"wrote {out}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
