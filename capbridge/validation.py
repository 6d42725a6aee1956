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
    arr = as_numbers(name, value)
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


# dtype kinds that convert to float without being numbers: booleans, complex numbers
# (the imaginary part dropped), dates and time spans (a datetime64 converts to its day count), strings, bytes, raw records
_NOT_NUMBERS = {"b": "a boolean", "c": "a complex number", "M": "a date", "m": "a time span", "U": "text",
                "S": "bytes", "V": "raw data"}


def as_numbers(name, value):
    """``value`` as a float array, refusing what converts to float without being a
    number (``np.asarray(np.datetime64("2020-01-01"), float)`` is 18262.0, ``True``
    is 1.0, ``"0.1"`` is 0.1): one :class:`CapbridgeInputError` naming ``name``."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):
        raise CapbridgeInputError(f"{name}={value!r} is not a number") from None
    kind = raw.dtype.kind
    if kind == "O":
        for v in raw.ravel().tolist():
            if not isinstance(v, numbers.Number) or isinstance(v, (bool, np.bool_, complex)):
                raise CapbridgeInputError(f"{name}={v!r} is not a number")
    elif kind in _NOT_NUMBERS:
        first = raw.ravel()[0] if raw.size else raw
        raise CapbridgeInputError(f"{name}={first!r} is {_NOT_NUMBERS[kind]}, not a number")
    try:
        return np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise CapbridgeInputError(f"{name}={value!r} is not a number") from None


# Grains in contact overlap in a DEM (the normal spring); up to this depth, in units of
# the normalising radius, a negative gap is a contact and lookups answer at gap 0.
# DEM overlaps are kept to ~1e-3-1e-2 R; deeper ones are a broken scene, not a contact.
CONTACT_OVERLAP_MAX = 0.05


def check_gap(name, value, *, overlap_max=CONTACT_OVERLAP_MAX, units=""):
    """Gaps between sphere surfaces as lookups take them: finite numbers, overlaps down
    to ``overlap_max`` (same units as ``value``; scalar or broadcastable) read as
    contact.  Returns the gaps with those overlaps set to 0.

    Deeper overlaps raise one :class:`CapbridgeInputError` naming the value and the
    allowed range.
    """
    arr = check_range(name, value, units=units)
    limit = np.broadcast_to(np.asarray(overlap_max, dtype=float), arr.shape)
    deep = arr < -limit * (1 + 1e-12)          # the limit itself, up to round-off, is allowed
    if np.any(deep):
        first = float(arr[deep].flat[0])
        lim = float(limit[deep].flat[0])
        raise CapbridgeInputError(
            f"{name}={first!r}{units} is outside the allowed range [{-lim:g}, inf): "
            f"grains overlapping by up to {lim:g}{units} (DEM contacts) count as touching, "
            f"deeper overlaps are not supported")
    return np.maximum(arr, 0.0)


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
