"""Which pendular bridges of a packing have coalesced (geometric criterion, plain numpy).

Two bridges on a shared grain i, to grains j and k, merge when their wetted caps on i
meet: ``beta_ij + beta_ik >= angle jik``, with beta the half filling angle *on grain i*
(the table's ``beta1`` if i is the smaller grain of the pair, ``beta2`` otherwise) and
angle jik the angle at i between the centre lines i->j and i->k (Miot et al. 2021; for a
symmetric top grain beta = alpha = half that angle).

:func:`find_coalescence` looks only at grains that hold two bridges or more (none: no
search at all), pairs their bridges, applies the criterion and groups the merged
bridges into clusters (connected components: a trimer of three bridges is one cluster).
It reports, never acts: the engine keeps the doublet forces of merged bridges until
triplet tables exist, and says so.
"""
from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["CoalescenceReport", "find_coalescence", "bridge_pairs_on_shared_grains"]


@dataclasses.dataclass
class CoalescenceReport:
    """Result of :func:`find_coalescence` (indices are grain indices of the caller).

    ``triplets``   (m, 3) grains (j, i, k) of every merged pair of bridges, i shared,
                   j < k;
    ``pairs``      (m, 2) bridge indices of those pairs (smaller first);
    ``closed``     (m,) True where j and k are bridged too (a triangle of bridges);
    ``margin``     (m,) beta_ij + beta_ik - angle jik [deg] (>= 0 when merged);
    ``clusters``   list of arrays of bridge indices, one per liquid cluster of >= 2
                   bridges; ``cluster_volumes`` their summed bridge volumes [m^3];
    ``searched``   False when no grain held two bridges (nothing was computed);
    ``candidates`` number of bridge pairs sharing a grain that were tested.
    """

    triplets: np.ndarray
    pairs: np.ndarray
    closed: np.ndarray
    margin: np.ndarray
    clusters: list
    cluster_volumes: np.ndarray
    searched: bool
    candidates: int

    @property
    def n_triplets(self):
        return int(self.pairs.shape[0])

    @property
    def n_clusters(self):
        return len(self.clusters)

    @property
    def coalesced_volume(self):
        return float(self.cluster_volumes.sum()) if self.cluster_volumes.size else 0.0

    @property
    def n_bridges_in_clusters(self):
        return int(sum(c.size for c in self.clusters))

    def summary(self):
        """JSON-friendly counts."""
        return {"searched": self.searched, "candidate_pairs": self.candidates,
                "triplets": self.n_triplets, "closed_triangles": int(self.closed.sum()),
                "clusters": self.n_clusters, "bridges_in_clusters": self.n_bridges_in_clusters,
                "coalesced_volume": self.coalesced_volume,
                "largest_cluster": int(max((c.size for c in self.clusters), default=0))}


def _empty(searched, candidates=0):
    e2 = np.empty((0, 2), np.intp)
    return CoalescenceReport(np.empty((0, 3), np.intp), e2, np.empty(0, bool), np.empty(0),
                             [], np.empty(0), searched, candidates)


def bridge_pairs_on_shared_grains(bi, bj, n_grains):
    """All pairs of bridges that share a grain.

    Returns ``(a, b, g, end_a, end_b)``: bridge indices a < b... (as found), the shared
    grain g and, for each, which end of the bridge it is (0: ``bi``, 1: ``bj``).  Empty
    arrays when no grain holds two bridges.
    """
    bi = np.asarray(bi, np.intp)
    bj = np.asarray(bj, np.intp)
    nb = bi.size
    deg = np.bincount(bi, minlength=n_grains) + np.bincount(bj, minlength=n_grains)
    if nb < 2 or deg.max(initial=0) < 2:
        e = np.empty(0, np.intp)
        return e, e, e, e, e
    grain = np.concatenate([bi, bj])
    bridge = np.concatenate([np.arange(nb), np.arange(nb)])
    end = np.concatenate([np.zeros(nb, np.intp), np.ones(nb, np.intp)])
    busy = deg[grain] >= 2
    grain, bridge, end = grain[busy], bridge[busy], end[busy]
    order = np.argsort(grain, kind="stable")
    grain, bridge, end = grain[order], bridge[order], end[order]
    start = np.searchsorted(grain, grain, side="left")
    count = deg[grain]
    rank = np.arange(grain.size) - start
    out_a, out_b, out_g, out_ea, out_eb = [], [], [], [], []
    for off in range(1, int(count.max())):
        sel = np.flatnonzero(rank + off < count)
        if sel.size == 0:
            break
        other = sel + off
        out_a.append(bridge[sel]); out_b.append(bridge[other]); out_g.append(grain[sel])
        out_ea.append(end[sel]); out_eb.append(end[other])
    return tuple(np.concatenate(x) for x in (out_a, out_b, out_g, out_ea, out_eb))


def find_coalescence(pos, bi, bj, beta_i, beta_j, volumes=None, n_grains=None,
                     pair_vectors=None):
    """Merged bridges by the geometric criterion.

    Parameters
    ----------
    pos : (n, 3) grain centres.
    bi, bj : (nb,) grains of every bridge.
    beta_i, beta_j : (nb,) half filling angles [deg] of each bridge on grain bi / bj.
    volumes : (nb,) bridge volumes (for the cluster volumes), optional.
    pair_vectors : callable, optional
        ``pair_vectors(pos, i, j)`` -> (m, 3) centre-to-centre vectors i -> j (default
        ``pos[j] - pos[i]``).  A periodic cell passes its nearest-image vectors
        (:meth:`~capbridge.dem.bridges.BridgeModel.pair_vectors`): raw differences of
        two grains across the boundary would give a wrong angle at the shared grain.
    """
    pos = np.asarray(pos, float)
    n_grains = pos.shape[0] if n_grains is None else int(n_grains)
    bi = np.asarray(bi, np.intp)
    bj = np.asarray(bj, np.intp)
    a, b, g, ea, eb = bridge_pairs_on_shared_grains(bi, bj, n_grains)
    if a.size == 0:
        return _empty(searched=False)
    beta_ends = np.stack([np.asarray(beta_i, float), np.asarray(beta_j, float)])
    other_ends = np.stack([bj, bi])            # the far grain seen from each end
    beta_a = beta_ends[ea, a]
    beta_b = beta_ends[eb, b]
    ja = other_ends[ea, a]
    kb = other_ends[eb, b]
    if pair_vectors is None:
        u, v = pos[ja] - pos[g], pos[kb] - pos[g]
    else:
        u, v = pair_vectors(pos, g, ja), pair_vectors(pos, g, kb)
    cosang = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    angle = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
    margin = beta_a + beta_b - angle
    hit = margin >= 0.0
    if not hit.any():
        return _empty(searched=True, candidates=int(a.size))
    a, b, g, ja, kb, margin = a[hit], b[hit], g[hit], ja[hit], kb[hit], margin[hit]
    a, b = np.minimum(a, b), np.maximum(a, b)          # canonical order
    ja, kb = np.minimum(ja, kb), np.maximum(ja, kb)
    nb = bi.size
    keys = np.minimum(bi, bj).astype(np.int64) * n_grains + np.maximum(bi, bj)
    closed = np.isin(ja.astype(np.int64) * n_grains + kb, keys)     # ja < kb already
    # clusters: connected components of the merge graph on bridges
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(nb, nb))
    _, labels = connected_components(graph, directed=False)
    involved = np.unique(np.concatenate([a, b]))
    clusters, vols = [], []
    vol = np.asarray(volumes, float) if volumes is not None else np.zeros(nb)
    lab = labels[involved]
    for lb in np.unique(lab):
        members = involved[lab == lb]
        clusters.append(members)
        vols.append(float(vol[members].sum()))
    return CoalescenceReport(np.column_stack([ja, g, kb]), np.column_stack([a, b]), closed,
                             margin, clusters, np.array(vols), True, int(hit.size))
