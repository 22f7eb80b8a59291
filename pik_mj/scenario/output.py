"""Where a scenario's run goes: the recording opened where rerun's options send it
(:func:`open_recorder`), the summary printed and the JSON written (:func:`report`).

rerun's options (:func:`rerun.script_add_args`, rerun 0.41) and what each does here:

* ``--save FILE.rrd``: the recording to a file, claimed by this run (another
  writer of the same file is refused) and checked whole when it closes;
* ``--connect [--url URL]``: to a running viewer (default
  ``rerun+http://127.0.0.1:9876/proxy``), probed first for a few seconds; with no
  viewer there the run is refused (exit 2) — or, with ``--save``, goes on into the
  file only and exits 2 once the file is written;
* ``--serve``: a web viewer and its gRPC server (``rerun --serve-web``) on
  127.0.0.1 unless ``--bind ADDRESS``; its URL is printed, and it serves the
  recording after the run until Ctrl-C (exit 130);
* ``--stdout``: the recording to standard output (the summary then goes to
  standard error); ``--save`` beside it is refused (pipe it through ``tee``);
* ``--headless``: no viewer is spawned; without ``--save`` nothing is kept, and
  the run says so;
* none of these: a viewer is spawned (rerun's ``spawn``).

``--save`` with ``--connect`` or ``--serve`` writes both.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import uuid
import webbrowser
from pathlib import Path
from typing import TextIO

import rerun as rr

from pik_mj.exceptions import OptionError, PikError
from pik_mj.record import Recorder
from pik_mj.record.sinks import (
    DEFAULT_VIEWER_URL,
    LOOPBACK,
    SavedFiles,
    WebViewer,
    probe_viewer,
)
from pik_mj.scenario.result import ScenarioResult


def open_recorder(args: argparse.Namespace, name: str) -> Recorder:
    """A :class:`Recorder` on a new stream where rerun's options send it (module
    docstring; as :func:`rerun.script_setup`, but the stream is not made the global
    one). The options' outcome is noted on ``args`` for :func:`report`:
    ``args.viewer`` (the :class:`~pik_mj.record.sinks.WebViewer` of ``--serve``) and
    ``args.unreached`` (why ``--connect`` found no viewer, when ``--save`` went on).

    Raises:
        OptionError: The destination cannot be opened (no viewer at ``--connect``
            without ``--save``, a file that cannot be written or is being written,
            a web viewer that does not start); the reason is given.
    """
    stream = rr.RecordingStream(f"pik_mj_{name}", recording_id=uuid.uuid4())
    files = SavedFiles()
    args.viewer, args.unreached = None, None
    try:
        sinks = _sinks(args, files)
        if args.stdout:
            stream.stdout()
        elif sinks:
            stream.set_sinks(*sinks)
        elif not args.headless:
            stream.spawn()
    except PikError as exc:
        files.release()
        raise OptionError(str(exc)) from None
    except (OSError, RuntimeError, ValueError) as exc:
        files.release()
        raise OptionError(f"cannot open the recording's destination: {exc}") from None
    return Recorder(stream, owns_stream=True, files=files)


def _sinks(args: argparse.Namespace, files: SavedFiles) -> list[object]:
    """rerun's sinks of ``--serve``, ``--connect`` and ``--save`` (checked, claimed)."""
    sinks: list[object] = []
    if args.serve:
        args.viewer = WebViewer(getattr(args, "bind", None) or LOOPBACK)
        print(f"serving the recording: {args.viewer.where()}", file=_out(args), flush=True)
        if _has_display():
            webbrowser.open(args.viewer.web_url)
        sinks.append(rr.GrpcSink(args.viewer.grpc_url))
    elif args.connect:
        try:
            sinks.append(rr.GrpcSink(probe_viewer(args.url)))
        except OptionError as exc:
            if args.save is None:
                raise
            args.unreached = args.url or DEFAULT_VIEWER_URL
            print(f"pik-mj: error: {exc}; recording to {args.save} only", file=sys.stderr)
    if args.save is not None:
        Path(args.save).parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(files.claim(args.save)))
    return sinks


def _has_display() -> bool:
    """Whether a browser can open a window here (a desktop session)."""
    return sys.platform in ("darwin", "win32") or bool(
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    )


def _out(args: argparse.Namespace) -> TextIO:
    """Where the run's lines go: standard error when the recording is on standard output."""
    return sys.stderr if getattr(args, "stdout", False) else sys.stdout


def report(result: ScenarioResult, args: argparse.Namespace) -> int:
    """Print the summary (and where the recording and JSON went); with ``--serve``,
    serve the recording until Ctrl-C (``KeyboardInterrupt`` goes on to the caller:
    exit 130). Returns 0 iff passed, 2 when ``--connect`` found no viewer (the
    recording went to ``--save``'s file only), else 1.

    Raises:
        OutputError: The JSON summary cannot be written (a full disk).
    """
    out = _out(args)
    if args.save:
        result.recording = str(args.save)
    print(result.summary(recording=False), file=out)
    if args.json:
        print(f"JSON summary: {result.to_json(args.json)}", file=out)
    if result.recording:
        print(f"recording: {result.recording}  (view with: rerun {result.recording})", file=out)
    elif args.headless and not args.serve and not args.connect:
        print("recording: none kept (--headless without --save FILE.rrd)", file=out)
    viewer = getattr(args, "viewer", None)
    if viewer is not None:
        serve_until_interrupted(viewer, out)
    if getattr(args, "unreached", None):
        print(
            f"pik-mj: error: no rerun viewer answered at {args.unreached} (--connect): the "
            f"recording went to {args.save} only",
            file=sys.stderr,
        )
        return 2
    return 0 if result.passed else 1


def serve_until_interrupted(viewer: WebViewer, out: TextIO | None = None) -> None:
    """Keep ``viewer`` serving the recording until Ctrl-C (re-raised, for exit 130)
    or until it stops on its own; it is stopped on leaving."""
    print(f"serving until Ctrl-C: {viewer.where()}", file=out or sys.stdout, flush=True)
    try:
        while viewer.running():
            time.sleep(0.2)
    finally:
        viewer.stop()
