"""The engines of a YADE process by label: what a PyRunner's command string reaches.

A PyRunner runs a string, so it finds its engine by label here.  After ``O.load`` in a
new process the registry is empty; :func:`get_engine` then asks the factory that the
engine module registers (``CapbridgeEngine.from_scene``) to rebuild the engine from the
scene's saved state.  Kept apart from the engine so that its helpers (the VTK recorder)
can find an engine without importing the engine module.
"""
from __future__ import annotations

__all__ = ["ENGINES", "get_engine", "set_factory"]

#: label -> engine
ENGINES: dict = {}
_FACTORY = []


def set_factory(factory):
    """``factory(label)`` rebuilds the engine of ``label`` from the scene (one factory)."""
    _FACTORY[:] = [factory]


def get_engine(label="capbridge"):
    """The engine registered under ``label`` (re-created from the scene's saved state
    after ``O.load`` in a new process)."""
    eng = ENGINES.get(label)
    if eng is not None:
        return eng
    if not _FACTORY:
        raise RuntimeError(f"no capbridge engine {label!r} in this process: import "
                           "capbridge.yade.engine (or run the scene's engine) first")
    return _FACTORY[0](label)
