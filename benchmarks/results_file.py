"""Writing one benchmark's section of ``benchmarks/RESULTS.md`` (shared by the benchmarks).

A section starts at a line ``heading`` (optionally followed by `` (date or label)``) and
runs to the next ``### `` heading.  Writing replaces that section in place, or appends it
at the end; the rest of the file is left as it is.
"""
from __future__ import annotations

from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"


def write_section(heading, text, path=RESULTS):
    """Replace the section of ``path`` that starts with ``heading`` by ``text`` (or
    append ``text``)."""
    old = path.read_text(encoding="utf-8") if path.exists() else ""
    lines = old.split("\n")
    start = next((k for k, line in enumerate(lines)
                  if line == heading or line.startswith(heading + " (")), None)
    text = text.rstrip("\n") + "\n"
    if start is None:
        new = old.rstrip("\n") + "\n\n" + text
    else:
        end = next((k for k in range(start + 1, len(lines)) if lines[k].startswith("### ")),
                   len(lines))
        tail = "\n".join(lines[end:])
        new = "\n".join(lines[:start]) + "\n" + text + ("\n" + tail if tail else "")
    path.write_text(new, encoding="utf-8")


def report(heading, text, write):
    """Print a benchmark's section ``text``; with ``write``, also put it in RESULTS.md
    (:func:`write_section`)."""
    print(text)
    if write:
        write_section(heading, text)
