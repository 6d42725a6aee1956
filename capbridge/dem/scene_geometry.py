"""The engine's links to the scene's geometry besides its spheres: periodic cells and
wall partners (called from :class:`~capbridge.yade.engine.CapbridgeEngine`).

Kept out of ``engine.py`` so that the engine only calls :func:`setup`, :func:`before_update`
and :func:`wall_forces`; the physics is in :mod:`capbridge.dem.periodic` and
:mod:`capbridge.dem.wall_bridges`.
"""
from __future__ import annotations

import numpy as np

from capbridge.dem.periodic import PeriodicCell, cell_matrix
from capbridge.dem.wall_bridges import WallBridges, WallSet, wall_bodies
from capbridge.validation import CapbridgeInputError

__all__ = ["setup", "before_update", "wall_forces", "drop_spheres"]


def setup(eng, O, sphere_theta):
    """At the engine's set-up (first step, or after a load): the periodic cell and the
    wall bridges of the scene, on ``eng._cell`` and ``eng.walls``."""
    m = eng.model
    eng._cell, eng._cell_drift, eng._cell_rebuilds = None, 0.0, -1
    if O.periodic:
        cell = PeriodicCell.from_scene(O)
        m.cell = m.cand.cell = cell
        eng._cell = cell
        _check_cell(eng)
    bodies = wall_bodies(O, getattr(eng, "walls_requested", False))
    eng.walls = None
    if bodies:
        if O.periodic and any(type(b.shape).__name__ != "Wall" for b in bodies):
            raise CapbridgeInputError(
                "wall bridges in a periodic cell: only Wall bodies (infinite planes) are "
                "supported there, not Box or Facet; give walls=[ids of Wall bodies] or "
                "walls=False")
        theta_w = eng._materials_theta(bodies)
        eng.walls = WallBridges(m, sphere_theta, WallSet(bodies, theta_w))
        eng.register_state("walls", eng.walls.get_state, eng.walls.set_state)
        eng._say("info", f"capbridge {eng.label!r}: {len(bodies)} wall partners, wall angles "
                 f"{np.unique(theta_w).tolist()} deg (exact sphere-wall slices solved when a "
                 "pair of angles first forms a bridge)")


def _check_cell(eng):
    m = eng.model
    if m.n == 0:                           # every wet grain erased: nothing to reach
        return
    r = float(m.radii.max())
    reach = 2.0 * r + max(float(np.nanmax(m.table.rupture)) * r, m.skin)
    eng._cell.check_reach(reach)


def before_update(eng, O, pos):
    """Before the bridges are updated: follow a deforming periodic cell (and rebuild
    the near-pair list when cell and grains together may have moved a skin)."""
    cell = eng._cell
    if cell is None:
        return
    m = eng.model
    m.cell = m.cand.cell = cell            # drop_grains makes a new list
    drift = cell.set(cell_matrix(O.cell.hSize))
    if drift > 0.0:
        _check_cell(eng)
    if m.cand.rebuilds != eng._cell_rebuilds:
        eng._cell_drift, eng._cell_rebuilds = 0.0, m.cand.rebuilds
    eng._cell_drift += drift
    ref = m.cand.ref
    if ref is not None and ref.shape == pos.shape and eng._cell_drift > 0.0:
        moved = float(np.linalg.norm(pos - ref, axis=1).max(initial=0.0))
        if 2.0 * moved + eng._cell_drift > m.skin:
            m.cand.ref = None              # the list is rebuilt in this update


def wall_forces(eng, O, pos, forces, changed, first):
    """The sphere forces ``forces`` plus the wall bridges' forces on the spheres, and
    the changed rows (or None); the reaction on the wall bodies goes to YADE."""
    w = eng.walls
    if w is None:
        return forces, changed
    f, touched = w.update(pos, O, first=first)
    forces = forces + f          # (an empty model's sums may be integer zeros)
    w.apply_reaction(O, eng.holds_forces)
    if changed is not None:
        changed = np.union1d(changed, touched)
    return forces, changed


def drop_spheres(eng, gone):
    """Erased spheres: their wall bridges leave with them."""
    if getattr(eng, "walls", None) is not None:
        eng.walls.drop_spheres(gone)
