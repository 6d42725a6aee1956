"""capbridge's capillary engine for YADE: volume-controlled doublet bridges from the tables.

Usage inside a YADE scene (``docs/yade_plugin.md`` has the parameters and a scene to
copy)::

    from capbridge.dem_plugin.engine import CapbridgeEngine
    cap = CapbridgeEngine(theta=30.0, gamma=0.073, bridge_volume=2e-12)
    O.engines = [ForceResetter(),
                 InsertionSortCollider([Bo1_Sphere_Aabb(), Bo1_Box_Aabb()]),
                 InteractionLoop([Ig2_Sphere_Sphere_ScGeom(), Ig2_Box_Sphere_ScGeom()],
                                 [Ip2_FrictMat_FrictMat_FrictPhys()],
                                 [Law2_ScGeom_FrictPhys_CundallStrack()]),
                 cap.pyrunner(),                 # after the contacts, before Newton
                 NewtonIntegrator(gravity=(0, 0, -9.81), damping=0.3)]

What runs where
---------------
YADE's compiled engines do the contacts (collider, Ig2/Ip2/Law2) and the integration;
the capillary bridges are a vectorised numpy step called by a ``PyRunner``:
positions of all grains in one bulk read (``yade._utils.coordsAndDisplacements``),
bridge formation from a Verlet list of near pairs (rebuilt with a k-d tree only when a
grain has moved half the skin), rupture against the table's rupture gap, forces from the
tabulated doublet solutions (:class:`~capbridge.dem_plugin.bridges.SceneTable`: the
surrogate's fine grid for the scene's angles and ratios only), and one ``O.forces.addF``
per wet grain.  No YADE interaction is read (``geom.normal`` is slow from Python), and
YADE's collider keeps its dry settings: bridges beyond contact are capbridge's own list,
not YADE interactions, so no enlarged detection range is needed.  With
``refresh_every=N`` the bridges are updated every N steps and their forces held as
permanent forces in between.

YADE's compiled engines where they can do the work (measured, see
``benchmarks/RESULTS.md``): a fixed volume per bridge on YADE's file radius
ratios runs natively in ``Law2_ScGeom_CapillaryPhys_Capillarity`` on capbridge's
volume-controlled files (:mod:`capbridge.dem_plugin.native_volume`); suction-controlled
scenes run in the same law on capbridge's suction export (:func:`suction_law2`).
This engine is for what those cannot do: a volume per bridge (conserved liquid, water
content), contact angles per material, any radius ratio, coalescence reports.
``CapillarityEngine`` (volume mode) was measured and not used: it gives no volume to
bridges formed after its first step (Python would have to), reads one table per
process, interpolates in tetrahedra (0.5-3 % between suctions) and its stale
tetrahedron cache (``yade_export.FORMAT_NOTES``) gives wrong forces, or, seen on
capbridge's files, a lookup that does not return.

Coalescence: every ``coalescence_every`` steps, if some grain holds two bridges, the
geometric criterion (:mod:`capbridge.dem_plugin.coalescence_detect`) is applied; merged
bridges are reported in :meth:`CapbridgeEngine.state` and in a log line whenever their
number changes.  Their forces stay the doublet forces of each bridge (no triplet table
yet).
"""
from __future__ import annotations

import logging
import math
import time
from contextlib import chdir  # YADE reads its capillary files from the working directory
from pathlib import Path

import numpy as np

from capbridge.dem_plugin.bridges import BridgeModel, LiquidRule, default_table_path
from capbridge.dem_plugin.coalescence_detect import find_coalescence

__all__ = ["CapbridgeEngine", "suction_law2", "get_engine", "ENGINE_PARAMETERS"]

log = logging.getLogger("capbridge.yade")

#: Engines by label, for the PyRunner commands.
_REGISTRY: dict = {}

#: name -> (default, meaning); the table of docs/yade_plugin.md is made from this.
ENGINE_PARAMETERS = {
    "theta": (0.0, "contact angle [deg]: one number, or a dict {material label or id: "
                   "angle} (a pair of different angles uses their mean)"),
    "gamma": (0.073, "liquid-gas surface tension [N/m]"),
    "bridge_volume": (None, "fixed rule: every bridge that forms gets this volume [m^3]"),
    "bridge_volume_star": (None, "fixed rule: every bridge gets V = V* r^3, r its smaller "
                                 "radius"),
    "liquid_volume": (None, "total liquid [m^3] (shared among the initial bridges)"),
    "water_content": (None, "total liquid as mass of liquid / mass of grains"),
    "saturation": (None, "total liquid as degree of saturation S_r = V_liquid / V_pores "
                         "(needs sample_volume)"),
    "sample_volume": (None, "volume of the sample [m^3], for saturation"),
    "liquid_density": (1000.0, "liquid density [kg/m^3], for water_content"),
    "conserve_liquid": (None, "True: liquid conserved (ruptured bridges return it to their "
                              "grains, new bridges take it from them); False: every bridge "
                              "gets the same fixed volume; default True for a total liquid, "
                              "False for a bridge volume"),
    "film_fraction": (0.5, "conserving rule: fraction of each grain's liquid a new bridge "
                           "takes"),
    "formation_gap": (0.0, "a bridge forms when the gap between surfaces is <= this [m]"),
    "initial_wet_gap": (None, "at the first step, pairs with gap <= this [m] get a bridge "
                              "(default formation_gap)"),
    "initial_pairs": (None, "at the first step, exactly these pairs of body ids get a bridge "
                            "(instead of initial_wet_gap)"),
    "refresh_every": (1, "update bridges and forces every N steps (forces held constant, "
                         "as permanent forces, in between)"),
    "force_tolerance": (1e-3, "a bridge's force vector is handed to YADE again only when "
                              "it has changed by more than this fraction of its magnitude "
                              "(held as a permanent force meanwhile); 0: every step"),
    "coalescence": (True, "detect coalesced bridges (report only)"),
    "coalescence_every": (100, "steps between coalescence checks"),
    "table": (None, "doublet table (path, Dataset or DoubletSurrogate); default the shipped "
                    "data/doublet_table.nc"),
    "ids": (None, "body ids of the wet spheres (default every sphere)"),
    "skin": (None, "Verlet skin of the near-pair list [m] (default 0.1 x smallest radius)"),
    "ratio_step": (0.01, "ratio node spacing for continuous size distributions"),
    "label": ("capbridge", "name of the engine (PyRunner label, registry key)"),
}


def get_engine(label="capbridge"):
    """The :class:`CapbridgeEngine` registered under ``label``."""
    return _REGISTRY[label]


def _yade():
    import yade  # noqa: F401  (the caller made it importable)
    from yade import wrapper
    return yade, wrapper


def _bulk_centres():
    """(n, 3) centres of all bodies, in ``O.bodies`` order: one bulk read per axis."""
    from yade import _utils

    return np.column_stack([np.fromiter(_utils.coordsAndDisplacements(k)[0], float)
                            for k in range(3)])


def _rows_of_ids(O):
    """``(rows, n)``: the row of every body id in :func:`_bulk_centres` (-1: no body)
    and the number of bodies."""
    order = np.array([b.id for b in O.bodies], np.intp)
    rows = np.full(order.max(initial=0) + 1, -1, np.intp)
    rows[order] = np.arange(order.size)
    return rows, order.size


class CapbridgeEngine:
    """Volume-controlled capillary bridges from capbridge's doublet table, in YADE.

    See :data:`ENGINE_PARAMETERS` (and ``docs/yade_plugin.md``) for the parameters.
    The engine reads the grains (radii, materials, masses) at its first step; create it
    before or after the bodies, but do not add or remove wet spheres afterwards
    (call :meth:`reset` if you do).

    Liquid rules (exactly one amount must be given):

    * ``bridge_volume`` / ``bridge_volume_star``: **fixed volume per bridge**.  Every
      bridge that forms (at the first step on the pairs within ``initial_wet_gap``,
      later at contact) gets that volume and keeps it until it ruptures.  Liquid is
      not conserved: a ruptured bridge's liquid leaves the scene, a new bridge brings
      new liquid (as in YADE's ViscElCapMat).  Ledger: active = initial + formed -
      ruptured.
    * ``liquid_volume`` / ``water_content`` / ``saturation``: a **total liquid** W.
      At the first step W is shared equally among the bridges formed then.  With
      ``conserve_liquid=True`` (default) the liquid is conserved: a ruptured bridge
      gives its liquid to its two grains (split in proportion to R^2), a new bridge
      at contact takes ``film_fraction`` of what each of its grains holds (no bridge if
      that is below the table's smallest V*; capped at its largest).  Ledger: bridges
      + liquid on grains = W.  With ``conserve_liquid=False`` the equal share becomes
      the fixed volume of every later bridge (fixed rule).
    """

    def __init__(self, theta=0.0, gamma=0.073, *, bridge_volume=None, bridge_volume_star=None,
                 liquid_volume=None, water_content=None, saturation=None, sample_volume=None,
                 liquid_density=1000.0, conserve_liquid=None, film_fraction=0.5,
                 formation_gap=0.0, initial_wet_gap=None, initial_pairs=None, refresh_every=1,
                 force_tolerance=1e-3, coalescence=True,
                 coalescence_every=100, table=None, ids=None, skin=None, ratio_step=0.01,
                 label="capbridge"):
        totals = [k for k, v in (("liquid_volume", liquid_volume), ("water_content", water_content),
                                 ("saturation", saturation)) if v is not None]
        per_bridge = [k for k, v in (("bridge_volume", bridge_volume),
                                     ("bridge_volume_star", bridge_volume_star)) if v is not None]
        if len(totals) + len(per_bridge) != 1:
            raise ValueError("give exactly one of bridge_volume, bridge_volume_star, "
                             "liquid_volume, water_content, saturation "
                             f"(got {totals + per_bridge or 'none'})")
        if saturation is not None and sample_volume is None:
            raise ValueError("saturation needs sample_volume (the volume of the sample, m^3)")
        if per_bridge and conserve_liquid:
            raise ValueError("conserve_liquid=True needs a total liquid (liquid_volume, "
                             "water_content or saturation), not a bridge volume")
        if int(refresh_every) < 1:
            raise ValueError("refresh_every must be >= 1")
        self.theta = theta
        self.gamma = float(gamma)
        self.amount = {"bridge_volume": bridge_volume, "bridge_volume_star": bridge_volume_star,
                       "liquid_volume": liquid_volume, "water_content": water_content,
                       "saturation": saturation}
        self.sample_volume = sample_volume
        self.liquid_density = float(liquid_density)
        self.conserve_liquid = conserve_liquid
        self.film_fraction = float(film_fraction)
        self.formation_gap = float(formation_gap)
        self.initial_wet_gap = initial_wet_gap
        self.initial_pairs = None if initial_pairs is None else [tuple(map(int, p)) for p in initial_pairs]
        self.refresh_every = int(refresh_every)
        self.force_tolerance = float(force_tolerance)
        if not self.force_tolerance >= 0:
            raise ValueError("force_tolerance must be >= 0")
        self.coalescence = bool(coalescence)
        self.coalescence_every = max(1, int(coalescence_every))
        self.table = table if table is not None else default_table_path()
        self.ids_requested = None if ids is None else [int(i) for i in ids]
        self.skin = skin
        self.ratio_step = float(ratio_step)
        self.label = str(label)
        self.model = None
        self.coalescence_report = None
        self._coal_summary = {"searched": False, "triplets": 0, "clusters": 0,
                              "coalesced_volume": 0.0, "checks": 0}
        self._perm_rows = np.empty(0, np.intp)
        self._last_geom = None
        self._coal_last = 0
        self._coal_logged = 0
        self.timings = {"steps": 0, "seconds": 0.0, "cpu_seconds": 0.0, "setup_seconds": 0.0,
                        "coalescence_seconds": 0.0}
        self.events = {"formed": 0, "ruptured": 0}
        self.messages = []
        _REGISTRY[self.label] = self

    # ----------------------------------------------------------------------- YADE side
    def pyrunner(self):
        """The ``PyRunner`` to put in ``O.engines`` after the ``InteractionLoop`` and
        before the ``NewtonIntegrator``."""
        _, wrapper = _yade()
        cmd = ("from capbridge.dem_plugin.engine import _REGISTRY as _cbr; "
               f"_cbr[{self.label!r}].step()")
        return wrapper.PyRunner(command=cmd, iterPeriod=self.refresh_every, initRun=True,
                                label=self.label)

    def reset(self):
        """Forget the bridges and the grains (read again at the next step)."""
        self._clear_perm()
        self.model = None

    def _materials_theta(self, bodies):
        th = self.theta
        out = np.empty(len(bodies))
        if isinstance(th, dict):
            for k, b in enumerate(bodies):
                m = b.material
                for key in (m.label, m.id, m):
                    if isinstance(key, (str, int)) and key in th:
                        out[k] = float(th[key])
                        break
                else:
                    raise ValueError(f"no contact angle for body {b.id}'s material "
                                     f"(label {m.label!r}, id {m.id}); theta has {list(th)}")
        else:
            out[:] = float(th)
        return out

    def _setup(self):
        t0 = time.perf_counter()
        yade, wrapper = _yade()
        O = yade.Omega()
        sphere_cls = wrapper.Sphere
        if self.ids_requested is None:
            bodies = [b for b in O.bodies if b is not None and isinstance(b.shape, sphere_cls)]
        else:
            bodies = [O.bodies[i] for i in self.ids_requested]
            if any(b is None or not isinstance(b.shape, sphere_cls) for b in bodies):
                raise ValueError("ids must be ids of existing spheres")
        if not bodies:
            raise ValueError("no spheres in the scene")
        if O.periodic:
            raise NotImplementedError("periodic cells are not supported by CapbridgeEngine")
        self.ids = np.array([b.id for b in bodies], np.intp)
        radii = np.array([b.shape.radius for b in bodies], float)
        theta = self._materials_theta(bodies)
        W = None
        a = self.amount
        if a["liquid_volume"] is not None:
            W = float(a["liquid_volume"])
        elif a["water_content"] is not None:
            mass = float(sum(b.state.mass for b in bodies))
            W = float(a["water_content"]) * mass / self.liquid_density
        elif a["saturation"] is not None:
            v_s = float((4.0 / 3.0 * math.pi * radii**3).sum())
            v_p = float(self.sample_volume) - v_s
            if not v_p > 0:
                raise ValueError(f"sample_volume {self.sample_volume:g} m^3 is not larger than "
                                 f"the grains' volume {v_s:g} m^3")
            W = float(a["saturation"]) * v_p
        rule = LiquidRule(bridge_volume=a["bridge_volume"],
                          bridge_volume_star=a["bridge_volume_star"], total_liquid=W,
                          conserve=self.conserve_liquid, film_fraction=self.film_fraction)
        self.model = BridgeModel(radii, theta, self.table, self.gamma, rule,
                                 formation_gap=self.formation_gap,
                                 initial_wet_gap=self.initial_wet_gap, skin=self.skin,
                                 with_beta=self.coalescence, ratio_step=self.ratio_step)
        self._map_rows()
        self.timings["setup_seconds"] += time.perf_counter() - t0
        tab = self.model.table
        self._say("info", f"capbridge engine {self.label!r}: {len(bodies)} spheres, rule "
                  f"{rule.kind}, angles {tab.thetas.tolist()} deg, ratio nodes "
                  f"{tab.ratio_nodes.size} ({'exact' if tab.discrete else 'interpolated'}), "
                  f"table slices {tab.nbytes / 1e6:.1f} MB, refresh every {self.refresh_every}")

    def _map_rows(self):
        """Rows of our spheres in the bulk position read (body iteration order)."""
        yade, _ = _yade()
        where, self._n_read = _rows_of_ids(yade.Omega())
        self._rows = where[self.ids]
        if np.any(self._rows < 0):
            raise RuntimeError("a wet sphere was erased; call reset()")

    def positions(self):
        """(n, 3) centres of the wet spheres, one bulk read per axis."""
        xyz = _bulk_centres()
        if xyz.shape[0] != self._n_read:
            self._map_rows()
        return xyz[self._rows]

    def step(self):
        """One update (called by the PyRunner)."""
        t0, c0 = time.perf_counter(), time.thread_time()
        yade, _ = _yade()
        O = yade.Omega()
        if self.model is None:
            self._setup()
        it = int(O.iter)
        pos = self.positions()
        pairs = None
        if not self.model.initialised and self.initial_pairs is not None:
            row = {b: k for k, b in enumerate(self.ids.tolist())}
            try:
                pairs = [(row[a], row[b]) for a, b in self.initial_pairs]
            except KeyError as exc:
                raise ValueError(f"initial_pairs: body {exc} is not a wet sphere") from None
        geom = self.model.update(pos, step=it, initial_pairs=pairs)
        self.events["formed"] += geom["formed"]
        self.events["ruptured"] += geom["ruptured"]
        forces, changed = self.model.grain_forces(geom, self.force_tolerance)
        self._apply(forces, changed, O)
        self._last_geom = geom
        if self.coalescence and (self._coal_summary["checks"] == 0
                                 or it - self._coal_last >= self.coalescence_every):
            self.check_coalescence(pos, geom)
            self._coal_last = it
        self.timings["steps"] += 1
        self.timings["seconds"] += time.perf_counter() - t0
        self.timings["cpu_seconds"] += time.thread_time() - c0

    def _apply(self, forces, changed, O):
        """Hand the grain forces to YADE: ``addF`` every step when nothing is held
        (tolerance 0, refresh every step), else permanent forces on changed grains."""
        if self.force_tolerance == 0.0 and self.refresh_every == 1:
            nz = np.flatnonzero(np.any(forces != 0.0, axis=1))
            add = O.forces.addF
            for i, f in zip(self.ids[nz].tolist(), forces[nz].tolist()):
                add(i, f)
            return
        setp = O.forces.setPermF
        for i, f in zip(self.ids[changed].tolist(), forces[changed].tolist()):
            setp(i, f)
        self.timings["perm_updates"] = self.timings.get("perm_updates", 0) + int(changed.size)
        self._perm_rows = np.union1d(self._perm_rows, changed)

    def _clear_perm(self):
        if self._perm_rows.size and self.model is not None:
            yade, _ = _yade()
            O = yade.Omega()
            for i in self.ids[self._perm_rows].tolist():
                O.forces.setPermF(i, (0.0, 0.0, 0.0))
        self._perm_rows = np.empty(0, np.intp)

    # --------------------------------------------------------------------- coalescence
    def check_coalescence(self, pos=None, geom=None):
        """Apply the coalescence criterion now; returns the report (also kept)."""
        t0 = time.perf_counter()
        m = self.model
        if pos is None:
            pos = self.positions()
        gap = (geom or self._last_geom or m.update(pos, form=False))["gap"]
        self._coal_summary["checks"] += 1
        deg = (np.bincount(m.bi, minlength=m.n) + np.bincount(m.bj, minlength=m.n)) if m.n_bridges else np.zeros(1)
        if deg.max(initial=0) < 2:            # no grain holds two bridges: no search
            rep = find_coalescence(pos, m.bi, m.bj, np.empty(0), np.empty(0), m.vol, m.n)
        else:
            bi_ang, bj_ang = m.filling_angles(gap)
            rep = find_coalescence(pos, m.bi, m.bj, bi_ang, bj_ang, m.vol, m.n)
        s = rep.summary()
        s["checks"] = self._coal_summary["checks"]
        s["iter"] = self._iter()
        self._coal_summary = s
        self.coalescence_report = rep
        # a log line when merged bridges appear or vanish, or their number moves by 10 %
        # (and by at least 2)
        last = self._coal_logged
        n = rep.n_triplets
        if (n > 0) != (last > 0) or abs(n - last) >= max(2.0, 0.1 * last):
            self._coal_logged = n
            self._say("warning", f"capbridge {self.label!r} iter {s['iter']}: {n} "
                      f"coalesced bridge pairs (triplets, {s['closed_triangles']} closed "
                      f"triangles) in {rep.n_clusters} liquid clusters holding "
                      f"{rep.coalesced_volume:.4g} m^3 in {rep.n_bridges_in_clusters} "
                      "bridges; their forces stay doublet forces (no triplet table yet)")
        self.timings["coalescence_seconds"] += time.perf_counter() - t0
        return rep

    def coalesced_triplets(self):
        """(m, 3) body ids (j, i, k) of the coalesced pairs of bridges (i shared)."""
        rep = self.coalescence_report
        if rep is None or rep.n_triplets == 0:
            return np.empty((0, 3), np.intp)
        return self.ids[rep.triplets]

    # ---------------------------------------------------------------------- reporting
    def _iter(self):
        try:
            yade, _ = _yade()
            return int(yade.Omega().iter)
        except Exception:  # pragma: no cover
            return -1

    def _say(self, level, text):
        self.messages.append(text)
        del self.messages[:-200]
        getattr(log, level)(text)

    def bridges(self):
        """Current bridges: dict of arrays (body ids, volume [m^3], V*, gap [m], force
        [N], rupture gap [m])."""
        m = self.model
        if m is None:
            return {}
        g = self._last_geom
        same = g is not None and g["gap"].size == m.n_bridges
        return {"id1": self.ids[m.bi], "id2": self.ids[m.bj], "volume": m.vol.copy(),
                "vstar": m.vstar.copy(), "gap": g["gap"].copy() if same else None,
                "force": g["force"].copy() if same else None, "rupture_gap": m.d_rupt_si.copy()}

    def budget(self):
        """The liquid ledger (:meth:`BridgeModel.budget`)."""
        return self.model.budget() if self.model is not None else {}

    def state(self):
        """JSON-friendly summary: bridges, liquid ledger, coalescence, timings."""
        m = self.model
        out = {"label": self.label, "iter": self._iter(), "initialised": m is not None,
               "refresh_every": self.refresh_every, "events": dict(self.events),
               "timings": dict(self.timings), "coalescence": dict(self._coal_summary)}
        if m is not None:
            g = self._last_geom
            out.update(n_spheres=int(m.n), n_bridges=m.n_bridges, budget=m.budget(),
                       thetas=m.table.thetas.tolist(), ratio_nodes=m.table.ratio_nodes.tolist(),
                       table_mbytes=m.table.nbytes / 1e6,
                       candidate_pairs=int(m.cand.i.size), verlet_rebuilds=m.cand.rebuilds,
                       total_force=float(g["force"].sum()) if g is not None else 0.0,
                       finite=bool(np.all(np.isfinite(g["force"]))) if g is not None else True)
        return out


# ------------------------------------------------------------------------------------
# Suction-controlled scenes: YADE's compiled Law2 with capbridge's export
# ------------------------------------------------------------------------------------


def suction_law2(directory, theta, suction, gamma=0.073, *, export_if_missing=True,
                 label="capillary", **export_kw):
    """YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity`` reading capbridge's ``M(r=...)``
    files for contact angle ``theta`` (suction-controlled bridges, native speed).

    ``suction`` = u_gas - u_liquid [Pa].  The files are looked for in ``directory``
    (suffix :func:`~capbridge.dem_plugin.yade_export.theta_suffix`); if missing they
    are computed with the exact solver (:func:`~capbridge.dem_plugin.yade_export.
    export_from_solver`, keyword arguments ``export_kw``; minutes for the full ratio
    set).  YADE reads them when the engine is built, so the working directory only
    matters here.  Use with ``Ip2_FrictMat_FrictMat_CapillaryPhys``,
    ``Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)`` and a detection range
    covering the rupture distance (``aabbEnlargeFactor`` / ``interactionDetectionFactor``).
    """
    from capbridge.dem_plugin import yade_export as ye

    directory = Path(directory)
    suffix = ye.theta_suffix(theta)
    files = [directory / ye.capillary_file_name(r, suffix) for r in ye.YADE_RATIOS]
    if not all(f.exists() for f in files):
        if not export_if_missing:
            raise FileNotFoundError(f"capillary files {suffix} missing in {directory}")
        ye.export_from_solver(directory, theta, suffix=suffix, delaunay=False, **export_kw)
    _, wrapper = _yade()
    with chdir(directory):
        return wrapper.Law2_ScGeom_CapillaryPhys_Capillarity(
            capillaryPressure=float(suction), surfaceTension=float(gamma),
            suffCapFiles=suffix, label=label)
