"""The JSON the commands print: numpy values as plain numbers, NaN and inf as null.

``json.dumps`` would write NaN as a bare ``NaN``, which is not JSON; a result without a
number (a bridge that did not converge) must still be readable by any JSON reader.
"""
from __future__ import annotations

import json

import numpy as np


def json_value(v):
    """An array or scalar as plain Python (nested lists), non-finite floats as None."""
    v = np.asarray(v)
    if v.ndim == 0:
        x = v.item()
        return None if isinstance(x, float) and not np.isfinite(x) else x
    return [json_value(x) for x in v]


def json_tree(x):
    """Dicts, lists, tuples and arrays of values as plain Python (:func:`json_value`),
    dict keys as strings."""
    if isinstance(x, dict):
        return {str(k): json_tree(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)) or isinstance(x, np.ndarray) and x.ndim:
        return [json_tree(v) for v in x]
    return json_value(x)


def print_json(x):
    """Print ``x`` (:func:`json_tree`) as indented JSON on stdout."""
    print(json.dumps(json_tree(x), indent=1))
