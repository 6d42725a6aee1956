"""Tables: netCDF schema, reading, checks and atomic writes; resumable sweeps; the
builders of the doublet, triplet and coalescence tables."""

from pathlib import Path

#: the shipped tables' folder (``data/`` beside the package)
DATA_DIR = Path(__file__).resolve().parents[2] / "data"
#: the shipped tables: doublets (exact Young-Laplace), coalesced triplets (Surface
#: Evolver) and the coalescence volumes of three equal spheres
DOUBLET_TABLE = DATA_DIR / "doublet_table.nc"
TRIPLET_TABLE = DATA_DIR / "triplet_table.nc"
#: the second triplet table (issue 18): the domain 1,000-grain packings reach (open side
#: up to 0.6, v up to 5); the DEM engine's table
TRIPLET_TABLE_PACKINGS = DATA_DIR / "triplet_table_packings.nc"
COALESCENCE_TABLE = DATA_DIR / "triplet_coalescence.nc"

# reading a table file runs the checks of its kind (units, bounds, sum rules, symmetry)
from capbridge.tables import checks as _checks  # noqa: E402
from capbridge.tables.netcdf_io import register_table_checks  # noqa: E402

register_table_checks(_checks.check_table, _checks.table_kind)
