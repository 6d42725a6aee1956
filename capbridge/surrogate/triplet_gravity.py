"""The triplet surrogate's response to gravity on the liquid (a mixin of TripletSurrogate).

A triplet table may carry the response of the pair forces to the gravity vector
b = Bo g_hat (:mod:`capbridge.tables.triplet_gravity`): per node, in the node's table
frame, G = ``force_gravity_gradient`` and C = ``force_gravity_curvature``.
:class:`TripletGravityResponse` fits them (``_fit_gravity``, called by
:meth:`TripletSurrogate.fit <capbridge.surrogate.triplet.TripletSurrogate.fit>`), looks
them up on (gaps, theta, v) and adds

    F_i(b) = F_i(0) + Q (G_i b_t + C_i b_t^2 / 2),   b_t = Q^T b

to the zero-gravity force vectors of :meth:`TripletSurrogate.predict_vectors
<capbridge.surrogate.triplet.TripletSurrogate.predict_vectors>` (Q the table frame of
each triangle, :func:`~capbridge.solvers.triplet.table_frame`).  The Bond range the
response is validated to comes from the table's held-out cases
(:func:`~capbridge.surrogate.triplet_holdout.gravity_holdout_errors`).

The mixin reads what the surrogate's ``fit`` set before it (``gaps_``, ``theta_``, the
fitted table) and writes the ``gravity_*`` attributes and ``has_gravity_``.
"""
from __future__ import annotations

import numpy as np

from capbridge.physics.gravity import BOND_MAX, check_bond, gravity_vector, liquid_weight
from capbridge.solvers.triplet import table_frame
from capbridge.status import HAS_RESULT, Status, status_in
from capbridge.surrogate.grid import FineAxis, Grid
from capbridge.surrogate.triplet_holdout import gravity_holdout_errors
from capbridge.surrogate.triplet_nodes import cell_max

__all__ = ["TripletGravityResponse", "fill_response", "sum_rule_residual"]


def fill_response(vals, ok, fillable, coords):
    """Values at the nodes ``fillable`` of a response grid (..., theta, gravity_v,
    features) from the valid nodes ``ok`` of their line: linear in gravity_v
    (interpolated between the nearest valid nodes on either side, else extrapolated from
    the two nearest, else the one), else the same along theta.  Only valid nodes are
    sources.  Returns (values, filled mask)."""
    vals = np.array(vals, float)
    filled = np.zeros(ok.shape, bool)
    for axis, x in ((4, coords[1]), (3, coords[0])):
        for idx in np.argwhere(fillable & ~filled):
            line = list(idx)
            line[axis] = slice(None)
            line = tuple(line)
            src = np.flatnonzero(ok[line])
            if src.size == 0:
                continue
            xi = x[idx[axis]]
            below, above = src[x[src] < xi], src[x[src] > xi]
            if below.size and above.size:
                pick = (below[-1], above[0])
            elif src.size >= 2:
                pick = tuple(src[np.argsort(np.abs(x[src] - xi))[:2]])
            else:
                pick = (src[0],)
            ys = vals[line][list(pick)]
            if len(pick) == 1:
                y = ys[0]
            else:
                w = (xi - x[pick[0]]) / (x[pick[1]] - x[pick[0]])
                y = ys[0] + w * (ys[1] - ys[0])
            vals[tuple(idx)] = y
            filled[tuple(idx)] = True
    return vals, filled


def sum_rule_residual(vals):
    """max |sum_i G_i / W - I| of response values (..., 54) (G / W first): the sum-rule
    residual of a node relative to its weight, as ``gravity_sum_residual``."""
    G = vals[..., :27].reshape(vals.shape[:-1] + (3, 3, 3))
    return np.abs(G.sum(axis=-3) - np.eye(3)).max(axis=(-2, -1))


class TripletGravityResponse:
    """Gravity part of :class:`~capbridge.surrogate.triplet.TripletSurrogate`: fit the
    table's response, look it up, add it to force vectors, summarise it."""

    def _fit_gravity(self, ds):
        """The table's response to gravity (if any) and its held-out validation.

        ``force_gravity_gradient`` G and ``force_gravity_curvature`` C (table frame of
        each node, :mod:`capbridge.tables.triplet_gravity`) are divided by the
        node's liquid weight W_node = v V*_coal / (2 pi) and interpolated multilinearly
        on the raw (d12, d13, d23, theta, gravity_v) grid (the simplex kernel is 2.6x
        faster but its held-out error is 15 % larger at Bo = 1); a lookup multiplies them by
        the weight W = V*/(2 pi) of the asked volume.  Written so, sum_i G_i = W I holds
        at every point to the largest ``gravity_sum_residual`` of the cell's nodes
        (multilinear weights are a convex combination), also between nodes where
        v V*_coal is not multilinear, and clipping v to the response's range keeps the
        grains' shares of the weight.
        """
        self.has_gravity_ = "force_gravity_gradient" in ds
        self.gravity_bond_max_ = 0.0
        self.gravity_errors_ = None
        if not self.has_gravity_:
            return
        dims = ("d12", "d13", "d23", "theta", "gravity_v")
        tdims = dims + ("grain", "component", "gravity_component")
        G = np.asarray(ds["force_gravity_gradient"].transpose(*tdims).values, float)
        C = np.asarray(ds["force_gravity_curvature"].transpose(*tdims).values, float)
        st = np.asarray(ds["gravity_status"].transpose(*dims).values)
        res = np.asarray(ds["gravity_sum_residual"].transpose(*dims).values, float)
        gv = np.asarray(ds["gravity_v"].values, float)
        Vc = np.asarray(ds["volume_coalescence"].transpose(*dims[:4]).values, float)
        W = liquid_weight(Vc[..., None] * gv)
        ok = status_in(st, HAS_RESULT) & np.isfinite(W) & (W > 0) & \
            np.isfinite(G).all((-3, -2, -1)) & np.isfinite(C).all((-3, -2, -1)) & \
            np.isfinite(res)
        Wn = np.where(ok, W, 1.0)[..., None, None, None]
        vals = np.concatenate([(G / Wn).reshape(ok.shape + (27,)),
                               (C / Wn).reshape(ok.shape + (27,))], -1)
        vals[~ok] = 0.0
        # a node whose response failed where the body exists (its six runs did not all
        # converge) is filled from its neighbours along v, else theta; cells touching
        # it answer APPROXIMATE (error: benchmarks/bench_gravity_fill.py)
        body = (st != Status.NOT_COMPUTED) & np.isfinite(W) & (W > 0)
        vals, filled = fill_response(vals, ok, body & ~ok,
                                     (np.asarray(self.theta_, float), gv))
        res = np.where(filled, sum_rule_residual(vals), res)
        ok = ok | filled
        if gv.size == 1:          # one volume ratio: the response taken constant in v
            gv = np.array([gv[0], gv[0] * 2.0])
            vals, ok, res, filled = (np.concatenate([x, x], axis=4)
                                     for x in (vals, ok, res, filled))
            self._gravity_single_v = True
        else:
            self._gravity_single_v = False
        self.gravity_v_ = np.asarray(ds["gravity_v"].values, float)
        coarse = [self.gaps_] * 3 + [self.theta_, gv]
        self.gravity_axes_ = [FineAxis(c, 1) for c in coarse]
        self.gravity_grid_ = Grid(np.ascontiguousarray(vals), "multilinear")
        self.gravity_cell_bad_ = np.ascontiguousarray(cell_max((~ok).astype(np.int8)))
        self.gravity_cell_filled_ = np.ascontiguousarray(cell_max(filled.astype(np.int8)))
        self.gravity_cell_residual_ = np.ascontiguousarray(
            cell_max(np.where(ok, res, 0.0)))
        # nodes outside a table's computed domain are not counted (max_bridge_gap)
        n_filled = int(filled[..., :self.gravity_v_.size].sum())
        self.gravity_nodes_ = {"with_response": int(ok[..., :self.gravity_v_.size].sum())
                               - n_filled, "filled": n_filled,
                               "total": int(np.sum(st != Status.NOT_COMPUTED))}
        if "gravity_holdout_force" in ds:
            self.gravity_errors_ = gravity_holdout_errors(self, ds)
            self.gravity_bond_max_ = self.gravity_errors_["bond_max_validated"]

    def _gravity_lookup(self, g, t, v, volume):
        """G, C (n, 3, 3, 3) in the table frame of each point for the liquid volume
        ``volume`` (lookup units), the cell's largest sum-rule residual and a status
        per point (int8 :class:`~capbridge.status.Status`): CONVERGED (available),
        APPROXIMATE (v outside the response's range: nearest v; or a node of the cell
        filled, :func:`fill_response`), NOT_CONVERGED (not available: a node of the
        cell has no response)."""
        gv = self.gravity_v_
        clipped = (v < gv[0] * (1 - 1e-9)) | (v > gv[-1] * (1 + 1e-9))
        vq = np.clip(v, gv[0], gv[-1])
        loc = [ax.locate(np.asarray(x, float)) for ax, x in
               zip(self.gravity_axes_, list(g) + [t, vq])]
        idx, fr = [a[0] for a in loc], [a[1] for a in loc]
        vals = self.gravity_grid_(idx, fr)
        W = liquid_weight(volume)[:, None, None, None]
        G = vals[:, :27].reshape(-1, 3, 3, 3) * W
        C = vals[:, 27:].reshape(-1, 3, 3, 3) * W
        cell = tuple(idx)
        bad = self.gravity_cell_bad_[cell] > 0
        approx = clipped | (self.gravity_cell_filled_[cell] > 0)
        code = np.where(bad, np.int8(Status.NOT_CONVERGED),
                        np.where(approx, np.int8(Status.APPROXIMATE),
                                 np.int8(Status.CONVERGED))).astype(np.int8)
        return G, C, self.gravity_cell_residual_[cell], code

    def gravity_summary(self):
        """The gravity content of the fitted table (JSON-friendly dict, or None): the
        response's volume ratios, nodes with a response, the supported and validated
        Bond ranges, the held-out errors (:func:`gravity_holdout_errors`) and the
        number of held-out cases outside the table's grid (skipped when it was made)."""
        self._check_fitted()
        if not self.has_gravity_:
            return None
        e = self.gravity_errors_
        out = {"gravity_v": self.gravity_v_.tolist(), "nodes": self.gravity_nodes_,
               "bond_max_supported": BOND_MAX,
               "bond_max_validated": float(self.gravity_bond_max_),
               "holdout_cases_skipped": int(self.table_.attrs.get(
                   "gravity_holdout_cases_skipped", 0))}
        if e is not None:
            out["holdout"] = {k: e[k] for k in ("threshold", "threshold_source", "bonds",
                                                "max_error_by_bond",
                                                "max_effect_error_by_bond",
                                                "n_cases_by_bond", "n_cases",
                                                "n_cases_used")}
        return out

    def _check_bond(self, bond):
        return check_bond(bond, self.has_gravity_, "triplet", "force_gravity_gradient",
                          "Surface Evolver (capbridge solve triplet --bond)")

    def _add_gravity(self, res, centres, V, t, gaps, s, shape, bond, gravity):
        """Add the response to gravity to ``res`` (see :meth:`predict_vectors`)."""
        bo = np.broadcast_to(self._check_bond(bond), shape)
        direction = (0.0, 0.0, -1.0) if gravity is None else gravity
        b = np.broadcast_to(gravity_vector(bo, direction), shape + (3,))
        res["gravity"] = np.array(b)
        F = res["forces"]
        first = np.zeros(shape + (3, 3))
        second = np.zeros(shape + (3, 3))
        resid = np.zeros(shape)
        status = np.array(res["status"], np.int8)
        # the answer without gravity, for callers that fall back on their own where
        # the response has no number (the DEM engine: the liquid's weight shared)
        res["status_without_gravity"] = status.copy()
        on = bo > 0
        if on.any():
            s = np.broadcast_to(s, shape)[on]
            Q = table_frame(centres[on])                      # table -> caller
            Vl = V[on] / s**3
            # an open side continued beyond the table (open_side="linear") takes the
            # response at the table's edge
            g = [np.minimum(gaps[on][:, m] / s, self.gaps_[-1]) for m in range(3)]
            G, Cv, resid_on, code = self._gravity_lookup(g, t[on], res["v"][on], Vl)
            bt = np.matmul(b[on][:, None, :], Q)[:, 0] * (s**2)[:, None]   # lookup units
            # the two terms of triplet_gravity_forces, as batched products
            d1 = np.matmul(G, bt[:, None, :, None])[..., 0]
            d2 = 0.5 * np.matmul(Cv, (bt**2)[:, None, :, None])[..., 0]
            QT = np.swapaxes(Q, -1, -2) * s[:, None, None]                 # back, F* units
            first[on] = np.matmul(d1, QT)
            second[on] = np.matmul(d2, QT)
            resid[on] = resid_on
            st = status[on]
            has = status_in(st, (Status.CONVERGED, Status.ABOVE_TOLERANCE))
            approx = (code == Status.APPROXIMATE) | (bo[on] > self.gravity_bond_max_ * (1 + 1e-12))
            st = np.where(has & approx, np.int8(Status.APPROXIMATE), st)
            st = np.where((code == Status.NOT_CONVERGED)
                          & status_in(st, HAS_RESULT + (Status.EXTRAPOLATED,)),
                          np.int8(Status.NOT_CONVERGED), st)
            status[on] = st
            nores = ~status_in(status, HAS_RESULT + (Status.EXTRAPOLATED,))
            first[nores] = np.nan
            second[nores] = np.nan
        res["forces"] = np.where(on[..., None, None], F + first + second, F)
        res["gravity_first_order"] = first
        res["gravity_second_order"] = second
        res["gravity_sum_residual"] = resid
        res["status"] = status
