"""The scene's geometry besides its spheres, for a bridge model: periodic cells and wall
partners.

Explicit data in, results out (the caller, :class:`~capbridge.yade.engine.CapbridgeEngine`,
keeps them): :func:`setup` makes a scene's periodic cell (attached to the bridge model)
and its wall bridges, :func:`before_update` follows a deforming cell, :func:`wall_forces`
adds the wall bridges' forces to the spheres' and :func:`drop_spheres` lets erased
spheres' wall bridges go.  The physics is in :mod:`capbridge.dem.periodic` and
:mod:`capbridge.dem.wall_bridges`.
"""
from __future__ import annotations

import numpy as np

from capbridge.dem.periodic import PeriodicCell, cell_matrix
from capbridge.dem.wall_bridges import WallBridges, WallSet
from capbridge.validation import CapbridgeInputError

__all__ = ["setup", "check_reach", "before_update", "wall_forces", "drop_spheres"]


def setup(O, model, sphere_theta, walls, wall_theta):
    """At set-up (first step, or after a load): the scene's periodic cell and its wall
    bridges.

    Parameters
    ----------
    O : yade.Omega
        The scene.
    model : BridgeModel
        The bridge model just made; a periodic cell is attached to it and to its
        near-pair list.
    sphere_theta : (n,) array
        Contact angles of the model's spheres [deg].
    walls : list of YADE bodies
        The wall partners (:func:`~capbridge.dem.wall_bridges.wall_bodies`; empty: none).
    wall_theta : (k,) array
        Their contact angles [deg].

    Returns
    -------
    (cell, wall_bridges) : (PeriodicCell or None, WallBridges or None)
        None where the scene is not periodic, where it has no wall partners.
    """
    cell = None
    if O.periodic:
        cell = PeriodicCell.from_scene(O)
        model.cell = model.cand.cell = cell
        check_reach(cell, model)
    if not walls:
        return cell, None
    if O.periodic and any(type(b.shape).__name__ != "Wall" for b in walls):
        raise CapbridgeInputError(
            "wall bridges in a periodic cell: only Wall bodies (infinite planes) are "
            "supported there, not Box or Facet; give walls=[ids of Wall bodies] or "
            "walls=False")
    return cell, WallBridges(model, sphere_theta, WallSet(walls, wall_theta))


def check_reach(cell, model):
    """The cell must be wide enough for the model's longest bridge and skin
    (:meth:`PeriodicCell.check_reach`)."""
    if model.n == 0:                       # every wet grain erased: nothing to reach
        return
    r = float(model.radii.max())
    cell.check_reach(2.0 * r + max(float(np.nanmax(model.table.rupture)) * r, model.skin))


def before_update(cell, model, h_size, pos, drift, rebuilds):
    """Before the bridges are updated: follow a deforming periodic cell, and have the
    near-pair list rebuilt when cell and grains together may have moved a skin.

    Parameters
    ----------
    cell : PeriodicCell
    model : BridgeModel
    h_size : the scene's cell matrix (``O.cell.hSize``)
    pos : (n, 3) centres of the wet spheres [m]
    drift, rebuilds : float, int
        What the last call returned (0.0 and -1 at set-up): the cell's drift since the
        near-pair list was last rebuilt, and the rebuild count it belongs to.

    Returns
    -------
    (drift, rebuilds) : (float, int)
        For the next call.
    """
    model.cell = model.cand.cell = cell    # drop_grains makes a new list
    moved_cell = cell.set(cell_matrix(h_size))
    if moved_cell > 0.0:
        check_reach(cell, model)
    if model.cand.rebuilds != rebuilds:    # a rebuild since: the drift counts from it
        drift, rebuilds = 0.0, model.cand.rebuilds
    drift += moved_cell
    ref = model.cand.ref
    if ref is not None and ref.shape == pos.shape and drift > 0.0:
        moved = float(np.linalg.norm(pos - ref, axis=1).max(initial=0.0))
        if 2.0 * moved + drift > model.skin:
            model.cand.ref = None          # the list is rebuilt in this update
    return drift, rebuilds


def wall_forces(walls, O, pos, forces, changed, first, holds_forces):
    """The sphere forces ``forces`` plus the wall bridges' forces on the spheres, and
    the changed rows (or None); the reaction on the wall bodies goes to YADE (added, or
    held as permanent forces with ``holds_forces``)."""
    if walls is None:
        return forces, changed
    f, touched = walls.update(pos, O, first=first)
    forces = forces + f          # (an empty model's sums may be integer zeros)
    walls.apply_reaction(O, holds_forces)
    if changed is not None:
        changed = np.union1d(changed, touched)
    return forces, changed


def drop_spheres(walls, gone):
    """Erased spheres (``gone``, a mask over the spheres): their wall bridges leave with
    them."""
    if walls is not None:
        walls.drop_spheres(gone)
