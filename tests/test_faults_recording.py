"""Faults of recordings: complete, or loudly incomplete.

Before: ``pik-mj run --save`` onto a full disk exited 0 with a truncated ``.rrd``
(rerun only logged an ERROR line); ``--json`` onto a full disk left a traceback and an
empty file; two ``Recorder.to_file`` on one path raised nothing and the file held one
of them or failed its checksum; ``--connect`` without a viewer exited 0 after ~11 s
and dropped everything; ``--connect --save F`` and ``--stdout --save F`` ignored
``--save``; ``--headless`` kept nothing without saying so; ``read_recording`` of a
truncated ``.rrd`` or of a text file was a traceback.

The full-disk cases run on a small tmpfs mounted for the test (skipped, saying why,
where the machine does not allow it).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest
from tmp_scenarios import add_scenario

from pik_mj import Recorder, cli
from pik_mj.exceptions import InvalidInput, OutputError, WriterBusy
from pik_mj.record import read_recording
from pik_mj.record.reader import RRD_END, check_complete, verify
from pik_mj.record.sinks import WebViewer
from pik_mj.scenario import ScenarioResult

TINY = '''
    """A tiny scenario: points on the iteration timeline."""
    import numpy as np
    from pik_mj.scenario import ScenarioResult, open_recorder, parser, report


    def run(recorder, points=50):
        for k in range(points):
            recorder.set_time("iteration", k)
            recorder.log_point("world/p", np.random.default_rng(k).random(3))
        return ScenarioResult("tiny")


    def main(argv=None):
        p = parser(__doc__, hold=False)
        p.add_argument("--points", type=int, default=50)
        args = p.parse_args(argv)
        with open_recorder(args, "tiny") as recorder:
            result = run(recorder, args.points)
        return report(result, args)
'''


@pytest.fixture
def tiny(monkeypatch, tmp_path):
    """``pik-mj run tiny``: a scenario that records ``--points`` random points."""
    add_scenario(monkeypatch, tmp_path, "tiny", TINY)


def points(recorder: Recorder, n: int) -> None:
    rng = np.random.default_rng(0)
    for k in range(n):
        recorder.set_time("iteration", k)
        recorder.log_point("world/p", rng.random(3))


# ------------------------------------------------------------------ full disk
def test_a_recorder_on_a_full_disk_raises_at_close_naming_the_file(small_disk):
    rrd = small_disk / "run.rrd"
    recorder = Recorder.to_file(rrd)
    points(recorder, 40_000)  # about 1 MB: four times the disk
    with pytest.raises(OutputError, match=rf"recording '{rrd}' is truncated"):
        recorder.close()
    assert recorder.closed
    # the file is released: a new recorder may write it once there is room
    rrd.unlink()
    with Recorder.to_file(rrd) as again:
        points(again, 10)
    check_complete(rrd)


def test_a_flush_on_a_full_disk_raises_naming_the_file(small_disk):
    rrd = small_disk / "run.rrd"
    recorder = Recorder.to_file(rrd)
    points(recorder, 40_000)
    with pytest.raises(OutputError, match=rf"recording '{rrd}' could not be written"):
        recorder.flush()
    with pytest.raises(OutputError):
        recorder.close()


def test_run_save_onto_a_full_disk_exits_1_naming_the_file(tiny, small_disk, capsys):
    rrd = small_disk / "tiny.rrd"
    status = cli.main(["run", "tiny", "--points", "40000", "--save", str(rrd), "--quiet"])
    err = capsys.readouterr().err
    assert status == 1
    assert f"pik-mj: error: recording '{rrd}' is truncated" in err
    assert "Traceback" not in err


def test_a_json_summary_onto_a_full_disk_leaves_no_file(small_disk):
    result = ScenarioResult("tiny")
    result.figures = {"values": list(range(100_000))}  # about 700 kB of JSON
    out = small_disk / "summary.json"
    with pytest.raises(OutputError, match=rf"JSON summary '{out}' could not be written: No space"):
        result.to_json(out)
    assert sorted(p.name for p in small_disk.iterdir()) == []  # no empty file, no .tmp-


# ------------------------------------------------------------------ one writer per file
def test_a_second_recorder_on_one_path_is_refused(tmp_path):
    rrd = tmp_path / "run.rrd"
    first = Recorder.to_file(rrd)
    with pytest.raises(
        WriterBusy, match=rf"recording '{rrd}' is being written by pid {os.getpid()}"
    ):
        Recorder.to_file(rrd)
    points(first, 100)
    first.close()
    data = read_recording(rrd)  # the first recorder's, whole
    assert len(data["world/p"].temporal["Points3D:positions"]) == 100
    with Recorder.to_file(rrd) as second:  # free again once closed
        points(second, 3)
    assert len(read_recording(rrd)["world/p"].temporal["Points3D:positions"]) == 3


def test_a_recorder_of_another_process_holds_its_file(tmp_path):
    rrd = tmp_path / "run.rrd"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys; from pik_mj import Recorder; "
            f"r = Recorder.to_file({str(rrd)!r}); print('open', flush=True); sys.stdin.read(); "
            "r.close()",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "open"
        with pytest.raises(WriterBusy, match=f"pid {holder.pid}"):
            Recorder.to_file(rrd)
        # the command line refuses it before any work
        assert cli.main(["validate", "x.json", "--save", str(rrd)]) == 2
    finally:
        holder.stdin.close()
        holder.wait(timeout=60)
    verify(rrd)  # the holder's recording is whole


# ------------------------------------------------------------------ destinations
def test_connect_without_a_viewer_fails_within_seconds(tiny, capsys, tmp_path):
    """Before: exit 0 after ~11 s of gRPC errors, the recording lost."""
    t0 = time.monotonic()
    status = cli.main(["run", "tiny", "--connect", "--url", free_url(), "--quiet"])
    elapsed = time.monotonic() - t0
    err = capsys.readouterr().err
    assert status == 2
    assert "--connect: no rerun viewer answers at rerun+http://127.0.0.1:" in err
    assert "Traceback" not in err
    assert elapsed < 10.0


def test_connect_without_a_viewer_still_writes_the_save_file(tiny, capsys, tmp_path):
    rrd = tmp_path / "kept.rrd"
    status = cli.main(["run", "tiny", "--connect", "--url", free_url(), "--save", str(rrd)])
    captured = capsys.readouterr()
    assert status == 2
    assert f"recording to {rrd} only" in captured.err
    assert f"recording: {rrd}" in captured.out
    verify(rrd)
    assert len(read_recording(rrd)["world/p"].temporal["Points3D:positions"]) == 50


def test_connect_with_save_writes_the_file_and_streams_to_the_viewer(tiny, capsys, tmp_path):
    """A rerun gRPC server (the one ``--serve`` starts) stands for the viewer."""
    viewer = WebViewer()
    try:
        rrd = tmp_path / "both.rrd"
        argv = ["run", "tiny", "--connect", "--url", viewer.grpc_url, "--save", str(rrd)]
        assert cli.main([*argv, "--quiet"]) == 0
        captured = capsys.readouterr()
        assert "no rerun viewer" not in captured.err
        assert f"recording: {rrd}" in captured.out
        assert len(read_recording(rrd)["world/p"].temporal["Points3D:positions"]) == 50
        assert viewer.running()
    finally:
        viewer.stop()


def test_stdout_with_save_is_refused_as_usage(tiny, capsys, tmp_path):
    status = cli.main(["run", "tiny", "--stdout", "--save", str(tmp_path / "x.rrd")])
    assert status == 2
    assert "--save cannot go with it" in capsys.readouterr().err
    assert not (tmp_path / "x.rrd").exists()
    assert cli.main(["run", "tiny", "--serve", "--connect"]) == 2
    assert "give one" in capsys.readouterr().err
    assert cli.main(["run", "tiny", "--bind", "127.0.0.1"]) == 2
    assert "--bind says where --serve listens" in capsys.readouterr().err
    assert cli.main(["run", "tiny", "--serve", "--bind", "localhost:80"]) == 2
    assert "is not an IP address" in capsys.readouterr().err


def test_stdout_carries_the_recording_and_the_summary_goes_to_stderr(tmp_path):
    """The recording on standard output is a whole .rrd: nothing else is printed there."""
    bootstrap = (
        "import sys; import pik_mj.scenarios as s; "
        f"s.__path__.append({str(tmp_path)!r}); s.SCENARIOS.append('tiny'); "
        "from pik_mj import cli; sys.exit(cli.main(sys.argv[1:]))"
    )
    (tmp_path / "tiny.py").write_text(TINY.replace("\n    ", "\n").lstrip())
    run = subprocess.run(
        [sys.executable, "-c", bootstrap, "run", "tiny", "--stdout", "--quiet"],
        capture_output=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr.decode()
    assert b"scenario tiny: PASSED" in run.stderr
    rrd = tmp_path / "piped.rrd"
    rrd.write_bytes(run.stdout)
    assert run.stdout.startswith(b"RRF2")
    assert len(read_recording(rrd)["world/p"].temporal["Points3D:positions"]) == 50


def test_headless_says_where_the_recording_went(tiny, capsys, tmp_path):
    assert cli.main(["run", "tiny", "--headless", "--quiet"]) == 0
    assert "recording: none kept (--headless without --save FILE.rrd)" in capsys.readouterr().out
    rrd = tmp_path / "h.rrd"
    assert cli.main(["run", "tiny", "--headless", "--save", str(rrd), "--quiet"]) == 0
    assert f"recording: {rrd}" in capsys.readouterr().out
    verify(rrd)


# ------------------------------------------------------------------ reading back
def test_reading_a_truncated_or_foreign_file_names_it(tmp_path):
    rrd = tmp_path / "whole.rrd"
    with Recorder.to_file(rrd) as recorder:
        points(recorder, 200)
    data = rrd.read_bytes()
    assert data[-12:].startswith(RRD_END)
    cut = tmp_path / "cut.rrd"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(InvalidInput, match=rf"recording '{cut}' is truncated"):
        read_recording(cut)
    text = tmp_path / "notes.rrd"
    text.write_text("not a recording\n")
    with pytest.raises(InvalidInput, match="is not a rerun recording"):
        read_recording(text)
    # a file that ends like an .rrd but whose footer is damaged: rerun cannot read it
    damaged = tmp_path / "damaged.rrd"
    damaged.write_bytes(data[:-40] + b"\xff" * 28 + data[-12:])
    with pytest.raises(InvalidInput, match="cannot be read by rerun"):
        verify(damaged)
    with pytest.raises(OutputError, match="incomplete"):
        cli.check_recording(damaged)


def free_url() -> str:
    """A viewer URL where nothing listens."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"rerun+http://127.0.0.1:{port}/proxy"
