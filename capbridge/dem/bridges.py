"""Volume-controlled liquid bridges between spheres, in plain numpy (no YADE here).

:class:`BridgeModel` holds the bridges of a packing: it forms them at contact with the
volume given by the liquid rule (:class:`~capbridge.dem.liquid_rule.LiquidRule`), keeps
the volume, ruptures them beyond the table's rupture gap, lets them re-form at a later
contact, and sums the bridge forces, equal and opposite along the centre line, on the
grains.  It keeps a ledger of the liquid (every formation and rupture, and the liquid
held on grains for the conserving rule) so that the total is accounted for at every
step.  Its numbers come from the scene's cut of the doublet table
(:class:`~capbridge.dem.scene_table.SceneTable`), its formation candidates from a
neighbour list (:class:`~capbridge.dem.neighbours.VerletList`).

Conventions (capbridge's): lengths over the *smaller* radius of the pair r,
ratio = R/r >= 1, V* = V/r^3, F* = F/(2 pi gamma r), attraction > 0, angles in degrees.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from capbridge.dem.liquid_rule import LiquidRule
from capbridge.dem.neighbours import VerletList
from capbridge.dem.scene_table import SceneTable, distinct_values
from capbridge.dimensionless import force_scale
# this module's public name from before the scene table had its own module (issue 17)
from capbridge.dem.scene_table import default_table_path

__all__ = ["SceneTable", "LiquidRule", "BridgeModel", "default_table_path",
           "distinct_values", "balance_error"]


#: The band s = sqrt(1 - d*/d*_rupt) >= ERROR_BAND of the doublet table's held-out error:
#: a bridge's relative gravity correction is taken at its smallest attraction in that band.
ERROR_BAND = 0.2


def balance_error(got, expected, scale):
    """Relative error of a liquid ledger: |got - expected| relative to the liquid
    expected, or, when (to round-off) none is expected any more (every bridge ruptured,
    every wet grain erased), to ``scale``, the liquid the ledger handled [m^3]."""
    denom = abs(expected) if abs(expected) > 1e-9 * abs(scale) else abs(scale)
    return abs(got - expected) / max(denom, 1e-300)


class BridgeModel:
    """Bridges of a packing of spheres, their volumes, rupture, re-formation and forces.

    Parameters
    ----------
    radii : (n,) sphere radii [m].
    theta : (n,) contact angle of each grain [deg]; a bridge between grains of different
        angles uses the exact slice of that pair of angles (computed at set-up by
        :mod:`capbridge.dem.mixed_angles`, angle of the smaller grain first).
    table : path / Dataset / DoubletSurrogate / :class:`SceneTable` built for the
        scene (pair angles and ratios), see :meth:`scene_table`.
    gamma : surface tension [N/m].
    liquid : :class:`LiquidRule`.
    formation_gap : a bridge forms when the gap between the surfaces is <= this [m]
        (0: at contact).
    initial_wet_gap : at :meth:`initialise`, pairs with gap <= this [m] get a bridge
        (default ``formation_gap``); use it to start from a wet packing whose grains
        are not all touching.
    skin : Verlet skin of the candidate list [m] (default 0.1 * smallest radius).
    with_beta : also tabulate the filling angles (coalescence detection).
    """

    def __init__(self, radii, theta, table, gamma, liquid, *, formation_gap=0.0,
                 initial_wet_gap=None, skin=None, with_beta=True, ratio_step=0.01):
        self.radii = np.ascontiguousarray(radii, float)
        self.n = self.radii.size
        # n = 0: a scene whose wet grains were all erased, restored (nothing to do)
        if np.any(~(self.radii > 0)):
            raise ValueError("radii must be positive")
        self.theta = np.broadcast_to(np.asarray(theta, float), (self.n,)).copy()
        self.gamma = float(gamma)
        if not self.gamma > 0:
            raise ValueError("gamma must be positive")
        self.liquid = liquid if isinstance(liquid, LiquidRule) else LiquidRule(**liquid)
        self.formation_gap = float(formation_gap)
        self.initial_wet_gap = self.formation_gap if initial_wet_gap is None else float(initial_wet_gap)
        r_min = float(self.radii.min()) if self.n else 0.0
        self.skin = float(skin) if skin is not None else 0.1 * r_min
        self.skin = max(self.skin, self.formation_gap, self.initial_wet_gap, 1e-12)
        # grain angle classes and the pair angle of each combination
        self.theta_classes, self.grain_class = np.unique(self.theta, return_inverse=True)
        tc = self.theta_classes
        # (angle on the smaller grain, angle on the larger) of every pair of classes that
        # the radii allow (class a can be the smaller, or equal, grain of a pair with b)
        t_small, t_large = np.meshgrid(tc, tc, indexing="ij")
        cls = np.arange(tc.size)
        r_lo = np.array([self.radii[self.grain_class == c].min() for c in cls])
        r_hi = np.array([self.radii[self.grain_class == c].max() for c in cls])
        possible = r_lo[:, None] <= r_hi[None, :]
        if isinstance(table, SceneTable):
            self.table = table
        else:
            variables = ("force", "beta1", "beta2") if with_beta else ("force",)
            ratios, continuous = self.pair_ratios()
            self.table = SceneTable(table, tc, ratios, variables=variables,
                                    ratio_step=ratio_step, continuous=continuous,
                                    theta_pairs=np.column_stack([t_small[possible],
                                                                 t_large[possible]]))
        self.pair_slice = np.full((tc.size, tc.size), -1, np.intp)   # -1: cannot occur
        self.pair_slice[possible] = self.table.slice_index(t_small[possible], t_large[possible])
        self.with_beta = with_beta and "beta1" in self.table.grids
        if self.table.s_axis.lo != 0.0:
            raise ValueError("the table's s axis must start at 0 (s = sqrt(1 - d/d_rupt))")
        self._check_fixed_volume()
        self.cand = VerletList(self.radii, self.skin, self.formation_gap)
        self._empty()
        self.films = np.zeros(self.n)
        # gravity part of each grain's force last handed to the DEM [N] (liquid_gravity)
        self.gravity_held = np.zeros((self.n, 3))
        self.ledger = {"rule": self.liquid.kind, "initial_volume": 0.0, "initial_count": 0,
                       "formed_count": 0, "formed_volume": 0.0, "ruptured_count": 0,
                       "ruptured_volume": 0.0, "formations_short_of_liquid": 0,
                       "total_liquid": self.liquid.total_liquid, "removed_grains": 0,
                       "removed_volume": 0.0}
        self.fixed_volume = self.liquid.bridge_volume
        self.initialised = False
        self._pending_refused = None

    # ------------------------------------------------------------------------ set-up
    def pair_ratios(self, max_radii=4):
        """Radius ratios the packing can produce and whether they form a continuum:
        (ratios, continuous).  Up to ``max_radii`` distinct radii, all their ratios
        (exact grids); more, the range [1, r_max/r_min]."""
        rad = distinct_values(self.radii)
        if rad.size <= max_radii:
            rr = rad[None, :] / rad[:, None]
            return distinct_values(rr[rr >= 1.0 - 1e-12]), False
        return np.array([1.0, rad[-1] / rad[0]]), True

    def _check_fixed_volume(self):
        if self.n == 0:
            return
        lo, hi = self.table.vstar_range
        rmin, rmax = float(self.radii.min()), float(self.radii.max())
        if self.liquid.bridge_volume is not None:
            v = self.liquid.bridge_volume
            vs = (v / rmax**3, v / rmin**3)
            if vs[0] < lo * (1 - 1e-12) or vs[1] > hi * (1 + 1e-12):
                raise ValueError(
                    f"bridge_volume {v:g} m^3 gives V* = V/r^3 from {vs[0]:g} to {vs[1]:g} "
                    f"over the grain radii [{rmin:g}, {rmax:g}] m; the table covers "
                    f"[{lo:g}, {hi:g}]: choose a volume inside "
                    f"[{lo * rmin**3:g}, {hi * rmax**3:g}] m^3 (when possible) or use "
                    "bridge_volume_star")
        if self.liquid.bridge_volume_star is not None:
            v = self.liquid.bridge_volume_star
            if v < lo * (1 - 1e-12) or v > hi * (1 + 1e-12):
                raise ValueError(f"bridge_volume_star {v:g} is outside the table's [{lo:g}, {hi:g}]")

    def _empty(self):
        e_i = np.empty(0, np.intp)
        e_f = np.empty(0)
        nS = self.table.s_axis.n
        self.pool = np.zeros((64, nS))          # force profile F*(s) of every bridge, by slot
        self.free = list(range(63, -1, -1))
        self.slot = e_i.copy()
        self.bi, self.bj, self.cidx = e_i, e_i.copy(), e_i.copy()
        self.vol, self.vstar, self.rsmall = e_f, e_f.copy(), e_f.copy()
        self.const = {"base": e_i.copy(), "fv": e_f.copy(), "fr": e_f.copy(), "d_rupt": e_f.copy()}
        self.d_rupt_si = e_f.copy()
        self.rsum = e_f.copy()                   # r_i + r_j
        self.inv_dr = e_f.copy()                 # 1 / rupture gap [1/m]
        self.fscale = e_f.copy()                 # 2 pi gamma r_small [N]
        self.fstar_min = e_f.copy()              # smallest F* over s >= 0.2 (gravity)
        self.keys = np.empty(0, np.int64)
        self.born = e_i.copy()
        self.held = np.empty((0, 3))             # force vector last handed to the DEM
        self._touched = e_i.copy()               # grains that lost a bridge this update

    @property
    def n_bridges(self):
        return int(self.bi.size)

    # ---------------------------------------------------------------------- formation
    def _volume_for(self, i, j):
        """Fixed rule: the volume of a new bridge between grains i, j."""
        rs = np.minimum(self.radii[i], self.radii[j])
        if self.liquid.bridge_volume_star is not None:
            return self.liquid.bridge_volume_star * rs**3
        return np.full(np.shape(i), float(self.fixed_volume))

    def _add(self, i, j, vol, step):
        i = np.asarray(i, np.intp)
        j = np.asarray(j, np.intp)
        if i.size == 0:
            return
        sw = i > j
        i, j = np.where(sw, j, i), np.where(sw, i, j)
        rs = np.minimum(self.radii[i], self.radii[j])
        ratio = np.maximum(self.radii[i], self.radii[j]) / rs
        vstar = vol / rs**3
        # the smaller grain (i when equal, as in filling_angles) carries theta1
        i_small = self.radii[i] <= self.radii[j]
        small, large = np.where(i_small, i, j), np.where(i_small, j, i)
        ti = self.pair_slice[self.grain_class[small], self.grain_class[large]]
        if np.any(ti < 0):                        # cannot happen with the model's radii
            raise RuntimeError("a bridge between angle classes the radii do not allow")
        c = self.table.bridge_constants(ti, ratio, vstar)
        keys = i.astype(np.int64) * self.n + j
        cidx = self.cand.index_of(keys)
        while len(self.free) < i.size:          # grow the pool of force profiles
            old = self.pool.shape[0]
            self.pool = np.vstack([self.pool, np.zeros_like(self.pool)])
            self.free[:0] = list(range(2 * old - 1, old - 1, -1))
        slots = np.array([self.free.pop() for _ in range(i.size)], np.intp)
        prof = self.table.rows("force", c)
        self.pool[slots] = prof
        # smallest attraction over s >= 0.2 (liquid_gravity.ERROR_BAND, the band of the
        # table's held-out error): the bridge's largest relative gravity correction
        band = self.table.s_axis.nodes >= ERROR_BAND
        self.fstar_min = np.concatenate([self.fstar_min, prof[:, band].min(axis=1)])
        self.slot = np.concatenate([self.slot, slots])
        if np.any(cidx >= 0):
            self.cand.has_bridge[cidx[cidx >= 0]] = True
        self.bi = np.concatenate([self.bi, i])
        self.bj = np.concatenate([self.bj, j])
        self.cidx = np.concatenate([self.cidx, cidx])
        self.vol = np.concatenate([self.vol, vol])
        self.vstar = np.concatenate([self.vstar, vstar])
        self.rsmall = np.concatenate([self.rsmall, rs])
        for k in self.const:
            self.const[k] = np.concatenate([self.const[k], c[k]])
        d_rupt_si = c["d_rupt"] * rs
        self.d_rupt_si = np.concatenate([self.d_rupt_si, d_rupt_si])
        self.rsum = np.concatenate([self.rsum, self.radii[i] + self.radii[j]])
        self.inv_dr = np.concatenate([self.inv_dr, 1.0 / d_rupt_si])
        self.fscale = np.concatenate([self.fscale, force_scale(rs, self.gamma)])
        self.keys = np.concatenate([self.keys, keys])
        self.born = np.concatenate([self.born, np.full(i.size, step, np.intp)])
        self.held = np.vstack([self.held, np.zeros((i.size, 3))])

    def set_volumes(self, rows, volumes):
        """Give bridges ``rows`` new volumes [m^3] (their force profile and rupture gap
        follow), keeping their birth step and held force.  The bridges move to the end of
        the arrays; the ledger is not touched (the caller keeps the total volume) and no
        grain is listed as having lost a bridge."""
        rows = np.asarray(rows, np.intp)
        if rows.size == 0:
            return
        i, j = self.bi[rows].copy(), self.bj[rows].copy()
        born, held = self.born[rows].copy(), self.held[rows].copy()
        mask = np.zeros(self.n_bridges, bool)
        mask[rows] = True
        touched = self._touched.copy()
        self._remove(mask)
        self._touched = touched            # no bridge was lost: no grain to re-list
        n0 = self.n_bridges
        self._add(i, j, np.asarray(volumes, float), 0)
        self.born[n0:] = born
        self.held[n0:] = held

    def _remove(self, mask):
        keep = ~mask
        gone = self.cidx[mask]
        gone = gone[gone >= 0]
        self.cand.has_bridge[gone] = False
        self.free.extend(self.slot[mask].tolist())
        self._touched = np.concatenate([self._touched, self.bi[mask], self.bj[mask]])
        for name in ("bi", "bj", "cidx", "vol", "vstar", "rsmall", "d_rupt_si", "keys", "born",
                     "slot", "held", "rsum", "inv_dr", "fscale", "fstar_min"):
            setattr(self, name, getattr(self, name)[keep])
        for k in self.const:
            self.const[k] = self.const[k][keep]

    def _film_share(self, i, j, vol):
        """Split ``vol`` between grains i and j in proportion to R^2 (onto their films)."""
        a, b = self.radii[i] ** 2, self.radii[j] ** 2
        np.add.at(self.films, i, vol * a / (a + b))
        np.add.at(self.films, j, vol * b / (a + b))

    def _form(self, i, j, step):
        """New bridges on touching pairs i, j (arrays) under the liquid rule.

        Conserved liquid (films): a grain that forms k bridges in this update gives each
        of them ``film_fraction / k`` of its film, so that the order of the pairs does
        not matter and a grain never gives more than ``film_fraction`` of its film in
        one update; the bridge volume is capped at the table's largest V* (the rest
        stays on the films, in proportion to what each grain offered); a pair whose
        bridge would be below the table's smallest V* is refused and its liquid stays
        on the films.  Returns (number formed, refused mask over the pairs)."""
        refused = np.zeros(i.size, bool)
        if i.size == 0:
            return 0, refused
        if self.liquid.kind == "fixed":
            vol = self._volume_for(i, j)
            self._add(i, j, vol, step)
            self.ledger["formed_count"] += int(i.size)
            self.ledger["formed_volume"] += float(vol.sum())
            return int(i.size), refused
        f = self.liquid.film_fraction
        lo, hi = self.table.vstar_range
        k = np.bincount(i, minlength=self.n) + np.bincount(j, minlength=self.n)
        offer_i = f * self.films[i] / k[i]
        offer_j = f * self.films[j] / k[j]
        want = offer_i + offer_j
        rs = np.minimum(self.radii[i], self.radii[j])
        v = np.minimum(want, hi * rs**3)
        refused = ~((v > 0) & (v >= lo * rs**3 * (1 + 1e-12)))
        ok = ~refused
        if ok.any():
            i, j, v, offer_i, want = i[ok], j[ok], v[ok], offer_i[ok], want[ok]
            take_i = offer_i * (v / want)
            self.films -= (np.bincount(i, take_i, minlength=self.n)
                           + np.bincount(j, v - take_i, minlength=self.n))
            np.maximum(self.films, 0.0, out=self.films)   # round-off of the subtractions
            self._add(i, j, v, step)
            self.ledger["formed_count"] += int(i.size)
            self.ledger["formed_volume"] += float(v.sum())
        self.ledger["formations_short_of_liquid"] += int(refused.sum())
        return int(ok.sum()), refused

    def initialise(self, pos, step=0, pairs=None):
        """First bridges: every pair with gap <= ``initial_wet_gap`` (or exactly the
        grain pairs ``pairs``, an (m, 2) array of indices), with the rule's volume (a
        total liquid is shared equally among them)."""
        pos = np.asarray(pos, float)
        self._empty()
        self.films[:] = 0.0
        self.cand.rebuild(pos, self.keys, self.n, np.empty(0, np.int64))
        if pairs is not None:
            pairs = np.asarray(pairs, np.intp).reshape(-1, 2)
            i, j = pairs[:, 0], pairs[:, 1]
            if np.any(i == j) or np.any((i < 0) | (j < 0) | (i >= self.n) | (j >= self.n)):
                raise ValueError("initial pairs must be pairs of two different grains")
        else:
            gap = self._cand_gaps(pos)
            wet = gap <= self.initial_wet_gap
            i, j = self.cand.i[wet], self.cand.j[wet]
        L = self.liquid
        if L.total_liquid is not None and L.conserve:
            # the liquid starts on the grains, as a uniform water content (films in
            # proportion to the grain volume), and the initial bridges take it from
            # there like any later one
            self.films[:] = float(L.total_liquid) * self.radii**3 / float((self.radii**3).sum())
            _, refused = self._form(i, j, step)
            self.ledger["formed_count"] = 0
            self.ledger["formed_volume"] = 0.0
            self._mark_refused(i[refused], j[refused])
        elif L.total_liquid is not None:
            if i.size == 0:
                raise ValueError("no initial bridges to share the liquid among: give a "
                                 "bridge_volume, wet a larger gap, or conserve=True")
            v = float(L.total_liquid) / i.size
            self.fixed_volume = v
            self.liquid = dataclasses.replace(L, total_liquid=None, bridge_volume=v,
                                              conserve=False)
            self._check_fixed_volume()
            self._add(i, j, np.full(i.size, v), step)
        else:
            self._add(i, j, self._volume_for(i, j), step)
        self.ledger["initial_count"] = self.n_bridges
        self.ledger["initial_volume"] = float(self.vol.sum())
        self.ledger["formations_short_of_liquid"] = 0
        self.ledger["bridge_volume"] = self.fixed_volume
        self.initialised = True

    # --------------------------------------------------------------------------- step
    def pair_vectors(self, pos, i, j):
        """Centre-to-centre vectors i -> j [m] of grain pairs, (m, 3).

        The one place where the engine turns positions into bridge geometry: a periodic
        cell (the shift to the nearest image) or a wall partner (the foot of the
        perpendicular on the wall) belongs here, and every gap, rupture test,
        formation test and force direction follows."""
        d = pos[j]
        d -= pos[i]
        cell = getattr(self, "cell", None)     # capbridge.dem.periodic.PeriodicCell
        if cell is not None:
            cell.min_image(d)
        return d

    def _cand_gaps(self, pos):
        ci, cj = self.cand.i, self.cand.j
        d = self.pair_vectors(pos, ci, cj)
        return np.sqrt(np.einsum("ij,ij->i", d, d)) - self.radii[ci] - self.radii[cj]

    def update(self, pos, step=0, form=True, initial_pairs=None):
        """Advance the bridges to positions ``pos`` (n, 3): ruptures, formations.

        Returns a dict with the bridge geometry of this step (``d`` centre-to-centre
        vectors i -> j and their length ``dist``, ``gap`` [m], ``force`` [N],
        attraction > 0) and the counts of events.
        """
        pos = np.asarray(pos, float)
        if not self.initialised:
            self.initialise(pos, step, pairs=initial_pairs)
        if self.cand.needs_rebuild(pos):
            self.cand.rebuild(pos, self.keys, self.n, self._pending_refused)
            self._pending_refused = None
            self.cidx = self.cand.index_of(self.keys)
        self._touched = np.empty(0, np.intp)
        # ruptures
        d = self.pair_vectors(pos, self.bi, self.bj)
        dist = np.sqrt(np.einsum("ij,ij->i", d, d))
        gap = dist - self.rsum
        broken = gap > self.d_rupt_si
        n_rupt = int(np.count_nonzero(broken))
        if n_rupt:
            v = self.vol[broken]
            self.ledger["ruptured_count"] += n_rupt
            self.ledger["ruptured_volume"] += float(v.sum())
            if self.liquid.kind == "conserved":
                self._film_share(self.bi[broken], self.bj[broken], v)
                self._release_refused(np.concatenate([self.bi[broken], self.bj[broken]]))
            self._remove(broken)
            keep = ~broken
            d, dist, gap = d[keep], dist[keep], gap[keep]
        # formations at contact
        n_form = 0
        if form and self.cand.i.size:
            # only pairs without a bridge, and not refused (no retry until a film grows)
            idx = np.flatnonzero(~(self.cand.has_bridge | self.cand.refused))
            dc = self.pair_vectors(pos, self.cand.i[idx], self.cand.j[idx])
            idx = idx[np.einsum("ij,ij->i", dc, dc) <= self.cand.reach2[idx]]
            if idx.size:
                n0 = self.n_bridges
                n_form, refused = self._form(self.cand.i[idx], self.cand.j[idx], step)
                self.cand.refused[idx[refused]] = True
                if n_form:
                    nd = self.pair_vectors(pos, self.bi[n0:], self.bj[n0:])
                    nds = np.sqrt(np.einsum("ij,ij->i", nd, nd))
                    d = np.vstack([d, nd])
                    dist = np.concatenate([dist, nds])
                    gap = np.concatenate([gap, nds - self.rsum[n0:]])
        # force: the bridge's own profile F*(s), s = sqrt(1 - gap / d_rupt)
        x = gap * self.inv_dr
        np.subtract(1.0, x, out=x)
        np.clip(x, 0.0, 1.0, out=x)
        u = np.sqrt(x, out=x)
        ax = self.table.s_axis
        u *= 1.0 / ax.step                      # the s axis starts at 0
        i_s = u.astype(np.intp)
        np.minimum(i_s, ax.n - 2, out=i_s)
        u -= i_s
        k = self.slot * self.pool.shape[1]
        k += i_s
        flat = self.pool.ravel()
        a = flat[k]
        force = flat[k + 1]
        force -= a
        force *= u
        force += a
        force *= self.fscale
        return {"d": d, "dist": dist, "gap": gap, "force": force, "ruptured": n_rupt,
                "formed": n_form}

    def grain_forces(self, geom, tolerance=0.0, list_changed=True):
        """Bridge forces summed on the grains, for the DEM.

        Returns ``(forces, changed)``: ``forces`` (n, 3) [N] (attraction: grain i is
        pulled towards j, j towards i; every bridge's pair of forces is equal and
        opposite along the centre line) and the indices of the grains whose force
        changed.  With ``tolerance > 0`` a bridge keeps the force vector last handed
        out (:attr:`held`) until the new one differs from it by more than
        ``tolerance`` times its magnitude; the sums use the held vectors, so action
        and reaction stay exactly opposite and only grains of updated (or ruptured)
        bridges are listed as changed.  ``list_changed=False``: ``changed`` is None
        (not needed when every force is handed out every step).
        """
        fv = geom["d"] * (geom["force"] / geom["dist"])[:, None]
        if tolerance > 0.0 and self.held.shape[0] == fv.shape[0]:
            diff = fv - self.held
            upd = np.einsum("ij,ij->i", diff, diff) > (tolerance * geom["force"]) ** 2
            self.held[upd] = fv[upd]
            changed = np.unique(np.concatenate([self.bi[upd], self.bj[upd], self._touched]))
        else:
            self.held = fv
            changed = None
        out = self._bridge_sums()
        if changed is None and list_changed:
            changed = np.unique(np.concatenate([self.bi, self.bj, self._touched]))
        return out, changed

    def held_grain_forces(self):
        """(n, 3) sums on the grains of the force vectors last handed out [N]: the
        bridges' forces and the liquid's weight (:attr:`gravity_held`, set by
        :class:`~capbridge.dem.liquid_gravity.LiquidGravity`)."""
        out = self._bridge_sums()
        if self.gravity_held.shape == out.shape:
            out += self.gravity_held
        return out

    def _bridge_sums(self):
        """(n, 3) sums on the grains of the bridges' force vectors last handed out."""
        h = self.held.ravel()
        xyz = np.arange(3)
        on_i = np.bincount((3 * self.bi[:, None] + xyz).ravel(), h, minlength=3 * self.n)
        on_j = np.bincount((3 * self.bj[:, None] + xyz).ravel(), h, minlength=3 * self.n)
        # (float even with no bridge: bincount of nothing gives integers)
        return (on_i - on_j).reshape(self.n, 3).astype(float, copy=False)

    def filling_angles(self, gap):
        """Half filling angles [deg] of each bridge on its grains bi and bj."""
        if not self.with_beta:
            raise RuntimeError("the SceneTable was built without beta1/beta2")
        gs = gap / self.rsmall
        sc = self.table.s_coordinate(gs, self.const["d_rupt"])
        b1 = self.table.lookup("beta1", self.const, gs, sc)   # on the smaller grain
        b2 = self.table.lookup("beta2", self.const, gs, sc)
        i_small = self.radii[self.bi] <= self.radii[self.bj]
        return np.where(i_small, b1, b2), np.where(i_small, b2, b1)

    # ---------------------------------------------------------------- liquid on films
    def _mark_refused(self, i, j):
        """Pairs (i, j) refused for lack of liquid: not tried again until a film of
        theirs grows (:meth:`_release_refused`)."""
        if i.size == 0:
            return
        lo, hi = np.minimum(i, j), np.maximum(i, j)
        c = self.cand.index_of(lo.astype(np.int64) * self.n + hi)
        self.cand.refused[c[c >= 0]] = True

    def _release_refused(self, grains):
        """Grains whose film grew (a rupture gave them liquid): their refused pairs may
        form a bridge again."""
        if self.cand.refused.any():
            grew = np.zeros(self.n, bool)
            grew[grains] = True
            self.cand.refused &= ~(grew[self.cand.i] | grew[self.cand.j])

    def drop_grains(self, gone):
        """Remove grains (erased from the scene): their bridges rupture by the rule
        (conserved: the bridge's liquid is split onto the two grains' films, in
        proportion to R^2), then the grains leave with their films; the liquid that
        leaves is counted in the ledger (``removed_volume``), so the budget stays
        exact.  Returns the new index of every old grain (-1: removed)."""
        gone = np.asarray(gone, bool)
        if not gone.any():
            return np.arange(self.n)
        hit = gone[self.bi] | gone[self.bj]
        if hit.any():
            v = self.vol[hit]
            self.ledger["ruptured_count"] += int(hit.sum())
            self.ledger["ruptured_volume"] += float(v.sum())
            if self.liquid.kind == "conserved":
                self._film_share(self.bi[hit], self.bj[hit], v)
            self._remove(hit)
        if self.liquid.kind == "conserved":
            self.ledger["removed_volume"] += float(self.films[gone].sum())
        self.ledger["removed_grains"] += int(gone.sum())
        keep = ~gone
        new_index = np.where(keep, np.cumsum(keep) - 1, -1)
        self.radii = np.ascontiguousarray(self.radii[keep])
        self.theta = self.theta[keep]
        self.grain_class = self.grain_class[keep]
        self.films = self.films[keep]
        if self.gravity_held.shape[0] == keep.size:
            self.gravity_held = self.gravity_held[keep]
        self.n = int(self.radii.size)
        self.bi, self.bj = new_index[self.bi], new_index[self.bj]
        self.keys = self.bi.astype(np.int64) * self.n + self.bj
        self.cand = VerletList(self.radii, self.skin, self.formation_gap)
        self.cidx = np.full(self.bi.size, -1, np.intp)
        return new_index

    # ----------------------------------------------------------------- save / restore
    def get_state(self):
        """Everything needed to continue exactly (a dict of arrays and JSON values):
        the bridges (grains, volume, birth step, force last handed out), the films,
        the refused pairs, the ledger and the liquid rule.  Force profiles and rupture
        gaps are not stored: :meth:`set_state` recomputes them from the table, which
        gives the same numbers."""
        return {"n": self.n, "radii": self.radii.copy(), "theta": self.theta.copy(),
                "bi": self.bi.copy(), "bj": self.bj.copy(), "vol": self.vol.copy(),
                "born": self.born.copy(), "held": self.held.copy(),
                "films": self.films.copy(), "gravity_held": self.gravity_held.copy(),
                "refused_keys": self.cand.keys[self.cand.refused].copy(),
                "ledger": dict(self.ledger), "fixed_volume": self.fixed_volume,
                "initialised": self.initialised, "liquid": dataclasses.asdict(self.liquid)}

    def set_state(self, st):
        """Continue from :meth:`get_state`'s dict (same grains, same table)."""
        radii = np.asarray(st["radii"], float)
        if radii.shape != self.radii.shape or not np.array_equal(radii, self.radii) \
                or not np.array_equal(np.asarray(st["theta"], float), self.theta):
            raise ValueError(f"saved bridge state is for {radii.size} grains with other radii "
                             f"or angles than the {self.n} grains of this model")
        self.liquid = LiquidRule(**st["liquid"])
        self.fixed_volume = st["fixed_volume"]
        self._empty()
        self.films = np.asarray(st["films"], float).copy()
        bi, bj = np.asarray(st["bi"], np.intp), np.asarray(st["bj"], np.intp)
        self._add(bi, bj, np.asarray(st["vol"], float), 0)
        self.born = np.asarray(st["born"], np.intp).copy()
        self.held = np.asarray(st["held"], float).reshape(-1, 3).copy()
        gh = st.get("gravity_held")            # absent in states saved before gravity
        self.gravity_held = (np.zeros((self.n, 3)) if gh is None
                             else np.asarray(gh, float).reshape(-1, 3).copy())
        self.ledger = dict(st["ledger"])
        self.initialised = bool(st["initialised"])
        self.cand.ref = None                       # rebuilt at the next update
        self._pending_refused = np.asarray(st["refused_keys"], np.int64)

    # ------------------------------------------------------------------------ budget
    def liquid_report(self, pore_volume=None):
        """Where the liquid is now: bridges, films, total [m^3] and, with the pore
        volume [m^3], the degree of saturation S_r = liquid / pores (total and in
        bridges)."""
        b = float(self.vol.sum()) + float(getattr(self, "wall_volume", 0.0))
        f = float(self.films.sum())
        out = {"bridges": b, "films": f, "total": b + f, "n_bridges": self.n_bridges,
               "wet_grains": int(np.count_nonzero(np.bincount(
                   np.concatenate([self.bi, self.bj]), minlength=self.n))),
               "saturation": None, "saturation_bridges": None}
        if pore_volume:
            out["saturation"] = (b + f) / pore_volume
            out["saturation_bridges"] = b / pore_volume
        return out

    def budget(self):
        """The liquid ledger.  ``balance`` is what the rule says must hold, exactly:

        fixed:     active = initial + formed - ruptured
        conserved: active + films = total_liquid - removed (liquid that left with
                   erased grains)
        """
        L = dict(self.ledger)
        active = float(self.vol.sum())
        L["active_count"] = self.n_bridges
        L["active_volume"] = active
        L["film_volume"] = float(self.films.sum())
        # liquid in wall bridges (capbridge.dem.wall_bridges), conserving rule
        L["wall_volume"] = float(getattr(self, "wall_volume", 0.0))
        if self.liquid.kind == "conserved":
            expected = float(self.liquid.total_liquid) - L["removed_volume"]
            got = active + L["film_volume"] + L["wall_volume"]
        else:
            expected = L["initial_volume"] + L["formed_volume"] - L["ruptured_volume"]
            got = active
        L["expected"] = expected
        L["accounted"] = got
        scale = (float(self.liquid.total_liquid) if self.liquid.kind == "conserved"
                 else L["initial_volume"] + L["formed_volume"])
        L["balance_error"] = balance_error(got, expected, scale)
        return L
