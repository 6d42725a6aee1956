"""Doublet force tables: the exact solver swept over (ratio, theta, V*, gap) -> netCDF.

The gap axis is mapped onto the stable branch: for every (ratio, theta, V*) the rupture
distance d*_rupt is solved first, and the table's gap coordinate is

    s = sqrt(1 - d* / d*_rupt)        (s = 1 at contact, s = 0 at rupture)

which keeps the table rectangular, makes rupture exact, and removes the square-root
singularity of the force at the fold (F* - F*_rupt ~ sqrt(d*_rupt - d*)), so that
smooth interpolation in s is accurate right up to rupture.

Gravity (:mod:`capbridge.tables.doublet_gravity`): two more phases, the response of
the grain forces to gravity on a sub-grid (``weight_share_axial``,
``force_gravity_curvature_axial``, ``weight_share_transverse``) and the rupture distance
with gravity along the axis (``rupture_gap_gravity`` on a smaller one).

Each phase (rupture distances, bridges, gravity response, rupture with gravity) is a
resumable :func:`run_sweep`; a phase
with failed chunks stops the build (:class:`~capbridge.tables.sweep.SweepFailedError`,
"N chunks failed, rerun to retry"): nothing is computed from placeholders, and the
finished chunks stay in the checkpoint directory for the rerun.
"""
from __future__ import annotations

import dataclasses
import json
import shlex
import sys

import numpy as np
import xarray as xr

from capbridge.tables.doublet_gravity import GravityPlan, gravity_datasets
from capbridge.tables.netcdf_io import TableError, validate_table, write_table
from capbridge.tables.sweep import run_sweep
from capbridge.solvers.young_laplace import SolverSettings, rupture_distance, solve_doublet
from capbridge.status import Status, cf_flag_attributes

OUTPUTS = ("force", "pressure", "beta1", "beta2", "neck_radius")

ATTRS = {
    "ratio": dict(units="1", long_name="radius ratio R2/R1 (R1, the smaller, normalises)"),
    "theta": dict(units="degree", long_name="contact angle on both grains"),
    "volume": dict(units="1", long_name="liquid bridge volume V* = V/R1^3"),
    "s": dict(units="1", long_name="gap coordinate s = sqrt(1 - d*/d*_rupt) (1 contact, 0 rupture)"),
    "gap": dict(units="1", long_name="gap between the sphere surfaces d* = d/R1"),
    "force": dict(units="1", long_name="axial capillary force F* = F/(2 pi gamma R1), attraction > 0"),
    "pressure": dict(units="1", long_name="capillary pressure P* = (p_liquid - p_gas) R1/gamma"),
    "beta1": dict(units="degree", long_name="half filling angle on grain 1"),
    "beta2": dict(units="degree", long_name="half filling angle on grain 2"),
    "neck_radius": dict(units="1", long_name="smallest radius of the bridge / R1"),
    "rupture_gap": dict(units="1", long_name="rupture distance d*_rupt (end of the stable branch)"),
    "rupture_force": dict(units="1", long_name="force F* at rupture"),
}


#: units a doublet table must carry (angles in degrees, the rest dimensionless)
UNITS = {name: a["units"] for name, a in ATTRS.items()}

SHIPPED_RATIOS = (1.0, 1.1, 1.25, 1.5, 1.75, 2.0, 3.0, 4.0, 5.0, 10.0)  # YADE's M(r=...) set
SHIPPED_THETA_MAX = 80.0
SHIPPED_VOLUME_MAX = 0.5


@dataclasses.dataclass(frozen=True)
class DoubletGrid:
    """Axes of a doublet table (theta in degrees, volumes dimensionless)."""

    ratio: tuple = (1.0,)
    theta: tuple = tuple(np.arange(0.0, 85.1, 5.0))
    volume: tuple = tuple(np.geomspace(1e-3, 0.5, 25))
    s: tuple = tuple(np.linspace(0.0, 1.0, 25))

    @classmethod
    def regular(cls, ratio=(1.0,), theta_step=5.0, theta_max=85.0, volume_min=1e-3,
                volume_max=0.5, n_volume=25, n_s=25):
        return cls(tuple(float(r) for r in ratio),
                   tuple(np.arange(0.0, theta_max + 1e-9, theta_step)),
                   tuple(np.geomspace(volume_min, volume_max, n_volume)),
                   tuple(np.linspace(0.0, 1.0, n_s)))

    @classmethod
    def shipped(cls, quick=False, ratios=None):
        """The grid of ``data/doublet_table.nc`` (``quick``: a small one for tests).

        s is clustered at both ends (contact and rupture), where F* varies fastest.
        """
        if quick:
            u = np.linspace(0.0, 1.0, 9)
            return cls(tuple(ratios or (1.0,)), (0.0, 15.0, 30.0, 45.0),
                       tuple(np.geomspace(1e-3, 0.1, 6)), tuple(0.5 * (1 - np.cos(np.pi * u))))
        u = np.linspace(0.0, 1.0, 25)
        return cls(tuple(ratios or SHIPPED_RATIOS), tuple(np.arange(0.0, SHIPPED_THETA_MAX + 1e-9, 5.0)),
                   tuple(np.geomspace(1e-3, SHIPPED_VOLUME_MAX, 25)),
                   tuple(0.5 * (1 - np.cos(np.pi * u))))

    def as_dict(self):
        return {k: list(map(float, v)) for k, v in dataclasses.asdict(self).items()}


# Module-level chunk solvers: picklable for worker processes and Dask.

def rupture_chunk(volume, theta, ratio):
    r = rupture_distance(volume, theta, ratio)
    return {"rupture_gap": r["gap"], "rupture_force": r["force"],
            "rupture_pressure": r["pressure"], "rupture_beta1": r["beta1"],
            "rupture_beta2": r["beta2"], "rupture_neck": r["neck_radius"],
            "status": r["status"]}


def bridge_chunk(gap, volume, theta, ratio):
    r = solve_doublet(gap, volume, theta, ratio)
    return {k: r[k] for k in OUTPUTS} | {"status": r["status"]}


def build_doublet_table(grid: DoubletGrid, *, checkpoint_dir=None, n_jobs=None,
                        scheduler=None, progress=True, command=None,
                        chunk_size=128, worker_timeout=None, gravity="auto") -> xr.Dataset:
    """Solve every grid point exactly and return the table as a labelled Dataset.

    ``gravity``: a :class:`~capbridge.tables.doublet_gravity.GravityPlan` adds the
    gravity phases (:mod:`capbridge.tables.doublet_gravity`), ``None`` leaves them
    out; ``"auto"`` (default) adds them with the default plan for the shipped grid
    (:meth:`DoubletGrid.shipped`, any ratios) and leaves them out for other grids (the
    quick test grid: the rupture phase with gravity costs ~5 s a point).

    Raises :class:`~capbridge.tables.sweep.SweepFailedError` after a phase with
    failed chunks (finished ones are kept in ``checkpoint_dir`` for the rerun).
    ``worker_timeout``: see :func:`run_sweep` (Dask; default its 600 s).
    """
    from capbridge.tables.sweep import DASK_WORKER_TIMEOUT

    wt = DASK_WORKER_TIMEOUT if worker_timeout is None else float(worker_timeout)
    settings = SolverSettings()
    R, T, V = np.meshgrid(grid.ratio, grid.theta, grid.volume, indexing="ij")
    ck = None if checkpoint_dir is None else f"{checkpoint_dir}/rupture"
    rup = run_sweep(rupture_chunk, {"volume": V.ravel(), "theta": T.ravel(), "ratio": R.ravel()},
                    checkpoint_dir=ck, n_jobs=n_jobs, scheduler=scheduler, progress=progress,
                    desc="rupture distances", chunk_size=max(8, chunk_size // 8),
                    settings=settings.as_dict(), worker_timeout=wt).raise_if_failed()
    shape3 = V.shape
    d_r = rup["rupture_gap"].reshape(shape3)
    s = np.asarray(grid.s)
    gap = d_r[..., None] * (1.0 - s**2)
    # rupture itself (s = 0) is the end state of the family: take it from that solve
    inner = s > 0
    gap_in = gap[..., inner]
    pts = {"gap": gap_in.ravel(),
           "volume": np.broadcast_to(V[..., None], gap_in.shape).ravel(),
           "theta": np.broadcast_to(T[..., None], gap_in.shape).ravel(),
           "ratio": np.broadcast_to(R[..., None], gap_in.shape).ravel()}
    # only where the rupture distance was found: the other points have no gap to solve
    # at (they stay NOT_CONVERGED); nothing is solved at a placeholder gap
    ok_pts = np.isfinite(pts["gap"])
    ck = None if checkpoint_dir is None else f"{checkpoint_dir}/bridges"
    res = run_sweep(bridge_chunk, {k: v[ok_pts] for k, v in pts.items()}, checkpoint_dir=ck,
                    n_jobs=n_jobs, scheduler=scheduler, progress=progress, desc="bridges",
                    chunk_size=chunk_size, settings=settings.as_dict(),
                    worker_timeout=wt).raise_if_failed()
    shape4 = shape3 + (s.size,)
    data = {}
    for name in OUTPUTS:
        flat = np.full(ok_pts.size, np.nan)
        flat[ok_pts] = res[name]
        full = np.full(shape4, np.nan)
        full[..., inner] = flat.reshape(gap_in.shape)
        data[name] = full
    status = np.full(shape4, int(Status.NOT_CONVERGED), np.int8)
    st_flat = np.full(ok_pts.size, int(Status.NOT_CONVERGED), np.int8)
    st_flat[ok_pts] = res["status"]
    status[..., inner] = st_flat.reshape(gap_in.shape)
    rup_ok = rup["status"].reshape(shape3) == Status.CONVERGED
    for name, key in (("force", "rupture_force"), ("pressure", "rupture_pressure"),
                      ("beta1", "rupture_beta1"), ("beta2", "rupture_beta2"),
                      ("neck_radius", "rupture_neck")):
        data[name][..., ~inner] = rup[key].reshape(shape3)[..., None]
    status[..., ~inner] = np.where(rup_ok, Status.CONVERGED, Status.NOT_CONVERGED)[..., None]
    # the end of the branch is the rupture point itself: a "ruptured" answer there
    # from the bridge solver (round-off at the fold) is not a result either way
    for name in OUTPUTS:
        data[name][status != Status.CONVERGED] = np.nan
    dims4 = ("ratio", "theta", "volume", "s")
    gravity = gravity_plan(grid, gravity)
    gds = None
    if gravity is not None:
        def phase(name, fn, inputs, size, phase_settings):
            ckp = None if checkpoint_dir is None else f"{checkpoint_dir}/{name}"
            return run_sweep(fn, inputs, checkpoint_dir=ckp, n_jobs=n_jobs,
                             scheduler=scheduler, progress=progress, desc=name.replace("_", " "),
                             chunk_size=size, settings=phase_settings,
                             worker_timeout=wt).raise_if_failed()

        gds = gravity_datasets(grid, np.where(rup_ok, d_r, np.nan), gravity, phase)
    ds = xr.Dataset(
        {name: (dims4, data[name], ATTRS[name]) for name in OUTPUTS}
        | {"gap": (dims4, np.where(status == Status.CONVERGED, gap, np.nan), ATTRS["gap"]),
           "status": (dims4, status, cf_flag_attributes()),
           "rupture_gap": (dims4[:3], np.where(rup_ok, d_r, np.nan), ATTRS["rupture_gap"]),
           "rupture_force": (dims4[:3], np.where(rup_ok, rup["rupture_force"].reshape(shape3), np.nan),
                             ATTRS["rupture_force"]),
           "rupture_status": (dims4[:3], rup["status"].reshape(shape3).astype(np.int8),
                              cf_flag_attributes() | {"long_name": "status of the rupture solve"})},
        coords={"ratio": ("ratio", np.asarray(grid.ratio), ATTRS["ratio"]),
                "theta": ("theta", np.asarray(grid.theta), ATTRS["theta"]),
                "volume": ("volume", np.asarray(grid.volume), ATTRS["volume"]),
                "s": ("s", s, ATTRS["s"])},
        attrs={"title": "capbridge doublet capillary-force table (exact Young-Laplace, no gravity)"
                        if gds is None else
                        "capbridge doublet capillary-force table (exact Young-Laplace; gravity "
                        "along the axis: first- and second-order response and rupture "
                        "distances)",
               "normalising_radius": "R1, the smaller sphere; ratio = R2/R1",
               "grid": json.dumps(grid.as_dict()),
               "capbridge_command": command or _this_command(),
               "solver_settings": str(settings.as_dict())})
    if gds is not None:
        attrs = ds.attrs | gds.attrs
        ds = ds.merge(gds)
        ds.attrs = attrs
    return ds


def _this_command():
    return " ".join(shlex.quote(a) for a in ["capbridge"] + sys.argv[1:])


def gravity_plan(grid, gravity="auto"):
    """The gravity phases of a table of ``grid``: ``gravity`` itself, or for "auto" the
    default :class:`GravityPlan` on the shipped grid (any ratios) and None elsewhere (a
    quick test grid: the rupture phase with gravity costs ~5 s a point)."""
    if isinstance(gravity, str) and gravity == "auto":
        return GravityPlan() if grid == DoubletGrid.shipped(ratios=grid.ratio) else None
    return gravity


def table_axes(grid, gravity="auto"):
    """Every dimension coordinate the table of ``grid`` will have (name -> values),
    the gravity sub-grids included: what an existing file is compared with before the
    sweep starts (:func:`~capbridge.tables.netcdf_io.check_table_target`)."""
    axes = grid.as_dict()
    plan = gravity_plan(grid, gravity)
    if plan is not None:
        axes |= {k: list(map(float, v)) for k, v in plan.axes(grid).items()}
    return axes


def save_doublet_table(ds: xr.Dataset, path, command=None, overwrite=False):
    """Write the table with CF attributes and provenance (see netcdf_io.write_table).

    An existing file of another grid is replaced only with ``overwrite=True``.
    """
    write_table(ds, path, command=command or ds.attrs.get("capbridge_command", _this_command()),
                solver_settings=SolverSettings().as_dict(), overwrite=overwrite)


def validate_doublet_table(ds: xr.Dataset, source="table") -> xr.Dataset:
    """Refuse a doublet table whose axes, units or values are not physical.

    Beyond :func:`capbridge.tables.netcdf_io.validate_table` (checksums, increasing
    axes, units; for a file also :func:`capbridge.tables.checks.check_doublet`,
    which repeats the bounds below and adds the gravity response's invariants): the
    doublet units (:data:`UNITS`); ratio >= 1, theta in [0, 180) deg,
    V* > 0, s in [0, 1]; where converged, filling angles in [0, 180] deg, neck radius
    and rupture distance > 0, and |F*| <= 2 ratio/(1 + ratio), the largest force two
    spheres can exert through a bridge (contact, V* -> 0, theta = 0: Derjaguin's
    2 pi gamma R_eff with R_eff = R1 R2/(R1 + R2)).  Raises :class:`TableError`.
    """
    validate_table(ds, source, UNITS)
    missing = [v for v in OUTPUTS + ("status", "rupture_gap", "rupture_status") if v not in ds]
    missing += [c for c in ("ratio", "theta", "volume", "s") if c not in ds.coords]
    if missing:
        raise TableError(f"{source} is not a complete capbridge doublet table: missing {missing}")
    axes = {"ratio": (1.0, np.inf, "[1, inf)"), "theta": (0.0, 180.0 - 1e-12, "[0, 180)"),
            "volume": (1e-300, np.inf, "(0, inf)"), "s": (0.0, 1.0, "[0, 1]")}
    for name, (lo, hi, text) in axes.items():
        v = ds[name].values
        if v.min() < lo or v.max() > hi:
            raise TableError(f"{source}: coordinate {name} spans [{v.min():g}, {v.max():g}], "
                             f"outside the physical range {text}")
    ok = ds["status"].values == Status.CONVERGED
    limit = (2 * ds["ratio"] / (1 + ds["ratio"])).values.reshape(-1, *(1,) * 3)
    checks = {"force": np.abs(ds["force"].values) <= limit * (1 + 1e-6),
              "beta1": (ds["beta1"].values >= 0) & (ds["beta1"].values <= 180),
              "beta2": (ds["beta2"].values >= 0) & (ds["beta2"].values <= 180),
              "neck_radius": ds["neck_radius"].values > 0}
    for name, good in checks.items():
        bad = ok & ~good
        if bad.any():
            i = tuple(int(k) for k in np.argwhere(bad)[0])
            raise TableError(f"{source}: {name}={ds[name].values[i]!r} at index {i} (ratio, "
                             f"theta, volume, s) is not physical for a converged point "
                             f"(|F*| <= 2 ratio/(1+ratio), angles in [0, 180], neck > 0)")
    rok = ds["rupture_status"].values == Status.CONVERGED
    if np.any(rok & ~(ds["rupture_gap"].values > 0)):
        raise TableError(f"{source}: a converged rupture distance is not positive")
    return ds
