"""The JSON manifest written beside each export (``*.capbridge.json``): the grid, the
capbridge version, the table's attributes and :data:`FORMAT_NOTES`, what YADE's source
leaves open about its formats and what capbridge chose."""
from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path

from capbridge.version import __version__

#: What is not settled by YADE's source, and what capbridge chose.
FORMAT_NOTES = (
    "CapillarityEngine: delta1/delta2 units.  The engine compares (Delta1+Delta2)*DEG_TO_RAD "
    "with an angle in its fusion check (degrees) but takes cos(Delta) in swInterface/"
    "wnInterface (radians).  capbridge writes degrees (as the M(r=...) files), so fusion "
    "detection is right and those two diagnostics are not; angle_unit='rad' flips it.",
    "CapillarityEngine: 'surface' is taken as liquid-gas area plus the dry areas of both "
    "spheres, the only reading consistent with intEnergy/wnInterface and with the value "
    "4 pi (R1^2 + R2^2) the engine sets without a bridge.  0 is written when the table has "
    "no liquid-gas area (YADE skips SInterface == 0 in intEnergy/wnInterface).",
    "CapillarityEngine: the distance of an overlapping contact is negative and not "
    "clamped (unlike Law2, which uses D = max(D, 0)); capbridge copies the contact "
    "(gap 0) solutions to distance -overlap_pad so contacts keep their bridge.",
    "CapillarityEngine: the triangulation is static: one input file per YADE process "
    "(a second engine's file is ignored with a warning).",
    "nn11/nn33 (M files) and arcLength (Delaunay file) are not computed by capbridge's "
    "solver: 0 is written.",
    "Law2: within a distance block a suction above the block's largest tabulated suction "
    "gives no bridge, and YADE's P = uc R/gamma can round one ulp above the written value. "
    "At the table's largest suction this can drop bridges even at contact (YADE logs 'No "
    "meniscus found at a contact'): keep scene suctions strictly inside the table.",
    "CapillarityEngine, volume control (imposePressure=False): YADE 2023.02a keeps one "
    "cached tetrahedron (and its normals) per bridge for both triangulations and does not "
    "reset it when the engine switches from its first, pressure-based step to the "
    "volume-based ones, so bridges present at that switch are first looked up with a "
    "tetrahedron of the pressure triangulation (wrong force and suction until the walk "
    "relocates).  Bridges whose interaction is created after the switch are fine; the "
    "test scene re-creates the interaction (utils.createInteraction) before setting "
    "vMeniscus.",
)


def write_manifest(path, table, info):
    """Write the manifest of an export of ``table`` to ``path``: the common record,
    updated with ``info`` (the format's own fields); returns ``path``."""
    conv = table.converged
    doc = {
        "generator": f"capbridge {__version__} (capbridge.yade.yade_export)",
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "theta_deg": table.theta,
        "grid": {"ratio": table.ratio.tolist(), "suction": table.suction.tolist(),
                 "gap": table.gap.tolist(),
                 "axes_convention": "capbridge: smaller radius r; suction = -P* = "
                                    "(p_gas - p_liquid) r / gamma; gap d/r"},
        "points": {"total": int(conv.size), "converged": int(conv.sum())},
        "table_attrs": {k: (v if isinstance(v, (str, int, float, bool, type(None))) else str(v))
                        for k, v in table.attrs.items()},
        "format_notes": list(FORMAT_NOTES),
    }
    doc.update(info)
    path = Path(path)
    path.write_text(json.dumps(doc, indent=1, default=str) + "\n")
    return path
