"""How the command line reports: every message one line starting ``capbridge:``.

The library's warnings become ``capbridge: warning: ...`` lines on stderr, and an
error's text is folded into one line (``capbridge: error: ...``, printed by
:func:`capbridge.cli.main`), so that a script or a user reads the outcome at a glance.
"""
from __future__ import annotations

import copy
import logging
import sys


class _LowerLevelFormatter:
    """``capbridge: warning: ...`` (lower-case level, like the error line)."""

    def __init__(self, fmt):
        self._fmt = logging.Formatter(fmt)

    def format(self, record):
        record = copy.copy(record)
        record.levelname = record.levelname.lower()
        return self._fmt.format(record)


def configure_logging(debug):
    """Warnings of the library as ``capbridge: warning: ...`` lines (tracebacks of failed
    chunks only with ``--debug``); left alone if the caller configured logging."""
    root, lib = logging.getLogger(), logging.getLogger("capbridge")
    if root.handlers or lib.handlers:
        return
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_LowerLevelFormatter("capbridge: %(levelname)s: %(message)s"))
    lib.addHandler(handler)
    lib.setLevel(logging.DEBUG if debug else logging.WARNING)
    lib.propagate = False


def one_line(exc):
    """The text of an exception on one line (an OSError's file name first)."""
    text = str(exc) or type(exc).__name__
    if isinstance(exc, OSError) and exc.filename is not None:
        text = f"{exc.filename}: {exc.strerror or text}"
    return " ".join(text.split())
