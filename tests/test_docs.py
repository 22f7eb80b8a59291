"""The code on the documentation's pages and in the README runs as printed.

Every fenced ``python`` block of ``README.md`` and ``docs/**/*.md`` is run: the
blocks of one page in order, in one namespace (a page reads top to bottom, as a
script), in a temporary working directory. A comment line just before a block
changes how it runs:

* ``<!-- docs-test: needs MENAGERIE_ROOT -->``: the block loads a MuJoCo
  Menagerie robot; it runs alone, in a namespace of its own, and is skipped
  (saying so) when ``MENAGERIE_ROOT`` is unset.
* ``<!-- docs-test: argv ARGS -->``: the block is a script reading its command
  line; it runs alone with ``sys.argv`` = ``[page, *ARGS]``.

The page list and the block count are checked too, so that a page whose blocks
stopped being found (a renamed fence) fails instead of passing empty.
"""

from __future__ import annotations

import os
import re
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
import rerun as rr

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
MARKER = re.compile(r"<!--\s*docs-test:\s*(.*?)\s*-->")
FENCE = re.compile(r"^(`{3,})\s*python\s*$")


@dataclass(frozen=True)
class Block:
    """A fenced python block of a page: its code, first line and marker."""

    page: Path
    line: int
    code: str
    marker: str = ""

    @property
    def alone(self) -> bool:
        return bool(self.marker)


def blocks(page: Path) -> list[Block]:
    """The fenced ``python`` blocks of ``page``, with the marker before each."""
    lines = page.read_text(encoding="utf-8").splitlines()
    found, i = [], 0
    while i < len(lines):
        fence = FENCE.match(lines[i].strip())
        if not fence:
            i += 1
            continue
        before = lines[i - 1].strip() if i else ""
        marker = MARKER.fullmatch(before)
        end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == fence.group(1))
        code = "\n".join(lines[i + 1 : end])
        found.append(Block(page, i + 1, code, marker.group(1) if marker else ""))
        i = end + 1
    return found


def _name(page: Path) -> str:
    return str(page.relative_to(ROOT))


def _exec(block: Block, namespace: dict) -> None:
    code = compile(block.code, f"{_name(block.page)}:{block.line}", "exec")
    exec(code, namespace)


def _runs(page: Path) -> list[pytest.param]:
    """The test cases of a page: its plain blocks together, each marked block alone."""
    found = blocks(page)
    plain = [b for b in found if not b.alone]
    cases = [pytest.param(page, tuple(plain), id=_name(page))] if plain else []
    cases += [pytest.param(page, (b,), id=f"{_name(page)}:{b.line}") for b in found if b.alone]
    return cases


CASES = [case for page in PAGES for case in _runs(page)]


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    """A temporary working directory; rerun's global and thread-local recordings
    as they were afterwards (a page's ``rr.script_setup`` sets the global one)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [sys.argv[0]])
    before = rr.get_global_data_recording(), rr.get_thread_local_data_recording()
    yield tmp_path
    rr.set_global_data_recording(before[0])
    rr.set_thread_local_data_recording(before[1])


@pytest.mark.parametrize(("page", "code"), CASES)
def test_page_code_runs(page: Path, code: tuple[Block, ...], in_tmp, monkeypatch):
    """The page's python runs without error (its asserts are the checks)."""
    namespace: dict = {"__name__": "__main__"}
    for block in code:
        if block.marker == "needs MENAGERIE_ROOT":
            if not os.environ.get("MENAGERIE_ROOT"):
                pytest.skip("MENAGERIE_ROOT is unset: the block loads a Menagerie robot")
        elif block.marker.startswith("argv"):
            argv = shlex.split(block.marker.removeprefix("argv"))
            monkeypatch.setattr(sys, "argv", [_name(page), *argv])
        elif block.marker:
            raise AssertionError(f"{_name(page)}:{block.line}: unknown marker {block.marker!r}")
        _exec(block, namespace)


def test_blocks_are_found():
    """Every page of the site is read, and the pages that show code have blocks."""
    names = {_name(p) for p in PAGES}
    assert {"README.md", "docs/getting_started.md", "docs/own_robot.md"} <= names
    counts = {_name(p): len(blocks(p)) for p in PAGES}
    assert counts["docs/getting_started.md"] >= 3
    assert counts["docs/recordings.md"] >= 2
    marked = [b for p in PAGES for b in blocks(p) if b.alone]
    assert any(b.marker == "needs MENAGERIE_ROOT" for b in marked)


def test_block_parser(tmp_path):
    """Fences, markers and the lines between are read as written."""
    page = tmp_path / "p.md"
    page.write_text(
        "text\n```python\na = 1\n```\n<!-- docs-test: argv --save x.rrd -->\n"
        "````python\nb = '```'\n````\n```bash\nls\n```\n"
    )
    found = blocks(page)
    assert [(b.line, b.code, b.marker) for b in found] == [
        (2, "a = 1", ""),
        (6, "b = '```'", "argv --save x.rrd"),
    ]


def test_readme_fits_a_few_screens():
    """The README: at most 250 lines, the two commands CI runs (.ci/run reads
    them after their markers), links into the site, and no history (no
    figures dated by commit)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 250
    for marker in ("<!-- ci: main-job", "<!-- ci: test"):
        after = text.split(marker, 1)[1].splitlines()
        assert after[1] == "```bash" and after[2].startswith("python3 -m venv .venv && ")
    assert re.search(r"\b(at|since|before) [0-9a-f]{7,40}\b", text) is None
    linked = set(re.findall(r"\]\((docs/[^)#]+)", text))
    assert "docs/getting_started.md" in linked
    assert all((ROOT / page).is_file() for page in linked), linked
