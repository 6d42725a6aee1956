"""Liquid bridges between spheres and YADE's walls, boxes and facets (plain numpy).

A wall partner is treated as a plane: the bridge is the exact sphere-plane bridge of
:mod:`capbridge.solvers.sphere_wall` (the radius ratio -> infinity limit of the
doublet), with the sphere's radius R as the normalising length:

    d* = (|x_c - x_f| - R) / R,   V* = V / R^3,   F = F*(d*, V*) 2 pi gamma R,

where x_c is the sphere's centre and x_f the *foot*, the point of the partner closest
to x_c (:func:`closest_points`): on a ``Wall`` the perpendicular foot on its plane, on
a ``Box`` the closest point of the (oriented) box, on a ``Facet`` the closest point of
the triangle.  The force pulls the sphere towards the foot, along n = (x_c - x_f) /
|x_c - x_f| (attraction > 0); the opposite force acts on the partner body at the foot
(with its torque about the body's centre).  On a face this is exact; near a box edge or
a facet's rim the partner is taken as the plane through the foot perpendicular to n
(an approximation, of the order of the bridge's radius over the distance to the edge).

Liquid: walls carry no film.  A wall bridge forms when the sphere's gap to the partner
is <= the engine's formation gap, with

* the fixed rule: the engine's bridge volume (``bridge_volume``, or V* R^3 for
  ``bridge_volume_star``, R the sphere's radius);
* the conserving rule: ``film_fraction`` of the sphere's film (shared among the wall
  bridges the sphere forms in the same step), capped at the table's largest V*;
  refused below its smallest V*, and not tried again until that film has grown.

On rupture (gap > the table's rupture gap d*_rupt(V*, theta_s, theta_w), not Lian's
rule) the whole volume returns to the sphere's film (conserving rule) or leaves the
scene (fixed rule).  The wall's contact angle is the one the engine's ``theta`` gives
the wall body's material.

Lookup: :class:`WallTable` holds one exact table slice (:func:`~capbridge.solvers.
sphere_wall.sphere_wall_table`) per (theta_s, theta_w) pair on the doublet table's
volume axis and its s = sqrt(1 - d*/d*_rupt) axis; at formation a bridge gets its
rupture gap (cubic spline of log d*_rupt in log V*) and its force profile F*(s)
(cubic spline in log V*, then in s onto a uniform fine s grid); a step is then a
linear interpolation in s, as for the doublets.
"""
from __future__ import annotations

import time

import numpy as np

from capbridge.dimensionless import force_scale
from capbridge.surrogate.wall import N_FINE_S, SphereWallSurrogate, profile_value
from capbridge.validation import CapbridgeInputError

__all__ = ["WallSet", "WallTable", "WallBridges", "closest_points", "WALL_SHAPES"]

#: YADE shape classes that can hold a wall bridge, and their kind code
WALL_SHAPES = {"Wall": 0, "Box": 1, "Facet": 2}

_TABLE_CACHE: dict = {}


# ------------------------------------------------------------------------------------
# Geometry
# ------------------------------------------------------------------------------------


def _rot(q):
    """Rotation matrix of a minieigen Quaternion (as numpy)."""
    m = q.toRotationMatrix()
    return np.array([[m[r, c] for c in range(3)] for r in range(3)], float)


def _closest_on_triangles(p, a, b, c):
    """Closest point of triangles (a, b, c) to points p, all (k, 3): the projection on
    the plane when it falls inside, else the closest point of the three edges."""
    ab, ac = b - a, c - a
    nrm = np.cross(ab, ac)
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    q = p - np.einsum("ij,ij->i", p - a, nrm)[:, None] * nrm
    # barycentric coordinates of q
    v2 = q - a
    d00, d01, d11 = (np.einsum("ij,ij->i", x, y) for x, y in ((ab, ab), (ab, ac), (ac, ac)))
    d20, d21 = np.einsum("ij,ij->i", v2, ab), np.einsum("ij,ij->i", v2, ac)
    den = d00 * d11 - d01 * d01
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    inside = (v >= 0) & (w >= 0) & (v + w <= 1)
    best = q.copy()
    if not inside.all():
        out = ~inside
        cand = []
        for s, e in ((a, b), (b, c), (c, a)):
            s, e, pp = s[out], e[out], p[out]
            se = e - s
            t = np.clip(np.einsum("ij,ij->i", pp - s, se) / np.einsum("ij,ij->i", se, se), 0, 1)
            cand.append(s + t[:, None] * se)
        cand = np.stack(cand)                                   # (3, k_out, 3)
        dist = np.linalg.norm(cand - p[out][None], axis=2)
        best[out] = cand[dist.argmin(axis=0), np.arange(out.sum())]
    return best


class WallSet:
    """The wall partners of a scene: YADE bodies with a Wall, Box or Facet shape.

    Geometry is read from the bodies (position, orientation) at every :meth:`read`,
    so moving and rotating walls (a triaxial box, a rotating drum's facets) are
    followed.
    """

    def __init__(self, bodies, theta):
        self.ids = np.array([b.id for b in bodies], np.intp)
        self.kind = np.array([WALL_SHAPES[type(b.shape).__name__] for b in bodies], np.intp)
        self.theta = np.asarray(theta, float)
        m = self.ids.size
        self.axis = np.zeros(m, np.intp)
        self.sense = np.zeros(m)
        self.ext = np.zeros((m, 3))
        self.verts = np.zeros((m, 3, 3))                      # facet vertices, local
        for k, b in enumerate(bodies):
            sh = b.shape
            if self.kind[k] == 0:
                self.axis[k], self.sense[k] = int(sh.axis), float(sh.sense)
            elif self.kind[k] == 1:
                self.ext[k] = tuple(sh.extents)
            else:
                self.verts[k] = [tuple(v) for v in sh.vertices]
        self.pos = np.zeros((m, 3))
        self.rot = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
        # the farthest a point of each partner can be from its body's centre (motion bound)
        self.size = np.maximum(np.linalg.norm(self.ext, axis=1),
                               np.linalg.norm(self.verts, axis=2).max(axis=1))

    def read(self, O):
        """Positions and orientations of the partner bodies now."""
        for k, i in enumerate(self.ids.tolist()):
            st = O.bodies[i].state
            self.pos[k] = tuple(st.pos)
            if self.kind[k]:
                self.rot[k] = _rot(st.ori)

    def motion_since(self, pos0, rot0):
        """Largest displacement [m] of any point of any partner since (pos0, rot0)."""
        if pos0 is None:
            return np.inf
        dp = np.linalg.norm(self.pos - pos0, axis=1)
        dr = np.linalg.norm(self.rot - rot0, axis=(1, 2)) * self.size
        return float((dp + dr).max(initial=0.0))


def closest_points(walls, w, centre):
    """Foot of each sphere centre on its partner.

    Parameters
    ----------
    walls : WallSet (geometry read)
    w : (k,) partner indices;  centre : (k, 3) sphere centres [m].

    Returns
    -------
    foot (k, 3) [m], unit normal n (k, 3) from the foot to the centre, distance (k,) [m]
    (inf where no bridge can exist: the centre inside a box, or on the side of a
    one-sided ``Wall`` that does not interact).
    """
    w = np.asarray(w, np.intp)
    centre = np.asarray(centre, float)
    foot = centre.copy()
    kind = walls.kind[w]
    for code in np.unique(kind):
        sel = np.flatnonzero(kind == code)
        ws, c = w[sel], centre[sel]
        if code == 0:                                          # infinite plane
            ax = walls.axis[ws]
            f = c.copy()
            f[np.arange(sel.size), ax] = walls.pos[ws, ax]
        elif code == 1:                                        # oriented box
            R = walls.rot[ws]
            local = np.einsum("kji,kj->ki", R, c - walls.pos[ws])
            local = np.clip(local, -walls.ext[ws], walls.ext[ws])
            f = walls.pos[ws] + np.einsum("kij,kj->ki", R, local)
        else:                                                  # triangle
            R = walls.rot[ws]
            v = walls.pos[ws][:, None, :] + np.einsum("kij,kvj->kvi", R, walls.verts[ws])
            f = _closest_on_triangles(c, v[:, 0], v[:, 1], v[:, 2])
        foot[sel] = f
    diff = centre - foot
    dist = np.linalg.norm(diff, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = diff / dist[:, None]
    bad = ~(dist > 0)
    wall0 = kind == 0
    if wall0.any():                       # a one-sided Wall interacts on its sense side
        side = np.sign(diff[np.flatnonzero(wall0), walls.axis[w[wall0]]])
        sense = walls.sense[w[wall0]]
        bad[np.flatnonzero(wall0)] |= (sense != 0) & (side != sense)
    dist = np.where(bad, np.inf, dist)
    n[bad] = 0.0
    return foot, n, dist


# ------------------------------------------------------------------------------------
# Table
# ------------------------------------------------------------------------------------


class WallTable:
    """Exact sphere-wall slices for the (theta_s, theta_w) pairs of a scene.

    Parameters
    ----------
    pairs : (p, 2) contact angles [deg] (sphere, wall).
    volumes : V* nodes (the doublet table's volume axis, so that both bridge kinds
        accept the same V* range).
    n_s : s nodes of each slice (:func:`~capbridge.solvers.sphere_wall.default_s_axis`).

    A slice is solved when a bridge of its pair first forms (once per process, cached;
    4-15 s each on a shared 2-core machine) and must converge at every node, else the
    engine stops with an error (never a silent NaN force).  The lookup is the one of
    :class:`~capbridge.surrogate.wall.SphereWallSurrogate` (``surrogate``), fitted on
    these slices.
    """

    def __init__(self, pairs, volumes, n_s=25):
        self.volumes = np.asarray(volumes, float)
        self.vstar_range = (float(self.volumes[0]), float(self.volumes[-1]))
        self.n_s = int(n_s)
        self.surrogate = SphereWallSurrogate(n_fine_s=N_FINE_S)
        self.fine_s = np.linspace(0.0, 1.0, N_FINE_S)
        self.ensure(pairs)

    @property
    def pairs(self):
        """(p, 2) (theta_s, theta_w) of the slices held."""
        return self.surrogate.pairs_ if self.surrogate.__sklearn_is_fitted__() \
            else np.empty((0, 2))

    def ensure(self, pairs):
        """Solve the slices of the (theta_s, theta_w) ``pairs`` not held yet."""
        from capbridge.solvers.sphere_wall import sphere_wall_table

        for ts, tw in np.unique(np.asarray(pairs, float).reshape(-1, 2), axis=0):
            if np.any(np.all(np.abs(self.pairs - (ts, tw)) <= 1e-9, axis=1)):
                continue
            key = (float(ts), float(tw), tuple(self.volumes.tolist()), self.n_s)
            if key not in _TABLE_CACHE:
                _TABLE_CACHE[key] = sphere_wall_table(ts, tw, self.volumes, self.n_s)
            self.surrogate.partial_fit(_TABLE_CACHE[key])   # checks every node converged

    def slice_index(self, theta_s, theta_w):
        """Slice of each (theta_s, theta_w) pair (solved now if not held yet)."""
        t = np.column_stack([np.atleast_1d(theta_s), np.atleast_1d(theta_w)]).astype(float)
        self.ensure(t)
        return self.surrogate.slice_index(t[:, 0], t[:, 1])

    def profiles(self, slice_idx, vstar):
        """Rupture gap d*_rupt and force profile F* on :attr:`fine_s` of bridges of
        volume ``vstar`` in slices ``slice_idx``: ((k,), (k, N_FINE_S))."""
        return self.surrogate.profiles(slice_idx, vstar)

    def predict(self, gap_star, vstar, theta_s, theta_w):
        """F* at (d*, V*) for checks against the exact solver (0 beyond rupture); the
        statuses: :meth:`SphereWallSurrogate.predict <capbridge.surrogate.wall.
        SphereWallSurrogate.predict>`."""
        g, v = np.broadcast_arrays(np.asarray(gap_star, float), np.asarray(vstar, float))
        self.ensure([[theta_s, theta_w]])
        return self.surrogate.predict(g, v, theta_s, theta_w)["force"]


# ------------------------------------------------------------------------------------
# The wall bridges of a scene
# ------------------------------------------------------------------------------------


class WallBridges:
    """Bridges between the engine's spheres and the wall partners (see module doc).

    Parameters
    ----------
    model : :class:`~capbridge.dem.bridges.BridgeModel` (radii, films, liquid
        rule, formation gap, skin of the spheres).
    sphere_theta : (n,) contact angle of each sphere [deg].
    walls : :class:`WallSet`.
    """

    def __init__(self, model, sphere_theta, walls):
        self.model = model
        self.walls = walls
        ts = np.asarray(sphere_theta, float)
        pairs = np.array([(a, b) for a in np.unique(ts) for b in np.unique(walls.theta)])
        if pairs.size and (np.any(pairs[:, 0] >= 90) or np.any(pairs[:, 1] > 90)):
            raise CapbridgeInputError(
                f"wall bridges need a sphere contact angle in [0, 90) deg and a wall angle in "
                f"[0, 90] deg (got pairs {pairs.tolist()})")
        # slices are solved when a pair first forms a bridge (most sphere angles never
        # meet most wall angles)
        self.table = WallTable(np.empty((0, 2)), model.table.surrogate.volume_)
        self.theta_s = ts
        self._empty()
        self.ledger = {"formed_count": 0, "formed_volume": 0.0, "ruptured_count": 0,
                       "ruptured_volume": 0.0, "initial_count": 0, "initial_volume": 0.0,
                       "removed_volume": 0.0, "formations_short_of_liquid": 0}
        self.initialised = False
        self._ref = None                       # (sphere positions, wall pos, wall rot)
        self.cand_k = self.cand_w = np.empty(0, np.intp)
        # pairs refused for lack of liquid (key k * n_partners + w, sorted) and the
        # sphere's film then: tried again only once that film has grown
        self.ref_key, self.ref_film = np.empty(0, np.int64), np.empty(0)
        self.applied = {}                      # wall body id -> (force, torque) held
        self.last = None
        self.timings = {"updates": 0, "seconds": 0.0, "rebuilds": 0, "rebuild_seconds": 0.0}

    def _empty(self):
        e = np.empty(0, np.intp)
        f = np.empty(0)
        self.k, self.w = e, e.copy()           # sphere row, partner index
        self.vol, self.vstar, self.d_rupt, self.fscale = f, f.copy(), f.copy(), f.copy()
        self.rows = np.empty((0, N_FINE_S))

    @property
    def n_bridges(self):
        return int(self.k.size)

    @property
    def volume(self):
        return float(self.vol.sum())

    # ------------------------------------------------------------------ formation
    def _add(self, k, w, vol):
        R = self.model.radii[k]
        vstar = vol / R**3
        p = self.table.slice_index(self.theta_s[k], self.walls.theta[w])
        d_r, rows = self.table.profiles(p, vstar)
        self.k = np.concatenate([self.k, k])
        self.w = np.concatenate([self.w, w])
        self.vol = np.concatenate([self.vol, vol])
        self.vstar = np.concatenate([self.vstar, vstar])
        self.d_rupt = np.concatenate([self.d_rupt, d_r * R])
        self.fscale = np.concatenate([self.fscale, force_scale(R, self.model.gamma)])
        self.rows = np.vstack([self.rows, rows])

    def _remove(self, mask):
        keep = ~mask
        for name in ("k", "w", "vol", "vstar", "d_rupt", "fscale", "rows"):
            setattr(self, name, getattr(self, name)[keep])

    def _form(self, k, w):
        """New bridges on sphere rows k at partners w under the engine's liquid rule."""
        m = self.model
        R = m.radii[k]
        lo, hi = self.table.vstar_range
        if m.liquid.kind == "fixed":
            if m.liquid.bridge_volume_star is not None:
                vol = m.liquid.bridge_volume_star * R**3
            else:
                vol = np.full(k.size, float(m.fixed_volume))
            bad = (vol < lo * R**3 * (1 - 1e-12)) | (vol > hi * R**3 * (1 + 1e-12))
            if bad.any():
                raise CapbridgeInputError(
                    f"wall bridge volume {vol[bad][0]:.4g} m^3 on a sphere of radius "
                    f"{R[bad][0]:.4g} m gives V* = {vol[bad][0] / R[bad][0]**3:.4g}, outside the "
                    f"table's [{lo:g}, {hi:g}]")
            self._add(k, w, vol)
            return k.size, np.zeros(k.size, bool)
        n_new = np.bincount(k, minlength=m.n)
        want = m.liquid.film_fraction * m.films[k] / n_new[k]
        vol = np.minimum(want, hi * R**3)
        refused = ~(vol >= lo * R**3 * (1 + 1e-12))
        ok = ~refused
        if ok.any():
            np.subtract.at(m.films, k[ok], vol[ok])
            np.maximum(m.films, 0.0, out=m.films)        # round-off of the subtractions
            self._add(k[ok], w[ok], vol[ok])
        if refused.any():
            self._set_refused(self._keys(k[refused], w[refused]), m.films[k[refused]])
        self.ledger["formations_short_of_liquid"] += int(refused.sum())
        return int(ok.sum()), refused

    def _keys(self, k, w):
        return k.astype(np.int64) * self.walls.ids.size + w

    def _set_refused(self, keys, films):
        """Record refused pairs (a pair refused again gets its new film)."""
        keep = ~np.isin(self.ref_key, keys)
        key = np.concatenate([self.ref_key[keep], keys])
        film = np.concatenate([self.ref_film[keep], films])
        order = np.argsort(key)
        self.ref_key, self.ref_film = key[order], film[order]

    def _candidates(self, pos, reach):
        """Sphere-partner pairs within ``reach`` [m] of contact, without a bridge."""
        n, m = pos.shape[0], self.walls.ids.size
        kk, ww = [np.empty(0, np.intp)], [np.empty(0, np.intp)]     # no sphere left: none
        for start in range(0, n, 4096):                 # bounded memory
            k = np.repeat(np.arange(start, min(n, start + 4096)), m)
            w = np.tile(np.arange(m), k.size // m)
            _, _, dist = closest_points(self.walls, w, pos[k])
            near = dist - self.model.radii[k] <= reach
            kk.append(k[near]); ww.append(w[near])
        return np.concatenate(kk), np.concatenate(ww)

    # ------------------------------------------------------------------------ step
    def update(self, pos, O, first=False):
        """Rupture, form and compute the wall bridges at sphere centres ``pos`` (n, 3).

        Returns ``(forces, touched)``: the (n, 3) forces on the spheres [N] and the rows
        whose wall force changed (bridged now or ruptured now)."""
        t0 = time.perf_counter()
        m = self.model
        self.walls.read(O)
        touched = [self.k.copy()]
        geo = None
        if self.n_bridges:
            geo = closest_points(self.walls, self.w, pos[self.k])
            broken = geo[2] - m.radii[self.k] > self.d_rupt
            if broken.any():
                self._rupture(broken)
                geo = tuple(a[~broken] for a in geo)
        # Verlet list of candidate pairs (skin = the spheres' skin)
        skin = m.skin
        moved = np.inf if self._ref is None or self._ref[0].shape != pos.shape else float(
            np.linalg.norm(pos - self._ref[0], axis=1).max(initial=0.0))
        if moved + self.walls.motion_since(*(self._ref[1:] if self._ref else (None, None))) \
                > 0.5 * skin:
            t_r = time.perf_counter()
            self.cand_k, self.cand_w = self._candidates(pos, skin + m.formation_gap)
            self._ref = (pos.copy(), self.walls.pos.copy(), self.walls.rot.copy())
            self.timings["rebuilds"] += 1
            self.timings["rebuild_seconds"] += time.perf_counter() - t_r
        reach = max(m.formation_gap, m.initial_wet_gap) if first else m.formation_gap
        n0 = self.n_bridges
        if self.cand_k.size:
            ckey = self._keys(self.cand_k, self.cand_w)
            free = ~np.isin(ckey, self._keys(self.k, self.w))
            if self.ref_key.size:
                # a refused pair is tried again only once its sphere's film has grown
                i = np.clip(np.searchsorted(self.ref_key, ckey), 0, self.ref_key.size - 1)
                was = np.where(self.ref_key[i] == ckey, self.ref_film[i], -1.0)
                free &= m.films[self.cand_k] > was
            ck, cw = self.cand_k[free], self.cand_w[free]
            if ck.size:
                _, _, dist = closest_points(self.walls, cw, pos[ck])
                go = dist - m.radii[ck] <= reach
                if go.any():
                    made, _ = self._form(ck[go], cw[go])
                    if self.ref_key.size:
                        keep = ~np.isin(self.ref_key, self._keys(self.k[n0:], self.w[n0:]))
                        self.ref_key, self.ref_film = self.ref_key[keep], self.ref_film[keep]
                    vol_new = float(self.vol[n0:].sum())
                    key = "initial" if first else "formed"
                    self.ledger[f"{key}_count"] += int(made)
                    self.ledger[f"{key}_volume"] += vol_new
        m.wall_volume = self.volume if m.liquid.kind == "conserved" else 0.0
        # forces: F = F*(s) 2 pi gamma R, s = sqrt(1 - gap/d_rupt), towards the foot
        forces = np.zeros((m.n, 3))
        if self.n_bridges:
            if self.n_bridges > n0:               # new bridges: their feet too
                new = closest_points(self.walls, self.w[n0:], pos[self.k[n0:]])
                geo = new if geo is None or n0 == 0 else tuple(
                    np.concatenate([a, b]) for a, b in zip(geo, new))
            foot, nrm, dist = geo
            gap = dist - m.radii[self.k]
            f = profile_value(self.rows, gap / self.d_rupt) * self.fscale
            fv = -nrm * f[:, None]
            np.add.at(forces, self.k, fv)
            self.last = {"foot": foot, "n": nrm, "gap": gap, "force": f, "fvec": fv}
        else:
            self.last = None
        touched.append(self.k)
        self.timings["updates"] += 1
        self.timings["seconds"] += time.perf_counter() - t0
        return forces, np.unique(np.concatenate(touched))

    def _rupture(self, mask):
        m = self.model
        k, v = self.k[mask], self.vol[mask]
        self.ledger["ruptured_count"] += int(mask.sum())
        self.ledger["ruptured_volume"] += float(v.sum())
        if m.liquid.kind == "conserved":
            np.add.at(m.films, k, v)                  # all of it back to the sphere
            m._release_refused(k)
        self._remove(mask)

    def reaction(self):
        """(wall body ids, forces (m, 3) [N], torques (m, 3) [N m] about the bodies'
        centres) of the bridges on their partners: equal and opposite to the spheres',
        acting at the foot."""
        m = self.walls.ids.size
        F, T = np.zeros((m, 3)), np.zeros((m, 3))
        if self.last is not None:
            fw = -self.last["fvec"]
            np.add.at(F, self.w, fw)
            np.add.at(T, self.w, np.cross(self.last["foot"] - self.walls.pos[self.w], fw))
        return self.walls.ids, F, T

    def apply_reaction(self, O, hold):
        """Hand the reaction to YADE: ``addF``/``addT`` every step, or (``hold``: the
        engine holds its forces between updates) as our share of the permanent force,
        the user's kept."""
        ids, F, T = self.reaction()
        if not hold:
            for i, f, t in zip(ids.tolist(), F.tolist(), T.tolist()):
                if any(f):
                    O.forces.addF(i, f)
                    O.forces.addT(i, t)
            return
        used = O.forces.getPermForceUsed()
        for i, f, t in zip(ids.tolist(), F.tolist(), T.tolist()):
            old_f, old_t = self.applied.get(i, ((0.0,) * 3, (0.0,) * 3))
            if old_f == tuple(f) and old_t == tuple(t):
                continue
            pf = np.array(tuple(O.forces.permF(i))) if used else np.zeros(3)
            pt = np.array(tuple(O.forces.permT(i))) if used else np.zeros(3)
            O.forces.setPermF(i, tuple(pf - old_f + f))
            O.forces.setPermT(i, tuple(pt - old_t + t))
            self.applied[i] = (tuple(f), tuple(t))

    def drop_spheres(self, gone):
        """Spheres (rows, mask over the old rows) erased from the scene: their wall
        bridges leave with them (their liquid is counted as removed); returns nothing,
        remaps the rows."""
        gone = np.asarray(gone, bool)
        hit = gone[self.k]
        if hit.any():
            self.ledger["removed_volume"] += float(self.vol[hit].sum())
            if self.model.liquid.kind == "conserved":
                self.model.ledger["removed_volume"] += float(self.vol[hit].sum())
            self._remove(hit)
        new = np.where(~gone, np.cumsum(~gone) - 1, -1)
        self.k = new[self.k]
        self.theta_s = self.theta_s[~gone]
        self._ref = None
        self.ref_key, self.ref_film = np.empty(0, np.int64), np.empty(0)

    # ----------------------------------------------------------------- reporting
    def summary(self):
        """Counts, volumes and the ledger of the wall bridges."""
        out = dict(self.ledger)
        out.update(n_bridges=self.n_bridges, volume=self.volume, n_partners=int(self.walls.ids.size),
                   timings=dict(self.timings), candidates=int(self.cand_k.size),
                   total_force=float(self.last["force"].sum()) if self.last is not None else 0.0)
        if self.model.liquid.kind == "fixed":
            exp = out["initial_volume"] + out["formed_volume"] - out["ruptured_volume"] \
                - out["removed_volume"]
            from capbridge.dem.bridges import balance_error

            out["balance_error"] = balance_error(self.volume, exp, out["initial_volume"]
                                                 + out["formed_volume"])
        return out

    def records(self, ids):
        """Per-bridge arrays for output: sphere body id, wall body id, ends (k, 2, 3)
        (sphere centre, foot), volume, force vector on the sphere, gap."""
        if self.last is None or self.n_bridges == 0:
            return None
        centre = self.last["foot"] + self.last["n"] * (self.last["gap"] + self.model.radii[self.k])[:, None]
        return {"id1": ids[self.k], "id2": self.walls.ids[self.w],
                "ends": np.stack([centre, self.last["foot"]], axis=1), "volume": self.vol.copy(),
                "force": self.last["fvec"].copy(), "gap": self.last["gap"].copy()}

    # ----------------------------------------------------------------- save / load
    def get_state(self):
        return {"k": self.k.copy(), "w": self.w.copy(), "vol": self.vol.copy(),
                "wall_ids": self.walls.ids.copy(), "ledger": dict(self.ledger),
                "initialised": self.initialised,
                "ref_key": self.ref_key.copy(), "ref_film": self.ref_film.copy(),
                "applied": [[i, list(f), list(t)] for i, (f, t) in self.applied.items()]}

    def set_state(self, st):
        if not np.array_equal(np.asarray(st["wall_ids"], np.intp), self.walls.ids):
            raise ValueError("saved wall bridges are for other wall bodies than the scene's")
        self._empty()
        k = np.asarray(st["k"], np.intp)
        if k.size:
            self._add(k, np.asarray(st["w"], np.intp), np.asarray(st["vol"], float))
        self.ledger = dict(st["ledger"])
        self.initialised = bool(st["initialised"])
        self.ref_key = np.asarray(st["ref_key"], np.int64)
        self.ref_film = np.asarray(st["ref_film"], float)
        # YADE drops permanent forces on load: nothing of ours is held any more
        self.applied = {}
        self._ref = None
        self.model.wall_volume = self.volume if self.model.liquid.kind == "conserved" else 0.0


def wall_bodies(O, wanted=True):
    """The scene's bodies that can hold a wall bridge: every Wall, Box and Facet body
    (``wanted=True``), none (False) or those of the given ids."""
    if wanted is False or wanted is None:
        return []
    if wanted is True:
        return [b for b in O.bodies if b is not None and type(b.shape).__name__ in WALL_SHAPES]
    out = []
    for i in wanted:
        b = O.bodies[int(i)] if 0 <= int(i) < len(O.bodies) else None
        if b is None or type(b.shape).__name__ not in WALL_SHAPES:
            raise CapbridgeInputError(f"walls: body {i} is not a Wall, Box or Facet")
        out.append(b)
    return out



