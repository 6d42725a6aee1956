"""Gravity in the doublet table: the response of the grain forces to gravity along the axis.

Representation
--------------
Gravity enters as the vector b = Bo g_hat (Bo = drho g R1^2 / gamma, g_hat the unit vector
along which gravity pulls), n is the unit vector from grain 1 to grain 2, W = V*/(2 pi)
the liquid's weight per unit of b in F* = F/(2 pi gamma R1) units.  The force vectors of
the liquid on the grains are represented to second order in the axial component b.n:

    F1(b) = F0 n + W [w (b.n) n + u (b - (b.n) n)] + (1/2) c (b.n)^2 n,
    F2(b) = -F0 n - (1/2) c (b.n)^2 n + W [(1 - w)(b.n) n + (1 - u)(b - (b.n) n)],

F0 the zero-gravity attraction (``force`` of the table), w = ``weight_share_axial`` the
share of the weight carried by grain 1 at first order with gravity along the axis,
c = ``force_gravity_curvature_axial`` = d^2 F / d(b.n)^2 of the attraction F (the mean of
the two axial forces) and u = ``weight_share_transverse`` the share of the transverse
weight on grain 1, the lever rule 1 - x_c/D of the liquid's centre of mass (exact at first
order: :func:`capbridge.physics.gravity.transverse_weight_share`).  F1 + F2 = W b
exactly (the grains carry the whole weight).  The second-order effect of the transverse
component b - (b.n) n is not represented (``benchmarks/gravity_doublet_validity.py``
measures it: 2e-4 of F0 at Bo = 2.14 for equal grains).

How w and c are computed
------------------------
At every node of a sub-grid of the table (:class:`GravityPlan`), the exact axisymmetric
solver with gravity along the axis (:mod:`capbridge.solvers.young_laplace_gravity`) is
run at b.n = +-h/2 and +-h (Bo = h/2, h; ``gravity_axis`` = +1 and -1: b.n = Bo
g_hat.n = Bo gravity_axis) and at Bo = 0 (the same discretisation: the polish of the
zero-gravity bridge on the ODE).  With the solver's signs (force1 pulls grain 1 towards
grain 2, force2 grain 2 towards grain 1), F1_vec = force1 n and F2_vec = -force2 n, and
central differences at the step k = h/2 and h give

    w(k) = [force1(+k) - force1(-k)] / (2 k W),
    c(k) = [F(+k) - 2 F(0) + F(-k)] / k^2,       F = (force1 + force2) / 2,

both with an error O(k^2); the table stores their Richardson extrapolation and, as the
point's own error estimate, the terms the second-order representation leaves out at
Bo = h, measured by the difference between the two steps (:func:`axial_response`,
``response_error``); a point whose estimate exceeds
``response_rtol`` of its attraction is ABOVE_TOLERANCE in ``gravity_status``.  That
happens near rupture only: there the attraction goes as sqrt(d*_rupt(b) - d*) and the
rupture distance moves with b (linearly, for ratio 1 quadratically), so the response is
singular and no fixed step resolves it.  For ratio 1 (equal angles) w = 1/2 follows from
the symmetry (force1(+k) = force2(-k)); it is computed, not imposed, and tested.

Each solve continues from the zero-gravity bridge to Bo = h by natural continuation in
Bo (landing on h/2 on the way), exactly as
:func:`~capbridge.solvers.young_laplace_gravity.solve_doublet_gravity` does before it
switches to pseudo-arclength continuation; that switch (which walks to the end of the
stable branch, several seconds per point) is not made here: a node where the natural
continuation fails is NOT_CONVERGED in ``gravity_status`` (in practice the nodes near
rupture, where the rupture distance at Bo = h is below the node's gap; see
``rupture_gap_gravity``); the nodes of a line beyond its first failure (towards rupture)
are not attempted and are NOT_CONVERGED too (:func:`gravity_chunk`).

Rupture with gravity
--------------------
``rupture_gap_gravity`` (bond, gravity_axis, ratio, theta, volume) is the rupture distance
of :func:`~capbridge.solvers.young_laplace_gravity.rupture_distance_gravity` on a small
sub-grid; for ratio 1 the two directions of gravity are equal by symmetry and the +1
column is the -1 one (computed once).

Reference: Miot et al. (2021), Granular Matter 23:66 (gravity on capillary bridges,
Bo = 2.14 for r = 4 mm glass beads and water).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from capbridge.dimensionless import centre_distance
from capbridge.solvers.young_laplace import solve_doublet
from capbridge.solvers.young_laplace_gravity import (GravitySettings, bridge_forces, stability_indicator,
                                                       newton_solve, point_dict,
                                                       zero_gravity_start,
                                                       rupture_distance_gravity)
from capbridge.status import Status, status_in
from capbridge.physics.gravity import transverse_weight_share

#: tolerance of a response point's own error estimate, relative to its attraction F0
#: (the doublet table's held-out error is 5e-5 median, 3.4e-3 max on the tabulated ratios)
RESPONSE_RTOL = 1e-3

RESPONSE_OUTPUTS = ("weight_share_axial", "force_gravity_curvature_axial",
                    "weight_share_transverse", "force_bond_zero", "response_error")

__all__ = ["GravityPlan", "RESPONSE_RTOL", "GRAVITY_ATTRS", "axial_response", "gravity_chunk",
           "rupture_gravity_chunk"]

def _subgrid_axis(units, quantity, subgrid):
    """CF attributes of an axis of one of the gravity sub-grids."""
    return dict(units=units, long_name=f"{quantity} ({subgrid} sub-grid)")


GRAVITY_ATTRS = {
    "gravity_theta": _subgrid_axis("degree", "contact angle on both grains",
                                   "gravity-response"),
    "gravity_volume": _subgrid_axis("1", "liquid bridge volume V* = V/R1^3",
                                    "gravity-response"),
    "gravity_s": _subgrid_axis("1", "gap coordinate s = sqrt(1 - d*/d*_rupt) of the "
                                    "zero-gravity rupture", "gravity-response"),
    "weight_share_axial": dict(
        units="1", long_name="share w of the liquid's weight carried by grain 1 at first "
                             "order, gravity along the axis: dF1/d(b.n) / (V*/(2 pi))"),
    "force_gravity_curvature_axial": dict(
        units="1", long_name="second derivative c = d2F*/d(b.n)2 of the attraction F* "
                             "(mean of the two axial forces) in b.n = Bo g_hat.n"),
    "weight_share_transverse": dict(
        units="1", long_name="share u of the transverse weight carried by grain 1 at first "
                             "order: 1 - x_c/D (lever rule, x_c the liquid's centre of mass "
                             "from the centre of grain 1, D the centre distance)"),
    "force_bond_zero": dict(
        units="1", long_name="attraction F* at Bo = 0 on the gravity solver's "
                             "discretisation (the F(0) of the curvature)"),
    "response_error": dict(
        units="1", long_name="error estimate of the second-order representation at "
                             "Bo = h, relative to F0: (4/3)(W |dw| h + |dc| h^2 / 2) / |F0|, "
                             "dw and dc the differences between steps h and h/2"),
    "rupture_bond": dict(units="1", long_name="Bond number Bo = drho g R1^2/gamma of the "
                                              "rupture distances with gravity"),
    "rupture_gravity_axis": dict(
        units="1", long_name="component g_hat.n of the direction of gravity along n "
                             "(grain 1 to grain 2): -1 grain 1 below, +1 grain 1 above"),
    "rupture_ratio": _subgrid_axis("1", "radius ratio R2/R1", "rupture"),
    "rupture_theta": _subgrid_axis("degree", "contact angle on both grains", "rupture"),
    "rupture_volume": _subgrid_axis("1", "liquid bridge volume V* = V/R1^3", "rupture"),
    "rupture_gap_gravity": dict(units="1", long_name="rupture distance d*_rupt with gravity "
                                                     "along the axis"),
}


@dataclasses.dataclass(frozen=True)
class GravityPlan:
    """Settings of the gravity phases of a doublet table.

    ``bond_step`` h of the central differences (Bo, with h/2 for the error estimate),
    ``response_rtol`` the tolerance of that estimate relative to F0; the response sub-grid takes every
    ``theta_every``-th theta, ``volume_every``-th volume and ``s_every``-th s node of the
    table counted from contact (s = 1), without s = 0 (rupture); the rupture sub-grid is
    ``rupture_ratios`` x ``rupture_thetas`` x ``rupture_volumes`` (the nodes of the
    table's axes nearest to them) x ``rupture_bonds`` x gravity_axis (-1, +1).
    """

    bond_step: float = 0.5
    response_rtol: float = RESPONSE_RTOL
    theta_every: int = 2
    volume_every: int = 2
    s_every: int = 2
    rupture_ratios: tuple = (1.0, 2.0)
    rupture_thetas: tuple = (0.0, 30.0, 60.0, 80.0)
    rupture_volumes: tuple = (1e-3, 0.01, 0.1, 0.5)
    rupture_bonds: tuple = (0.1, 0.5, 1.0, 2.14, 2.5)

    def settings(self):
        return {"bond_step": self.bond_step, "response_rtol": self.response_rtol,
                "differences": "central at h and h/2, Richardson-extrapolated",
                "solver": GravitySettings().as_dict(),
                "line_stop": "no attempt beyond the first failure of a line towards rupture"}

    @staticmethod
    def _every(values, k, from_end=False):
        idx = np.arange(len(values))
        pick = idx[::-1][::k][::-1] if from_end else idx[::k]
        return pick

    def response_indices(self, grid):
        """Indices (theta, volume, s) of the response sub-grid in the table's axes."""
        s = np.asarray(grid.s)
        i_s = self._every(s, self.s_every, from_end=True)
        i_s = i_s[s[i_s] > 0]
        i_v = self._every(grid.volume, self.volume_every, from_end=True)
        return self._every(grid.theta, self.theta_every), i_v, i_s

    def axes(self, grid):
        """Coordinates of the gravity sub-grids of a table of ``grid`` (name -> values):
        what the table's gravity dimensions will hold, known before any solve."""
        it, iv, i_s = self.response_indices(grid)
        ir, jt, kv = self.rupture_indices(grid)
        th, vol = np.asarray(grid.theta, float), np.asarray(grid.volume, float)
        return {"gravity_theta": th[it], "gravity_volume": vol[iv],
                "gravity_s": np.asarray(grid.s, float)[i_s],
                "rupture_bond": np.asarray(self.rupture_bonds, float),
                "rupture_gravity_axis": np.array([-1.0, 1.0]),
                "rupture_ratio": np.asarray(grid.ratio, float)[ir],
                "rupture_theta": th[jt], "rupture_volume": vol[kv]}

    def rupture_indices(self, grid):
        """Indices (ratio, theta, volume) of the rupture sub-grid (nodes of the table)."""
        def nearest(axis, wanted):
            axis = np.asarray(axis, float)
            return np.array(sorted({int(np.argmin(np.abs(axis - w))) for w in wanted
                                    if axis.min() - 1e-9 <= w <= axis.max() + 1e-9}), int)

        logv = np.log(np.asarray(grid.volume, float))
        i_v = np.array(sorted({int(np.argmin(np.abs(logv - np.log(v))))
                               for v in self.rupture_volumes}), int)
        return (nearest(grid.ratio, self.rupture_ratios),
                nearest(grid.theta, self.rupture_thetas), i_v)


def _solve_natural(gap, volume, theta, ratio, bonds, gravity_axis, zg, settings):
    """Bridges at Bo = each of ``bonds`` (ascending) by natural continuation from the
    zero-gravity bridge ``zg`` (the first stage of solve_doublet_gravity, without its walk
    to the branch end); the continuation lands on every one of them.

    Returns (forces dict at Bo = 0, list of forces dicts at ``bonds``), or (.., None)
    where the continuation fails before the last of them.
    """
    t1 = np.radians(theta)
    pt = point_dict(gap, volume, t1, t1, ratio, bonds[-1], gravity_axis)
    z0 = zero_gravity_start(pt, zg)
    if not np.all(np.isfinite(z0)):
        return None, None
    p0 = dict(pt, b=0.0)
    z, ok, _, J, info = newton_solve(z0, p0, settings)
    if not ok or stability_indicator(J) <= 0:
        return None, None
    at_zero = bridge_forces(z, info, p0)
    sign = 1.0 if pt["b"] >= 0 else -1.0
    hist = [(0.0, z)]
    done, step, found = 0.0, min(bonds[0], settings.bond_step), []
    for target in bonds:
        while done < target:
            nxt = min(done + step, target)
            zp = (z if len(hist) < 2
                  else z + (z - hist[-2][1]) * (nxt - done) / (done - hist[-2][0]))
            ptn = dict(pt, b=sign * nxt)
            zn, ok, _, Jn, info_n = newton_solve(zp, ptn, settings, max_iter=8)
            ok = (ok and stability_indicator(Jn) > 0
                  and bool(np.all(np.abs(zn - zp) <= 0.25 * (1.0 + np.abs(zp)))))
            if ok:
                done, z, info = nxt, zn, info_n
                hist.append((done, z))
                step = min(1.5 * step, settings.bond_step)
                continue
            step *= 0.5
            if step < 0.2 * settings.bond_step:
                return at_zero, None
        found.append(bridge_forces(z, info, dict(pt, b=sign * target)))
    return at_zero, found


def axial_response(gap, volume, theta, ratio, bond_step=0.5, rtol=RESPONSE_RTOL,
                   settings=None):
    """First- and second-order response of a doublet to gravity along its axis.

    Central differences at the steps h and h/2 (solves at b.n = 0, +-h/2, +-h), combined
    by Richardson extrapolation (the O(h^2) error terms cancel):

        w = [4 w(h/2) - w(h)] / 3,   c = [4 c(h/2) - c(h)] / 3,

    with w(h) = [force1(+h) - force1(-h)] / (2 h W), c(h) = [F(+h) - 2 F(0) + F(-h)] / h^2
    and W = V*/(2 pi).  The difference between the two steps measures the next terms of
    the expansion, those the second-order representation leaves out: at Bo = h they
    amount to the force

        e = (4/3) [W |w(h) - w(h/2)| h + |c(h) - c(h/2)| h^2 / 2]

    (w(k) = w + a k^2 + ...: the omitted cubic term at b.n = h is W a h^3 and
    w(h) - w(h/2) = 3 a h^2 / 4), the point's own error estimate.  Near rupture the
    expansion fails (the attraction goes as sqrt(d*_rupt(b) - d*) and d*_rupt moves with
    b): there e grows, and a point with e > ``rtol`` |F0| is ABOVE_TOLERANCE.

    Parameters
    ----------
    gap, volume : array_like
        d* = d/R1 and V* = V/R1^3 [-].
    theta : array_like
        Contact angle on both grains [deg], in [0, 90).
    ratio : array_like
        R2/R1 in [1, 10].
    bond_step : float
        h [-]: the solves are at b.n = 0, +-h/2 and +-h.
    rtol : float
        Tolerance of the error estimate e relative to the attraction |F0| at Bo = 0.
    settings : GravitySettings, optional

    Returns
    -------
    dict of 1-D arrays
        ``weight_share_axial`` w [-], ``force_gravity_curvature_axial`` c [F*],
        ``weight_share_transverse`` u [-] (lever rule of the Bo = 0 bridge),
        ``force_bond_zero`` F(0) [F*], ``response_error`` e / |F0| [-] and ``status``:
        CONVERGED, ABOVE_TOLERANCE (e > rtol |F0|: numbers kept, flagged),
        NOT_CONVERGED (a solve failed: every output NaN) or the zero-gravity status where
        that bridge is not converged.

    Examples
    --------
    Equal grains carry half of the weight each (the mirror symmetry swapping them):

    >>> r = axial_response(0.1, 0.05, 30.0, 1.0)
    >>> abs(float(r["weight_share_axial"][0]) - 0.5) < 1e-8
    True
    """
    settings = settings or GravitySettings()
    gap, volume, theta, ratio = (np.ravel(a).astype(float)
                                 for a in np.broadcast_arrays(gap, volume, theta, ratio))
    n = gap.size
    out = {k: np.full(n, np.nan) for k in RESPONSE_OUTPUTS}
    out["status"] = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    h = float(bond_step)
    zg = solve_doublet(gap, volume, theta, ratio)
    for i in range(n):
        if zg["status"][i] != Status.CONVERGED:
            out["status"][i] = zg["status"][i]
            continue
        zi = {k: zg[k][i] for k in ("pressure", "beta1", "beta2")}
        solves = [_solve_natural(gap[i], volume[i], theta[i], ratio[i], (0.5 * h, h), axis,
                                 zi, settings) for axis in (1.0, -1.0)]
        if any(f0 is None or found is None for f0, found in solves):
            continue
        f0 = solves[0][0]
        W = volume[i] / (2.0 * np.pi)
        w, c = [], []
        for k, step in enumerate((0.5 * h, h)):
            plus, minus = solves[0][1][k], solves[1][1][k]
            w.append((plus["force1"] - minus["force1"]) / (2.0 * step * W))
            c.append((plus["force"] - 2.0 * f0["force"] + minus["force"]) / step**2)
        err = 4.0 / 3.0 * (W * abs(w[1] - w[0]) * h + 0.5 * abs(c[1] - c[0]) * h**2)
        out["weight_share_axial"][i] = (4.0 * w[0] - w[1]) / 3.0
        out["force_gravity_curvature_axial"][i] = (4.0 * c[0] - c[1]) / 3.0
        out["force_bond_zero"][i] = f0["force"]
        out["weight_share_transverse"][i] = transverse_weight_share(
            f0["moment"], f0["volume"], centre_distance(gap[i], ratio[i]))
        out["response_error"][i] = err / abs(f0["force"])
        out["status"][i] = (Status.CONVERGED if err <= rtol * abs(f0["force"])
                            else Status.ABOVE_TOLERANCE)
    return out


# Module-level chunk solvers: picklable for worker processes.

def gravity_chunk(gap, volume, theta, ratio, bond_step=0.5, rtol=RESPONSE_RTOL):
    """Chunk of the response phase (:func:`axial_response`), line by line.

    The points of one (ratio, theta, volume) line are solved from contact (smallest gap)
    towards rupture; after the first point whose solves fail, the points of larger gap
    of that line are not attempted and are NOT_CONVERGED too: a failed natural
    continuation costs several converged points, and beyond it the
    bridge at Bo = h is closer to, or past, its rupture (the stable branch at fixed V*
    and Bo is the gap interval [0, d*_rupt(Bo)]).
    """
    n = np.size(gap)
    out = {k: np.full(n, np.nan) for k in RESPONSE_OUTPUTS}
    out["status"] = np.full(n, int(Status.NOT_CONVERGED), np.int8)
    keys = np.stack([np.asarray(ratio, float), np.asarray(theta, float),
                     np.asarray(volume, float)], axis=1)
    _, line = np.unique(keys, axis=0, return_inverse=True)
    for j in np.unique(line):
        idx = np.flatnonzero(line.ravel() == j)
        for i in idx[np.argsort(np.asarray(gap)[idx], kind="stable")]:
            r = axial_response(gap[i], volume[i], theta[i], ratio[i], bond_step=bond_step,
                               rtol=rtol)
            for k in out:
                out[k][i] = r[k][0]
            if r["status"][0] == Status.NOT_CONVERGED:
                break
    return out


def rupture_gravity_chunk(volume, theta, ratio, bond, gravity_axis):
    """Chunk of the rupture phase (:func:`rupture_distance_gravity`)."""
    r = rupture_distance_gravity(volume, theta, bond, ratio, gravity_axis=gravity_axis)
    return {"rupture_gap_gravity": r["gap"], "status": r["status"]}


def gravity_datasets(grid, rupture_gap, plan, phase):
    """The two gravity phases of a doublet table as a Dataset to merge into it.

    ``rupture_gap`` (ratio, theta, volume): the zero-gravity rupture distances (NaN where
    not found); ``phase(name, chunk_fn, inputs, chunk_size, settings)`` runs one
    resumable sweep and returns its result.
    """
    import functools
    import json

    import xarray as xr

    from capbridge.status import cf_flag_attributes

    it, iv, _ = plan.response_indices(grid)
    ax = plan.axes(grid)
    ratio = np.asarray(grid.ratio, float)
    th, vol, s = ax["gravity_theta"], ax["gravity_volume"], ax["gravity_s"]
    d_r = rupture_gap[:, it][:, :, iv]
    R, T, V, S = np.meshgrid(ratio, th, vol, s, indexing="ij")
    gap = d_r[..., None] * (1.0 - S**2)
    ok = np.isfinite(gap).ravel()
    inputs = {"gap": gap.ravel()[ok], "volume": V.ravel()[ok], "theta": T.ravel()[ok],
              "ratio": R.ravel()[ok]}
    res = phase("gravity_response", functools.partial(gravity_chunk, bond_step=plan.bond_step,
                                                      rtol=plan.response_rtol),
                inputs, len(s), plan.settings())
    shape = R.shape
    data = {}
    for name in RESPONSE_OUTPUTS:
        flat = np.full(ok.size, np.nan)
        flat[ok] = res[name]
        data[name] = flat.reshape(shape)
    st = np.full(ok.size, int(Status.NOT_CONVERGED), np.int8)
    st[ok] = res["status"]
    st = st.reshape(shape)
    for name in data:    # ABOVE_TOLERANCE keeps its numbers (the surrogate flags them)
        data[name][~status_in(st, (Status.CONVERGED, Status.ABOVE_TOLERANCE))] = np.nan
    gdims = ("ratio", "gravity_theta", "gravity_volume", "gravity_s")
    dv = {name: (gdims, arr, GRAVITY_ATTRS[name]) for name, arr in data.items()}
    dv["gravity_status"] = (gdims, st, cf_flag_attributes() | {
        "long_name": "status of the gravity-response solves at b.n = 0, +-h/2, +-h "
                     "(above_tolerance: response_error > response_rtol)"})
    # rupture with gravity
    rr, rt, rv = ax["rupture_ratio"], ax["rupture_theta"], ax["rupture_volume"]
    bonds, axes = ax["rupture_bond"], ax["rupture_gravity_axis"]
    B, G, RR, RT, RV = np.meshgrid(bonds, axes, rr, rt, rv, indexing="ij")
    # ratio 1: both directions are equal by symmetry, the +1 one is not solved
    need = ~((RR == 1.0) & (G == 1.0))
    rin = {"volume": RV[need], "theta": RT[need], "ratio": RR[need], "bond": B[need],
           "gravity_axis": G[need]}
    rres = phase("rupture_gravity", rupture_gravity_chunk, rin, 4, GravitySettings().as_dict())
    rg = np.full(B.shape, np.nan)
    rs = np.full(B.shape, int(Status.NOT_CONVERGED), np.int8)
    rg[need], rs[need] = rres["rupture_gap_gravity"], rres["status"]
    if np.any(~need):
        one = RR[:, 0] == 1.0                  # (bond, ratio, theta, volume)
        rg[:, 1][one] = rg[:, 0][one]
        rs[:, 1][one] = rs[:, 0][one]
    rg[rs != Status.CONVERGED] = np.nan
    rdims = ("rupture_bond", "rupture_gravity_axis", "rupture_ratio", "rupture_theta",
             "rupture_volume")
    dv["rupture_gap_gravity"] = (rdims, rg, GRAVITY_ATTRS["rupture_gap_gravity"])
    dv["rupture_gravity_status"] = (rdims, rs, cf_flag_attributes() | {
        "long_name": "status of the rupture solve with gravity"})
    coords = {"gravity_theta": ("gravity_theta", th, GRAVITY_ATTRS["gravity_theta"]),
              "gravity_volume": ("gravity_volume", vol, GRAVITY_ATTRS["gravity_volume"]),
              "gravity_s": ("gravity_s", s, GRAVITY_ATTRS["gravity_s"]),
              "rupture_bond": ("rupture_bond", bonds, GRAVITY_ATTRS["rupture_bond"]),
              "rupture_gravity_axis": ("rupture_gravity_axis", axes,
                                       GRAVITY_ATTRS["rupture_gravity_axis"]),
              "rupture_ratio": ("rupture_ratio", rr, GRAVITY_ATTRS["rupture_ratio"]),
              "rupture_theta": ("rupture_theta", rt, GRAVITY_ATTRS["rupture_theta"]),
              "rupture_volume": ("rupture_volume", rv, GRAVITY_ATTRS["rupture_volume"])}
    ds = xr.Dataset(dv, coords=coords)
    ds.attrs["gravity_bond_step"] = float(plan.bond_step)
    ds.attrs["gravity_response_rtol"] = float(plan.response_rtol)
    ds.attrs["gravity_settings"] = json.dumps(dataclasses.asdict(plan)
                                              | {"solver": GravitySettings().as_dict()})
    ds.attrs["gravity_representation"] = (
        "F1(b) = F0 n + W [w (b.n) n + u (b - (b.n) n)] + c (b.n)^2 n / 2, "
        "F2(b) = -F0 n - c (b.n)^2 n / 2 + W [(1 - w)(b.n) n + (1 - u)(b - (b.n) n)], "
        "b = Bo g_hat, n from grain 1 to grain 2, W = V*/(2 pi), w = weight_share_axial, "
        "c = force_gravity_curvature_axial, u = weight_share_transverse "
        "(see capbridge.tables.doublet_gravity)")
    return ds
