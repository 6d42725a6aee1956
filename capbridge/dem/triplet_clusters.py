"""Coalesced triplets in a DEM packing: liquid clusters with the triplet table's forces.

Plain numpy bookkeeping (no YADE here), used by
:class:`~capbridge.yade.engine.CapbridgeEngine` on top of its
:class:`~capbridge.dem.bridges.BridgeModel`.

The rule (documented in ``docs/guide.md``, "Coalesced triplets")
--------------------------------------------------------------------
**Merge.**  At every coalescence check the detector
(:func:`~capbridge.dem.coalescence_detect.find_coalescence`) reports the bridges
whose wetted caps meet on a shared grain, grouped into connected clusters.  A cluster
that touches exactly three grains (two bridges on a shared grain, or a closed triangle;
every bridge among the three grains joins it) becomes one liquid body of volume
V = sum of its bridges' volumes (exact: the bridges keep their volumes in the model's
ledger while merged, so the liquid budget does not move) if the triplet table has the
coalesced body there (status with a result) and does not say the separated state has
the lower energy.  From then on the three grains get the table's pair forces
(:meth:`~capbridge.surrogate.triplet.TripletSurrogate.predict_vectors` at the three
current centres, lengths / the smallest radius, forces * 2 pi gamma r) *instead of* the doublet forces of those
bridges, at every step.  Between lookups the pair forces are the first-order expansion
of the last lookup in the cluster's gaps (:attr:`LiquidClusters.expansion`, slopes from
the same call); a cluster is looked up again when a gap has moved by more than
:data:`REUSE_GAP` (2e-3 r), when its expanded v = V*/V*_coal comes near the table's v
range, or when its liquid or the gravity changed.  In 1,000-grain packings this looks
up 1-3 % of the cluster-steps, with grain forces within 2.4e-4 (p99; max 6.9e-4) of a
lookup at every step (``benchmarks/bench_triplet_expansion.py``).

**Split.**  At every step the cluster's answer (above) is checked; it splits back
into separate bridges when

* the geometry or volume leaves the coalesced body's domain: gaps or angle outside the
  table, v = V*/V*_coal outside the table (no extrapolated number is used), or a
  status without a result (``NO_EQUILIBRIUM``: the coalesced body does not exist there;
  ``NOT_CONVERGED``) -> event ``split_geometry``;
* the table says the separated state has the lower energy (``lower_energy_state`` ==
  "separated"; the paper's criterion on drying / separation) -> ``split_energy``.

The liquid of a split cluster is shared among its bridges at **equal Laplace pressure**
(one angle): by default on the doublet table's P*(d*, V*) (:func:`table_equal_pressure`,
milliseconds; volumes within ~1e-4 of the exact state, measured; unequal radii with
each bridge in its own units at one SI pressure) or, with ``split_solver="exact"``, from
exact doublets (equal radii only)
(:func:`~capbridge.tables.coalescence.separated_state`, seconds per split:
measured 813 s for 331 splits in 400 steps of a 1,000-grain packing, in a cost test with
the development table relabelled to cover contact: too slow as a default).
If the solve has no answer (unequal radii with the exact solver; the configuration
does not exist at this volume; the table method also when a bridge would be past its pressure fold, which
only the exact solver follows; a share outside the doublet table's V* range) the
bridges keep the volumes they had when they merged (shares proportional to them:
exactly those volumes), counted as ``split_share_fallback``.  The shares add up to
the cluster volume to round-off (the last share is the remainder), so the ledger stays
exact; a bridge whose gap is beyond its rupture gap at its new share then ruptures at
once by the engine's own rule (conserved liquid: onto the two grains' films).  Merge
and split use the same test (a result, not "separated"), so a cluster does not chatter;
between the two (caps apart again but the coalesced body still valid) it persists: the
hysteresis of coalescence.

**Funicular onset.**  A detected cluster touching four grains or more is never treated
as a triplet: its bridges keep their doublet forces (the fallback), it is counted
(``funicular_fallback``, once per new cluster) and reported (number, grains, volume).  A
merged triplet whose bridges join such a cluster is released to its bridges (volumes
unchanged) under the same fallback.

**Other fallbacks** (doublet forces kept, counted): three grains of different contact
angles (``mixed_angle``: the table has one angle), merge candidates the table cannot
answer (``merge_refused``), a cluster whose bridge ruptured by the doublet rule or left
with an erased grain (``dissolved``).  Unequal radii use the surrogate's documented
approximation (status ``APPROXIMATE``), counted (``approximate``, per merge).

**No cost without coalescence.**  The triplet table is loaded at the first merge
candidate (:attr:`LiquidClusters.loaded`), never before; with no cluster the engine
does not call this module at all.

Conventions: grain indices are the model's (rows of ``BridgeModel``); SI units (m, m^3,
N); angles in degrees.

References
----------
Miot et al. (2021), Granular Matter 23:66: coalescence of two bridges on a shared grain,
the force of the coalesced body, and the energy criterion on drying.
"""
from __future__ import annotations

import time

import numpy as np

from capbridge.dimensionless import force_scale
from capbridge.physics.gravity import BOND_MAX
from capbridge.status import HAS_RESULT, Status, status_in
from capbridge.validation import CONTACT_OVERLAP_MAX, CapbridgeInputError

__all__ = ["LiquidClusters", "EVENTS", "set_bridge_volumes", "triangle_centres",
           "load_surrogate", "table_equal_pressure", "SPLIT_SOLVERS"]

#: event counters of :class:`LiquidClusters` (name -> meaning)
EVENTS = {
    "merged": "bridges merged into a coalesced triplet (triplet forces from then on)",
    "split_geometry": "clusters split: geometry/volume outside the coalesced body's domain "
                      "(out of the table, no equilibrium, no result)",
    "split_energy": "clusters split: the separated state has the lower energy",
    "split_share_fallback": "splits whose equal-pressure shares could not be solved: the "
                            "bridges kept their merge-time volumes",
    "funicular_fallback": "clusters of >= 4 grains detected (doublet forces kept)",
    "approximate": "merges of unequal radii (surrogate approximation, status approximate)",
    "open_side": "merges of triplets whose open side lies beyond the table, answered by its "
                 "continuation (status approximate; surrogate.triplet_open_side)",
    "mixed_angle": "coalesced triplets of different contact angles (doublet forces kept; "
                   "counted at every check)",
    "merge_refused": "coalesced triplets the table cannot answer or where the separated "
                     "state is lower (doublet forces kept; once per triplet until it "
                     "merges or its caps part)",
    "dissolved": "clusters whose bridge ruptured by the doublet rule or left with an "
                 "erased grain",
    "absorbed": "bridges formed between two grains of a live cluster after its merge: "
                "their liquid joins the cluster (no doublet force on top of the "
                "cluster's)",
}

_SEPARATED = 1                # LOWER_ENERGY_STATES code of "separated"
_PAIRS = ((0, 1), (0, 2), (1, 2))
#: what a refused merge candidate keeps of its lookup (LiquidClusters._candidates)
_REFUSAL_KEYS = ("status", "lower", "asked", "v")
#: between lookups a cluster's pair forces are expanded to first order in its lookup
#: gaps (gaps / its smallest radius, contacts at 0) about those of its last lookup,
#: while no gap moved by more than this; the slopes are forward differences over it.
#: Clusters in a packing move ~3.5e-5 r per step: 1-3 % of the cluster-steps are
#: looked up, forces within 2.4e-4 (p99) of a lookup at every step (the surrogate is
#: multilinear between refined nodes: the slopes are secants; benchmarks/RESULTS.md,
#: "forces between lookups"); statuses and the energy criterion are decided at this
#: resolution (the v range's edges at V_MARGIN)
REUSE_GAP = 2e-3
#: ... and while its expanded v = V*/V*_coal stays this far (relative) inside the
#: table's v range
V_MARGIN = 1e-4
#: ``expansion["toward"]`` of a gap whose moved triangles have no result either way
PINNED = 2
#: why a cluster's gravity part is not the table's response (codes 1, 2, 3; 0: it is)
GRAVITY_FALLBACKS = ("table_has_no_response", "bond_above_max", "no_response_number")
#: how a split cluster shares its liquid (LiquidClusters split_solver)
SPLIT_SOLVERS = ("table", "exact", "merge_volumes")


def table_equal_pressure(doublet, gaps, volume, theta, vstar_range, n_grid=96, newton=6,
                         radii=None):
    """Volumes of separate bridges sharing ``volume`` at one Laplace pressure, from the
    doublet table (lengths in units of a reference radius r0).

    Each bridge b at gap d_b has the tabulated P*_b(V*) at fixed gap; on its
    exchange-stable branch (volumes between the pressure minimum and, at large contact
    angles, the pressure maximum, where dP/dV > 0: the branch of
    :func:`~capbridge.tables.coalescence.separated_state` for every bridge not past its
    pressure fold) P*_b is inverted on a log grid, the common P* with
    sum_b V_b(P*) = V* is found by bisection (the sum increases with P*), then Newton
    steps on (V_b, P*) with the surrogate's slopes make the tabulated pressures equal to
    ~1e-10.  The equal-pressure state is thus exact for the table; its error against
    exact doublets is the table's P* interpolation error (compared in
    ``tests/test_triplet_clusters.py``).  Unequal radii: each bridge is looked up in its
    own units (its smaller radius s_b r0, ratio of its grains), and the pressures are
    compared in the reference unit, P*_b / s_b (the same SI pressure), volumes summed
    as V*_b s_b^3.

    Parameters
    ----------
    doublet : DoubletSurrogate (fitted).
    gaps : (nb,) gaps d/r0 of the bridges (>= 0).
    volume : float, total V/r0^3.
    theta : float, contact angle [deg].
    vstar_range : (low, high) V* range of the table (each bridge in its own units).
    radii : (nb, 2), optional
        The two grains' radii of each bridge / r0 (default: all 1).

    Returns
    -------
    ndarray (nb,) or None
        V_b/r0^3 (their sum is ``volume`` to round-off), or None when no such state
        exists on the table (a bridge cannot exist at any share, the common pressure is
        outside the branches, a share outside the table's V* range).
    """
    gaps = np.maximum(np.asarray(gaps, float), 0.0)
    R = np.ones((gaps.size, 2)) if radii is None else np.asarray(radii, float)
    s = R.min(axis=1)                          # each bridge's own length unit / r0
    ratio = R.max(axis=1) / s
    gb = gaps / s
    lo, hi = vstar_range
    if volume <= float(np.sum(lo * s**3)):
        return None
    # each bridge's volumes up to the table's top or the whole liquid, in its own units
    grid = np.stack([np.geomspace(lo, t, n_grid) for t in np.minimum(hi, volume / s**3)])
    r = doublet.predict(gb[:, None], grid, theta, ratio=ratio[:, None],
                        variables=("pressure",))
    P = np.where(r["status"] == Status.CONVERGED, r["pressure"], np.nan)
    branches = []
    for Pb, Vb, sb in zip(P, grid, s):
        ok = np.isfinite(Pb)
        if ok.sum() < 2:
            return None
        k = np.flatnonzero(ok)
        k = k[np.argmin(Pb[k]):]                   # right of the pressure minimum
        # ... and left of the pressure maximum: at large contact angles P*(V*) turns
        # down again (theta = 60 deg at contact: from V* ~ 0.4), where a bridge
        # exchanging liquid at equal pressure is unstable; that part is not the branch
        rise = np.diff(Pb[k]) > 0
        if not rise.all():
            k = k[:int(np.argmin(rise)) + 1]
        if k.size < 2 or np.any(np.diff(k) != 1):
            return None
        branches.append((Pb[k] / sb, Vb[k] * sb**3))      # reference units
    p_lo = max(b[0][0] for b in branches)
    p_hi = min(b[0][-1] for b in branches)
    if not p_lo < p_hi:
        return None

    def shares(p):
        return np.array([np.exp(np.interp(p, Pb, np.log(Vb))) for Pb, Vb in branches])

    if shares(p_lo).sum() > volume or shares(p_hi).sum() < volume:
        return None
    a, b = p_lo, p_hi
    for _ in range(60):                             # bisection on the common pressure
        m = 0.5 * (a + b)
        if shares(m).sum() < volume:
            a = m
        else:
            b = m
    V = shares(0.5 * (a + b))
    V *= volume / V.sum()
    for _ in range(newton):
        # P_b(V_b) = p for all b, sum V_b = volume: dV_b = (p - P_b)/s_b + dp/s_b
        v_own = V / s**3
        h = 1e-6 * v_own
        q = doublet.predict(np.concatenate([gb, gb]), np.concatenate([v_own, v_own + h]),
                            theta, ratio=np.concatenate([ratio, ratio]),
                            variables=("pressure",))
        if np.any(q["status"] != Status.CONVERGED):
            return None
        Pv, Ph = q["pressure"][:gaps.size] / s, q["pressure"][gaps.size:] / s
        slope = (Ph - Pv) / (h * s**3)
        if np.any(slope <= 0):
            return None
        p = np.sum(Pv / slope) / np.sum(1 / slope) + (volume - V.sum()) / np.sum(1 / slope)
        V = V + (p - Pv) / slope
        if np.any(V / s**3 < lo) or np.any(V / s**3 > hi):
            return None
    return V


def triangle_centres(L01, L02, L12):
    """Centres of three spheres with centre distances L01, L02, L12, in a local frame.

    Grain 0 at the origin, grain 1 on +x, grain 2 in the xy plane (y >= 0).

    Parameters
    ----------
    L01, L02, L12 : array_like (k,)
        Centre-to-centre distances [any length unit].

    Returns
    -------
    ndarray (k, 3, 3)
        Centres (grain, xyz).
    """
    L01, L02, L12 = (np.asarray(x, float) for x in (L01, L02, L12))
    x = (L01**2 + L02**2 - L12**2) / (2.0 * L01)        # law of cosines
    y = np.sqrt(np.maximum(L02**2 - x**2, 0.0))
    c = np.zeros(L01.shape + (3, 3))
    c[..., 1, 0] = L01
    c[..., 2, 0] = x
    c[..., 2, 1] = y
    return c


def load_surrogate(table=None, coalescence_table=None):
    """The triplet surrogate the engine uses: ``table`` (default the shipped
    ``data/triplet_table_packings.nc``, :func:`~capbridge.surrogate.triplet.
    engine_table`) fitted with ``out_of_range="clip"`` (a volume ratio outside the
    table is a status, not an exception), ``open_side="linear"`` (an open side beyond
    the table up to 1.0 is answered by the table's continuation, status approximate:
    :mod:`~capbridge.surrogate.triplet_open_side`) and with the dense coalescence
    volumes ``coalescence_table`` (default ``triplet_coalescence.nc`` beside the table,
    if it exists and covers the table's gaps and angles), with ``method="auto"``."""
    from pathlib import Path

    from capbridge.surrogate.load import default_coalescence_table
    from capbridge.surrogate.triplet import TripletSurrogate, engine_table

    path = Path(table) if table is not None else engine_table()
    if not path.exists():
        raise CapbridgeInputError(f"triplet table {path} not found: give "
                                  "triplet_table=... or triplet_forces=False")
    coal = coalescence_table
    if coal is None:
        coal = default_coalescence_table(path, path.parent / "triplet_coalescence.nc")
    return TripletSurrogate(method="auto", out_of_range="clip", open_side="linear").fit(
        path, coalescence_table=coal)


def set_bridge_volumes(model, rows, volumes):
    """Give bridges ``rows`` of a :class:`~capbridge.dem.bridges.BridgeModel` new
    volumes [m^3]: :meth:`BridgeModel.set_volumes` (kept as a function for callers)."""
    model.set_volumes(rows, volumes)


#: the statistics of :meth:`LiquidClusters.life_summary` that are distributions
SAMPLED_STATS = ("lives", "merge_jumps", "split_jumps")

#: values kept per distribution; beyond that a uniform sample of this size, so that a
#: long run's saved state does not grow with its events (800 kB each at most)
STATS_KEPT = 100_000


def _record(stats, key, values):
    """Add ``values`` to the distribution ``key`` of ``stats``: every value up to
    :data:`STATS_KEPT`, then reservoir sampling (value n replaces a uniformly drawn
    slot with probability STATS_KEPT / n; the draw is seeded by n, so a restart
    continues the same sample), with the exact count and maximum beside it."""
    kept = stats[key]
    for x in values:
        n = stats[key + "_n"]
        stats[key + "_n"] = n + 1
        stats[key + "_max"] = max(stats[key + "_max"], float(x))
        if len(kept) < STATS_KEPT:
            kept.append(float(x))
        else:
            j = int(np.random.default_rng(n).integers(0, n + 1))
            if j < STATS_KEPT:
                kept[j] = float(x)


def _new_stats():
    """Counters of how clusters live (:meth:`LiquidClusters.report`, ``"life"``)."""
    return {"cluster_steps": 0,
            **{k: [] for k in SAMPLED_STATS}, **{k + "_n": 0 for k in SAMPLED_STATS},
            **{k + "_max": 0.0 for k in SAMPLED_STATS},
            "triplets_seen": 0, "triplets_live": 0,
            "triplets_refused": 0, "triplets_mixed": 0, "larger_seen": 0,
            **{"refused_" + k: 0 for k in REFUSAL_REASONS},
            **{"split_" + k: 0 for k in REFUSAL_REASONS}}


#: why a coalesced triplet met at a check keeps doublet forces (:meth:`LiquidClusters.
#: life_summary`)
REFUSAL_REASONS = {
    "gaps_or_angle": "a gap or the contact angle outside the table's axes",
    "volume": "v = V / V_coal outside the table's v axis",
    "no_result": "a cell without a result (node not converged, no equilibrium)",
    "separated_lower": "the separated bridges have the lower energy",
}


def _refusal_reasons(res, ok):
    """Counts of the refused lookups ``~ok`` of :meth:`LiquidClusters.lookup`, by reason
    (:data:`REFUSAL_REASONS`).  Gaps and angle inside the table, a lookup that answered
    (v known) out of range or extrapolated: its v is outside the table ("volume"); a
    lookup without an answer (a refused input) or a cell without a result:
    "no_result"."""
    st, asked, v = res["status"][~ok], res["asked"][~ok], res["v"][~ok]
    has = status_in(st, HAS_RESULT)
    out_v = asked & ~has & np.isfinite(v) & status_in(st, (Status.OUT_OF_RANGE,
                                                            Status.EXTRAPOLATED))
    return {"gaps_or_angle": int((~asked).sum()), "volume": int(out_v.sum()),
            "no_result": int((asked & ~has & ~out_v).sum()),
            "separated_lower": int((asked & has).sum())}


#: the last bridge keys sorted by _sorted_keys: (keys, order, sorted keys).  A model
#: replaces its keys array whenever a bridge forms or ruptures (never edits it), so the
#: same array object means the same bridges (the reference held here keeps its id)
_SORTED_KEYS = [None, None, None]


def _sorted_keys(keys):
    """(argsort, sorted values) of a model's bridge keys, sorted once per keys array:
    several searches a step (the clusters' rows, the bridges they follow)."""
    if _SORTED_KEYS[0] is not keys:
        order = np.argsort(keys, kind="stable")
        _SORTED_KEYS[:] = [keys, order, keys[order]]
    return _SORTED_KEYS[1], _SORTED_KEYS[2]


def _no_expansion(n):
    """Rows of :attr:`LiquidClusters.expansion` for ``n`` clusters without one (NaN
    gaps: the next step looks them up)."""
    return {"gaps": np.full((n, 3), np.nan), "f": np.full((n, 3), np.nan),
            "slope": np.full((n, 3, 3), np.nan), "gravity": np.full((n, 3, 3), np.nan),
            "vc": np.full(n, np.nan), "vc_slope": np.full((n, 3), np.nan),
            "toward": np.zeros((n, 3), np.int8),
            "status": np.full(n, Status.OUT_OF_RANGE, np.int8),
            "lower": np.full(n, 3, np.int8), "v": np.full(n, np.nan),
            "asked": np.zeros(n, bool), "gravity_reason": np.zeros(n, np.int8)}


def _same_gravity(a, b):
    """True when two gravity settings ((g (3,), drho) or None) are the same."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.array_equal(np.asarray(a[0], float), b[0]) and float(a[1]) == b[1])


def _bridge_grain_forces(model, geom, grains, members):
    """(k, 3, 3) doublet forces [N] of the bridges ``members`` (k, 3, 2; -1 padded) on
    the grains ``grains`` (k, 3) of each cluster: what the cluster's liquid gave those
    grains as separate bridges (attraction along the centre lines)."""
    k = grains.shape[0]
    out = np.zeros((k, 3, 3))
    rows = LiquidClusters._rows(model, members.reshape(-1, 2)).reshape(k, 3)
    for c, m in np.argwhere(rows >= 0):
        b = rows[c, m]
        fv = geom["d"][b] * (geom["force"][b] / geom["dist"][b])
        out[c, grains[c] == model.bi[b]] += fv
        out[c, grains[c] == model.bj[b]] -= fv
    return out


def _jumps(before, after, r, gamma):
    """Largest change of a grain's force per cluster, in units of 2 pi gamma r."""
    return (np.linalg.norm(after - before, axis=-1).max(axis=1)
            / force_scale(r, gamma)).tolist()


class LiquidClusters:
    """Coalesced triplets of a packing: merge, triplet forces, split (module docstring).

    Parameters
    ----------
    gamma : float
        Surface tension [N/m].
    surrogate : TripletSurrogate, optional
        A fitted surrogate (tests); else one is fitted from ``table`` at the first merge
        candidate (lazy).
    table : path, optional
        Triplet table (default the shipped ``data/triplet_table_packings.nc``).
    coalescence_table : path, optional
        Dense coalescence volumes for the surrogate (default ``data/triplet_coalescence.nc``
        when it exists).
    split_solver : {"table", "exact", "merge_volumes"}
        Shares of a split: ``"table"`` (default) equal Laplace pressure from the doublet
        table's P*(d*, V*) (:func:`table_equal_pressure`: milliseconds, pressures equal
        to the table's interpolation error); ``"exact"`` equal pressure from exact
        doublets (:func:`~capbridge.tables.coalescence.separated_state`:
        seconds per split); ``"merge_volumes"`` the merge-time volumes (no solve).
    """

    def __init__(self, gamma, surrogate=None, table=None, coalescence_table=None,
                 split_solver="table"):
        if split_solver not in SPLIT_SOLVERS:
            raise CapbridgeInputError(f"split_solver={split_solver!r}: allowed "
                                      f"{list(SPLIT_SOLVERS)}")
        self.gamma = float(gamma)
        self._sur = surrogate
        self.table = table
        self.coalescence_table = coalescence_table
        self.split_solver = split_solver
        self._doublet = None
        self.events = {k: 0 for k in EVENTS}
        self.timings = {"load_seconds": 0.0, "lookup_seconds": 0.0, "split_seconds": 0.0}
        self.loads = 0
        self._clear()
        self.funicular = {"clusters": 0, "grains": 0, "volume": 0.0, "largest": 0}
        self._funicular_keys = set()
        self._refused = {}                   # refused merge candidates: their lookup
        self.last = None
        #: gravity on the liquid, set by the engine at every step: (g [m/s^2] (3,),
        #: drho [kg/m^3]) or None (:meth:`gravity_forces`)
        self.gravity = None
        self.gravity_fallback = 0
        #: why clusters got the equal weight share (:meth:`gravity_forces`)
        self.gravity_fallback_reasons = {name: 0 for name in GRAVITY_FALLBACKS}
        self._expansion_gravity = None       # the gravity of the expansions' lookups
        self._expansion_table = None         # and their surrogate
        self._now = 0
        self.stats = _new_stats()

    def _clear(self):
        self.grains = np.empty((0, 3), np.intp)        # sorted grain triple per cluster
        self.members = np.empty((0, 3, 2), np.intp)    # bridge grain pairs, -1 padded
        self.volume = np.empty(0)                      # cluster liquid [m^3]
        self.born = np.empty(0, np.intp)
        self.approx = np.empty(0, bool)
        self.last_forces = np.empty((0, 3, 3))         # grain forces last step [N]
        self.expansion = _no_expansion(0)
        # the bridges the clusters were last followed against (_follow_bridges)
        self._appends = 0
        self._followed = (None, -1)

    def _append(self, grains, members, volume, born, approx):
        """One new cluster, last in every per-cluster array."""
        self._appends += 1
        self.grains = np.vstack([self.grains, grains[None]])
        self.members = np.concatenate([self.members, members[None]])
        self.volume = np.append(self.volume, volume)
        self.born = np.append(self.born, born)
        self.approx = np.append(self.approx, approx)
        self.last_forces = np.concatenate([self.last_forces, np.full((1, 3, 3), np.nan)])
        self.expansion = {k: np.concatenate([v, e]) for (k, v), e in
                          zip(self.expansion.items(), _no_expansion(1).values())}

    # ------------------------------------------------------------------ the table
    @property
    def loaded(self):
        """True once a triplet table has been read (or a surrogate given)."""
        return self._sur is not None

    @property
    def n(self):
        return int(self.volume.size)

    def surrogate(self):
        """The triplet surrogate, fitted from the table at the first call (lazy)."""
        if self._sur is None:
            t0 = time.perf_counter()
            self._sur = load_surrogate(self.table, self.coalescence_table)
            if self.split_solver == "table":
                self.doublet_surrogate()     # read with the triplet table: a split then
            self.loads += 1                  # costs its solve only (~3 ms)
            self.timings["load_seconds"] += time.perf_counter() - t0
        return self._sur

    # --------------------------------------------------------------- lookups
    @staticmethod
    def _rows(model, pairs):
        """Rows in the model of the bridges between grain pairs (k, 2); -1: none (or
        a padding pair -1)."""
        pairs = np.asarray(pairs, np.intp).reshape(-1, 2)
        out = np.full(pairs.shape[0], -1, np.intp)
        if model.n_bridges == 0 or pairs.shape[0] == 0:
            return out
        lo, hi = pairs.min(axis=1), pairs.max(axis=1)
        keys = lo.astype(np.int64) * model.n + hi
        order, sk = _sorted_keys(model.keys)
        at = np.minimum(np.searchsorted(sk, keys), sk.size - 1)
        found = (sk[at] == keys) & (lo >= 0)
        out[found] = order[at[found]]
        return out

    def bridge_rows(self, model):
        """Rows in the model of the bridges merged into the clusters (gravity on the
        liquid: their doublet gravity part is replaced by the cluster's,
        :meth:`gravity_forces`)."""
        if not self.n:
            return np.empty(0, np.intp)
        rows = self._rows(model, self.members.reshape(-1, 2))
        return rows[rows >= 0]

    def lookup(self, model, pos, grains, volume, gravity=False, slopes=False):
        """Triplet table answer for clusters on ``grains`` (k, 3) at centres ``pos``.

        Gaps below zero (grains in contact overlap in a DEM) are taken as contact, as
        the doublet bridges do, down to :data:`~capbridge.validation.CONTACT_OVERLAP_MAX`
        of the pair's smaller radius; a cluster with a deeper overlap is not looked up
        (OUT_OF_RANGE, not ``asked``).  Returns a dict: ``f`` (k, 3) pair forces [N] in the
        order (0,1), (0,2), (1,2) of each triple (attraction > 0), ``status`` (k,),
        ``lower`` (k,) lower-energy-state codes, ``u`` (k, 3, 3) unit vectors of the
        pairs (actual centre lines), ``gaps`` (k, 3) [m].  With ``gravity`` (and
        :attr:`gravity` set), the same lookup also gives ``gravity`` (k, 3, 3): the
        gravity parts of the grain forces [N] in the scene frame
        (:meth:`gravity_forces`); ``status`` stays the answer without gravity (a
        cluster whose gravity response has no number keeps its forces, with the
        weight shared equally, counted).  With ``slopes``, also ``slope`` (k, 3, 3):
        d f_p / d g_m [N], the pair forces' forward differences in the lookup gaps g
        (gaps / the smallest radius, contacts at 0) over :data:`REUSE_GAP`, from the
        same call, with ``vc``, ``vc_slope`` and ``toward`` (:meth:`_slopes`).
        """
        t0 = time.perf_counter()
        out = self._answer(self._geometry(model, pos, grains), volume, gravity, slopes)
        self._count_gravity(out.pop("gravity_reason"))
        self.timings["lookup_seconds"] += time.perf_counter() - t0
        return out

    @staticmethod
    def _geometry(model, pos, grains):
        """Pair vectors, unit vectors, gaps [m] and radii of the clusters ``grains``."""
        R = model.radii[grains]                                    # (k, 3)
        d = np.stack([model.pair_vectors(pos, grains[:, a], grains[:, b])
                      for a, b in _PAIRS], 1)
        dist = np.sqrt(np.einsum("kpi,kpi->kp", d, d))
        Rsum = np.stack([R[:, a] + R[:, b] for a, b in _PAIRS], 1)
        Rmin = np.stack([np.minimum(R[:, a], R[:, b]) for a, b in _PAIRS], 1)
        # lengths / R_min (the normalising radius), as TripletSurrogate.predict_si does
        return {"d": d, "u": d / dist[..., None], "gaps": dist - Rsum, "R": R,
                "Rsum": Rsum, "r": R.min(axis=1), "theta": model.theta[grains[:, 0]],
                "contact": dist - Rsum >= -CONTACT_OVERLAP_MAX * Rmin}

    def _answer(self, geo, volume, gravity, slopes):
        """:meth:`lookup` on the geometry ``geo`` of :meth:`_geometry`; also
        ``gravity_reason`` (k,) codes of :data:`GRAVITY_FALLBACKS` (0: none)."""
        sur = self.surrogate()
        gaps, R, r, theta = geo["gaps"], geo["R"], geo["r"], geo["theta"]
        k = gaps.shape[0]
        g = np.maximum(gaps, 0.0)
        out = {"f": np.full((k, 3), np.nan), "status": np.full(k, Status.OUT_OF_RANGE, np.int8),
               "lower": np.full(k, 3, np.int8), "u": geo["u"], "gaps": gaps,
               "v": np.full(k, np.nan), "gravity_reason": np.zeros(k, np.int8)}
        grav = self._gravity_request(gravity, sur, r, out["gravity_reason"]) if k else None
        # clusters whose gaps (scaled as predict_vectors scales them) or angle are
        # outside the table, or with a DEM overlap deeper than a contact's, are
        # OUT_OF_RANGE without a lookup
        out["asked"] = sur.covers(g[:, 0] / r, g[:, 1] / r, g[:, 2] / r, theta,
                                  radii=R / r[:, None]) & np.all(geo["contact"], axis=1)
        ask = np.flatnonzero(out["asked"])
        if grav is not None:
            out["gravity"] = np.full((k, 3, 3), np.nan)
        if slopes:
            out["slope"] = np.full((k, 3, 3), np.nan)
            out["vc"], out["vc_slope"] = np.full(k, np.nan), np.full((k, 3), np.nan)
            out["toward"] = np.zeros((k, 3), np.int8)
        if ask.size:
            # the scene's own centres (grain 0 at the origin): forces and gravity parts
            # come back in the scene frame; contacts are looked up at gap 0 there
            C = np.zeros((ask.size, 3, 3))
            C[:, 1], C[:, 2] = geo["d"][ask, 0], geo["d"][ask, 1]
            rk = r[ask]
            C, V, t = C / rk[:, None, None], volume[ask] / rk**3, theta[ask]
            Rk = R[ask] / rk[:, None]
            bond = None if grav is None else grav["bond"][ask]
            if slopes:
                # the same call also looks up three triangles, each with one lookup
                # gap REUSE_GAP wider (narrower where wider leaves the table; neither:
                # no slopes, the cluster is looked up at every step)
                gn = g[ask] / rk[:, None]
                # (direction, gap m, cluster): one covers call for all six moves
                moved = gn + REUSE_GAP * np.array([-1.0, 1.0])[:, None, None, None] * \
                    np.eye(3)[None, :, None, :]                          # (2, 3, n, 3)
                inside = sur.covers(*moved.reshape(-1, 3).T, np.tile(t, 6),
                                    radii=np.tile(Rk, (6, 1))).reshape(2, 3, -1) & \
                    (np.diagonal(moved, axis1=1, axis2=3).transpose(0, 2, 1) >= 0)
                step = np.where(inside[1], REUSE_GAP, np.where(inside[0], -REUSE_GAP,
                                                                0.0)).T     # (n, 3)
                side = gn + geo["Rsum"][ask] / rk[:, None]
                C = np.concatenate([C] + [triangle_centres(*(side + step[:, m, None] *
                                                            np.eye(3)[m]).T)
                                          for m in range(3)])
                V, t, Rk = np.tile(V, 4), np.tile(t, 4), np.tile(Rk, (4, 1))
                if bond is not None:
                    bond = np.concatenate([bond, np.zeros(3 * ask.size)])
            kw = {} if grav is None else {"bond": bond, "gravity": grav["direction"]}
            try:
                res = sur.predict_vectors(C, V, t, radii=Rk, **kw)
            except CapbridgeInputError:
                if ask.size > 1:     # one cluster refused (e.g. no triangle): one by one
                    for c in ask:
                        one = self._answer({key: x[c:c + 1] for key, x in geo.items()},
                                           volume[c:c + 1], gravity, slopes)
                        for key in ("f", "status", "lower", "gravity", "v", "slope",
                                    "vc", "vc_slope", "toward", "gravity_reason"):
                            if key in out:
                                out[key][c] = one[key][0]
                if grav is not None:
                    out["gravity"] = self._gravity_fallback(out["gravity"], grav, volume,
                                                            out["gravity_reason"])
                return out
            n = ask.size
            fs = force_scale(rk, self.gamma)
            f = np.stack([res[name] for name in ("f12", "f13", "f23")], -1)
            out["f"][ask] = f[:n] * fs[:, None]
            status = res.get("status_without_gravity", res["status"])
            out["status"][ask] = status[:n]
            out["v"][ask] = res["v"][:n]
            out["lower"][ask] = res["lower_energy_state"][:n]
            if slopes:
                for key, x in self._slopes(sur, f, status, res["volume_coalescence"],
                                           step, gn, side, V[:n], t[:n], Rk[:n]).items():
                    out[key][ask] = x * (fs[:, None, None] if key == "slope" else 1)
            if grav is not None:
                part = res["gravity_first_order"][:n] + res["gravity_second_order"][:n]
                part[grav["bond"][ask] == 0.0] = np.nan     # Bo above the table's
                out["gravity"][ask] = part * fs[:, None, None]
        if grav is not None:
            out["gravity"] = self._gravity_fallback(out["gravity"], grav, volume,
                                                    out["gravity_reason"])
        return out

    @staticmethod
    def _slopes(sur, f, status, vc, step, gn, side, V, t, R):
        """Forward differences (``slope`` (n, 3, 3) [F*], ``vc_slope`` (n, 3)) of the
        pair forces f and of V*_coal / r^3 from the lookups of the clusters (the first
        n rows of f, status, vc) and of their three moved triangles (one block of n
        rows per gap, moved by ``step``).  A triangle moved into a cell without a
        result (a hole or edge of the table) is moved the other way in one more call;
        the cluster's expansion then holds only while that gap does not move toward
        the cell (``toward`` (n, 3): +1, -1 the direction, 0 none).  No result either
        way: no slope in that gap, the expansion holds while it does not move
        (``toward`` :data:`PINNED`).  No result at the cluster itself: NaN slopes."""
        n = gn.shape[0]
        step = step.copy()
        has = status_in(status, HAS_RESULT).reshape(4, n)
        fm, vcm = f[n:].reshape(3, n, 3).copy(), vc[n:].reshape(3, n).copy()
        toward = np.zeros((n, 3), np.int8)
        m, c = np.nonzero(~has[1:] & has[0])
        back = -step[c, m]
        moved = gn[c] + back[:, None] * np.eye(3)[m]
        flip = (back != 0) & sur.covers(*moved.T, t[c], radii=R[c]) & \
            (moved[np.arange(c.size), m] >= 0)
        m, c, back = m[flip], c[flip], back[flip]
        if c.size:
            try:
                res = sur.predict_vectors(triangle_centres(*(side[c] + back[:, None] *
                                                             np.eye(3)[m]).T),
                                          V[c], t[c], radii=R[c])
            except CapbridgeInputError:
                res = None
            if res is not None:
                ok = status_in(res["status"], HAS_RESULT)
                m, c, back = m[ok], c[ok], back[ok]
                fm[m, c] = np.stack([res[k][ok] for k in ("f12", "f13", "f23")], -1)
                vcm[m, c] = res["volume_coalescence"][ok]
                has[1 + m, c] = True
                toward[c, m] = -np.sign(back).astype(np.int8)
                step[c, m] = back
        # no result either way (e.g. a contact, gap 0, whose wider triangle is in a
        # hole): no slope in that gap, the expansion holds while the gap stays put
        pinned = ~has[1:].T & has[0][:, None]                              # (n, m)
        toward[pinned] = PINNED
        mp, cp = np.nonzero(pinned.T)
        fm[mp, cp], vcm[mp, cp] = f[:n][cp], vc[:n][cp]                   # zero slopes
        step[pinned] = REUSE_GAP
        h = np.where(step == 0, np.nan, step).T                            # (m, n)
        slope = np.where(has[0][:, None, None], np.transpose(
            (fm - f[:n]) / h[..., None], (1, 2, 0)), np.nan)               # (n, p, m)
        return {"slope": slope, "vc": vc[:n], "vc_slope": ((vcm - vc[:n]) / h).T,
                "toward": toward}

    def _expanded_lookup(self, model, pos):
        """The step's answer for the live clusters: the pair forces of each cluster's
        last lookup expanded to first order in its lookup gaps (:attr:`expansion`),
        while no gap moved by more than :data:`REUSE_GAP` since that lookup and the
        cluster, its liquid and the gravity are the same; a fresh lookup with slopes
        otherwise (with it, those of the others that moved by more than half of
        :data:`REUSE_GAP`, so that fresh lookups come in few calls).  Statuses, the
        lower-energy state and the gravity parts are those of the last lookup.  Same
        keys as :meth:`lookup`."""
        t0 = time.perf_counter()
        geo = self._geometry(model, pos, self.grains)
        e = self.expansion
        sur = self._check_expansion_source()
        g = np.maximum(geo["gaps"], 0.0) / geo["r"][:, None]
        with np.errstate(invalid="ignore"):
            drift = np.max(np.abs(g - e["gaps"]), axis=1)        # NaN: no expansion
        dg = np.where(np.isfinite(e["gaps"]), g - e["gaps"], 0.0)
        # v = V*/V*_coal moves with the gaps: a cluster near the table's v range is
        # looked up (its status, e.g. "extrapolated" above the range, is the lookup's)
        with np.errstate(invalid="ignore"):
            v = self.volume / geo["r"]**3 / (e["vc"] + np.einsum("km,km->k",
                                                                  e["vc_slope"], dg))
            inside = (v >= sur.v_[0] * (1 + V_MARGIN)) & (v <= sur.v_[-1] * (1 - V_MARGIN))
        keep = (drift <= REUSE_GAP) & np.isfinite(e["slope"]).all(axis=(1, 2)) & \
            np.all(geo["contact"], axis=1) & inside & ~np.any(
                (dg * e["toward"] > 0) | ((e["toward"] == PINNED) & (dg != 0)), axis=1)
        if not keep.all():
            fresh = np.flatnonzero(~keep | (drift > 0.5 * REUSE_GAP))
            sub = {key: x[fresh] for key, x in geo.items()}
            self._store_expansion(fresh, sub, self._answer(sub, self.volume[fresh], True, True))
            dg[fresh] = 0.0
        out = {"f": e["f"] + np.einsum("kpm,km->kp", np.nan_to_num(e["slope"]), dg),
               "u": geo["u"], "gaps": geo["gaps"]}
        out.update({key: e[key].copy() for key in ("status", "lower", "v", "asked")})
        if self._expansion_gravity is not None and self._gravity_answered():
            out["gravity"] = e["gravity"].copy()
        self._count_gravity(e["gravity_reason"])
        self.timings["lookup_seconds"] += time.perf_counter() - t0
        return out

    def _check_expansion_source(self):
        """The surrogate; the expansions are dropped if it or the gravity changed since
        they were made (then every cluster is looked up)."""
        sur = self.surrogate()
        if self._expansion_table is None:          # a new engine, or after a restart
            self._expansion_table = sur
        if sur is not self._expansion_table or \
                not _same_gravity(self.gravity, self._expansion_gravity):
            self._expansion_table = sur
            self.expansion["gaps"][:] = np.nan
            self._expansion_gravity = None if self.gravity is None else \
                (np.array(self.gravity[0], float), float(self.gravity[1]))
        return sur

    def _store_expansion(self, rows, geo, res):
        """Clusters ``rows`` expand from the answer ``res`` (of :meth:`_answer` with
        slopes) at their geometry ``geo``."""
        e = self.expansion
        e["gaps"][rows] = np.maximum(geo["gaps"], 0.0) / geo["r"][:, None]
        for key in ("f", "slope", "vc", "vc_slope", "toward", "status", "lower", "v",
                    "asked", "gravity_reason"):
            e[key][rows] = res[key]
        e["gravity"][rows] = res["gravity"] if "gravity" in res else np.nan

    def _gravity_answered(self):
        """True when the lookups give gravity parts (gravity on the liquid and a table
        with a response; without one the forces are the zero-gravity ones, counted)."""
        g_vec, drho = self._expansion_gravity
        return bool(np.any(g_vec != 0) and drho != 0 and
                    getattr(self.surrogate(), "has_gravity_", False))

    def _count_gravity(self, reason):
        """Count the clusters of one lookup that fell back, by reason code."""
        counts = np.bincount(reason, minlength=len(GRAVITY_FALLBACKS) + 1)
        for name, c in zip(GRAVITY_FALLBACKS, counts[1:]):
            self.gravity_fallback_reasons[name] += int(c)
        # "table_has_no_response" keeps the zero-gravity forces; the others the equal
        # share of the weight (gravity_fallback)
        self.gravity_fallback += int(counts[1:].sum())

    def _gravity_request(self, gravity, sur, r, reason):
        """What the lookup needs for gravity on the clusters' liquid, or None (no
        gravity, or a table without a response: then :meth:`_gravity_fallback` is not
        needed either, the forces are the zero-gravity ones, counted in ``reason``)."""
        if not gravity or self.gravity is None:
            return None
        g_vec, drho = np.asarray(self.gravity[0], float), float(self.gravity[1])
        gn = float(np.linalg.norm(g_vec))
        if gn == 0.0 or drho == 0.0:
            return None
        if not getattr(sur, "has_gravity_", False):
            reason[:] = GRAVITY_FALLBACKS.index("table_has_no_response") + 1
            return None
        bond = drho * gn * r**2 / self.gamma
        above = bond > BOND_MAX
        return {"direction": g_vec, "bond": np.where(above, 0.0, bond), "above": above}

    def _gravity_fallback(self, part, grav, volume, reason):
        """Clusters whose gravity response has no number (since the surrogate fills a
        node whose runs failed from its neighbours, only cells without a body or a
        table without a response) or whose Bo is above the table's get the liquid's weight
        shared equally by their three grains (the first-order answer for three equal
        grains in an equilateral triangle), with their reason code in ``reason``."""
        bad = ~np.all(np.isfinite(part), axis=(1, 2))
        reason[bad & ~grav["above"]] = GRAVITY_FALLBACKS.index("no_response_number") + 1
        reason[grav["above"]] = GRAVITY_FALLBACKS.index("bond_above_max") + 1
        if bad.any():
            g_vec, drho = np.asarray(self.gravity[0], float), float(self.gravity[1])
            weight = drho * volume[bad, None] * g_vec             # [N], the liquid's weight
            part[bad] = (weight / 3.0)[:, None, :]
        return part

    def gravity_forces(self, model, pos):
        """Gravity parts of the live clusters' grain forces [N], (k, 3, 3) [cluster,
        grain, xyz] in the scene frame.

        With g and drho from :attr:`gravity` and b = Bo g_hat (Bo = drho |g| r^2 /
        gamma, r the cluster's smallest radius), the triplet table's response
        (:meth:`~capbridge.surrogate.triplet.TripletSurrogate.predict_vectors` with
        ``bond`` and ``gravity``: F_i(b) - F_i(0) = Q (G_i b_t + C_i b_t^2 / 2), the
        first- and diagonal second-order terms; they sum over the grains to the
        liquid's weight drho V g up to the table's ``gravity_sum_residual``) at the
        grains' own centres (gaps below zero taken as contact), in the scene frame
        (the table frame of those centres, :func:`~capbridge.solvers.triplet.
        table_frame`, is applied by the surrogate).  A cluster whose Bo is above the
        surrogate's ``BOND_MAX`` or whose response has no number there gets the
        liquid's weight shared equally by its three grains (:meth:`_gravity_fallback`,
        counted in :attr:`gravity_fallback` and by reason in
        :attr:`gravity_fallback_reasons`); zero for a table without a gravity response.
        The engine's step gets these parts from its one lookup per step
        (:meth:`lookup` with ``gravity=True``); this method is that lookup's part.
        """
        out = np.zeros((self.n, 3, 3))
        if not self.n:
            return out
        res = self.lookup(model, pos, self.grains, self.volume, gravity=True)
        return res["gravity"] if "gravity" in res else out

    # ----------------------------------------------------------------- step
    def step(self, model, pos, geom, report=None, step=0):
        """One engine step (after ``model.update``): merge what ``report`` found,
        look the clusters up, split those that left their domain, and put the triplet
        forces in place of their bridges' doublet forces.

        Parameters
        ----------
        model : BridgeModel
        pos : (n, 3) grain centres [m].
        geom : dict returned by ``model.update`` for ``pos`` (its ``force`` is edited:
            bridges of a cluster get 0).
        report : CoalescenceReport, optional
            A detector report on the model's current bridges (a check this step).
        step : int
            DEM step (for the clusters' birth).

        Returns
        -------
        dict
            ``forces`` (n, 3) triplet forces on the grains [N] (to add to the doublet
            sums), ``grains`` the grains they act on, ``geom`` the bridge geometry to
            use (a new one from ``model.update(pos, form=False)`` if a split changed
            volumes, else ``geom``), ``ruptured`` bridges ruptured by that update.
        """
        ruptured = 0
        self._now = step
        if self.n:
            self._follow_bridges(model)
        merged0 = self.events["merged"]
        if report is not None and report.n_triplets:
            self._merge(model, pos, report, step)
        elif report is not None:
            self._note_funicular([])
        n_before = self.n - (self.events["merged"] - merged0)     # new ones are last
        # the bridges' forces on the grains of the new clusters, for the jump at merge
        merged_from = _bridge_grain_forces(model, geom, self.grains[n_before:],
                                           self.members[n_before:])
        forces = np.zeros((model.n, 3))
        if not self.n:
            self.last = None
            return {"forces": forces, "grains": np.empty(0, np.intp), "geom": geom,
                    "ruptured": 0}
        res = self._expanded_lookup(model, pos)
        ok = status_in(res["status"], HAS_RESULT)
        energy = ok & (res["lower"] == _SEPARATED)
        geometry = ~ok
        if geometry.any() or energy.any():
            self.events["split_geometry"] += int(geometry.sum())
            self.events["split_energy"] += int(energy.sum())
            which = np.flatnonzero(geometry | energy)
            for reason, n in _refusal_reasons(res, ~(geometry | energy)).items():
                self.stats["split_" + reason] += n
            gone = {"grains": self.grains[which], "members": self.members[which],
                    "forces": self.last_forces[which]}
            new = np.zeros(self.n, bool)
            new[n_before:] = True
            merged_from = merged_from[~np.isin(np.flatnonzero(new), which)]
            changed = self._split(model, pos, which)
            if changed:
                touched = model._touched.copy()
                n0 = model.ledger["ruptured_count"]
                geom = model.update(pos, step=step, form=False)
                model._touched = np.concatenate([touched, model._touched])
                ruptured = model.ledger["ruptured_count"] - n0
            # jump at split: the cluster's forces of the step before (none for a
            # cluster split in its merge step) -> its bridges' forces now
            was = np.isfinite(gone["forces"]).all(axis=(1, 2)) & ~new[which]
            if was.any():
                _record(self.stats, "split_jumps", _jumps(
                    gone["forces"][was], _bridge_grain_forces(
                        model, geom, gone["grains"][was], gone["members"][was]),
                    model.radii[gone["grains"][was]].min(axis=1), self.gamma))
            # the surviving clusters' bridges kept their volumes and gaps: the update
            # cannot have ruptured them
            keep = ok & ~energy
            res = {k: v[keep] for k, v in res.items()}
        if self.n:
            rows = self._rows(model, self.members.reshape(-1, 2)).reshape(-1, 3)
            geom["force"][rows[rows >= 0]] = 0.0           # the triplet replaces them
            fv = res["f"][..., None] * res["u"]            # (k, pair, xyz)
            F = np.zeros((self.n, 3, 3))
            for m, (a, b) in enumerate(((0, 1), (0, 2), (1, 2))):
                F[:, a] += fv[:, m]
                F[:, b] -= fv[:, m]
            if "gravity" in res:
                F += res["gravity"]
            np.add.at(forces, self.grains.ravel(), F.reshape(-1, 3))
            fresh = self.born == step
            fresh[:self.n - merged_from.shape[0]] = False
            if fresh.any():
                _record(self.stats, "merge_jumps", _jumps(
                    merged_from, F[fresh], model.radii[self.grains[fresh]].min(axis=1),
                    self.gamma))
            self.last_forces = F
        self.stats["cluster_steps"] += self.n
        self.last = {"status": res["status"], "f": res["f"], "gaps": res["gaps"]}
        return {"forces": forces, "grains": np.unique(self.grains), "geom": geom,
                "ruptured": ruptured}

    # ----------------------------------------------------------------- merge
    def _merge(self, model, pos, report, step):
        """New clusters from a detector report (indices: the model's bridges)."""
        bi, bj = model.bi, model.bj
        have = set(map(tuple, self.members.reshape(-1, 2)[
            self.members.reshape(-1, 2)[:, 0] >= 0].tolist()))
        cand, funicular, fun_rows = [], [], []
        T = np.empty((0, 3), np.intp)
        if report.clusters:
            # the grains of every cluster at once: sorted unique (cluster, grain) keys
            sizes = np.array([c.size for c in report.clusters], np.intp)
            label = np.repeat(np.arange(sizes.size), sizes)
            b = np.concatenate(report.clusters)
            key = np.unique(np.concatenate([label, label]) * model.n
                            + np.concatenate([bi[b], bj[b]]))
            count = np.bincount(key // model.n, minlength=sizes.size)
            start = np.cumsum(count) - count
            grain = key % model.n
            three = np.flatnonzero(count == 3)
            T = grain[start[three, None] + np.arange(3)]
            vol = np.bincount(label, weights=model.vol[b], minlength=sizes.size)
            for c in np.flatnonzero(count >= 4):
                funicular.append((grain[start[c]:start[c] + count[c]], float(vol[c])))
                fun_rows.append(report.clusters[c])
        if T.size:
            # every bridge among the three grains joins (a closed triangle): the rows of
            # the three pairs of each triple, in one search
            rows = self._rows(model, np.stack([T[:, [0, 1]], T[:, [0, 2]], T[:, [1, 2]]],
                                              1).reshape(-1, 2)).reshape(-1, 3)
            mixed = np.ptp(model.theta[T], axis=1) > 0
            self.events["mixed_angle"] += int(mixed.sum())
            for g, rw, mx in zip(T, rows, mixed):
                b = rw[rw >= 0]
                pairs = [(int(bi[x]), int(bj[x])) for x in b]
                self.stats["triplets_seen"] += 1
                if mx:
                    self.stats["triplets_mixed"] += 1
                elif any(p in have for p in pairs):
                    self.stats["triplets_live"] += 1          # already merged
                else:
                    cand.append((g, pairs, float(model.vol[b].sum())))
        self.stats["larger_seen"] += len(funicular)
        self._note_funicular(funicular)
        if funicular and self.n:
            # merged triplets whose bridges joined a funicular cluster: released to
            # their bridges (volumes unchanged, doublet forces)
            rows = self._rows(model, self.members.reshape(-1, 2)).reshape(-1, 3)
            gone = np.isin(rows, np.concatenate(fun_rows)).any(axis=1)
            self._remove(gone)
        if not cand:
            self._refused = {}
            return
        grains = np.array([g for g, _, _ in cand], np.intp)
        vol = np.array([v for _, _, v in cand])
        t0 = time.perf_counter()
        self._check_expansion_source()
        geo = self._geometry(model, pos, grains)
        keys = [tuple(g.tolist()) for g in grains]
        res, looked = self._candidates(geo, vol, keys)
        self.timings["lookup_seconds"] += time.perf_counter() - t0
        ok = status_in(res["status"], HAS_RESULT) & (res["lower"] != _SEPARATED)
        self.stats["triplets_live"] += int(ok.sum())
        self.stats["triplets_refused"] += int((~ok).sum())
        for reason, n in _refusal_reasons(res, ok).items():
            self.stats["refused_" + reason] += n
        # refused triplets are counted once, not at every check while they stay refused
        refused = {keys[k]: self._refused.get(keys[k]) if looked[k] < 0 else
                   {"gaps": res["lookup_gaps"][k], "volume": float(vol[k]),
                    **{key: res[key][k] for key in _REFUSAL_KEYS}}
                   for k in np.flatnonzero(~ok).tolist()}
        self.events["merge_refused"] += len(refused.keys() - self._refused.keys())
        self._refused = refused
        gaps = np.maximum(geo["gaps"], 0.0) / geo["r"][:, None]
        beyond = self.surrogate().continues(*gaps.T, radii=geo["R"] / geo["r"][:, None])
        self.events["open_side"] += int((ok & beyond).sum())
        for k in np.flatnonzero(ok):
            g, pairs, v = cand[k]
            mem = np.full((3, 2), -1, np.intp)
            mem[:len(pairs)] = pairs
            approx = bool(np.ptp(model.radii[g]) > 1e-12 * model.radii[g].max())
            self._append(g, mem, v, step, approx)
            self.events["merged"] += 1
            self.events["approximate"] += int(approx)
        new = np.flatnonzero(ok)           # all looked up: a refusal kept is not ok
        if new.size:
            self._store_expansion(np.arange(self.n - new.size, self.n),
                                  {key: x[new] for key, x in geo.items()},
                                  {key: x[looked[new]] for key, x in res["lookup"].items()})

    def _candidates(self, geo, volume, keys):
        """The merge candidates' answers (``status``, ``lower``, ``asked``, ``v`` and
        ``lookup_gaps``, (k,) rows) and the positions of the looked-up ones (``looked``,
        (k,) int: their row in ``res["lookup"]``, -1 for the others).  A triplet
        refused at the last check keeps that refusal while its liquid is the same and
        its lookup gaps moved by at most :data:`REUSE_GAP` since it was looked up (the
        resolution of the expansions); the others are looked up (with slopes: a merged
        cluster's first expansion)."""
        k = len(keys)
        g = np.maximum(geo["gaps"], 0.0) / geo["r"][:, None]
        kept = np.zeros(k, bool)
        for i, key in enumerate(keys):
            m = self._refused.get(key)
            kept[i] = m is not None and m["volume"] == volume[i] and \
                float(np.max(np.abs(g[i] - m["gaps"]))) <= REUSE_GAP
        ask = np.flatnonzero(~kept)
        looked = np.full(k, -1, np.intp)
        looked[ask] = np.arange(ask.size)
        res = {"status": np.empty(k, np.int8), "lower": np.empty(k, np.int8),
               "asked": np.empty(k, bool), "v": np.empty(k), "lookup_gaps": g}
        if ask.size:
            sub = self._answer({key: x[ask] for key, x in geo.items()}, volume[ask],
                               True, True)
            for key in _REFUSAL_KEYS:
                res[key][ask] = sub[key]
            res["lookup"] = sub
        for i in np.flatnonzero(kept):
            for key in _REFUSAL_KEYS:
                res[key][i] = self._refused[keys[i]][key]
        return res, looked

    def _follow_bridges(self, model):
        """The live clusters against the model's bridges, from one search of the three
        grain pairs of each cluster: a cluster whose member bridge is gone (doublet
        rupture, erased grain) is dissolved; a bridge that formed between two grains of
        a live cluster (a gap closed after the merge) is part of the coalesced body: it
        joins the cluster's members and its volume the cluster's liquid, so its
        doublet force is not added to the cluster's forces (the liquid would be
        counted twice)."""
        if self._followed[0] is model.keys and self._followed[1] == self._appends:
            return              # no bridge formed or ruptured, no cluster new since
        T = self.grains
        pairs = np.stack([T[:, [0, 1]], T[:, [0, 2]], T[:, [1, 2]]], 1)      # (k, 3, 2)
        rows = self._rows(model, pairs.reshape(-1, 2)).reshape(-1, 3)
        mem = np.sort(self.members, axis=-1)                    # -1 padding stays -1
        member = (mem[:, None, :, :] == pairs[:, :, None, :]).all(-1).any(-1)   # (k, 3)
        lost = (member & (rows < 0)).any(axis=1)
        if lost.any():
            self.events["dissolved"] += int(lost.sum())
            self._remove(lost)
            rows, member = rows[~lost], member[~lost]
        for c, m in np.argwhere((rows >= 0) & ~member):
            b = rows[c, m]
            slot = int(np.flatnonzero(self.members[c, :, 0] < 0)[0])
            self.members[c, slot] = (model.bi[b], model.bj[b])
            self.volume[c] += model.vol[b]
            self.expansion["gaps"][c] = np.nan          # a new volume: a new lookup
            self.events["absorbed"] += 1
        self._followed = (model.keys, self._appends)

    def _note_funicular(self, funicular):
        """Count new >= 4-grain clusters (once each) and keep the current ones' sizes."""
        keys = {tuple(g.tolist()) for g, _ in funicular}
        self.events["funicular_fallback"] += len(keys - self._funicular_keys)
        self._funicular_keys = keys
        self.funicular = {"clusters": len(funicular),
                          "grains": int(sum(g.size for g, _ in funicular)),
                          "volume": float(sum(v for _, v in funicular)),
                          "largest": int(max((g.size for g, _ in funicular), default=0))}

    # ----------------------------------------------------------------- split
    def _remove(self, mask):
        keep = ~np.asarray(mask, bool)
        _record(self.stats, "lives", (self._now - self.born[~keep]).tolist())
        self.grains, self.members = self.grains[keep], self.members[keep]
        self.volume, self.born, self.approx = self.volume[keep], self.born[keep], \
            self.approx[keep]
        self.last_forces = self.last_forces[keep]
        self.expansion = {k: v[keep] for k, v in self.expansion.items()}

    def _split(self, model, pos, which):
        """Split clusters ``which`` into their bridges at equal pressure (module
        docstring); returns True if bridge volumes changed."""
        t0 = time.perf_counter()
        changed = False
        for c in which:
            mem = self.members[c][self.members[c][:, 0] >= 0]
            rows = self._rows(model, mem)
            vols = self._shares(model, pos, self.grains[c], mem, model.vol[rows])
            if vols is None:
                self.events["split_share_fallback"] += 1
            else:
                model.set_volumes(rows, vols)
                changed = True
        self._remove(np.isin(np.arange(self.n), which))
        self.timings["split_seconds"] += time.perf_counter() - t0
        return changed

    def _shares(self, model, pos, grains, members, merge_vols):
        """Equal-pressure volumes [m^3] of the bridges ``members`` sharing the liquid
        of the cluster (their sum is exactly the cluster volume: the last share is the
        remainder), or None when they cannot be solved (then the merge-time volumes
        stay)."""
        if self.split_solver == "merge_volumes":
            return None
        R = model.radii[grains]
        theta = float(model.theta[grains[0]])
        equal = np.ptp(R) <= 1e-12 * R.max()
        if not 0.0 <= theta < 90.0 or (not equal and self.split_solver == "exact"):
            return None                  # the exact split is for equal spheres
        r = float(R.min())               # the reference length
        P = ((0, 1), (0, 2), (1, 2))
        where = {int(g): k for k, g in enumerate(grains)}
        local = tuple(tuple(sorted((where[int(a)], where[int(b)]))) for a, b in members)
        d = [np.linalg.norm(model.pair_vectors(pos, grains[[a]], grains[[b]])[0])
             - R[a] - R[b] for a, b in P]
        g = [max(x, 0.0) / r for x in d]
        V = float(merge_vols.sum())
        lo, hi = model.table.vstar_range
        if self.split_solver == "table":
            v = table_equal_pressure(self.doublet_surrogate(), [g[P.index(b)] for b in local],
                                     V / r**3, theta, (lo, hi),
                                     radii=[(R[a] / r, R[b] / r) for a, b in local])
            if v is None:
                return None
            v = v * r**3
        else:
            from capbridge.tables.coalescence import separated_state
            try:
                s = separated_state(*g, V / r**3, theta, local)
            except (CapbridgeInputError, ValueError):
                return None
            if s["status"] != Status.CONVERGED:
                return None
            v = np.array([s["volumes"][b] for b in local]) * r**3
        if not np.all(np.isfinite(v) & (v > 0)):
            return None
        own = np.array([min(R[a], R[b]) for a, b in local])      # each bridge's unit
        if np.any(v < lo * own**3) or np.any(v > hi * own**3):
            return None                  # outside the doublet table: keep merge volumes
        v[-1] = V - v[:-1].sum()         # exact total
        return v

    def doublet_surrogate(self):
        """The doublet surrogate for the "table" split (the shipped doublet table,
        fitted when the triplet table is read, or at the first split)."""
        if self._doublet is None:
            from capbridge.dem.bridges import default_table_path
            from capbridge.surrogate.doublet import DoubletSurrogate

            t0 = time.perf_counter()
            self._doublet = DoubletSurrogate().fit(default_table_path())
            # the equal grains' pressure grid that every split reads, built now
            self._doublet.predict(0.0, float(self._doublet.volume_[0]), 0.0,
                                  variables=("pressure",))
            self.timings["load_seconds"] += time.perf_counter() - t0
        return self._doublet

    # --------------------------------------------------------------- reporting
    def report(self):
        """JSON-friendly summary: events, current clusters, funicular clusters, table."""
        out = {"events": dict(self.events), "clusters": self.n,
               "cluster_volume": float(self.volume.sum()), "approximate_clusters":
               int(self.approx.sum()), "funicular": dict(self.funicular),
               "table_loaded": self.loaded, "table_loads": self.loads,
               "timings": dict(self.timings)}
        out["born"] = self.born.tolist()            # DEM step of each cluster's merge
        out["gravity_fallback"] = self.gravity_fallback
        out["gravity_fallback_reasons"] = dict(self.gravity_fallback_reasons)
        out["life"] = self.life_summary()
        if self.last is not None and self.n:
            out["statuses"] = [Status(int(s)).name.lower() for s in self.last["status"]]
        return out

    def life_summary(self):
        """How the clusters lived: cluster-steps, lives of the ended clusters (steps),
        the largest change of a grain's force at merge and at split (units of
        2 pi gamma r: median, p90, max), and the coalesced triplets met at the checks:
        answered by the table (merged or alive), refused (out of the table, no result,
        separated lower: doublet forces kept), of mixed angles; clusters of four
        grains or more met at the checks."""
        st = self.stats

        def dist(x, n=None, top=None):
            x = np.asarray(x, float)
            if not x.size:
                return {"n": 0}
            out = {"n": int(x.size if n is None else n), "median": float(np.median(x)),
                   "p90": float(np.percentile(x, 90)),
                   "max": float(x.max() if top is None else top)}
            if out["n"] > x.size:     # median and p90 of the uniform sample
                out["sampled"] = int(x.size)
            return out

        def kept(key):
            return dist(st[key], st[key + "_n"], st[key + "_max"])

        alive = (self._now - self.born).tolist()
        return {"cluster_steps": int(st["cluster_steps"]),
                "ended_lives": kept("lives"), "alive_ages": dist(alive),
                "merge_jump": kept("merge_jumps"), "split_jump": kept("split_jumps"),
                **{k: int(st[k]) for k in ("triplets_seen", "triplets_live",
                                           "triplets_refused", "triplets_mixed",
                                           "larger_seen")},
                "refused_by_reason": {k: int(st["refused_" + k]) for k in REFUSAL_REASONS},
                "splits_by_reason": {k: int(st["split_" + k]) for k in REFUSAL_REASONS}}

    def remap(self, new_index):
        """Grains were erased (``BridgeModel.drop_grains`` returned ``new_index``):
        clusters on a removed grain dissolve, the others are renumbered."""
        new_index = np.asarray(new_index, np.intp)
        if not self.n:
            return
        gone = (new_index[self.grains] < 0).any(axis=1)
        self.events["dissolved"] += int(gone.sum())
        self._remove(gone)
        m = self.members
        self.grains = new_index[self.grains]
        self.members = np.where(m >= 0, new_index[np.maximum(m, 0)], -1)

    # ----------------------------------------------------------- save / restore
    def get_state(self):
        """Clusters and counters, for the engine's saved state (register_state)."""
        return {"grains": self.grains.copy(), "members": self.members.copy(),
                "volume": self.volume.copy(), "born": self.born.copy(),
                "approx": self.approx.copy(), "events": dict(self.events),
                "funicular": dict(self.funicular),
                "funicular_keys": [list(k) for k in sorted(self._funicular_keys)],
                "refused_keys": [list(k) for k in sorted(self._refused)],
                # what each kept of its lookup (None: look it up at the next check)
                "refused_lookups": [None if self._refused[k] is None else
                                    {key: (v.tolist() if isinstance(v, np.ndarray) else
                                           v.item() if isinstance(v, np.generic) else v)
                                     for key, v in self._refused[k].items()}
                                    for k in sorted(self._refused)],
                "stats": {k: (list(v) if isinstance(v, list) else v)
                          for k, v in self.stats.items()},
                # the expansions, so that a restart looks up where the run would have
                **{"expansion_" + k: v.copy() for k, v in self.expansion.items()},
                "expansion_made_under": None if self._expansion_gravity is None else
                [self._expansion_gravity[0].tolist(), self._expansion_gravity[1]]}

    def set_state(self, st):
        """Continue from :meth:`get_state` (the table is loaded again only when needed)."""
        self._followed = (None, -1)
        self.grains = np.asarray(st["grains"], np.intp).reshape(-1, 3)
        self.members = np.asarray(st["members"], np.intp).reshape(-1, 3, 2)
        self.volume = np.asarray(st["volume"], float).ravel()
        self.born = np.asarray(st["born"], np.intp).ravel()
        self.approx = np.asarray(st["approx"], bool).ravel()
        self.last_forces = np.full((self.volume.size, 3, 3), np.nan)
        # restart files written before the expansions look every cluster up again
        self.expansion = _no_expansion(self.volume.size)
        if "expansion_gaps" in st:
            self.expansion = {k: np.asarray(st["expansion_" + k], v.dtype).reshape(v.shape)
                              for k, v in self.expansion.items()}
        eg = st.get("expansion_made_under")
        self._expansion_gravity = None if eg is None else (np.asarray(eg[0], float),
                                                           float(eg[1]))
        self.events.update({k: int(v) for k, v in st["events"].items()})
        self.funicular = dict(st["funicular"])
        self._funicular_keys = {tuple(k) for k in st["funicular_keys"]}
        keys = [tuple(k) for k in st.get("refused_keys", [])]
        # saved before the refusals kept their lookups: looked up at the next check
        kept = st.get("refused_lookups") or [None] * len(keys)
        self._refused = {k: None if m is None else {**m, "gaps": np.asarray(m["gaps"])}
                         for k, m in zip(keys, kept)}
        # restart files written before the counters existed start them afresh
        self.stats = _new_stats()
        self.stats.update({k: (list(v) if isinstance(self.stats.get(k), list) else v)
                           for k, v in st.get("stats", {}).items() if k in self.stats})
        for k in SAMPLED_STATS:        # saved before the counts were kept beside them
            if k + "_n" not in st.get("stats", {}):
                self.stats[k + "_n"] = len(self.stats[k])
                self.stats[k + "_max"] = max(self.stats[k], default=0.0)
