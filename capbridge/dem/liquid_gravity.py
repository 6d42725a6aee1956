"""Gravity on the liquid of the bridges, for :class:`~capbridge.yade.engine.CapbridgeEngine`.

Plain numpy (YADE is only touched by :func:`newton_gravity`, which reads the scene's
``NewtonIntegrator.gravity``).

Physics
-------
The liquid of a bridge of volume V weighs drho g V (drho = rho_liquid - rho_gas, g the
gravity vector of the scene) and the two grains carry it.  In capbridge's units
(lengths / r, r the smaller radius of the pair; F* = F / (2 pi gamma r)) gravity enters
as b = Bo g_hat, Bo = drho |g| r^2 / gamma, and with n the unit vector from grain 1 (the
smaller) to grain 2, b_n = b . n, b_perp = b - b_n n, W = V*/(2 pi)
(:func:`capbridge.physics.gravity.doublet_gravity_forces`):

    F1 = F0 n + W [w b_n n + u b_perp] + c b_n^2 n / 2
    F2 = -F0 n - c b_n^2 n / 2 + W [(1 - w) b_n n + (1 - u) b_perp]

F0 n, -F0 n are the zero-gravity forces the engine already applies; this module adds the
rest.  In SI the part added on the two grains sums to drho V g exactly (the liquid's
weight rides on the grains); for equal grains and angles each carries drho V g / 2.

w = u = 1/2 is exact for equal grains and angles (mirror symmetry).  When the doublet
table carries its gravity response (``weight_share_axial``,
``force_gravity_curvature_axial``, ``weight_share_transverse``) w, c and u are the
table's at each bridge's (ratio, theta, V*, s) (:meth:`LiquidGravity.response`; bridges
of two different angles keep 1/2, 0, 1/2); a table without it gives w = u = 1/2 and
c = 0 for every bridge (:data:`SHARE_AXIAL`, :data:`CURVATURE_AXIAL`).  The bridge's
rupture distance stays the zero-gravity one.

When is it worth it
-------------------
The gravity part on a grain relative to the capillary attraction is about

    epsilon = Bo V* / (4 pi F*)

(the first-order part; the second-order |c| Bo^2 / (2 F*) is left out of the decision:
c depends on the gap, and it is smaller except near rupture).

With F* the smallest attraction of the bridge's profile over s = sqrt(1 - d*/d*_rupt)
>= 0.2 (:data:`ERROR_BAND`, d* <= 0.96 d*_rupt) this is the largest relative correction
the bridge can have in its life there (its volume is fixed, so a bridge's decision does
not change while it lives).  It is compared with the doublet table's own error over the
same band: the largest of its held-out median relative force errors
(``holdout_median_rel_error_force_ratio*_band0.2`` attributes, the surrogate against the
exact solver at random points; 5.1e-5 to 6.1e-5 in the shipped table), or 1e-3 when the
table has none (:data:`FALLBACK_TABLE_ERROR`).  With
``gravity_correction="auto"`` a bridge gets the correction when its epsilon exceeds that
error; the scene-level decision printed at start-up takes the largest epsilon over the
bridges present and the bridges the liquid rule can make between the scene's radii.

References
----------
Miot et al. (2021), Granular Matter 23:66, section 3.4 (gravity on the liquid bridge).
"""
from __future__ import annotations

import math

import numpy as np

from capbridge.status import Status
from capbridge.surrogate.base import has_number
from capbridge.surrogate.doublet import BOND_MAX
from capbridge.surrogate.grid import FineAxis, rows_linear
from capbridge.dem.bridges import ERROR_BAND, distinct_values
from capbridge.physics.gravity import doublet_gravity_forces
from capbridge.validation import CapbridgeInputError

__all__ = ["DEFAULT_LIQUID_DENSITY", "FALLBACK_TABLE_ERROR", "GRAVITY_MODES", "ERROR_BAND",
           "SHARE_AXIAL", "CURVATURE_AXIAL", "BOND_RANGE", "triplet_table_has_gravity",
           "newton_gravity", "check_gravity", "table_error", "relative_correction", "bridge_gravity_forces",
           "LiquidGravity"]

#: Density difference water - air at 20 C [kg/m^3] (998.2 - 1.2).
DEFAULT_LIQUID_DENSITY = 997.0
#: Table error assumed when the doublet table carries no held-out error [-].
FALLBACK_TABLE_ERROR = 1e-3
#: Largest Bond number of the surrogates' range (tables and Evolver checks: Bo 0 to 2.5).
BOND_RANGE = BOND_MAX
#: Values of the engine's ``gravity_correction``.
GRAVITY_MODES = ("auto", "on", "off")
#: First-order share of the weight on the smaller grain, gravity along the axis, when
#: the doublet table has no ``weight_share_axial`` (exact
#: 1/2 for equal grains and angles only).  With it: :meth:`LiquidGravity.response`.
SHARE_AXIAL = 0.5
#: d2F*/db_n^2 of the attraction when the doublet table has no
#: ``force_gravity_curvature_axial`` (second order; 0 when the table has none).
CURVATURE_AXIAL = 0.0


def newton_gravity(O):
    """Gravity vector [m/s^2] of the scene: ``gravity`` of the first
    ``NewtonIntegrator`` in ``O.engines``; zeros when there is none.

    Parameters
    ----------
    O : yade.Omega

    Returns
    -------
    ndarray (3,)
    """
    for e in O.engines:
        if type(e).__name__ == "NewtonIntegrator":
            return np.array([float(x) for x in e.gravity])
    return np.zeros(3)


def table_error(surrogate):
    """The doublet table's own force error, for the gravity decision.

    Parameters
    ----------
    surrogate : DoubletSurrogate (fitted) or xarray.Dataset

    Returns
    -------
    (float, str)
        The largest held-out *median* relative force error over the table's ratio
        checks with the band s >= 0.2 (``holdout_median_rel_error_force_ratio*_band0.2``),
        and where it comes from; :data:`FALLBACK_TABLE_ERROR` if there is none.
    """
    ds = getattr(surrogate, "table_", surrogate)
    attrs = getattr(ds, "attrs", {}) or {}
    vals = [float(v) for k, v in attrs.items()
            if k.startswith("holdout_median_rel_error_force_") and k.endswith("_band0.2")]
    vals = [v for v in vals if math.isfinite(v)]
    if vals:
        return max(vals), (f"largest held-out median force error of the doublet table, "
                          f"{len(vals)} ratios")
    return FALLBACK_TABLE_ERROR, ("1e-3 assumed: the doublet table has no held-out error")


def triplet_table_has_gravity(path):
    """True if the triplet table at ``path`` carries a gravity response
    (``force_gravity_gradient``); reads the file's metadata only."""
    import xarray as xr

    try:
        with xr.open_dataset(path) as ds:
            return "force_gravity_gradient" in ds
    except (OSError, ValueError):
        return False


def relative_correction(bond, vstar, fstar):
    """Size of the first-order gravity part of a grain's force relative to the
    attraction (the decision's measure; the second order is left out, see the module
    docstring).

    epsilon = Bo V* / (4 pi F*)

    Parameters
    ----------
    bond : array_like
        Bo = drho g r^2 / gamma of the bridge (r its smaller radius) [-].
    vstar : array_like
        V* = V / r^3 [-].
    fstar : array_like
        Attraction F* = F / (2 pi gamma r) [-] (> 0; floored at 1e-12).

    Returns
    -------
    ndarray

    >>> round(float(relative_correction(2.0, 0.1, 1.0)), 6)
    0.015915
    """
    bo = np.asarray(bond, float)
    f = np.maximum(np.asarray(fstar, float), 1e-12)
    return bo * np.asarray(vstar, float) / (4.0 * np.pi * f)


def bridge_gravity_forces(d, dist, r_i, r_j, vstar, fscale, g_vec, drho, gamma,
                          share=SHARE_AXIAL, curvature=CURVATURE_AXIAL,
                          share_transverse=SHARE_AXIAL):
    """Gravity part of the forces of bridges on their two grains [N].

    Parameters
    ----------
    d : (m, 3) centre-to-centre vectors from grain i to grain j [m].
    dist : (m,) their lengths [m].
    r_i, r_j : (m,) radii of grains i and j [m].
    vstar : (m,) V* = V / r^3, r = min(r_i, r_j).
    fscale : (m,) 2 pi gamma r [N].
    g_vec : (3,) gravity vector [m/s^2].
    drho : density difference liquid - gas [kg/m^3].
    gamma : surface tension [N/m].
    share, curvature, share_transverse : (m,) or scalar
        w, c and u of each bridge (:data:`SHARE_AXIAL`, :data:`CURVATURE_AXIAL`,
        :data:`SHARE_AXIAL` by default).

    Returns
    -------
    (f_i, f_j) : (m, 3) each
        The parts of :func:`~capbridge.physics.gravity.doublet_gravity_forces` beyond
        the zero-gravity attraction, in N; f_i + f_j = drho V g.
    """
    g_vec = np.asarray(g_vec, float)
    g = float(np.linalg.norm(g_vec))
    rs = np.minimum(r_i, r_j)
    bond = drho * g * rs**2 / gamma
    b = bond[:, None] * (g_vec / g)[None, :]
    n = d / dist[:, None]
    i_small = r_i <= r_j
    n1 = np.where(i_small[:, None], n, -n)          # from the smaller grain to the other
    f1, f2 = doublet_gravity_forces(0.0, n1, vstar, b, share, curvature, share_transverse)
    f1 *= fscale[:, None]
    f2 *= fscale[:, None]
    return np.where(i_small[:, None], f1, f2), np.where(i_small[:, None], f2, f1)


def check_gravity(g):
    """The gravity vector [m/s^2] of the scene's ``NewtonIntegrator``, checked: three
    finite components (a NaN would end deep in the gravity lookup)."""
    g = np.asarray(g, float)
    if g.shape != (3,) or not np.all(np.isfinite(g)):
        raise CapbridgeInputError(
            f"NewtonIntegrator.gravity={tuple(g.ravel().tolist())!r} is not a vector of "
            "three finite numbers [m/s^2]: the engine reads it for the liquid's weight")
    return g


class LiquidGravity:
    """Gravity on the liquid of an engine's bridges: decision, forces, state.

    Parameters
    ----------
    mode : {"auto", "on", "off"}
        "auto": a bridge gets the correction when its largest relative correction
        (:func:`relative_correction` at the smallest attraction of its profile over
        s >= :data:`ERROR_BAND`) exceeds the table's error; "on": every bridge;
        "off": none.
    drho : float
        Density difference liquid - gas [kg/m^3].
    gamma : float
        Surface tension [N/m].
    """

    def __init__(self, mode, drho, gamma):
        self.mode = mode
        self.drho = float(drho)
        self.gamma = float(gamma)
        self.g = None                       # gravity vector of the last decision
        self.applied = False
        self.eps = None
        self.eps_source = ""
        self.summary = {}
        self.n_corrected = 0
        self.clusters_on = False            # clusters get the triplet table's response
        self.doublet_response = False       # w, c from the doublet table
        self._profiles = None               # w, u, c of each pool slot along gravity_s

    # --------------------------------------------------------------- decision
    def _rule_bridges(self, model):
        """Bridges the liquid rule can make between the scene's radii: (r_small,
        ratio, V*) of pairs of distinct radii (the smallest and largest only beyond
        four radii), volumes clipped to the table's range."""

        rad = distinct_values(model.radii)
        if rad.size == 0:                   # every wet grain erased: no bridge to make
            return np.empty(0), np.empty(0), np.empty(0)
        if rad.size > 4:
            rad = rad[[0, -1]]
        a, b = np.meshgrid(rad, rad, indexing="ij")
        keep = a <= b
        rs, rl = a[keep], b[keep]
        L = model.liquid
        lo, hi = model.table.vstar_range
        if L.bridge_volume_star is not None:
            v = np.full(rs.size, float(L.bridge_volume_star))
        elif model.fixed_volume is not None:
            v = float(model.fixed_volume) / rs**3
        elif L.total_liquid is not None:
            # a first bridge between two grains of uniform water content
            film = float(L.total_liquid) / float((model.radii**3).sum())
            v = L.film_fraction * film * (rs**3 + rl**3) / rs**3
        else:
            return np.empty(0), np.empty(0), np.empty(0)
        v = np.minimum(v, hi)
        ok = v >= lo
        return rs[ok], (rl / rs)[ok], v[ok]

    def estimate(self, model, g):
        """Largest relative correction over the bridges present and those the rule
        can make (every angle slice of the scene), at gravity ``g`` [m/s^2]."""
        gn = float(np.linalg.norm(g))
        rel = [0.0]
        if model.n_bridges:
            bo = self.drho * gn * model.rsmall**2 / self.gamma
            rel.append(float(relative_correction(bo, model.vstar, model.fstar_min).max()))
        rs, ratio, v = self._rule_bridges(model)
        slices = np.unique(model.pair_slice[model.pair_slice >= 0])
        if rs.size and slices.size:
            S, K = np.meshgrid(slices, np.arange(rs.size), indexing="ij")
            S, K = S.ravel(), K.ravel()
            tab = model.table
            c = tab.bridge_constants(S, ratio[K], v[K])
            fmin = tab.rows("force", c)[:, tab.s_axis.nodes >= ERROR_BAND].min(axis=1)
            bo = self.drho * gn * rs[K]**2 / self.gamma
            rel.append(float(relative_correction(bo, v[K], fmin).max()))
        return max(rel)

    def decide(self, model, g, why="start-up", *, triplet_table=None, walls=False):
        """Decide for the scene at gravity ``g``; returns the line to print.

        Parameters
        ----------
        model : BridgeModel
            The scene's bridges and grains.
        g : (3,) gravity vector [m/s^2].
        why : str
            What made the decision (in the line).
        triplet_table : path or None
            The triplet table when coalesced triplets get its forces
            (``triplet_forces=True``), else None: with a gravity response there, the
            liquid clusters get it (:meth:`cluster_gravity`).
        walls : bool
            True when the scene has wall bridges (the line says they carry no gravity).
        """
        self.g = np.array(g, float)
        gn = float(np.linalg.norm(self.g))
        if self.eps is None:
            self.eps, self.eps_source = table_error(model.table.surrogate)
        sur = model.table.surrogate
        self.doublet_response = bool(getattr(sur, "has_gravity_", False))
        r_max = float(model.radii.max(initial=0.0))
        bo_max = self.drho * gn * r_max**2 / self.gamma
        rel = self.estimate(model, self.g) if gn > 0 else 0.0
        nums = (f"Bo of the largest grain (R = {r_max:.4g} m) {bo_max:.4g}, largest relative "
                f"correction {rel:.3g}, table error {self.eps:.3g} ({self.eps_source})")
        if gn == 0.0:
            self.applied, what = False, "none: NewtonIntegrator.gravity is zero or absent"
        elif self.mode == "off":
            self.applied, what = False, "off (gravity_correction='off')"
        elif self.mode == "on":
            self.applied, what = True, "applied to every bridge (gravity_correction='on')"
        elif rel > self.eps:
            self.applied, what = True, ("applied to each bridge whose relative correction "
                                        "exceeds the table error (gravity_correction='auto')")
        else:
            self.applied, what = False, ("skipped: the largest relative correction is below "
                                         "the table error (gravity_correction='auto')")
        self.summary = {"applied": self.applied, "mode": self.mode, "bond_largest": bo_max,
                        "largest_relative_correction": rel, "table_error": self.eps,
                        "gravity": self.g.tolist(), "liquid_density": self.drho}
        extra = "" if not self.applied else (
            "; weight shares w, u and curvature c from the doublet table's gravity response "
            "(equal angles; w = u = 1/2, c = 0 for mixed angles)" if self.doublet_response
            else "; w = u = 1/2, c = 0 (the doublet table has no gravity response)")
        self.clusters_on = False
        if self.applied and triplet_table is not None:
            self.clusters_on = triplet_table_has_gravity(triplet_table)
            extra += ("; liquid clusters of coalesced triplets get the triplet table's "
                      "gravity response" if self.clusters_on else
                      "; liquid clusters of coalesced triplets keep their zero-gravity "
                      "forces (the triplet table has no gravity response)")
        walls = "; wall bridges carry no gravity" if walls else ""
        high = (f"; Bo {bo_max:.3g} is beyond the range Bo <= {BOND_RANGE:g} of capbridge's "
                "gravity checks" if self.applied and bo_max > BOND_RANGE else "")
        return (f"gravity on the liquid ({why}, g = {self.g.tolist()} m/s^2, drho = "
                f"{self.drho:g} kg/m^3): {what}; {nums}{extra}{walls}{high}")

    # ----------------------------------------------------------------- forces
    def refresh(self, g, model, it, *, triplet_table=None, walls=False):
        """Decide at the first call and whenever the scene's gravity ``g`` (its
        :func:`newton_gravity`, at iteration ``it``) changed; ``triplet_table`` and
        ``walls`` as for :meth:`decide`.

        Returns
        -------
        (level, line) or None
            The log level ("info" at the start, "warning" for a change) and the line of
            a new decision; None when the decision stands.
        """
        if self.g is not None and np.array_equal(g, self.g):
            return None
        check_gravity(g)                    # a NaN would end deep in the lookup
        start = self.g is None
        line = self.decide(model, g, "start-up" if start else f"gravity changed at iter {it}",
                           triplet_table=triplet_table, walls=walls)
        return ("info" if start else "warning"), line

    def cluster_gravity(self):
        """(g [m/s^2], drho [kg/m^3]) for the liquid clusters when the correction is
        applied and the triplet table has a gravity response, else None."""
        if self.applied and self.clusters_on:
            return self.g.copy(), self.drho
        return None

    def grain_forces(self, model, geom, exclude=None, *, holds_forces=False,
                     force_tolerance=0.0):
        """Gravity parts on the grains [N] (n, 3) for this refresh (after
        :meth:`refresh`), and the rows of grains whose held part changed (for held
        forces), or ``(None, None)`` when nothing is or was applied.

        Parameters
        ----------
        model : BridgeModel
        geom : the bridges' geometry of this refresh (``BridgeModel.update``).
        exclude : rows of bridges merged into a liquid cluster (they get none), or None.
        holds_forces : bool
            False: the parts are added every step (all of them returned, no rows);
            True: held as permanent forces, a grain's part handed out again when it
            moved by more than ``force_tolerance`` of its size.

        What is handed out is kept in the bridge model's ``gravity_held`` (saved with
        it, part of ``held_grain_forces``)."""
        n = model.n
        if model.gravity_held.shape[0] != n:
            model.gravity_held = np.zeros((n, 3))
        held = model.gravity_held
        if not self.applied or model.n_bridges == 0:
            self.n_corrected = 0
            if not held.any():
                return None, None
            new = np.zeros((n, 3))
        else:
            use = np.ones(model.n_bridges, bool)
            if exclude is not None and exclude.size:
                use[exclude] = False
            if self.mode == "auto":
                bo = self.drho * float(np.linalg.norm(self.g)) * model.rsmall**2 / self.gamma
                use &= relative_correction(bo, model.vstar, model.fstar_min) > self.eps
            k = np.flatnonzero(use)
            self.n_corrected = int(k.size)
            if self.doublet_response is None:
                self.doublet_response = bool(model.table.surrogate.has_gravity_)
            w, c, u = (self.response(model, geom, k) if self.doublet_response
                       else (SHARE_AXIAL, CURVATURE_AXIAL, SHARE_AXIAL))
            fi, fj = bridge_gravity_forces(geom["d"][k], geom["dist"][k],
                                           model.radii[model.bi[k]], model.radii[model.bj[k]],
                                           model.vstar[k], model.fscale[k], self.g, self.drho,
                                           self.gamma, w, c, u)
            xyz = np.arange(3)
            new = (np.bincount((3 * model.bi[k, None] + xyz).ravel(), fi.ravel(),
                               minlength=3 * n)
                   + np.bincount((3 * model.bj[k, None] + xyz).ravel(), fj.ravel(),
                                 minlength=3 * n)).reshape(n, 3)
        if not holds_forces:
            model.gravity_held = new
            return new, None
        diff = new - held
        tol = force_tolerance
        # a grain's part is handed out again when it moved by more than the tolerance
        # (any change with tolerance 0, refresh_every > 1); a part that drops to zero
        # always is
        upd = np.einsum("ij,ij->i", diff, diff) > (tol * tol) * np.einsum("ij,ij->i", new, new)
        held[upd] = new[upd]
        return held.copy(), np.flatnonzero(upd)

    def response(self, model, geom, k):
        """w, c and u of bridges ``k`` at their current gaps from the doublet table's
        gravity response (``weight_share_axial``, ``force_gravity_curvature_axial``,
        ``weight_share_transverse``, as ``DoubletSurrogate.gravity_response`` at (ratio,
        theta, V*, s)).  Bridges of two different angles (the table has equal angles)
        and points where the response has no number keep w = u = 1/2, c = 0.

        A bridge's ratio, angle and V* do not change while it lives: its w, u, c are
        looked up once, on the nodes of the response's s axis (:meth:`_profiles_for`),
        and each refresh interpolates them linearly in s (the grid kernel,
        :mod:`capbridge.surrogate.grid`), which is the surrogate's multilinear
        interpolation with the other coordinates fixed."""
        w = np.full(k.size, SHARE_AXIAL)
        c = np.full(k.size, CURVATURE_AXIAL)
        u = np.full(k.size, SHARE_AXIAL)
        bi, bj = model.bi[k], model.bj[k]
        ri, rj = model.radii[bi], model.radii[bj]
        small, large = np.where(ri <= rj, bi, bj), np.where(ri <= rj, bj, bi)
        same = np.flatnonzero(np.abs(model.theta[small] - model.theta[large]) <= 1e-9)
        if not same.size:
            return w, c, u
        kk = k[same]
        prof, code, s_axis = self._profiles_for(model, kk)
        s = np.sqrt(np.clip(1.0 - geom["gap"][kk] / model.d_rupt_si[kk], 0.0, 1.0))
        # s outside the nodes: the end node's value
        j, t = s_axis.locate(np.clip(s, s_axis.lo, s_axis.hi))
        val = rows_linear(prof, j, t)
        rows = np.arange(kk.size)
        ok = has_number(code[rows, j]) & has_number(code[rows, j + 1]) & \
            np.isfinite(val).all(-1)
        w[same[ok]], u[same[ok]], c[same[ok]] = val[ok, 0], val[ok, 1], val[ok, 2]
        return w, c, u

    def _profiles_for(self, model, kk):
        """(w, u, c) on the response's s nodes for bridges ``kk`` (m, n_s, 3), the
        surrogate's code at each node (m, n_s) and the s axis (a
        :class:`~capbridge.surrogate.grid.FineAxis` on the nodes).  Kept by the bridge
        model's pool slot, with the bridge's key and V* it was made for: derived state,
        remade after a load or when a slot changes hands."""
        sur = model.table.surrogate
        if self._profiles is None:
            s_nodes = np.asarray(sur.table_["gravity_s"].values, float)
            # refine=1: the nodes themselves (not uniform: located by an index map)
            self._profiles = {"s": s_nodes, "s_axis": FineAxis(s_nodes, 1),
                              "key": np.full(0, -1, np.int64),
                              "vstar": np.zeros(0), "val": np.zeros((0, s_nodes.size, 3)),
                              "code": np.zeros((0, s_nodes.size), np.int8)}
        P = self._profiles
        n_slots, ns = model.pool.shape[0], P["s"].size
        if P["key"].size < n_slots:                       # the pool grew
            grow = n_slots - P["key"].size
            P["key"] = np.concatenate([P["key"], np.full(grow, -1, np.int64)])
            P["vstar"] = np.concatenate([P["vstar"], np.zeros(grow)])
            P["val"] = np.concatenate([P["val"], np.zeros((grow, ns, 3))])
            P["code"] = np.concatenate([P["code"], np.full((grow, ns), Status.NOT_COMPUTED,
                                                           np.int8)])
        slot = model.slot[kk]
        stale = (P["key"][slot] != model.keys[kk]) | (P["vstar"][slot] != model.vstar[kk])
        if stale.any():
            new = kk[stale]
            ri, rj = model.radii[model.bi[new]], model.radii[model.bj[new]]
            small = np.where(ri <= rj, model.bi[new], model.bj[new])
            m = new.size
            r = sur.gravity_response(np.repeat(np.maximum(ri, rj) / np.minimum(ri, rj), ns),
                                     np.repeat(model.theta[small], ns),
                                     np.repeat(model.vstar[new], ns), np.tile(P["s"], m))
            sl = slot[stale]
            P["val"][sl] = np.stack([r["share"], r["share_transverse"], r["curvature"]],
                                    -1).reshape(m, ns, 3)
            P["code"][sl] = r["status"].reshape(m, ns)
            P["key"][sl], P["vstar"][sl] = model.keys[new], model.vstar[new]
        return P["val"][slot], P["code"][slot], P["s_axis"]

    # ------------------------------------------------------------------ state
    def get_state(self):
        """The decision, for ``O.tags`` (see ``state_io``; the gravity forces last
        handed out are the bridge model's ``gravity_held``)."""
        return {"mode": self.mode, "drho": self.drho,
                "g": None if self.g is None else self.g.tolist(),
                "applied": bool(self.applied), "clusters_on": bool(self.clusters_on),
                "doublet_response": bool(self.doublet_response),
                "eps": self.eps, "eps_source": self.eps_source,
                "summary": dict(self.summary)}

    def set_state(self, st):
        """Inverse of :meth:`get_state`."""
        self.mode = st["mode"]
        self.drho = float(st["drho"])
        self.g = None if st["g"] is None else np.array(st["g"], float)
        self.applied = bool(st["applied"])
        self.clusters_on = bool(st.get("clusters_on", False))
        # a state saved before this key: what the table says, at the first refresh
        self.doublet_response = st.get("doublet_response")
        self.eps = st["eps"]
        self.eps_source = st["eps_source"]
        self.summary = dict(st["summary"])
