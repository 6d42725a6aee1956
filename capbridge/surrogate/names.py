"""Output names of the surrogates: the API's dict keys and the CSV columns of
``capbridge lookup``, mapped in one place (light: no scikit-learn, for the CLI)."""
from __future__ import annotations

#: output names of the lookups (API, dict keys) -> their column in ``capbridge lookup``
#: CSV files (and the keys of ``capbridge solve``'s JSON): the one place where the two
#: are mapped.  The CSV names are the ones users have (F, P, d_rupt).
CSV_COLUMNS = {"force": "F", "pressure": "P", "beta1": "beta1", "beta2": "beta2",
               "rupture_gap": "d_rupt", "status": "status",
               # coalesced triplets
               "f12": "f12", "f13": "f13", "f23": "f23", "volume_coalescence": "V_coal",
               "v": "v", "V0": "V0", "dV": "dV", "energy_difference": "E_coal_minus_E_sep",
               "force_error": "f_error", "lower_energy_state": "lower_energy_state"}
#: every output name of the API
OUTPUT_NAMES = tuple(CSV_COLUMNS)
#: the numbers of a doublet lookup (``capbridge lookup doublet``), in column order
DOUBLET_OUTPUTS = ("force", "pressure", "beta1", "beta2", "rupture_gap")
#: the numbers of a coalesced-triplet lookup (``capbridge lookup triplet``)
TRIPLET_OUTPUTS = ("f12", "f13", "f23", "pressure", "volume_coalescence", "v", "V0", "dV",
                   "energy_difference", "force_error")
#: the numbers of a sphere-wall lookup (:class:`~capbridge.surrogate.wall.SphereWallSurrogate`)
WALL_OUTPUTS = ("force", "pressure", "rupture_gap")


def csv_columns(names):
    """API name -> CSV column for ``names`` (a dict, in their order)."""
    return {n: CSV_COLUMNS[n] for n in names}
