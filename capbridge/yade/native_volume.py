"""Fixed-volume bridges at YADE's native speed: ``Law2_ScGeom_CapillaryPhys_Capillarity``
reading volume-controlled solutions from capbridge's table.

YADE's compiled capillary law looks a bridge up by (radius ratio R/r, gap D = d/R,
P = u_c R / gamma) with R the larger radius and u_c one suction for the whole scene.
When every bridge holds the same volume (the *fixed volume per bridge* rule), the
bridge between two given spheres at a given gap is fully determined, so the third
coordinate is free to carry something else: with ``capillaryPressure = gamma / L``,
P = R / L is the larger radius in units of a reference length L.  The ``M(r=...)``
files written here hold, in the row of every P, the *volume-controlled* bridge of the
pair (R/rho, R) with the rule's volume:

``bridge_volume_star`` V*:  V = V* r^3 (r the smaller radius); every row is the same
                            bridge in units of R, so P does not matter at all;
``bridge_volume`` V [m^3]:  V* = V / r^3 changes with the size of the pair; the rows
                            hold every size the files are asked for (at most four
                            distinct radii).

Every pair radius ratio of the scene must be one of YADE's ten file ratios (mono- and
bidisperse packings such as 1:1.25 or 1:2): between two files YADE would interpolate
linearly the bridges of two other pairs.

The gap axis is uniform in s = sqrt(1 - d/d_rupt) for every bridge the scene can form
(ratios and radii), so YADE's linear interpolation between distance blocks follows the
force up to the exact rupture distance, where the block of that pair ends.  Bridges
form at contact and are erased past rupture by YADE itself, as with suction control.

What YADE then does natively: form at contact, keep the volume, rupture past d_rupt,
re-form at the next contact, forces along the centre line (equal and opposite).
What it cannot: a volume that differs per bridge (conserved liquid), several contact
angles (one file set per engine), radius ratios between its ten ratio files (see
:func:`ratio_interpolation_error`), coalescence reports at every step.  Use
:class:`~capbridge.yade.engine.CapbridgeEngine` for those.
"""
from __future__ import annotations

import warnings
from contextlib import chdir  # YADE reads its capillary files from the working directory
from pathlib import Path

import numpy as np

from capbridge.yade import yade_export as ye
from capbridge.dem.bridges import SceneTable, default_table_path, distinct_values
from capbridge.status import Status

__all__ = ["volume_suction_table", "NativeVolumeBridges", "ratio_interpolation_error"]


def _needed_ratios(radii, max_radii=8):
    """YADE's file ratios a scene's pairs use.  Every pair ratio must be one of them:
    between two files YADE interpolates linearly in ratio the bridges of two *other*
    pairs (same larger radius), which for a fixed V* have other volumes (errors of
    tens of per cent near rupture)."""
    rad = distinct_values(radii)
    yr = np.array(ye.YADE_RATIOS)
    if rad.size > max_radii:
        raise ValueError(f"{rad.size} distinct radii: the native fixed-volume path needs pair "
                         f"radius ratios among YADE's file ratios {list(ye.YADE_RATIOS)}; use "
                         "CapbridgeEngine for continuous size distributions")
    pr = distinct_values((rad[None, :] / rad[:, None])[rad[None, :] >= rad[:, None] * (1 - 1e-12)])
    off = [float(r) for r in pr if not np.any(np.isclose(yr, r, rtol=1e-9, atol=0))]
    if off:
        raise ValueError(f"pair radius ratios {off} are not among YADE's file ratios "
                         f"{list(ye.YADE_RATIOS)}: YADE would interpolate between other pairs' "
                         "bridges; use CapbridgeEngine for these radii")
    top = pr[-1]
    return yr[yr <= top * (1 + 1e-9)], rad


def volume_suction_table(theta, radii, *, bridge_volume=None, bridge_volume_star=None,
                         table=None, n_gaps=60, max_exact_radii=4):
    """The :class:`~capbridge.yade.yade_export.SuctionTable` whose export makes
    YADE's Law2 apply fixed-volume bridges (see the module docstring).

    ``bridge_volume`` (SI) needs at most ``max_exact_radii`` distinct radii (one row per
    size the files can be asked for); ``bridge_volume_star`` takes any radii.  Returns
    ``(suction_table, info)``; give the engine ``capillaryPressure = gamma / info['L']``.
    """
    if (bridge_volume is None) == (bridge_volume_star is None):
        raise ValueError("give exactly one of bridge_volume, bridge_volume_star")
    ratios, rad = _needed_ratios(radii)
    st = SceneTable(table if table is not None else default_table_path(), [theta], ratios,
                    variables=("force", "beta1", "beta2"))
    lo, hi = st.vstar_range
    L = float(rad[-1])
    if bridge_volume is not None and rad.size == 1:
        # one size: a fixed volume is a fixed V*
        bridge_volume_star, bridge_volume = float(bridge_volume) / rad[0] ** 3, None
    if bridge_volume_star is not None:
        vs = float(bridge_volume_star)
        if not lo * (1 - 1e-12) <= vs <= hi * (1 + 1e-12):
            raise ValueError(f"V* = {vs:g} outside the table's [{lo:g}, {hi:g}]")
        # every row is the same bridge whatever P: two rows spanning every P asked
        s_axis = np.array([1e-3 * rad[0] / (ratios[-1] * L), 1e3])
        vstar = np.full(2, min(max(vs, lo), hi))
        families = [(rho, vstar[0]) for rho in ratios]          # (ratio, V*) bridges formed
    else:
        V = float(bridge_volume)
        if rad.size > max_exact_radii:
            raise NotImplementedError(
                f"{rad.size} distinct radii: YADE's Law2 cannot hold a fixed SI volume for a "
                "continuous size distribution accurately; use bridge_volume_star, or "
                "CapbridgeEngine (Python) for this rule")
        vs_pairs = V / rad**3
        if vs_pairs.min() < lo * (1 - 1e-12) or vs_pairs.max() > hi * (1 + 1e-12):
            raise ValueError(f"bridge_volume {V:g} m^3 gives V* from {vs_pairs.min():g} to "
                             f"{vs_pairs.max():g} over the radii; the table covers [{lo:g}, {hi:g}]")
        # the smaller radii r = s L the files are asked for: a pair's larger radius R
        # over every file ratio
        s_axis = distinct_values((rad[:, None] / ratios[None, :]).ravel() / L)
        vstar = V / (s_axis * L) ** 3
        families = [(r2 / r1, V / r1**3) for r1 in rad for r2 in rad if r2 >= r1 * (1 - 1e-12)]
    ok_v = (vstar >= lo * (1 - 1e-12)) & (vstar <= hi * (1 + 1e-12))
    vq = np.clip(vstar, lo, hi)
    # gap axis: uniform in s = sqrt(1 - d/d_rupt) for every bridge the scene forms, plus
    # the same for every file ratio at each row (so each file ends at its own ruptures)
    sigma = np.linspace(0.0, 1.0, int(n_gaps))
    sigma = np.concatenate([sigma, np.linspace(0.0, sigma[1], 9)[1:-1]])   # finer next to rupture
    fam_r = np.array([f[0] for f in families])
    fam_v = np.array([f[1] for f in families])
    fam_t = SceneTable(st.surrogate, [theta], fam_r, variables=("force",))
    d_fam = fam_t.predict(0.0, fam_v, theta, fam_r)["rupture_gap"]
    rr, kk = np.meshgrid(ratios, np.arange(s_axis.size), indexing="ij")
    d_rows = st.predict(0.0, vq[kk], theta, rr)["rupture_gap"]            # (ratio, row)
    # uniform in s (rupture) and in d (contact), and a point just past each rupture so
    # that YADE's fade to zero past the last block a bridge holds is negligible
    grids = [d_fam[:, None] * (1 - sigma**2), d_fam[:, None] * sigma, d_fam[:, None] * (1 + 1e-9)]
    if bridge_volume_star is not None:
        grids += [d_rows[:, :1] * (1 - sigma**2), d_rows[:, :1] * sigma]
    gaps = distinct_values(np.concatenate([[0.0]] + [g.ravel() for g in grids]), rtol=1e-10)
    R, K, G = np.meshgrid(ratios, np.arange(s_axis.size), gaps, indexing="ij")
    pred = st.predict(G, vq[K], theta, R, ("force", "beta1", "beta2"))
    alive = (G <= pred["rupture_gap"]) & ok_v[K]
    status = np.where(alive, int(Status.CONVERGED), int(Status.RUPTURED))
    edge = None
    if bridge_volume is not None:
        edge = _rupture_rows(st, theta, ratios, gaps, V, L, s_axis, lo, hi)
    table_ = ye.SuctionTable(
        ratio=ratios, suction=s_axis, gap=gaps, volume=np.where(alive, vq[K], np.nan),
        force=np.where(alive, pred["force"], 0.0), beta1=np.where(alive, pred["beta1"], np.nan),
        beta2=np.where(alive, pred["beta2"], np.nan), status=status, theta=theta, edge=edge,
        attrs={"source": "capbridge.yade.native_volume",
               "meaning": "suction axis = smaller radius / L, not a suction: volume-controlled "
                          "bridges with a fixed volume per bridge",
               "L": L, "bridge_volume": bridge_volume, "bridge_volume_star": bridge_volume_star})
    # rupture distance over r1 + r2 for the detection range of the scene's pairs
    reach = float(np.max(d_fam / (1.0 + fam_r)))
    info = {"L": L, "ratios": ratios.tolist(), "n_gaps": int(gaps.size),
            "n_rows": int(s_axis.size), "max_rupture_over_rsum": reach,
            "rule": "bridge_volume_star" if bridge_volume_star is not None else "bridge_volume",
            "vstar": bridge_volume_star}
    return table_, info


def _rupture_rows(sur_tab, theta, ratios, gaps, V, L, s_axis, lo, hi, n_iter=60):
    """For every ratio and grid gap g: the size s whose bridge ruptures exactly at g
    (bisection on s, the rupture gap decreasing with s), as SuctionTable.edge."""
    n_r, n_g = ratios.size, gaps.size
    out = {k: np.full((n_r, n_g), np.nan) for k in ye.SuctionTable.EDGE_KEYS}
    s_lo = max(s_axis[0], (V / hi) ** (1 / 3) / L)
    s_hi = min(s_axis[-1], (V / lo) ** (1 / 3) / L)
    for i, rho in enumerate(ratios):
        def d_r(s):
            return sur_tab.predict(0.0, V / (s * L) ** 3, theta, rho)["rupture_gap"]
        d_lo, d_hi = d_r(np.array([s_lo]))[0], d_r(np.array([s_hi]))[0]
        inside = (gaps > d_hi) & (gaps < d_lo)
        if not inside.any():
            continue
        g = gaps[inside]
        a = np.full(g.size, s_lo)
        b = np.full(g.size, s_hi)
        for _ in range(n_iter):
            m = 0.5 * (a + b)
            big = d_r(m) > g
            a = np.where(big, m, a)
            b = np.where(big, b, m)
        s = 0.5 * (a + b)
        vs = V / (s * L) ** 3
        p = sur_tab.predict(g * (1 - 1e-12), vs, theta, rho, ("force", "beta1", "beta2"))
        out["suction"][i, inside] = s
        out["gap"][i, inside] = g
        out["volume"][i, inside] = vs
        for k in ("force", "beta1", "beta2"):
            out[k][i, inside] = p[k]
    return out


class NativeVolumeBridges:
    """Fixed-volume bridges through YADE's compiled Law2 (module docstring).

    >>> nb = NativeVolumeBridges("tables", theta=30, radii=radii, bridge_volume_star=0.02)
    ... # doctest: +SKIP
    >>> O.engines = [ForceResetter(),
    ...     InsertionSortCollider([Bo1_Sphere_Aabb(aabbEnlargeFactor=nb.detection_factor)]),
    ...     InteractionLoop([Ig2_Sphere_Sphere_ScGeom(interactionDetectionFactor=nb.detection_factor)],
    ...                     [Ip2_FrictMat_FrictMat_CapillaryPhys()],
    ...                     [Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)]),
    ...     nb.law2(), NewtonIntegrator(...)]                       # doctest: +SKIP

    Parameters: ``directory`` for the files, ``theta`` [deg], ``radii`` of the wet
    spheres (or the distinct radii), exactly one of ``bridge_volume`` [m^3] /
    ``bridge_volume_star``, ``gamma`` [N/m], ``n_gaps`` (distance blocks per bridge
    family), ``table``.
    """

    def __init__(self, directory, theta, radii, *, bridge_volume=None, bridge_volume_star=None,
                 gamma=0.073, n_gaps=60, table=None, suffix=None):
        self.directory = Path(directory)
        self.theta = float(theta)
        self.gamma = float(gamma)
        self.radii = distinct_values(radii)
        self.bridge_volume = bridge_volume
        self.bridge_volume_star = bridge_volume_star
        self.suffix = suffix or ("_cbvol" + ye.theta_suffix(theta)[len("_theta") - 1:])
        self.table, self.info = volume_suction_table(
            theta, self.radii, bridge_volume=bridge_volume, bridge_volume_star=bridge_volume_star,
            table=table, n_gaps=n_gaps)
        self.L = self.info["L"]
        self._radius = {}                  # body id -> radius, filled by scan()
        with warnings.catch_warnings():
            # the ratios above the scene's get bridge-free placeholder files on purpose
            warnings.filterwarnings("ignore", message="writing bridge-free placeholder")
            warnings.filterwarnings("ignore", message=".*non-converged points inside")
            # a file ending at the last gap while bridges hold there is what is wanted:
            # that gap is the rupture distance of the scene's largest bridge
            warnings.filterwarnings("ignore", message=".*still hold a bridge at the last gap")
            self.paths = ye.write_capillary_files(self.table, self.directory, self.suffix,
                                                  missing="stub")

    @property
    def capillary_pressure(self):
        """The ``capillaryPressure`` [Pa] that makes P = R / L."""
        return self.gamma / self.L

    @property
    def detection_factor(self):
        """``aabbEnlargeFactor`` / ``interactionDetectionFactor`` covering rupture."""
        return 1.0 + 1.05 * self.info["max_rupture_over_rsum"]

    def law2(self, label="capillary"):
        """The configured ``Law2_ScGeom_CapillaryPhys_Capillarity`` (reads the files now)."""
        from yade import wrapper

        with chdir(self.directory):
            return wrapper.Law2_ScGeom_CapillaryPhys_Capillarity(
                capillaryPressure=self.capillary_pressure, surfaceTension=self.gamma,
                suffCapFiles=self.suffix, label=label)

    # ------------------------------------------------------------------ bookkeeping
    def scan(self, coalescence=True, pairs=False):
        """Read YADE's bridges (a Python loop over the interactions: call it now and
        then, not every step).  Returns a dict: number of bridges, their total volume
        and what the rule says it must be, and the coalescence summary (geometric
        criterion on YADE's filling angles: ``Delta1`` on the smaller grain)."""
        import yade
        from capbridge.dem.coalescence_detect import find_coalescence
        from capbridge.yade.engine import bulk_centres, rows_of_ids

        O = yade.Omega()
        id1, id2, vol, dl1, dl2 = [], [], [], [], []
        for i in O.interactions:
            if not i.isReal:
                continue
            p = i.phys
            if getattr(p, "meniscus", False) and p.vMeniscus > 0:
                id1.append(i.id1); id2.append(i.id2); vol.append(p.vMeniscus)
                dl1.append(p.Delta1); dl2.append(p.Delta2)
        id1, id2 = np.array(id1, np.intp), np.array(id2, np.intp)
        vol = np.array(vol)
        for b in set(id1.tolist()) | set(id2.tolist()):
            if b not in self._radius:
                self._radius[b] = O.bodies[b].shape.radius
        r1 = np.array([self._radius[b] for b in id1.tolist()])
        r2 = np.array([self._radius[b] for b in id2.tolist()])
        if self.bridge_volume is not None:
            expected = np.full(id1.size, float(self.bridge_volume))
        else:
            expected = float(self.bridge_volume_star) * np.minimum(r1, r2) ** 3
        out = {"n_bridges": int(id1.size), "total_volume": float(vol.sum()),
               "rule_volume": float(expected.sum()),
               "max_volume_deviation": float(np.max(np.abs(vol / expected - 1), initial=0.0))}
        if pairs:
            out["pairs"] = np.column_stack([id1, id2])
        if coalescence and id1.size:
            where, n_bodies = rows_of_ids(O)
            small1 = r1 <= r2
            dl1, dl2 = np.array(dl1), np.array(dl2)
            rep = find_coalescence(bulk_centres(), where[id1], where[id2],
                                   np.where(small1, dl1, dl2), np.where(small1, dl2, dl1), vol,
                                   n_grains=n_bodies)
            out["coalescence"] = rep.summary()
        return out

    def bridge_volume_of(self, r1, r2):
        """The volume [m^3] of a bridge between radii r1, r2 under the rule."""
        if self.bridge_volume is not None:
            return float(self.bridge_volume)
        return float(self.bridge_volume_star) * min(r1, r2) ** 3


def ratio_interpolation_error(theta, vstar, ratio, gaps_star, table=None):
    """Relative force error of YADE's linear interpolation between its two ratio files
    around ``ratio`` against capbridge's lookup, for a V* bridge at ``gaps_star``."""
    ratios = np.array(ye.YADE_RATIOS)
    k = int(np.searchsorted(ratios, ratio))
    lo, hi = ratios[k - 1], ratios[k]
    st = SceneTable(table if table is not None else default_table_path(), [theta],
                    [lo, hi, ratio])
    g = np.asarray(gaps_star, float)
    # YADE: each file at the same larger radius R = ratio r and the same D = d/R
    f = {}
    for rho in (lo, hi):
        r_small = ratio / rho                       # in units of the pair's smaller radius
        f[rho] = st.predict(g / r_small, vstar, theta, rho)["force"] * r_small
    w = (ratio - lo) / (hi - lo)
    yade = (1 - w) * f[lo] + w * f[hi]
    true = st.predict(g, vstar, theta, ratio)["force"]
    return yade / true - 1.0
