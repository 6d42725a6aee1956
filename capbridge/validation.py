"""Checks at the boundary: bad input fails loudly, naming the value and the allowed range."""
from __future__ import annotations

import numpy as np


class CapbridgeInputError(ValueError):
    """An input value outside the range capbridge supports."""


def check_range(name, value, low=-np.inf, high=np.inf, *, low_open=False, high_open=False,
                units="", hint=""):
    """Return ``value`` as a float array after checking it is finite and in range.

    Raises :class:`CapbridgeInputError` naming ``name``, the first offending value and
    the allowed interval, e.g. ``volume V*=-0.1 is outside [0, inf)``.
    """
    arr = np.asarray(value, dtype=float)
    bad = ~np.isfinite(arr)
    if low_open:
        bad |= arr <= low
    else:
        bad |= arr < low
    if high_open:
        bad |= arr >= high
    else:
        bad |= arr > high
    if np.any(bad):
        first = arr[bad].flat[0] if arr.ndim else float(arr)
        interval = f"{'(' if low_open else '['}{_fmt(low)}, {_fmt(high)}{')' if high_open else ']'}"
        where = "" if arr.ndim == 0 else f" ({int(bad.sum())} of {arr.size} values)"
        msg = f"{name}={first!r}{units} is outside the allowed range {interval}{where}"
        if hint:
            msg += f"; {hint}"
        raise CapbridgeInputError(msg)
    return arr


def _fmt(x):
    if np.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:g}"
