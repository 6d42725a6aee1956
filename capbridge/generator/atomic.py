"""Atomic file replacement, shared by table writers and sweep checkpoints."""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path


@contextlib.contextmanager
def atomic_target(path, suffix=""):
    """Yield a temporary path beside ``path``; on success it replaces ``path``.

    Readers never see a partial file, and a kill leaves at most a ``.tmp-*`` file
    (harmless, safe to delete).  On an exception the temporary file is removed.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".tmp-{path.name}-", suffix=suffix)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
