"""Engine state as text, for YADE's ``O.tags`` (saved with the scene).

YADE saves a scene (``O.save``, ``O.saveTmp``) with its engines, but a ``PyRunner``
carries only its command: the Python objects behind it are not in the file.  capbridge
keeps what a restart needs in the scene's own ``O.tags`` (a dict of strings YADE
saves and loads with everything else): :func:`pack` turns a state, a dict of named
parts (``{"bridges": {...}, "engine": {...}, ...}``), each a dict of numpy arrays and
JSON values, into one ASCII string (a compressed ``.npz`` in base64, the JSON values
in one entry), :func:`unpack` turns it back.  Arrays come back bit for bit, so forces
recomputed from them are the same numbers.

Adding state (e.g. liquid clusters) needs no change here: give the engine another part
(:meth:`capbridge.yade.engine.CapbridgeEngine.register_state`).
"""
from __future__ import annotations

import base64
import io
import json

import numpy as np

__all__ = ["pack", "unpack", "FORMAT"]

#: version tag of the packed format (checked by :func:`unpack`)
FORMAT = "capbridge-state-1"


def _split(parts):
    arrays, plain = {}, {}
    for part, values in parts.items():
        if "/" in part:
            raise ValueError(f"state part name {part!r} must not contain '/'")
        plain[part] = {}
        for key, val in values.items():
            if isinstance(val, np.ndarray):
                arrays[f"{part}/{key}"] = val
            else:
                plain[part][key] = val
    return arrays, plain


def pack(parts):
    """``{part: {key: ndarray | JSON value}}`` -> ASCII string (base64 of an npz)."""
    arrays, plain = _split(parts)
    arrays["__json__"] = np.frombuffer(json.dumps({"format": FORMAT, "plain": plain}).encode(),
                                       np.uint8)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def unpack(text):
    """Inverse of :func:`pack`."""
    with np.load(io.BytesIO(base64.b64decode(text.encode("ascii")))) as z:
        meta = json.loads(bytes(z["__json__"]).decode())
        if meta.get("format") != FORMAT:
            raise ValueError(f"saved capbridge state has format {meta.get('format')!r}, "
                             f"this capbridge reads {FORMAT!r}")
        out = {part: dict(values) for part, values in meta["plain"].items()}
        for name in z.files:
            if name == "__json__":
                continue
            part, key = name.split("/", 1)
            out.setdefault(part, {})[key] = z[name]
    return out
