"""Restarts of :class:`~capbridge.yade.engine.CapbridgeEngine`: its entries in ``O.tags``
and the ``O.save`` / ``O.saveTmp`` hooks.

What a saved scene holds, per engine label (keys ``capbridge:<label>:<what>``):

``params``
    the engine's 28 flat keywords as JSON (:func:`params_json`; the shipped doublet
    table as ``"default"``, a table object as ``null``, ``theta`` as a number or
    ``{"by_material": [[key, angle], ...]}``).  This format is the one of every
    capbridge release since restarts exist; an engine made with keyword groups
    (:mod:`capbridge.yade.config`) saves the same flat keywords, so old and new
    files read alike (:func:`saved_params`).
``state``
    the bridges, films, ledger, held forces and registered parts
    (:mod:`capbridge.yade.state_io`), once the engine has started.
``live``
    a mark: ``live:<uuid>`` in the running scene, ``saved:<uuid>`` in a saved file, so
    that the engine knows, at its next step, that the scene was loaded.

:func:`install_save_hooks` wraps YADE's ``Omega.save`` / ``Omega.saveTmp`` so that every
running engine writes its state first (:func:`stashed`); the engine reads it back at its
first step after ``O.load`` (:meth:`CapbridgeEngine._sync`).
"""
from __future__ import annotations

import contextlib
import json
import uuid
from pathlib import Path

import numpy as np

from capbridge.yade import state_io
from capbridge.yade.registry import ENGINES

__all__ = ["TAG", "CapbridgeStateError", "tag_key", "tag_get", "pyrunners", "stashed",
           "install_save_hooks", "jsonable", "theta_to_json", "theta_from_json",
           "params_json", "saved_params", "write_state", "live_mark", "saved_mark"]

#: prefix of the engine's entries in ``O.tags``
TAG = "capbridge"


class CapbridgeStateError(RuntimeError):
    """The scene and the engine's state do not belong together (e.g. a scene loaded
    without capbridge's saved state)."""


def tag_key(label, what):
    return f"{TAG}:{label}:{what}"


def tag_get(O, key):
    try:
        return O.tags[key]
    except KeyError:
        return None


def live_mark():
    """A new mark of the live scene."""
    return f"live:{uuid.uuid4().hex}"


def saved_mark():
    """A new mark of a saved scene."""
    return f"saved:{uuid.uuid4().hex}"


def pyrunners(O, label):
    """Positions in ``O.engines`` of the PyRunners labelled ``label``, and the engines."""
    engs = list(O.engines)
    return [k for k, e in enumerate(engs)
            if type(e).__name__ == "PyRunner" and e.label == label], engs


@contextlib.contextmanager
def stashed(O):
    """Write every running engine's state into ``O.tags`` for a save, then mark the
    live scene as live again (the saved file carries a different mark, so the engine
    knows it was loaded)."""
    done = []
    for eng in list(ENGINES.values()):
        if pyrunners(O, eng.label)[0]:
            eng.stash(O)
            done.append(eng)
    try:
        yield
    finally:
        for eng in done:
            if eng.live_mark is not None:
                O.tags[tag_key(eng.label, "live")] = eng.live_mark


def install_save_hooks():
    """Wrap YADE's ``Omega.save`` and ``Omega.saveTmp`` so that the engines' states go
    into the saved scene (idempotent; done when an engine is made).  Saving through
    YADE's C++ side only (e.g. the Qt controller's save button) bypasses them."""
    from yade import wrapper

    om = wrapper.Omega
    if getattr(om, "_capbridge_hooked", False):
        return
    orig_save, orig_tmp = om.save, om.saveTmp

    def save(self, *args, **kw):
        with stashed(self):
            return orig_save(self, *args, **kw)

    def save_tmp(self, *args, **kw):
        with stashed(self):
            return orig_tmp(self, *args, **kw)

    save.__doc__ = (orig_save.__doc__ or "") + "\n(capbridge: engine states saved in O.tags)"
    save_tmp.__doc__ = (orig_tmp.__doc__ or "") + "\n(capbridge: engine states saved in O.tags)"
    om.save, om.saveTmp = save, save_tmp
    om._capbridge_hooked = True


def jsonable(v):
    """Parameters as plain JSON values (numpy scalars and arrays to Python)."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, (list, tuple)):
        return [jsonable(x) for x in v]
    return v


def theta_to_json(theta):
    """Contact angles as JSON (material keys keep their type: label or id; a key of
    another type, e.g. a Material object, cannot be saved: None)."""
    if isinstance(theta, dict):
        if not all(isinstance(k, (str, int)) for k in theta):
            return None
        return {"by_material": [[jsonable(k), float(v)] for k, v in theta.items()]}
    return float(theta)


def theta_from_json(theta):
    if isinstance(theta, dict):
        return {k: v for k, v in theta["by_material"]}
    return theta


def params_json(flat):
    """The flat keywords as saved in ``O.tags`` (``flat``: the 28 keywords as given)."""
    table, triplet_table = flat["table"], flat["triplet_table"]
    out = {k: jsonable(v) for k, v in flat.items() if k not in ("table", "theta")}
    # the shipped table by name, so that a saved scene loads on another machine
    out["table"] = ("default" if table is None else
                    str(table) if isinstance(table, (str, Path)) else None)
    out["theta"] = theta_to_json(flat["theta"])
    out["triplet_table"] = None if triplet_table is None else str(triplet_table)
    return out


def saved_params(O, label):
    """The flat keywords of the engine ``label`` saved in the scene (for
    ``CapbridgeEngine(**params)``); a :class:`CapbridgeStateError` when none is saved or
    it was made with what a scene cannot hold."""
    text = tag_get(O, tag_key(label, "params"))
    if text is None:
        raise CapbridgeStateError(
            f"no CapbridgeEngine {label!r} in this process and none saved in the scene: "
            f"create it (CapbridgeEngine(..., label={label!r})) before running")
    params = json.loads(text)
    if params.get("table") is None or params.get("theta") is None:
        what = ("a table object" if params.get("table") is None
                else "Material objects as keys of theta")
        raise CapbridgeStateError(
            f"CapbridgeEngine {label!r} was made with {what}, which the scene cannot "
            f"hold: create it again the same way (label={label!r}) after O.load and "
            "before running; its state is then read from the scene")
    params["theta"] = theta_from_json(params["theta"])
    if params["table"] == "default":
        params["table"] = None
    return params


def write_state(O, label, params, parts):
    """Write the parameters and, when ``parts`` is not None (the engine has started),
    the state into ``O.tags``, marked as saved."""
    O.tags[tag_key(label, "params")] = json.dumps(params)
    if parts is None:
        return
    O.tags[tag_key(label, "state")] = state_io.pack(parts)
    O.tags[tag_key(label, "live")] = saved_mark()
