"""Where a scenario's run goes: the recording opened where rerun's options send it
(:func:`open_recorder`), the summary printed and the JSON written (:func:`report`)."""

from __future__ import annotations

import argparse
import uuid
from pathlib import Path

import rerun as rr

from pik_mj.exceptions import OptionError
from pik_mj.record import Recorder
from pik_mj.scenario.result import ScenarioResult


def open_recorder(args: argparse.Namespace, name: str) -> Recorder:
    """A :class:`Recorder` on a new stream where rerun's options send it
    (as :func:`rerun.script_setup`, but the stream is not made the global one):
    ``--save FILE.rrd``, ``--stdout``, ``--serve`` (a web viewer), ``--connect``
    (a running viewer), a spawned viewer, or nothing kept with ``--headless``.

    Raises:
        OptionError: The sink cannot be opened (a bad ``--url``, no viewer to
            spawn, a file that cannot be created); rerun's reason is given.
    """
    stream = rr.RecordingStream(f"pik_mj_{name}", recording_id=uuid.uuid4())
    try:
        if args.stdout:
            stream.stdout()
        elif args.serve:
            rr.serve_web_viewer(open_browser=True, connect_to=stream.serve_grpc())
        elif args.connect:
            stream.connect_grpc(args.url)
        elif args.save is not None:
            Path(args.save).parent.mkdir(parents=True, exist_ok=True)
            stream.save(args.save)
        elif not args.headless:
            stream.spawn()
    except (OSError, RuntimeError, ValueError) as exc:
        raise OptionError(f"cannot open the recording's destination: {exc}") from None
    return Recorder(stream, owns_stream=True)


def report(result: ScenarioResult, args: argparse.Namespace) -> int:
    """Print the summary (and where the recording and JSON went); 0 iff passed."""
    if args.save:
        result.recording = str(args.save)
    print(result.summary(recording=False))
    if args.json:
        print(f"JSON summary: {result.to_json(args.json)}")
    if result.recording:
        print(f"recording: {result.recording}  (view with: rerun {result.recording})")
    rr.script_teardown(args)
    return 0 if result.passed else 1
