"""capbridge's capillary engine for YADE: volume-controlled doublet bridges from the tables.

Usage inside a YADE scene (``docs/yade_plugin.md`` has the parameters and a scene to
copy)::

    from capbridge.yade.engine import CapbridgeEngine
    from capbridge.yade.config import BridgeVolume, Speed
    cap = CapbridgeEngine(theta=30.0, gamma=0.073, liquid=BridgeVolume(2e-12),
                          speed=Speed(refresh_every=1))
    # the same engine with the flat keywords (the shim kept for older scenes and
    # restart files, see capbridge.yade.config):
    # cap = CapbridgeEngine(theta=30.0, gamma=0.073, bridge_volume=2e-12)
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
tabulated doublet solutions (:class:`~capbridge.dem.bridges.SceneTable`: the
surrogate's fine grid for the scene's angles and ratios only), and one ``O.forces.addF``
per wet grain.  No YADE interaction is read (``geom.normal`` is slow from Python), and
YADE's collider keeps its dry settings: bridges beyond contact are capbridge's own list,
not YADE interactions, so no enlarged detection range is needed.  With
``refresh_every=N`` the bridges are updated every N steps and their forces held as
permanent forces in between.

YADE's compiled engines where they can do the work (measured, see
``benchmarks/RESULTS.md``): a fixed volume per bridge on YADE's file radius
ratios runs natively in ``Law2_ScGeom_CapillaryPhys_Capillarity`` on capbridge's
volume-controlled files (:mod:`capbridge.yade.native_volume`); suction-controlled
scenes run in the same law on capbridge's suction export (:func:`suction_law2`).
This engine is for what those cannot do: a volume per bridge (conserved liquid, water
content), contact angles per material, any radius ratio, coalescence reports.
``CapillarityEngine`` (volume mode) was measured and not used: it gives no volume to
bridges formed after its first step (Python would have to), reads one table per
process, interpolates in tetrahedra (0.5-3 % between suctions) and its stale
tetrahedron cache (``yade_export.FORMAT_NOTES``) gives wrong forces, or, seen on
capbridge's files, a lookup that does not return.

Forces are added, never set: with the defaults (refresh every step,
``force_tolerance=0``) the engine calls ``O.forces.addF`` once per wet grain and step,
on top of whatever the contact laws, the user's ``addF`` and the user's permanent
forces put there.  With ``refresh_every > 1`` or ``force_tolerance > 0`` it holds its
forces as permanent forces, *adding* its change to the permanent force present
(``permF - ours_before + ours_now``), so a permanent force the user set before is kept.

Gravity on the liquid (:mod:`capbridge.dem.liquid_gravity`): the engine reads g
from the scene's ``NewtonIntegrator.gravity`` at every refresh (never writes it) and adds
to the two grains of every bridge the liquid's weight drho V g, split as
:func:`capbridge.physics.gravity.doublet_gravity_forces` says (drho =
``liquid_density``).  ``gravity_correction="auto"`` applies it to the bridges where it is
larger than the doublet table's own error and prints one start-up line with the
numbers; "on" / "off" force it.  Wall bridges carry no gravity; triplet clusters get the
triplet table's gravity response when it has one.

Restarts: the engine's state (bridges, volumes, films, ledger, held forces, and any part
registered with :meth:`CapbridgeEngine.register_state`) is written into the scene's
``O.tags`` whenever the scene is saved (``O.save``, ``O.saveTmp``: capbridge wraps them
when the first engine is made) and read back at the first step after ``O.load`` /
``O.loadTmp``, in this process or in a new one (the PyRunner re-creates the engine
from the saved parameters, the flat keywords whichever way the engine was made, if no
engine of its label exists).  YADE drops every permanent force on load; the engine puts
its own back (the user's are the user's).

Misuse is an error, not a silent zero: every group and keyword is checked when the
engine is made (:mod:`capbridge.yade.engine_options`: type, range, which go together,
the doublet table read then, the grains already in the scene), then the PyRunner outside
ForceResetter ... NewtonIntegrator, two PyRunners of one label, impossible liquid
amounts, a non-finite gravity, spheres added while running.  Erased spheres: their
bridges rupture (liquid onto the surviving grain's film under the conserving rule) and
the grain leaves with its film; the ledger counts that liquid (``removed_volume``).
With every wet sphere erased the engine idles (no force, ledger exact).

Coalescence: every ``coalescence_every`` steps, if some grain holds two bridges, the
geometric criterion (:mod:`capbridge.dem.coalescence_detect`) is applied; merged
bridges are reported in :meth:`CapbridgeEngine.state` and in a log line whenever their
number changes.  With ``triplet_forces=True`` (opt-in) a
coalesced triplet becomes one liquid cluster whose three grains get the triplet table's
pair forces instead of its bridges' doublet forces, until it splits back into bridges
at equal pressure (:mod:`capbridge.dem.triplet_clusters` has the rule; clusters
of four grains or more keep their doublet forces and are reported).  The triplet table
is read at the first coalesced triplet only: a scene without one does no triplet work.
"""
from __future__ import annotations

import logging
import time

import numpy as np

from capbridge.dem import scene_geometry
from capbridge.yade import engine_options, persistence, state_io
from capbridge.yade.config import (ENGINE_PARAMETERS, EngineConfig, flat_keywords_given,
                                   is_group)
from capbridge.dem.bridges import BridgeModel, LiquidRule, default_table_path
from capbridge.dem.coalescence_detect import find_coalescence
from capbridge.dem.wall_bridges import wall_bodies
# GRAVITY_MODES: public here before 0.2 (tests/test_public_surface.py)
from capbridge.dem.liquid_gravity import (DEFAULT_LIQUID_DENSITY, GRAVITY_MODES,  # noqa: F401
                                          LiquidGravity, newton_gravity)
from capbridge.validation import CapbridgeInputError
from capbridge.yade.persistence import CapbridgeStateError, install_save_hooks
from capbridge.yade.registry import ENGINES, get_engine, set_factory
from capbridge.yade.suction import suction_law2

__all__ = ["CapbridgeEngine", "suction_law2", "get_engine", "ENGINE_PARAMETERS",
           "EngineConfig", "CapbridgeStateError", "install_save_hooks", "MAX_VOID_RATIO"]

log = logging.getLogger("capbridge.yade")


#: Largest liquid volume per grain volume (void ratio 1): see
#: :data:`capbridge.yade.engine_options.MAX_VOID_RATIO`
MAX_VOID_RATIO = engine_options.MAX_VOID_RATIO

#: name -> (default, meaning) of the keywords: :data:`capbridge.yade.config.ENGINE_PARAMETERS`
#: (the option table of docs/yade_plugin.md is made from it)
ENGINE_PARAMETERS = ENGINE_PARAMETERS


def _runner(label):
    """What the PyRunner runs: the engine of ``label``'s step."""
    get_engine(label).step()


def _yade():
    import yade  # noqa: F401  (the caller made it importable)
    from yade import wrapper
    return yade, wrapper


def bulk_centres():
    """(n, 3) centres of all bodies, in ``O.bodies`` order: one bulk read per axis."""
    from yade import _utils

    return np.column_stack([np.fromiter(_utils.coordsAndDisplacements(k)[0], float)
                            for k in range(3)])


def rows_of_ids(O):
    """``(rows, n)``: the row of every body id in :func:`bulk_centres` (-1: no body)
    and the number of bodies."""
    order = np.array([b.id for b in O.bodies], np.intp)
    rows = np.full(order.max(initial=0) + 1, -1, np.intp)
    rows[order] = np.arange(order.size)
    return rows, order.size


class CapbridgeEngine:
    """Volume-controlled capillary bridges from capbridge's doublet table, in YADE.

    Made from keyword groups (:mod:`capbridge.yade.config`)::

        CapbridgeEngine(theta=20, gamma=0.073, liquid=WaterContent(0.01),
                        coalescence=Coalescence(every=10), speed=Speed(refresh_every=10))

    ``liquid`` one of ``BridgeVolume``, ``BridgeVolumeStar``, ``LiquidVolume``,
    ``WaterContent``, ``Saturation``; ``formation`` a ``Formation``, ``bodies`` a
    ``Bodies``, ``coalescence`` a ``Coalescence``, ``gravity`` a ``GravityCorrection``,
    ``speed`` a ``Speed``; beside them the top-level ``liquid_density``, ``table`` and
    ``label``.  The shim, kept for scenes written before the groups and for restart
    files (which store them): the 28 flat keywords below, mapped onto the same groups
    (:meth:`EngineConfig.from_flat`), for the groups not given.  A flat keyword set
    beside its own group (``speed=Speed(), skin=1e-4``) is an error; one given at its
    default cannot be told from one left out and gives way to the group
    (:func:`~capbridge.yade.config.flat_keywords_given`).  Either way the groups are
    ``self.config``, and the engine, its saved parameters and its forces are the same.
    See :data:`ENGINE_PARAMETERS` (and ``docs/yade_plugin.md``) for the parameters and
    :data:`~capbridge.yade.engine_options.OPTION_RULES` for what each allows (checked
    here, when the engine is made: every error a
    :class:`~capbridge.validation.CapbridgeInputError`).
    The engine reads the grains (radii, materials, masses) at its first step; create it
    before or after the bodies.  Erased wet spheres leave with their liquid (ledger);
    spheres added later are refused with an error (give ``ids`` or call :meth:`reset`).

    Liquid rules (exactly one amount must be given):

    * ``bridge_volume`` / ``bridge_volume_star``: **fixed volume per bridge**.  Every
      bridge that forms (at the first step on the pairs within ``initial_wet_gap``,
      later at contact) gets that volume and keeps it until it ruptures.  Liquid is
      not conserved: a ruptured bridge's liquid leaves the scene, a new bridge brings
      new liquid (as in YADE's ViscElCapMat).  Ledger: active = initial + formed -
      ruptured.
    * ``liquid_volume`` / ``water_content`` / ``saturation``: a **total liquid** W.
      With ``conserve_liquid=True`` (default) the liquid is carried by the grains
      (films, at the start in proportion to grain volume: a uniform water content)
      and conserved: every bridge, at the first step or later, forms at contact from
      the two films (``film_fraction`` of each, shared among the bridges a grain forms
      in the same step; none if that is below the table's smallest V*, and the pair
      is not tried again until a rupture gives one of its grains liquid; capped at
      the largest), a ruptured bridge gives its liquid back to its two grains (split
      in proportion to R^2).  Ledger: bridges + films = W (minus liquid on erased
      grains).  With ``conserve_liquid=False`` W is shared equally among the first
      step's bridges and that becomes the fixed volume of every later bridge.
    """

    def __init__(self, theta=0.0, gamma=0.073, *, bridge_volume=None, bridge_volume_star=None,
                 liquid_volume=None, water_content=None, saturation=None, sample_volume=None,
                 liquid_density=None, conserve_liquid=None, film_fraction=0.5,
                 formation_gap=0.0, initial_wet_gap=None, initial_pairs=None, refresh_every=1,
                 force_tolerance=0.0, coalescence=True,
                 coalescence_every=10, table=None, ids=None, skin=None, ratio_step=0.01,
                 label="capbridge", triplet_forces=False, triplet_table=None, walls=False,
                 triplet_split="table", gravity_correction="auto", liquid=None,
                 formation=None, bodies=None, gravity=None, speed=None):
        # the groups and the flat keywords set beside them, checked once, here, into the
        # groups (capbridge.yade.config; the checks are engine_options', one line naming
        # the keyword and what is allowed); ``coalescence`` is the flat keyword (a bool)
        # or the Coalescence group
        flat = {k: v for k, v in locals().items() if k in ENGINE_PARAMETERS}
        groups = {"liquid": liquid, "formation": formation, "bodies": bodies,
                  "coalescence": flat.pop("coalescence") if is_group(coalescence) else None,
                  "gravity": gravity, "speed": speed}
        self.config = EngineConfig.from_keywords(groups, flat_keywords_given(flat))
        opts = self.config.checked()
        self.theta = self.config.theta
        self.gamma = opts["gamma"]
        self.amount = {k: opts[k] for k in engine_options.LIQUID_AMOUNTS}
        self.sample_volume = opts["sample_volume"]
        # water by default: 1000 kg/m^3 for water_content (as before gravity was added),
        # 997 kg/m^3 (water - air at 20 C) for the liquid's weight
        rho = opts["liquid_density"]
        self.liquid_density = 1000.0 if rho is None else rho
        self.gravity_correction = opts["gravity_correction"]
        self.gravity = LiquidGravity(self.gravity_correction,
                                     DEFAULT_LIQUID_DENSITY if rho is None else rho, self.gamma)
        self.conserve_liquid = opts["conserve_liquid"]
        self.film_fraction = opts["film_fraction"]
        self.formation_gap = opts["formation_gap"]
        self.initial_wet_gap = opts["initial_wet_gap"]
        self.initial_pairs = opts["initial_pairs"]
        self.refresh_every = opts["refresh_every"]
        self.force_tolerance = opts["force_tolerance"]
        self.coalescence = opts["coalescence"]
        self.coalescence_every = opts["coalescence_every"]
        self.triplet_split = opts["triplet_split"]
        self._init_triplets(opts["triplet_forces"], opts["triplet_table"])
        self.table = opts["table"] if opts["table"] is not None else default_table_path()
        self.ids_requested = opts["ids"]
        self.skin = opts["skin"]
        self.ratio_step = opts["ratio_step"]
        self.label = opts["label"]
        # walls and periodic cells: capbridge.dem.scene_geometry
        self.walls_requested = opts["walls"]
        # the doublet table read and checked now (not at the first step), and the
        # grains the scene already holds checked against the keywords
        self._opts = opts
        self._doublet = engine_options.load_doublet_table(opts["table"], opts)
        self._check_scene_now(opts)
        self.walls, self._cell = None, None
        self.model = None
        self.coalescence_report = None
        self._coal_summary = {"searched": False, "triplets": 0, "clusters": 0,
                              "coalesced_volume": 0.0, "checks": 0}
        self.pore_volume = None
        self._last_geom = None
        self._coal_last = 0
        self._coal_logged = 0
        self.timings = {"steps": 0, "seconds": 0.0, "cpu_seconds": 0.0, "setup_seconds": 0.0,
                        "coalescence_seconds": 0.0}
        self.events = {"formed": 0, "ruptured": 0}
        self.messages = []
        self._live = None                     # mark of the live scene in O.tags
        self._applied = np.empty((0, 3))      # our share of each grain's permanent force
        self._erased = 0
        self._parts = {}                      # extra state: name -> (get, set)
        self.register_state("clusters", self._clusters_get, self._clusters_set)
        self.register_state("gravity", self.gravity.get_state, self.gravity.set_state)
        # what a saved scene holds: the flat keywords, as JSON, whether the engine was
        # made from groups or from them (capbridge.yade.persistence)
        self._params = persistence.params_json(self.config.flat())
        old = ENGINES.get(self.label)
        if old is not None and old is not self and old._in_scene():
            raise CapbridgeInputError(
                f"label {self.label!r} is taken by another CapbridgeEngine whose PyRunner is in "
                "O.engines: give every engine its own label (label='...')")
        ENGINES[self.label] = self
        try:
            install_save_hooks()
        except ImportError:                   # no YADE here (numpy-only use)
            pass

    @classmethod
    def configure(cls, theta=0.0, gamma=0.073, *, liquid=None, formation=None, bodies=None,
                  coalescence=None, gravity=None, speed=None, **flat):
        """The engine of keyword groups and the flat keywords of the groups not given, as
        the constructor takes them, but strict: every flat keyword given counts, so one
        beside its own group is an error even at its default
        (:meth:`EngineConfig.build`)."""
        return cls.from_config(EngineConfig.build(
            theta, gamma, liquid=liquid, formation=formation, bodies=bodies,
            coalescence=coalescence, gravity=gravity, speed=speed, **flat))

    @classmethod
    def from_config(cls, config):
        """The engine of an :class:`~capbridge.yade.config.EngineConfig`."""
        if not isinstance(config, EngineConfig):
            raise CapbridgeInputError(f"config={config!r} is not an EngineConfig")
        return cls(**config.as_keywords())

    @classmethod
    def from_scene(cls, label="capbridge"):
        """The engine saved in the current scene's ``O.tags`` under ``label`` (after
        ``O.load`` in a new process): made again from its saved parameters; its
        state is read at its first step."""
        yade, _ = _yade()
        return cls(**persistence.saved_params(yade.Omega(), label))

    def register_state(self, name, get, set_):
        """Add a part to what is saved with the scene and restored after a load:
        ``get()`` returns a dict of numpy arrays and JSON values, ``set_(dict)`` takes
        it back (called after the bridges are restored)."""
        if name in ("engine", "bridges"):
            raise ValueError(f"state part {name!r} is the engine's own")
        self._parts[name] = (get, set_)

    def _in_scene(self):
        try:
            yade, _ = _yade()
        except ImportError:
            return False
        return bool(persistence.pyrunners(yade.Omega(), self.label)[0])

    # ----------------------------------------------------------------------- YADE side
    def pyrunner(self):
        """The ``PyRunner`` to put in ``O.engines`` after the ``InteractionLoop`` and
        before the ``NewtonIntegrator``."""
        _, wrapper = _yade()
        cmd = f"from capbridge.yade.engine import _runner; _runner({self.label!r})"
        return wrapper.PyRunner(command=cmd, iterPeriod=self.refresh_every, initRun=True,
                                label=self.label)

    def reset(self):
        """Forget the bridges and the grains (read again at the next step, dry), and
        any state of this engine saved in the current scene."""
        self._clear_perm()
        self.model = None
        self.clusters = None
        self._live = None
        self.gravity.g = None                 # decided again at the next step
        try:
            yade, _ = _yade()
            O = yade.Omega()
            # O.tags cannot delete a key: an empty state means "none"
            if persistence.tag_get(O, persistence.tag_key(self.label, "state")) is not None:
                O.tags[persistence.tag_key(self.label, "state")] = ""
                O.tags[persistence.tag_key(self.label, "live")] = ""
        except ImportError:
            pass

    def _scene_bodies(self, O, wrapper, ids=None):
        """The wet spheres and wall partners the scene holds now, as
        :func:`~capbridge.yade.engine_options.check_scene` takes them:
        ``(spheres, walls, complete)``; ``complete`` when ``ids`` are given and all
        present (ids not in the scene yet are skipped: they may be added later)."""
        sph = wrapper.Sphere
        n_b = len(O.bodies)

        def body(i):
            return O.bodies[i] if 0 <= i < n_b else None

        if ids is None:
            bodies = [b for b in O.bodies if b is not None and isinstance(b.shape, sph)]
            complete = False
        else:
            bodies = []
            for i in ids:
                b = body(i)
                if b is None:
                    continue
                if not isinstance(b.shape, sph):
                    raise CapbridgeInputError(f"ids: body {i} is a {type(b.shape).__name__}, "
                                              "not a sphere")
                bodies.append(b)
            complete = len(bodies) == len(ids)
        spheres = [(b.id, b.shape.radius, b.state.mass, b.material.label, b.material.id)
                   for b in bodies]
        w = self.walls_requested
        if w is True:
            wall_b = [b for b in O.bodies if b is not None
                      and type(b.shape).__name__ in engine_options.WALL_SHAPES]
        else:
            wall_b = [b for b in map(body, w or []) if b is not None]
        walls = [(b.id, type(b.shape).__name__, b.material.label, b.material.id)
                 for b in wall_b]
        return spheres, walls, complete

    def _check_scene_now(self, opts):
        """At construction: the keywords against the spheres and walls the scene holds
        already (nothing without YADE or without bodies; all again at the first step)."""
        try:
            yade, wrapper = _yade()
        except ImportError:
            return
        spheres, walls, complete = self._scene_bodies(yade.Omega(), wrapper,
                                                      self.ids_requested)
        engine_options.check_scene(opts, self._doublet, spheres, walls, complete=complete,
                                   liquid_density=self.liquid_density)

    def _materials_theta(self, bodies, what="body"):
        """Contact angle of every body from its material
        (:func:`~capbridge.yade.engine_options.material_angles`)."""
        return engine_options.material_angles(
            self.theta, [(b.id, b.material.label, b.material.id) for b in bodies], what)

    def _setup(self, ids=None, table=None, restoring=None):
        """Read the grains and build the bridge model (at the first step; after a
        load, ``restoring`` is the saved liquid rule)."""
        t0 = time.perf_counter()
        yade, wrapper = _yade()
        O = yade.Omega()
        sphere_cls = wrapper.Sphere
        ids = self.ids_requested if ids is None else [int(i) for i in ids]
        if ids is None:
            bodies = [b for b in O.bodies if b is not None and isinstance(b.shape, sphere_cls)]
        else:
            n_b = len(O.bodies)
            bodies = [O.bodies[i] if 0 <= i < n_b else None for i in ids]
            if any(b is None or not isinstance(b.shape, sphere_cls) for b in bodies):
                raise CapbridgeInputError("ids must be ids of existing spheres")
        if not bodies and restoring is None:  # (restored with none: all were erased)
            raise ValueError("no spheres in the scene")
        self.ids = np.array([b.id for b in bodies], np.intp)
        radii = np.array([b.shape.radius for b in bodies], float)
        theta = self._materials_theta(bodies)
        # the keywords against the whole scene (as when the engine was made); after a
        # load the liquid in the saved ledger holds, whatever grains were erased before
        spheres, walls, _ = self._scene_bodies(O, wrapper, self.ids.tolist())
        engine_options.check_scene(self._opts, self._doublet, spheres, walls,
                                   complete=restoring is None,
                                   liquid_density=self.liquid_density)
        a = self.amount
        masses = [b.state.mass for b in bodies]
        W, v_s, v_p = engine_options.liquid_total(a, radii, masses, self.sample_volume,
                                                  self.liquid_density)
        if bodies:
            rule = LiquidRule(bridge_volume=a["bridge_volume"],
                              bridge_volume_star=a["bridge_volume_star"], total_liquid=W,
                              conserve=self.conserve_liquid, film_fraction=self.film_fraction)
        else:                                  # every wet grain erased: the saved rule
            rule = LiquidRule(**restoring)
        self.pore_volume = v_p
        self.model = BridgeModel(radii, theta, self._doublet if table is None else table,
                                 self.gamma, rule,
                                 formation_gap=self.formation_gap,
                                 initial_wet_gap=self.initial_wet_gap, skin=self.skin,
                                 with_beta=self.coalescence, ratio_step=self.ratio_step)
        self._setup_geometry(O, theta)
        self._map_rows()
        self.timings["setup_seconds"] += time.perf_counter() - t0
        tab = self.model.table
        self._say("info", f"capbridge engine {self.label!r}: {len(bodies)} spheres, rule "
                  f"{rule.kind}, angles {tab.thetas.tolist()} deg, ratio nodes "
                  f"{tab.ratio_nodes.size} ({'exact' if tab.discrete else 'interpolated'}), "
                  f"table slices {tab.nbytes / 1e6:.1f} MB, refresh every {self.refresh_every}")

    def _setup_geometry(self, O, sphere_theta):
        """The periodic cell and the wall bridges of the scene
        (:func:`capbridge.dem.scene_geometry.setup`), kept here."""
        bodies = wall_bodies(O, self.walls_requested)
        wall_theta = self._materials_theta(bodies)      # checked by check_scene already
        self._cell, self.walls = scene_geometry.setup(O, self.model, sphere_theta, bodies,
                                                      wall_theta)
        self._cell_drift, self._cell_rebuilds = 0.0, -1
        if self.walls is not None:
            self.register_state("walls", self.walls.get_state, self.walls.set_state)
            self._say("info", f"capbridge {self.label!r}: {len(bodies)} wall partners, "
                      f"wall angles {np.unique(wall_theta).tolist()} deg (exact "
                      "sphere-wall slices solved when a pair of angles first forms a bridge)")

    def _map_rows(self):
        """Rows of our spheres in the bulk position read (body iteration order);
        erased spheres leave the model (:meth:`BridgeModel.drop_grains`), added spheres
        are an error."""
        yade, wrapper = _yade()
        O = yade.Omega()
        where, self._n_read = rows_of_ids(O)
        ids = self.ids
        rows = np.where(ids < where.size, where[np.minimum(ids, where.size - 1)], -1)
        gone = rows < 0
        if gone.any():
            new_index = self.model.drop_grains(gone)
            scene_geometry.drop_spheres(self.walls, gone)
            if self.clusters is not None:
                self.clusters.remap(new_index)
            lost = ids[gone]
            self.ids = ids[~gone]
            self._erased += int(gone.sum())
            if self._applied.shape[0] == gone.size:
                self._applied = self._applied[~gone]
            rows = rows[~gone]
            b = self.model.budget()
            self._say("warning", f"capbridge {self.label!r}: {lost.size} wet spheres erased "
                      f"(ids {lost[:10].tolist()}{' ...' if lost.size > 10 else ''}): their "
                      f"bridges ruptured, {b['removed_volume']:.4g} m^3 of liquid left with "
                      "them in all (ledger removed_volume)")
        if self.ids_requested is None:
            sph = wrapper.Sphere
            n_sph = sum(1 for b in O.bodies if b is not None and isinstance(b.shape, sph))
            if n_sph > self.ids.size:
                known = set(self.ids.tolist())
                new = [b.id for b in O.bodies if b is not None and isinstance(b.shape, sph)
                       and b.id not in known]
                raise CapbridgeInputError(
                    f"{len(new)} spheres were added after capbridge engine {self.label!r} "
                    f"started (ids {new[:10]}): they would stay dry; give the wet spheres' "
                    "ids (ids=[...]) or call cap.reset() (starts again, bridges lost)")
        self._rows = rows

    def positions(self):
        """(n, 3) centres of the wet spheres, one bulk read per axis."""
        xyz = bulk_centres()
        if xyz.shape[0] != self._n_read:
            self._map_rows()
        return xyz[self._rows]

    def step(self):
        """One update (called by the PyRunner)."""
        t0, c0 = time.perf_counter(), time.thread_time()
        yade, _ = _yade()
        O = yade.Omega()
        self._sync(O)
        it = int(O.iter)
        pos = self.positions()
        pairs = None
        if not self.model.initialised and self.initial_pairs is not None:
            row = {b: k for k, b in enumerate(self.ids.tolist())}
            try:
                pairs = [(row[a], row[b]) for a, b in self.initial_pairs]
            except KeyError as exc:
                raise ValueError(f"initial_pairs: body {exc} is not a wet sphere") from None
        first = not self.model.initialised
        self._step_pos = pos                  # the centres this step's forces belong to (VTK)
        if self._cell is not None:                   # the periodic cell follows O.cell
            self._cell_drift, self._cell_rebuilds = scene_geometry.before_update(
                self._cell, self.model, O.cell.hSize, pos, self._cell_drift,
                self._cell_rebuilds)
        geom = self.model.update(pos, step=it, initial_pairs=pairs)
        self.events["formed"] += geom["formed"]
        self.events["ruptured"] += geom["ruptured"]
        rep = None
        if self.coalescence and (self._coal_summary["checks"] == 0
                                 or it - self._coal_last >= self.coalescence_every):
            rep = self.check_coalescence(pos, geom)
            self._coal_last = it
        # g from NewtonIntegrator: a decision at the start and when it changed
        said = self.gravity.refresh(
            newton_gravity(O), self.model, it, walls=self.walls is not None,
            triplet_table=self.triplet_table if self.triplet_forces else None)
        if said is not None:
            self._say(said[0], f"capbridge {self.label!r}: {said[1]}")
        tri = None
        if self.triplet_forces and ((rep is not None and rep.n_triplets) or
                                    (self.clusters is not None and self.clusters.n)):
            tri = self._triplet_step(pos, geom, rep, it)
            geom = tri["geom"]
        forces, changed = self.model.grain_forces(geom, self.force_tolerance, self.holds_forces)
        if tri is not None and tri["grains"].size:
            forces += tri["forces"]
            if changed is not None:
                changed = np.union1d(changed, tri["grains"])
        # gravity on the liquid (bridges merged into a liquid cluster: the cluster's
        # gravity response instead, or none)
        in_clusters = (self.clusters.bridge_rows(self.model)
                       if self.gravity.applied and self.clusters is not None
                       and self.clusters.n else None)
        g_forces, g_changed = self.gravity.grain_forces(
            self.model, geom, in_clusters, holds_forces=self.holds_forces,
            force_tolerance=self.force_tolerance)
        if g_forces is not None:
            forces = forces + g_forces
            if changed is not None and g_changed is not None:
                changed = np.union1d(changed, g_changed)
        forces, changed = scene_geometry.wall_forces(self.walls, O, pos, forces, changed,
                                                     first, self.holds_forces)
        self._apply(forces, changed, O)
        self._last_geom = geom
        self.timings["steps"] += 1
        self.timings["seconds"] += time.perf_counter() - t0
        self.timings["cpu_seconds"] += time.thread_time() - c0

    @property
    def holds_forces(self):
        """True when the forces are held as permanent forces between updates."""
        return self.force_tolerance > 0.0 or self.refresh_every > 1

    def _apply(self, forces, changed, O):
        """Hand the grain forces to YADE, always *adding* to what is there: ``addF``
        every step when nothing is held (tolerance 0, refresh every step); else our
        change of each changed grain's permanent force, on top of the permanent force
        present (the user's stays)."""
        if not self.holds_forces:
            nz = np.flatnonzero(np.any(forces != 0.0, axis=1))
            add = O.forces.addF
            for i, f in zip(self.ids[nz].tolist(), forces[nz].tolist()):
                add(i, f)
            return
        self._add_perm(changed, forces[changed], O)

    def _add_perm(self, rows, new, O):
        """Permanent force of grains ``rows`` := present - our old share + ``new``."""
        if self._applied.shape[0] != self.ids.size:
            self._applied = np.zeros((self.ids.size, 3))
        if rows.size == 0:
            return
        perm, setp = O.forces.permF, O.forces.setPermF
        ids = self.ids[rows].tolist()
        if O.forces.getPermForceUsed():
            present = np.array([tuple(perm(i)) for i in ids], float).reshape(-1, 3)
        else:   # YADE's permF is not safe to read before any permanent force exists
            present = np.zeros((len(ids), 3))
        total = present - self._applied[rows] + new
        for i, f in zip(ids, total.tolist()):
            setp(i, f)
        self._applied[rows] = new
        self.timings["perm_updates"] = self.timings.get("perm_updates", 0) + int(rows.size)

    def _clear_perm(self):
        """Take our share out of the permanent forces (the user's stay)."""
        if self.model is not None and self._applied.shape[0] == self.ids.size:
            rows = np.flatnonzero(np.any(self._applied != 0.0, axis=1))
            if rows.size:
                yade, _ = _yade()
                self._add_perm(rows, np.zeros((rows.size, 3)), yade.Omega())
        self._applied = np.empty((0, 3))

    # ------------------------------------------------------------------ save / restore
    def _sync(self, O):
        """Before a step: set up at the first step, restore after a load, check the
        engine list now and then."""
        live = persistence.tag_get(O, persistence.tag_key(self.label, "live"))
        if self.model is not None and live == self._live:
            if self.timings["steps"] % 100 == 0:
                self._check_engines(O)
            return
        self._check_engines(O)
        stash = persistence.tag_get(O, persistence.tag_key(self.label, "state")) or None
        if stash is not None and live is not None and live.startswith("saved:"):
            self._restore(O, stash)
        elif self.model is None:
            engine_options.check_gravity(newton_gravity(O))     # before any set-up work
            self._setup()
            self._applied = np.zeros((self.ids.size, 3))
        else:
            raise CapbridgeStateError(
                f"capbridge engine {self.label!r}: the scene was replaced (O.load / O.reset) "
                "by one without this engine's saved state, so its bridges do not belong to "
                "it; call cap.reset() to start it dry on the new scene")
        self._live = persistence.live_mark()
        O.tags[persistence.tag_key(self.label, "live")] = self._live

    def _engine_state(self):
        return {"ids": self.ids.copy(), "events": dict(self.events),
                "coalescence": dict(self._coal_summary), "coal_last": int(self._coal_last),
                "coal_logged": int(self._coal_logged), "erased": int(self._erased),
                "pore_volume": self.pore_volume, "holds_forces": self.holds_forces}

    def stash(self, O):
        """Write the parameters and, once started, the state into ``O.tags`` (called by
        the ``O.save`` hooks, :mod:`capbridge.yade.persistence`)."""
        parts = None
        if self.model is not None:
            parts = {"engine": self._engine_state(), "bridges": self.model.get_state()}
            for name, (get, _) in self._parts.items():
                parts[name] = get()
        persistence.write_state(O, self.label, self._params, parts)

    _stash = stash

    @property
    def live_mark(self):
        """The mark of the live scene in ``O.tags`` (None before the first step)."""
        return self._live

    def _restore(self, O, text):
        """Continue from a saved state (after ``O.load`` / ``O.loadTmp``)."""
        t0 = time.perf_counter()
        st = state_io.unpack(text)
        eng = st["engine"]
        ids = np.asarray(eng["ids"], np.intp)
        same = self.model is not None and np.array_equal(ids, self.ids)
        # same grains as the live model: its table (slices) serves again
        self._setup(ids=ids.tolist(), table=self.model.table if same else None,
                    restoring=st["bridges"]["liquid"])
        self.model.set_state(st["bridges"])
        self.clusters = None
        for name, (_, set_) in self._parts.items():
            if name in st:
                set_(st[name])
        self.events = dict(eng["events"])
        self._coal_summary = dict(eng["coalescence"])
        self._coal_last, self._coal_logged = int(eng["coal_last"]), int(eng["coal_logged"])
        self._erased = int(eng["erased"])
        self._last_geom = None
        # YADE drops every permanent force on load: ours go back on (the user's are
        # the user's to set again)
        self._applied = np.zeros((self.ids.size, 3))
        if self.holds_forces:
            f = self.model.held_grain_forces()     # the liquid's weight included
            rows = np.flatnonzero(np.any(f != 0.0, axis=1))
            self._add_perm(rows, f[rows], O)
        self.timings["restore_seconds"] = self.timings.get("restore_seconds", 0.0) + \
            time.perf_counter() - t0
        self._say("info", f"capbridge engine {self.label!r}: state restored at iter {int(O.iter)} "
                  f"({self.model.n_bridges} bridges) in {time.perf_counter() - t0:.2f} s")

    def _check_engines(self, O):
        """The PyRunner must be in O.engines once, after ForceResetter and before
        NewtonIntegrator (else its forces are wiped before they act), with the
        engine's period."""
        mine, engs = persistence.pyrunners(O, self.label)
        names = [type(e).__name__ for e in engs]
        if len(mine) != 1:
            raise CapbridgeInputError(
                f"{len(mine)} PyRunners labelled {self.label!r} in O.engines {names}: put "
                "cap.pyrunner() there exactly once, and give every CapbridgeEngine its own "
                "label")
        k = mine[0]
        reset = [i for i, n in enumerate(names) if n == "ForceResetter"]
        newton = [i for i, n in enumerate(names) if n == "NewtonIntegrator"]
        if not (reset and newton and reset[0] < k < newton[0]):
            raise CapbridgeInputError(
                f"capbridge engine {self.label!r} is at position {k} of O.engines {names}: it "
                "must be after ForceResetter and before NewtonIntegrator (its forces are "
                "otherwise reset before they act); put cap.pyrunner() right after the "
                "InteractionLoop")
        if int(engs[k].iterPeriod) != self.refresh_every:
            raise CapbridgeInputError(
                f"the PyRunner of capbridge engine {self.label!r} has iterPeriod="
                f"{engs[k].iterPeriod}, the engine refresh_every={self.refresh_every}: make "
                "it with cap.pyrunner()")

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
            rep = find_coalescence(pos, m.bi, m.bj, bi_ang, bj_ang, m.vol, m.n,
                                   pair_vectors=m.pair_vectors)
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
                      "bridges; " + ("triplets get the triplet table's forces, larger "
                                     "clusters keep doublet forces" if self.triplet_forces
                                     else "their forces stay doublet forces "
                                          "(triplet_forces off)"))
        self.timings["coalescence_seconds"] += time.perf_counter() - t0
        return rep

    def coalesced_triplets(self):
        """(m, 3) body ids (j, i, k) of the coalesced pairs of bridges (i shared)."""
        rep = self.coalescence_report
        if rep is None or rep.n_triplets == 0:
            return np.empty((0, 3), np.intp)
        return self.ids[rep.triplets]

    # ---------------------------------------------------------------- coalesced triplets
    def _init_triplets(self, triplet_forces, triplet_table):
        """Triplet forces on when asked (the table is checked here, by
        :func:`~capbridge.yade.engine_options.check_triplet_table`; it is fitted at
        the first coalesced triplet)."""
        self.triplet_forces, self.triplet_table = engine_options.check_triplet_table(
            triplet_forces, triplet_table, self.coalescence)
        self.clusters = None              # made at the first coalesced triplet

    def _triplet_step(self, pos, geom, rep, it):
        """Liquid clusters of coalesced triplets (:class:`LiquidClusters`): merge, the
        table's forces, split; ruptures of a split are counted as ruptures."""
        if self.clusters is None:
            from capbridge.dem.triplet_clusters import LiquidClusters

            self.clusters = LiquidClusters(self.gamma, table=self.triplet_table,
                                           split_solver=self.triplet_split)
        loads = self.clusters.loads
        self.clusters.gravity = self.gravity.cluster_gravity()
        out = self.clusters.step(self.model, pos, geom, rep, it)
        self.events["ruptured"] += out["ruptured"]
        if self.clusters.loads > loads:
            self._say("info", f"capbridge {self.label!r} iter {it}: triplet table "
                      f"{self.triplet_table.name} read in "
                      f"{self.clusters.timings['load_seconds']:.2f} s (first coalesced triplet)")
        return out

    def triplet_report(self):
        """Coalesced-triplet clusters: on/off, events, clusters, funicular fallback."""
        if self.clusters is None:
            return {"enabled": self.triplet_forces, "table_loaded": False, "clusters": 0}
        return {"enabled": self.triplet_forces, **self.clusters.report()}

    def _clusters_get(self):
        return {} if self.clusters is None else self.clusters.get_state()

    def _clusters_set(self, st):
        if st:
            from capbridge.dem.triplet_clusters import LiquidClusters

            self.clusters = LiquidClusters(self.gamma, table=self.triplet_table,
                                           split_solver=self.triplet_split)
            self.clusters.set_state(st)

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
               "erased_spheres": self._erased,
               "refresh_every": self.refresh_every, "events": dict(self.events),
               "timings": dict(self.timings), "coalescence": dict(self._coal_summary)}
        if m is not None:
            g = self._last_geom
            out.update(n_spheres=int(m.n), n_bridges=m.n_bridges, budget=m.budget(),
                       liquid=m.liquid_report(self.pore_volume),
                       thetas=m.table.thetas.tolist(), ratio_nodes=m.table.ratio_nodes.tolist(),
                       table_mbytes=m.table.nbytes / 1e6,
                       candidate_pairs=int(m.cand.i.size), verlet_rebuilds=m.cand.rebuilds,
                       triplets=self.triplet_report(),
                       total_force=float(g["force"].sum()) if g is not None else 0.0,
                       finite=bool(np.all(np.isfinite(g["force"]))) if g is not None else True)
            out["walls"] = self.walls.summary() if self.walls is not None else None
            out["gravity"] = dict(self.gravity.summary,
                                  bridges_corrected=self.gravity.n_corrected)
            out["periodic"] = self._cell.h.tolist() if self._cell is not None else None
        return out

    def snapshot(self):
        """The bridges of the last step as explicit data (what
        :func:`capbridge.yade.engine_vtk.bridge_arrays` takes): the bridge model, the
        step's geometry, the centres its forces were computed at, the wet spheres' ids,
        the wall bridges and the coalescence report."""
        return {"model": self.model, "geom": self._last_geom,
                "pos": getattr(self, "_step_pos", None), "ids": getattr(self, "ids", None),
                "walls": self.walls, "report": self.coalescence_report}

    def write_vtk(self, path, overwrite=False):
        """Write the current bridges (sphere-sphere and wall) to a VTK file (``.vtp`` or
        ``.vtk``) and, beside it, the liquid clusters (``<stem>_clusters<suffix>``) when
        there are any; see :mod:`capbridge.yade.engine_vtk`."""
        from capbridge.yade.engine_vtk import write_vtk

        return write_vtk(self.snapshot(), path, overwrite=overwrite)

    def vtk_recorder(self, directory, every=100, prefix=None, overwrite=False):
        """A ``PyRunner`` that writes the bridges every ``every`` steps into ``directory``
        (a ParaView time series, :mod:`capbridge.yade.engine_vtk`); put it in
        ``O.engines`` after the capillary PyRunner."""
        from capbridge.yade.engine_vtk import vtk_recorder

        return vtk_recorder(self.label, directory, every=every, prefix=prefix,
                            overwrite=overwrite)


set_factory(CapbridgeEngine.from_scene)   # get_engine after O.load in a new process
