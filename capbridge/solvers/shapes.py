"""Minimised liquid surfaces as triangle meshes, written as VTK files for ParaView.

Researchers look at bridge shapes: whether a coalesced body wraps under the line of the
bottom grains, where the contact lines sit, how a bridge bulges.  A
:class:`LiquidShape` is the liquid-gas surface of a solved case (the wetted caps are
the grains' own surface and are not meshed) together with the grains and the case it
belongs to.  It comes from

* Surface Evolver (:func:`capbridge.solvers.evolver.minimise` with
  ``Settings(keep_shape=True)``, or :func:`capbridge.solvers.triplet_evolver.evolver_triplet`
  with ``keep_shape=True``): the final mesh of the accepted result (the finest
  refinement level its numbers come from), one triangle per Evolver facet;
* the exact axisymmetric doublet (:func:`doublet_shape`): the Young-Laplace meridian
  revolved about the axis of the two grains.

:func:`write_shape` writes two files next to each other (``.vtp`` or ``.vtk``, by the
suffix): the surface (``out.vtp``: triangles, cell data ``body``, point data
``contact_grain``) and the grains (``out_grains.vtp``: one vertex per grain at its
centre, point data ``radius``, ``grain``, ``contact_angle``, ``wetted``).  In ParaView,
show the grains with the Glyph filter: glyph type Sphere, scale array ``radius``, scale
factor 2 (ParaView's sphere glyph has radius 0.5).

Units and frame: lengths in units of the normalising radius r of the solver (grain
radius 1: every grain of a triplet, the smaller grain R1 of a doublet), in the frame
of the reported forces and centres (a triplet: grains 2 and 3 on the x axis symmetric
about x = 0, grain 1 at z > 0; a doublet: grain 1 at the origin, grain 2 on +x).  The
title of both files (a comment in ``.vtp``, the header line in ``.vtk``) states the
unit, the case (gaps, contact angles, V*, Bo), the status and how the surface was made.
Indices are 0-based (grain 0 is "grain 1" of the command line's output).
"""
from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from capbridge.solvers.young_laplace import bridge_meridian, solve_doublet
from capbridge.status import HAS_RESULT, Status, status_name
from capbridge.validation import CapbridgeInputError, check_range
from capbridge.vtk_io import check_vtk_path, write_polydata

__all__ = ["LiquidShape", "doublet_shape", "write_shape", "shape_paths"]

#: meridian points and azimuthal steps of a revolved doublet (about 12 000 triangles)
DOUBLET_MESH = (81, 72)


@dataclasses.dataclass(frozen=True, eq=False)     # arrays: no element-wise __eq__
class LiquidShape:
    """The liquid-gas surface of a solved case, its grains and the case.

    Attributes
    ----------
    points : numpy.ndarray, shape (P, 3)
        Surface vertices, lengths / r, frame of the reported forces.
    triangles : numpy.ndarray of int, shape (T, 3)
        Rows of ``points``; each triangle's normal (right-hand rule) points out of the
        liquid.
    body : numpy.ndarray of int, shape (T,)
        0-based liquid body of every triangle (one body: all 0).
    contact_grain : numpy.ndarray of int, shape (P,)
        0-based grain whose contact line a vertex lies on, -1 for the free surface.
    centres : numpy.ndarray, shape (N, 3)
        Grain centres, lengths / r.
    radii : numpy.ndarray, shape (N,)
        Grain radii / r.
    contact_angles : numpy.ndarray, shape (N,)
        Contact angle on every grain [deg].
    volumes : tuple of float
        Liquid volume V* = V / r^3 of every body.
    status : str
        Status of the result (:mod:`capbridge.status`, by name).
    method : str
        How the surface was made (solver, refinement level or mesh size).
    bond : float
        Bond number Bo = drho g r^2 / gamma (0: no gravity).
    gravity_dir : tuple of float or None
        Direction in which gravity pulls (None without gravity).
    wetted : tuple of int
        0-based grains wetted by the liquid.
    """

    points: np.ndarray
    triangles: np.ndarray
    body: np.ndarray
    contact_grain: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    contact_angles: np.ndarray
    volumes: tuple
    status: str
    method: str
    bond: float = 0.0
    gravity_dir: tuple | None = None
    wetted: tuple = ()

    @property
    def gaps(self):
        """Gap d* between the surfaces of every pair of grains, {(i, j): d}, 0-based."""
        c, r = np.asarray(self.centres, float), np.asarray(self.radii, float)
        return {(i, j): float(np.linalg.norm(c[i] - c[j]) - r[i] - r[j])
                for i, j in itertools.combinations(range(len(r)), 2)}

    @property
    def title(self):
        """One line: unit, case, status and method (at most 255 characters, the limit of
        the legacy format's header)."""
        n = len(self.radii)
        sep = "-" if n > 9 else ""
        gaps = " ".join(f"d{i + 1}{sep}{j + 1}={d:.6g}" for (i, j), d in self.gaps.items())
        parts = [f"capbridge liquid surface, lengths / r (grain radii "
                 f"{_values(self.radii)})", gaps,
                 f"theta={_values(self.contact_angles)} deg",
                 f"V*={'+'.join(f'{v:.6g}' for v in self.volumes)}",
                 f"Bo={self.bond:.6g}" + ("" if not self.bond or self.gravity_dir is None
                                          else " along ({:.6g},{:.6g},{:.6g})".format(
                                              *self.gravity_dir)),
                 f"status {self.status}", f"{self.method}, {len(self.triangles)} triangles"]
        return "; ".join(parts)[:255]


def _values(values):
    """One value if all are equal, else all of them (6 significant digits)."""
    v = np.asarray(values, float).ravel()
    if v.size and np.all(v == v[0]):
        return f"{v[0]:.6g}"
    return " ".join(f"{x:.6g}" for x in v)


# --------------------------------------------------------------------------------------
# The exact doublet: the meridian revolved
# --------------------------------------------------------------------------------------


def doublet_shape(gap, volume, theta, ratio=1.0, theta2=None, *, result=None,
                  n_meridian=DOUBLET_MESH[0], n_azimuth=DOUBLET_MESH[1]):
    """The exact axisymmetric doublet (no gravity) as a triangle mesh.

    Parameters
    ----------
    gap : float
        Gap d* = d / R1 between the sphere surfaces [-].
    volume : float
        Liquid volume V* = V / R1^3 [-].
    theta : float
        Contact angle on grain 1 [deg].
    ratio : float
        Radius ratio R2 / R1 >= 1 [-].
    theta2 : float, optional
        Contact angle on grain 2 [deg]; defaults to ``theta``.
    result : dict, optional
        The output of :func:`capbridge.solvers.young_laplace.solve_doublet` (or
        ``solve_doublet_suction``) for these inputs, if already computed; otherwise the
        doublet is solved here.
    n_meridian : int
        Points along the meridian, from contact line to contact line, denser near the
        ends; the necks are added, so that the smallest distance of a vertex from the
        axis is the solver's ``neck_radius``.
    n_azimuth : int
        Points around the axis.

    Returns
    -------
    LiquidShape
        Lengths / R1; grain 1 (radius 1) at the origin, grain 2 (radius ``ratio``) on
        +x at 1 + ratio + gap: the frame of ``capbridge solve doublet``.  Every vertex
        lies on the exact surface; the mesh's enclosed volume approaches V* as the
        square of the mesh spacing (0.2-0.4 % smaller at the default size).

    Raises
    ------
    CapbridgeInputError
        No bridge to draw (status ruptured or not converged), or a mesh size below
        (3, 8).
    """
    n_meridian = int(check_range("n_meridian", n_meridian, 3, 100_000))
    n_azimuth = int(check_range("n_azimuth", n_azimuth, 8, 100_000))
    theta2 = theta if theta2 is None else theta2
    r = solve_doublet(gap, volume, theta, ratio, theta2) if result is None else result
    st = Status(int(r["status"]))
    if st not in HAS_RESULT:
        raise CapbridgeInputError(f"no bridge to draw at d*={float(gap):.6g}, "
                                  f"V*={float(volume):.6g}: status {status_name(st)}")
    x, y = bridge_meridian(gap, float(r["pressure"]), float(r["beta1"]), float(r["beta2"]),
                           theta, theta2, n=n_meridian, ratio=ratio, necks=True)
    phi = 2.0 * np.pi * np.arange(n_azimuth) / n_azimuth
    m, k = len(x), n_azimuth
    points = np.stack([np.repeat(x, k), np.outer(y, np.cos(phi)).ravel(),
                       np.outer(y, np.sin(phi)).ravel()], axis=1)
    i, j = np.meshgrid(np.arange(m - 1), np.arange(k), indexing="ij")
    a, b = i * k + j, i * k + (j + 1) % k                # ring i, azimuths j and j + 1
    c, d = a + k, b + k                                  # ring i + 1
    # x grows along the meridian and phi about +x: (a, b, c) turns the normal away from
    # the axis, out of the liquid, as Evolver's facets
    triangles = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                                np.stack([b, d, c], -1).reshape(-1, 3)])
    contact = np.full(m * k, -1, dtype=np.int64)
    contact[:k], contact[-k:] = 0, 1
    return LiquidShape(points=points, triangles=triangles,
                       body=np.zeros(len(triangles), np.int64), contact_grain=contact,
                       centres=np.array([[0.0, 0.0, 0.0], [1.0 + ratio + gap, 0.0, 0.0]]),
                       radii=np.array([1.0, float(ratio)]),
                       contact_angles=np.array([float(theta), float(theta2)]),
                       volumes=(float(r["volume"]),), status=status_name(st),
                       method=f"exact Young-Laplace meridian revolved ({m} x {k} points)",
                       wetted=(0, 1))


# --------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------


def shape_paths(path, overwrite=False, flag="overwrite=True"):
    """The two files :func:`write_shape` writes, checked before anything is computed.

    Parameters
    ----------
    path : str or Path
        The surface file, ``.vtp`` or ``.vtk``.
    overwrite : bool
        Accept existing files (they will be replaced).
    flag : str
        How the caller asks for a replacement, named in the message (the command line
        passes its option).

    Returns
    -------
    (Path, Path)
        The surface file and the grains file next to it, ``<stem>_grains<suffix>``.

    Raises
    ------
    CapbridgeInputError
        A suffix other than .vtp/.vtk, or a folder that does not exist.
    FileExistsError
        One of the two files exists and ``overwrite`` is false.
    """
    surface = check_vtk_path(path, overwrite, flag)
    return surface, check_vtk_path(surface.with_name(f"{surface.stem}_grains"
                                                     f"{surface.suffix}"), overwrite, flag)


def write_shape(shape, path, *, overwrite=False):
    """Write a liquid surface and its grains as VTK files for ParaView.

    Parameters
    ----------
    shape : LiquidShape, BridgeResult or dict
        The shape; or a :class:`capbridge.solvers.evolver.BridgeResult` (its ``shape``),
        or the output of :func:`capbridge.solvers.triplet_evolver.evolver_triplet`
        (its ``"shape"``), solved with ``keep_shape=True``.
    path : str or Path
        The surface file, ``.vtp`` (XML, ParaView's own) or ``.vtk`` (legacy).  The
        grains go next to it, in ``<stem>_grains<suffix>``.
    overwrite : bool
        Replace existing files (default: refuse, naming the first that exists, before
        writing either).

    Returns
    -------
    (Path, Path)
        The surface file and the grains file.

    Raises
    ------
    CapbridgeInputError
        No shape in ``shape`` (not kept, or a result without a solution), or a bad path.
    FileExistsError
        A file exists and ``overwrite`` is false.

    Notes
    -----
    The surface file holds one triangle per facet, cell data ``body`` (0-based liquid
    body) and point data ``contact_grain`` (0-based grain of a contact-line vertex, -1
    elsewhere).  The grains file holds one vertex per grain at its centre with point
    data ``radius``, ``grain`` (0-based), ``contact_angle`` [deg] and ``wetted`` (1 if
    the liquid wets the grain).  Both titles state the unit (lengths / r) and the case.
    """
    shape = _shape_of(shape)
    surface, grains = shape_paths(path, overwrite)
    title = shape.title
    write_polydata(surface, shape.points, shape.triangles, "polys",
                   cell_data={"body": np.asarray(shape.body, np.int64)},
                   point_data={"contact_grain": np.asarray(shape.contact_grain, np.int64)},
                   title=title, overwrite=overwrite)
    n = len(shape.radii)
    wetted = np.isin(np.arange(n), list(shape.wetted)).astype(np.int64)
    write_polydata(grains, shape.centres, np.arange(n), "verts",
                   point_data={"radius": np.asarray(shape.radii, float),
                               "grain": np.arange(n),
                               "contact_angle": np.asarray(shape.contact_angles, float),
                               "wetted": wetted},
                   title=f"grains of {surface.name}: " + title, overwrite=overwrite)
    return surface, grains


def _shape_of(obj):
    """The LiquidShape in ``obj`` (itself, a result's ``shape``, a dict's ``"shape"``)."""
    if isinstance(obj, LiquidShape):
        return obj
    shape = obj.get("shape") if isinstance(obj, dict) else getattr(obj, "shape", None)
    if isinstance(shape, LiquidShape):
        return shape
    status = obj.get("status") if isinstance(obj, dict) else getattr(obj, "status", None)
    if isinstance(status, Status):
        status = status_name(status)
    raise CapbridgeInputError(
        f"no liquid surface to write (status {status or 'unknown'}): Surface Evolver "
        "keeps one only for a result with numbers (converged, above_tolerance) solved "
        "with keep_shape=True; the exact doublet's is made by doublet_shape()")
