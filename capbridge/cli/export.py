"""``capbridge export-yade``: YADE's own capillary files from the exact solver.

YADE's ``Law2_ScGeom_CapillaryPhys_Capillarity`` reads tabulated bridges (the
``M(r=...)`` files); :func:`capbridge.yade.yade_export.export_from_solver` writes them
from the exact suction-controlled solver, one set per contact angle, into a directory
this command makes (or reuses) and prints the files written.
"""
from __future__ import annotations

from pathlib import Path

from capbridge.validation import CapbridgeInputError


def cmd_export_yade(args):
    """One set of YADE capillary files per ``--theta`` in ``--directory``."""
    from capbridge.tabular_io import check_output_path
    from capbridge.yade.yade_export import export_from_solver

    out = Path(args.directory)
    if out.exists() and not out.is_dir():
        raise CapbridgeInputError(f"--directory {out} is a file, not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CapbridgeInputError(f"--directory {out} cannot be made: {exc.strerror or exc}") from None
    check_output_path(out / "probe", what="--directory")
    for theta in args.theta:
        _, paths = export_from_solver(out, theta, n_gaps=args.n_gaps)
        for p in (paths if isinstance(paths, (list, tuple)) else [paths]):
            print(p)
    return 0
