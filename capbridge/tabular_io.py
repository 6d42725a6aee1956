"""Reading point lists (CSV) and checking output paths, for every command-line lookup.

A CSV of points is a user's file: each problem is refused with one line naming the
file, the row and the column, never coerced (``True`` is not 1.0, a duplicated column
is not renamed, a row with an extra field is not shifted).  Output paths are checked
before anything is computed, so that a long computation never ends in "cannot write".
"""
from __future__ import annotations

import csv
import io
import os
import re
import tempfile
from pathlib import Path

import numpy as np

from capbridge.validation import CapbridgeInputError

__all__ = ["read_points_csv", "check_output_path", "check_new_output", "parse_number"]

# a decimal number (sign, digits, point, exponent) or nan/inf: what a CSV of points
# may hold; Python's float() would also take "1_000", and pandas "True"
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf|infinity)$",
                     re.IGNORECASE)


def parse_number(text):
    """``float(text)`` if ``text`` is a plain decimal number (or nan/inf), else None."""
    t = text.strip()
    return float(t) if _NUMBER.match(t) else None


def _read_text(path):
    path = Path(path)
    if not path.exists():
        raise CapbridgeInputError(f"input file {path} does not exist")
    if path.is_dir():
        raise CapbridgeInputError(f"input {path} is a directory, not a CSV file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise CapbridgeInputError(f"cannot read {path}: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise CapbridgeInputError(
            f"{path} is not UTF-8 text (byte {exc.start}: {raw[exc.start:exc.start + 1]!r}); "
            f"save it as UTF-8 CSV") from None
    if not text.strip():
        raise CapbridgeInputError(f"{path} is empty; expected a header row and points")
    return text


def read_points_csv(path, required, optional=(), reserved=()):
    """Read a CSV of points: a header row, then one point per row.

    Parameters
    ----------
    path : str or path-like
    required : sequence of str
        Columns that must be present; their cells must be numbers.
    optional : sequence of str
        Columns that may be present; their cells must then be numbers too.
    reserved : sequence of str
        Names the command will write (outputs): an input column of that name is
        refused rather than overwritten.

    Returns
    -------
    columns : dict name -> list of str
        Every column as read (text), in file order, for writing back unchanged.
    numbers : dict name -> numpy.ndarray
        The required and present optional columns as float arrays.

    Raises
    ------
    CapbridgeInputError
        One line naming the file and, for a bad cell, its line number and column.
    """
    text = _read_text(path)
    rows = [r for r in csv.reader(io.StringIO(text, newline="")) if any(c.strip() for c in r)]
    header = [h.strip() for h in rows[0]]
    body = rows[1:]
    if any(not h for h in header):
        raise CapbridgeInputError(f"{path}: the header row has an empty column name: {header}")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise CapbridgeInputError(f"{path}: duplicate column(s) {dup} in the header row")
    clash = [h for h in header if h in reserved]
    if clash:
        raise CapbridgeInputError(
            f"{path}: input column(s) {clash} have the names of outputs; rename them "
            f"(outputs: {list(reserved)})")
    missing = [c for c in required if c not in header]
    if missing:
        opt = f" (optional {', '.join(optional)})" if optional else ""
        raise CapbridgeInputError(
            f"{path}: missing column(s) {missing}; required: {', '.join(required)}{opt}, "
            f"found: {header}")
    if not body:
        raise CapbridgeInputError(f"{path}: no points after the header row")
    # line numbers as an editor shows them (header = line 1), blank lines skipped
    lines = _line_numbers(text)
    for k, row in enumerate(body):
        if len(row) != len(header):
            raise CapbridgeInputError(
                f"{path}: line {lines[k + 1]} has {len(row)} fields, the header has "
                f"{len(header)} ({', '.join(header)})")
    columns = {h: [row[j] for row in body] for j, h in enumerate(header)}
    numbers = {}
    for name in list(required) + [c for c in optional if c in header]:
        vals = np.empty(len(body))
        for k, cell in enumerate(columns[name]):
            x = parse_number(cell)
            if x is None:
                raise CapbridgeInputError(
                    f"{path}: line {lines[k + 1]}, column {name!r}: {cell!r} is not a number")
            vals[k] = x
        numbers[name] = vals
    return columns, numbers


def _line_numbers(text):
    """File line number (1-based) of each non-blank CSV record, in order."""
    out, line = [], 1
    reader = csv.reader(io.StringIO(text, newline=""))
    for row in reader:
        if any(c.strip() for c in row):
            out.append(line)
        line = reader.line_num + 1
    return out


def check_output_path(path, what="output"):
    """Check, before computing, that a file can be written at ``path``.

    The directory must exist and accept new files (tried, not guessed: ``os.access``
    says yes to root on read-only file systems); ``path`` must not be a directory,
    and an existing file must be writable.  Returns ``Path(path)``.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise CapbridgeInputError(f"{what} {path} is a directory; give a file name")
    if not parent.is_dir():
        raise CapbridgeInputError(f"{what} {path}: directory {parent} does not exist")
    try:
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".tmp-probe-"):
            pass
        if path.exists() and not os.access(path, os.W_OK):
            raise PermissionError(13, "file is read-only")
    except OSError as exc:
        raise CapbridgeInputError(f"{what} {path} cannot be written: "
                                  f"{exc.strerror or exc}") from None
    return path


def check_new_output(path, inputs=(), overwrite=False, flag="--overwrite", what="--output"):
    """:func:`check_output_path`, and nothing of the user's is replaced: ``path`` may not
    be one of the ``inputs``, and an existing file only with ``overwrite`` (``flag``
    names the option in the message).  Returns ``Path(path)``."""
    path = check_output_path(path, what=what)
    if any(Path(i).exists() and path.exists() and path.samefile(i) for i in inputs):
        raise CapbridgeInputError(f"{what} {path} is the input file; give another name")
    if path.exists() and not overwrite:
        raise CapbridgeInputError(f"{what} {path} exists; give another name, or {flag} "
                                  f"to replace it")
    return path
