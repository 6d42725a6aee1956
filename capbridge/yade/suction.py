"""Suction-controlled scenes: YADE's compiled ``Law2_ScGeom_CapillaryPhys_Capillarity``
on capbridge's exported capillary files (:func:`suction_law2`; also reached as
``capbridge.yade.engine.suction_law2``)."""
from __future__ import annotations

from contextlib import chdir  # YADE reads its capillary files from the working directory
from pathlib import Path

__all__ = ["suction_law2"]


def suction_law2(directory, theta, suction, gamma=0.073, *, export_if_missing=True,
                 label="capillary", theta2=None, **export_kw):
    """YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity`` reading capbridge's ``M(r=...)``
    files for contact angle ``theta`` (suction-controlled bridges, native speed).

    ``suction`` = u_gas - u_liquid [Pa].  The files are looked for in ``directory``
    (suffix :func:`~capbridge.yade.yade_export.theta_suffix`); if missing they
    are computed with the exact solver (:func:`~capbridge.yade.yade_export.
    export_from_solver`, keyword arguments ``export_kw``; minutes for the full ratio
    set).  YADE reads them when the engine is built, so the working directory only
    matters here.  Use with ``Ip2_FrictMat_FrictMat_CapillaryPhys``,
    ``Law2_ScGeom_FrictPhys_CundallStrack(neverErase=True)`` and a detection range
    covering the rupture distance (``aabbEnlargeFactor`` / ``interactionDetectionFactor``).
    ``theta2``: angle on the larger grain (the files then hold that pair of angles for
    every bridge of the scene: right only when all bridges join the two materials).
    """
    from capbridge.yade import yade_export as ye

    directory = Path(directory)
    suffix = ye.theta_suffix(theta, theta2)
    files = [directory / ye.capillary_file_name(r, suffix) for r in ye.YADE_RATIOS]
    if not all(f.exists() for f in files):
        if not export_if_missing:
            raise FileNotFoundError(f"capillary files {suffix} missing in {directory}")
        ye.export_from_solver(directory, theta, suffix=suffix, delaunay=False, theta2=theta2,
                              **export_kw)
    from yade import wrapper
    with chdir(directory):
        return wrapper.Law2_ScGeom_CapillaryPhys_Capillarity(
            capillaryPressure=float(suction), surfaceTension=float(gamma),
            suffCapFiles=suffix, label=label)
