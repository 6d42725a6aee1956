"""Checks at the boundary: bad input fails loudly, naming the value and the allowed range."""
from __future__ import annotations

import numbers

import numpy as np


class CapbridgeInputError(ValueError):
    """An input value outside the range capbridge supports."""


def check_range(name, value, low=-np.inf, high=np.inf, *, low_open=False, high_open=False,
                units="", hint=""):
    """Return ``value`` as a float array after checking it is finite and in range.

    Raises :class:`CapbridgeInputError` naming ``name``, the first offending value and
    the allowed interval, e.g. ``volume V*=-0.1 is outside [0, inf)``.  An infinite
    end is always printed open: it is never an allowed value.
    """
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise CapbridgeInputError(f"{name}={value!r} is not a number") from None
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
        msg = f"{name}={first!r}{units} is outside the allowed range " \
              f"{interval_text(low, high, low_open, high_open)}"
        if arr.ndim:
            msg += f" ({int(bad.sum())} of {arr.size} values)"
        if hint:
            msg += f"; {hint}"
        raise CapbridgeInputError(msg)
    return arr


def check_int(name, value, low=None, high=None, hint=""):
    """Return ``value`` as an ``int`` after checking it is an integer in [low, high].

    Booleans and non-integral floats are refused (``refine=2.5`` is a slip, not 2).
    """
    ok = isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))
    if not ok and isinstance(value, (float, np.floating)) and float(value).is_integer():
        ok = True
    if not ok:
        raise CapbridgeInputError(f"{name}={value!r} is not an integer"
                                  + (f"; {hint}" if hint else ""))
    v = int(value)
    lo = -np.inf if low is None else low
    hi = np.inf if high is None else high
    if not lo <= v <= hi:
        msg = f"{name}={v} is outside the allowed range {interval_text(lo, hi)}"
        raise CapbridgeInputError(msg + (f"; {hint}" if hint else ""))
    return v


def check_choice(name, values, allowed):
    """Check that every item of ``values`` (a string or an iterable) is in ``allowed``."""
    items = [values] if isinstance(values, str) else list(values)
    unknown = [v for v in items if v not in allowed]
    if unknown:
        raise CapbridgeInputError(f"{name}: unknown {unknown}; allowed: {list(allowed)}")
    return items


def interval_text(low, high, low_open=False, high_open=False):
    """``[a, b]``-style text of an interval; infinite ends print open (``[0, inf)``)."""
    lo_open = low_open or np.isinf(low)
    hi_open = high_open or np.isinf(high)
    return f"{'(' if lo_open else '['}{_fmt(low)}, {_fmt(high)}{')' if hi_open else ']'}"


def _fmt(x):
    if np.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:g}"
