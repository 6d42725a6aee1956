"""VTK output of a running :class:`~capbridge.yade.engine.CapbridgeEngine` (for ParaView).

``cap.write_vtk("bridges.vtp")`` writes the bridges of the current step;
``O.engines += [cap.vtk_recorder("out", every=100)]`` writes them every 100 steps as a
ParaView time series (``out/<label>_bridges.pvd``), beside YADE's own ``VTKRecorder``
files of the grains.  The files are written by :mod:`capbridge.dem.vtk_output`
(one line cell per bridge, SI units):

* ends: at the positions the engine's last step used (the forces' positions; YADE's
  own ``VTKRecorder`` after ``NewtonIntegrator`` shows the grains one step later): the
  two grain centres of a sphere-sphere bridge (in a periodic cell the second
  end is the nearest image of the second grain, so no line spans the cell), or the
  sphere's centre and the foot on the wall of a wall bridge;
* cell data ``volume`` [m^3], ``force`` [N] (vector on the first end, attraction
  towards the second) and ``force_magnitude``, ``status`` (0 a doublet bridge, 4
  coalesced: part of a liquid cluster), ``cluster`` (-1: none), ``gap`` [m],
  ``id1``, ``id2`` (body ids), ``wall`` (1 for a wall bridge);
* clusters (``*_clusters*``): one vertex per liquid cluster at the mean of its bridges'
  midpoints, with ``volume`` [m^3] and ``n_grains``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from capbridge.dem import vtk_output
from capbridge.status import Status
from capbridge.validation import CapbridgeInputError
from capbridge.yade.registry import get_engine

__all__ = ["bridge_arrays", "write_vtk", "vtk_recorder"]

TITLE = "capbridge liquid bridges of a YADE scene (SI: m, m^3, N)"

#: recorders by name, for their PyRunner commands
_RECORDERS: dict = {}


def bridge_arrays(model, geom, pos, ids, walls=None, report=None):
    """The bridges of an engine's last step as arrays for
    :func:`vtk_output.write_bridges` (``ends``, ``volume``, ``force``, ``status``,
    ``cluster``, ``extra``) and the clusters for :func:`vtk_output.write_clusters` (or
    None).  The arguments are :meth:`CapbridgeEngine.snapshot`'s: the bridge model, the
    last step's geometry (``gap``, ``d``, ``force``), the centres [m] that step's
    forces were computed at (the grains have moved by one NewtonIntegrator step since:
    ends, gaps and forces belong together), the wet spheres' body ids, the wall
    bridges and the coalescence report."""
    m, g = model, geom
    if m is None:
        raise CapbridgeInputError("the capbridge engine has not run a step yet: nothing to write")
    nb = m.n_bridges
    if g is None or pos is None or g["d"].shape[0] != nb or pos.shape[0] != m.n:
        raise CapbridgeInputError("the capbridge engine's bridges changed since its last "
                                  "step: write the VTK file right after a step")
    d = m.pair_vectors(pos, m.bi, m.bj)              # nearest image in a periodic cell
    dist = np.linalg.norm(d, axis=1)
    ends = np.stack([pos[m.bi], pos[m.bi] + d], axis=1)
    force = d * (g["force"] / dist)[:, None]          # on grain bi, towards bj
    status = np.full(nb, int(Status.CONVERGED), np.int32)
    cluster = np.full(nb, -1, np.int32)
    rep = report
    clusters = None
    if rep is not None and rep.n_clusters and max(int(c.max()) for c in rep.clusters) < nb:
        mid = 0.5 * (ends[:, 0] + ends[:, 1])
        cen, ng = [], []
        for c, members in enumerate(rep.clusters):
            cluster[members] = c
            status[members] = int(Status.COALESCED)
            cen.append(mid[members].mean(axis=0))
            ng.append(np.unique(np.concatenate([m.bi[members], m.bj[members]])).size)
        clusters = {"centroid": np.array(cen), "volume": np.asarray(rep.cluster_volumes),
                    "n_grains": np.array(ng)}
    extra = {"gap": g["gap"], "id1": ids[m.bi], "id2": ids[m.bj],
             "wall": np.zeros(nb, np.int32)}
    vol = m.vol
    wr = walls.records(ids) if walls is not None else None
    if wr is not None:
        k = wr["volume"].size
        ends = np.concatenate([ends, wr["ends"]])
        vol = np.concatenate([vol, wr["volume"]])
        force = np.concatenate([force, wr["force"]])
        status = np.concatenate([status, np.full(k, int(Status.CONVERGED), np.int32)])
        cluster = np.concatenate([cluster, np.full(k, -1, np.int32)])
        extra = {"gap": np.concatenate([extra["gap"], wr["gap"]]),
                 "id1": np.concatenate([extra["id1"], wr["id1"]]),
                 "id2": np.concatenate([extra["id2"], wr["id2"]]),
                 "wall": np.concatenate([extra["wall"], np.ones(k, np.int32)])}
    return {"ends": ends, "volume": vol, "force": force, "status": status,
            "cluster": cluster, "extra": extra}, clusters


def write_vtk(snapshot, path, overwrite=False):
    """Write the bridges of ``snapshot`` (:meth:`CapbridgeEngine.snapshot`, the arguments
    of :func:`bridge_arrays`) to ``path`` (``.vtp``/``.vtk``) and, when there are liquid
    clusters, ``<stem>_clusters<suffix>`` beside it.  Returns the files written."""
    path = Path(path)
    b, clusters = bridge_arrays(**snapshot)
    out = [vtk_output.write_bridges(path, b["ends"], b["volume"], b["force"], b["status"],
                                    b["cluster"], extra=b["extra"], title=TITLE,
                                    overwrite=overwrite)]
    if clusters is not None:
        out.append(vtk_output.write_clusters(path.with_name(f"{path.stem}_clusters{path.suffix}"),
                                             title=TITLE, overwrite=overwrite, **clusters))
    return out


def vtk_recorder(label, directory, every=100, prefix=None, overwrite=False):
    """A ``PyRunner`` writing the bridges of the engine labelled ``label`` every
    ``every`` steps into ``directory`` (``<prefix>_bridges_<iter>.vtp`` and a ``.pvd``
    time series; prefix default the label).  Files of an earlier run with the same
    prefix are an error unless ``overwrite=True``.  The PyRunner finds the engine by
    its label (:func:`~capbridge.yade.registry.get_engine`) at each write: after
    ``O.load`` in a new process it carries on with the engine made again there, in the
    same directory (the series continues)."""
    from yade import wrapper

    every = int(every)
    if every < 1:
        raise CapbridgeInputError(f"every={every}: the recorder period must be >= 1 step")
    prefix = label if prefix is None else str(prefix)
    directory = Path(directory).resolve()
    _RECORDERS[(str(directory), prefix)] = vtk_output.BridgeVTKRecorder(
        directory, prefix=prefix, overwrite=overwrite)
    cmd = ("from capbridge.yade.engine_vtk import _record; "
           f"_record({label!r}, {str(directory)!r}, {prefix!r})")
    return wrapper.PyRunner(command=cmd, iterPeriod=every, initRun=False,
                            label=f"{label}_vtk")


def _record(label, directory, prefix):
    """What the recorder's PyRunner runs."""
    import yade

    rec = _RECORDERS.get((directory, prefix))
    if rec is None:        # a loaded scene in a new process: continue the series
        rec = vtk_output.BridgeVTKRecorder(directory, prefix=prefix, overwrite=True)
        rec.overwrite = False
        for what in rec.series:
            rec.series[what] = _old_series(Path(directory) / f"{prefix}_{what}.pvd")
        _RECORDERS[(directory, prefix)] = rec
    O = yade.Omega()
    b, clusters = bridge_arrays(**get_engine(label).snapshot())
    rec.record(int(O.iter), float(O.time), b["ends"], b["volume"], b["force"], b["status"],
               b["cluster"], extra=b["extra"], clusters=clusters, title=TITLE)


def _old_series(pvd):
    """(time, file) entries of an existing ParaView collection (empty if none)."""
    import xml.etree.ElementTree as ET

    if not pvd.exists():
        return []
    return [(float(e.get("timestep")), pvd.parent / e.get("file"))
            for e in ET.parse(pvd).getroot().iter("DataSet")]
