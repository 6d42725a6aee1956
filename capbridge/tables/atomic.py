"""Atomic file replacement, shared by table writers and sweep checkpoints."""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path


def current_umask():
    """The process umask, read without changing it where Linux allows (``/proc``)."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)   # portable fallback: set and restore at once
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_target(path, suffix=""):
    """Yield a temporary path beside ``path``; on success it replaces ``path``.

    Readers never see a partial file, and a kill leaves at most a ``.tmp-*`` file
    (harmless, safe to delete).  On an exception the temporary file is removed.
    The final file gets the mode an ordinary ``open(path, "w")`` would give
    (0666 minus the umask): ``mkstemp`` alone would make it 0600 whatever the umask.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".tmp-{path.name}-", suffix=suffix)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
