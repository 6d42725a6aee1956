"""Parsing the machine-readable report printed by :func:`.script.report`."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Snapshot:
    """State of the surface at one report: energies, bodies, mesh, contact edges."""

    tag: str
    energy: float = np.nan
    area: float = np.nan
    counts: tuple = (0, 0, 0)
    newton_steps: int = 0
    newton_rejected: int = 0
    last_newton_de: float = np.nan
    scale: float = np.nan
    indefinite: int = 0                 # Newton steps that met an indefinite Hessian
    body_volume: dict = field(default_factory=dict)
    body_target: dict = field(default_factory=dict)
    body_pressure: dict = field(default_factory=dict)
    vertex_ids: np.ndarray = None       # (nv,)
    vertices: np.ndarray = None         # (nv, 3)
    facets: np.ndarray = None           # (nf, 3) vertex ids, oriented
    facet_body: np.ndarray = None       # (nf,)
    contact_edges: dict = field(default_factory=dict)   # constraint -> (m, 2) vertex ids
    hits: dict = field(default_factory=dict)            # one-sided constraint -> count

    @property
    def n_facets(self):
        return 0 if self.facets is None else len(self.facets)

    def index_of(self):
        """Map vertex id -> row in ``vertices``."""
        return {int(v): i for i, v in enumerate(self.vertex_ids)}

    def triangle_mesh(self, contact_constraints):
        """The free surface as a triangle mesh on the rows of ``vertices``.

        Parameters
        ----------
        contact_constraints : dict
            (body index, grain index) -> contact constraint number, 0-based indices
            (:attr:`.datafile.MeshedProblem.contact_constraints`).

        Returns
        -------
        triangles : numpy.ndarray of int, shape (nf, 3)
            Rows of ``vertices`` of every facet, in Evolver's orientation (the normal
            points out of the liquid).
        body : numpy.ndarray of int, shape (nf,)
            0-based index of the liquid body each facet bounds.
        contact_grain : numpy.ndarray of int, shape (nv,)
            0-based grain whose contact line a vertex lies on; -1 for the free surface.
        """
        idx = self.index_of()
        rows = np.vectorize(idx.__getitem__, otypes=[np.int64])
        triangles = rows(self.facets).reshape(-1, 3)
        contact_grain = np.full(len(self.vertex_ids), -1, dtype=np.int64)
        for (_, g), cn in contact_constraints.items():
            e = self.contact_edges.get(cn)
            if e is not None and e.size:
                contact_grain[rows(e.ravel())] = g
        return triangles, self.facet_body.astype(np.int64) - 1, contact_grain


class ReportError(ValueError):
    pass


def parse_reports(text):
    """All complete ``@BEGIN``..``@END`` blocks in ``text``, as a dict tag -> Snapshot."""
    out = {}
    cur = None
    verts, facets, cedges = [], [], {}
    for line in text.splitlines():
        if not line.startswith("@"):
            continue
        parts = line.split()
        key = parts[0]
        try:
            if key == "@BEGIN":
                cur = Snapshot(tag=parts[1])
                verts, facets, cedges = [], [], {}
            elif cur is None:
                continue
            elif key == "@E":
                cur.energy = float(parts[1])
            elif key == "@A":
                cur.area = float(parts[1])
            elif key == "@N":
                cur.counts = tuple(int(p) for p in parts[1:4])
            elif key == "@R":
                cur.newton_steps = int(parts[1])
                cur.newton_rejected = int(parts[2])
                cur.last_newton_de = float(parts[3])
                cur.scale = float(parts[4])
            elif key == "@I":
                cur.indefinite = int(parts[1])
            elif key == "@B":
                b = int(parts[1])
                cur.body_volume[b] = float(parts[2])
                cur.body_target[b] = float(parts[3])
                cur.body_pressure[b] = float(parts[4])
            elif key == "@V":
                verts.append((int(parts[1]), float(parts[2]), float(parts[3]),
                              float(parts[4])))
            elif key == "@F":
                facets.append(tuple(int(p) for p in parts[1:6]))
            elif key == "@C":
                cedges.setdefault(int(parts[1]), []).append((int(parts[3]), int(parts[4])))
            elif key == "@H":
                cur.hits[int(parts[1])] = int(parts[2])
            elif key == "@END":
                v = np.array(verts, float).reshape(-1, 4)
                cur.vertex_ids = v[:, 0].astype(int)
                cur.vertices = v[:, 1:]
                f = np.array(facets, int).reshape(-1, 5)
                cur.facets = f[:, 1:4]
                cur.facet_body = f[:, 4]
                cur.contact_edges = {k: np.array(e, int).reshape(-1, 2)
                                     for k, e in cedges.items()}
                out[cur.tag] = cur
                cur = None
        except (IndexError, ValueError) as exc:
            raise ReportError(f"cannot parse Evolver report line {line!r}: {exc}") from exc
    return out
