"""Tables: netCDF schema, reading, checks and atomic writes; resumable sweeps; the
builders of the doublet, triplet and coalescence tables."""

from pathlib import Path

#: the shipped tables' folder (``data/`` beside the package)
DATA_DIR = Path(__file__).resolve().parents[2] / "data"
