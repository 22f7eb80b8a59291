"""Sphinx configuration of pik_mj's documentation site.

Why Sphinx: pik_mj's docstrings are written with Sphinx's roles and directives
(``:func:``, ``:class:``, ``.. math::``) in Google style, which autodoc and
napoleon render as they are; MyST lets the pages themselves be Markdown, as the
README is. Build (warnings are errors, as in CI)::

    pip install -e ".[docs]"
    sphinx-build -W -b html docs out/docs
"""

from __future__ import annotations

import re
from pathlib import Path

DOCS = Path(__file__).resolve().parent

project = "pik_mj"
author = "pik_mj developers"
copyright = "pik_mj developers"
release = version = "0.1.0"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "scenarios/figures/*"]

# MyST: $...$ math, ::: fences for directives, anchors for ## and ### headings.
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3

# autodoc: the signature's type hints in the description; members in source order.
autodoc_typehints = "description"
autodoc_member_order = "bysource"
autosummary_generate = True  # api/generated/: one page per module, made at build time
templates_path = ["_templates"]
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False
napoleon_use_ivar = True  # "Attributes:" as fields: dataclass fields are documented once

html_theme = "furo"
html_title = f"pik_mj {release}"
html_static_path: list[str] = []

# Pages other parts of the project write; until one exists its toctree entry is
# dropped and a link to it is left as its text, rather than made a warning.
OPTIONAL_PAGES = ("walking", "priority", "benchmarks")


def _drop_missing_pages(app, docname: str, source: list[str]) -> None:
    missing = [p for p in OPTIONAL_PAGES if not (DOCS / f"{p}.md").is_file()]
    if not missing:
        return
    text = source[0]
    if docname == root_doc:
        lines = text.splitlines(keepends=True)
        text = "".join(line for line in lines if line.strip() not in missing)
    pages = "|".join(re.escape(p) for p in missing)
    link = re.compile(rf"\[([^\]]+)\]\((?:\.\./)*(?:{pages})\.md(?:#[^)]*)?\)")
    source[0] = link.sub(r"\1", text)


# Docstrings write |x| for a norm; reStructuredText reads it as a substitution.
# Outside literals, roles and math blocks the bars are escaped (shown as written).
# A literal followed by a letter or digit (``x``s, ``scale``³) ends with an
# escaped space, without which reStructuredText does not end it.
_LITERAL = re.compile(r"(``.*?``|`[^`]*`)")
_GLUED = re.compile(r"(``[^`]+``)(?=\w)")
_BARS = re.compile(r"(?<!\\)\|([^|\s][^|]*?)\|")


def _escape_docstring(app, what, name, obj, options, lines: list[str]) -> None:
    math_indent = None
    for i, line in enumerate(lines):
        indent = len(line) - len(line.lstrip())
        if math_indent is not None and (not line.strip() or indent > math_indent):
            continue
        math_indent = indent if line.strip().startswith(".. math::") else None
        if math_indent is not None:
            continue
        parts = _LITERAL.split(_GLUED.sub(r"\1\\ ", line))
        parts[::2] = [_BARS.sub(r"\\|\1\\|", p) for p in parts[::2]]
        lines[i] = "".join(parts)


def setup(app) -> None:
    app.connect("source-read", _drop_missing_pages)
    app.connect("autodoc-process-docstring", _escape_docstring)
