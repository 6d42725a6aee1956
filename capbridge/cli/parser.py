"""The pieces the command line's parser is built from (:func:`capbridge.cli.build_parser`).

The argparse parser class (negative numbers as values, errors in one line), the
argument type of a number in a range, and the options several commands share: the
three gaps of a triplet, the Evolver refinement level, and gravity (``--bond``,
``--gravity``) read into a Bond number and a unit direction.
"""
from __future__ import annotations

import argparse
import re
import sys

import numpy as np

from capbridge.physics.gravity import gravity_vector
from capbridge.validation import CapbridgeInputError, check_range, interval_text

#: global option (anywhere on the line, like --debug): use unverified tables
ALLOW_UNVERIFIED_OPTION = "--allow-unverified-table"

# a negative number in any float notation (argparse's own pattern misses "-1e6")
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$"
                              # or a vector x,y,z that starts with one (--gravity -1,0,0)
                              r"|^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(,[-+]?[\d.eE+-]*)+$",
                              re.IGNORECASE)


class CommandLineParser(argparse.ArgumentParser):
    """argparse with negative numbers in exponent form as values, and one-line errors."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self._negative_number_matcher = _NEGATIVE_NUMBER

    def error(self, message):
        print(f"capbridge: error: {self.prog}: {message} (see `{self.prog} --help`)",
              file=sys.stderr)
        sys.exit(2)


def number_in_range(low=-np.inf, high=np.inf, low_open=False, integer=False, hint=""):
    """argparse type: a finite number in [low, high] (``low_open``: (low, high]);
    ``hint`` ends the message of a value outside the range (why the range)."""
    def parse(text):
        try:
            v = int(text) if integer else float(text)
        except ValueError:
            kind = "an integer" if integer else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {kind}") from None
        if not np.isfinite(v) or v < low or v > high or (low_open and v == low):
            raise argparse.ArgumentTypeError(
                f"{v!r} is outside the allowed range {interval_text(low, high, low_open)}"
                + (f" ({hint})" if hint else ""))
        return v
    return parse


#: --max-refine of the Evolver solves: level 2 at least (below, no error estimate)
EVOLVER_REFINE = (2, 6)
_REFINE_HINT = ("Surface Evolver results need level 2 at least: the error estimate "
                "compares the forces of levels 1 and 2")


def evolver_refine_level():
    """argparse type of ``--max-refine`` for the Evolver solves (:data:`EVOLVER_REFINE`)."""
    return number_in_range(*EVOLVER_REFINE, integer=True, hint=_REFINE_HINT)


def add_triplet_gaps(parser):
    """The three gaps of a triplet (--d12, --d13, --d23), as every triplet command takes them."""
    for i, j in ((1, 2), (1, 3), (2, 3)):
        parser.add_argument(f"--d{i}{j}", type=float, required=True,
                            help=f"gap between grains {i} and {j}, d/r")


def add_shape_options(parser, unit, note=""):
    """``--shape OUT.vtp`` and ``--overwrite`` of the solve commands (lengths / ``unit``;
    ``note``: which surface the command writes, when it is not Surface Evolver's)."""
    parser.add_argument("--shape", default=None, metavar="OUT.vtp",
                        help=f"also write the liquid surface (triangles, lengths / {unit}) to "
                             "OUT.vtp (or .vtk) and the grains to OUT_grains.vtp, for "
                             "ParaView" + (f" ({note})" if note else ""))
    parser.add_argument("--overwrite", action="store_true",
                        help="replace existing --shape files")


def add_evolver_gravity_options(parser, frame):
    """``--bond`` and ``--gravity`` of the Surface Evolver solves (``frame``: the frame of
    the direction, in words)."""
    parser.add_argument("--bond", type=float, default=None, metavar="BO",
                        help="gravity on the liquid: Bond number Bo = drho g r^2/gamma in "
                             "[0, 5]")
    parser.add_argument("--gravity", default=None, metavar="X,Y,Z",
                        help=f"direction along which gravity pulls (default 0,0,-1) in {frame}")


def parse_gravity(bond, gravity, bond_max, what):
    """(Bo, unit direction) from ``--bond BO`` and ``--gravity X,Y,Z`` (text or None).

    Bo in [0, ``bond_max``] (``what`` names the limit in the message); the direction
    along which gravity pulls, three finite components not all zero, default (0, 0, -1);
    ``--gravity`` without ``--bond`` is refused.  Returns (0.0, None) without
    ``--bond``.  Errors: one CapbridgeInputError line naming the value and the range.
    """
    if bond is None:
        if gravity is not None:
            raise CapbridgeInputError(f"--gravity {gravity} needs --bond BO (the Bond "
                                      f"number, in [0, {bond_max:g}])")
        return 0.0, None
    bo = float(check_range("--bond", bond, 0.0, bond_max,
                           hint=f"Bond number Bo = drho g r^2 / gamma ({what})"))
    if gravity is None:
        return bo, np.array([0.0, 0.0, -1.0])
    parts = [p.strip() for p in str(gravity).split(",")]
    try:
        g = np.array([float(p) for p in parts])
    except ValueError:
        g = None
    if g is None or g.size != 3 or not np.all(np.isfinite(g)) or not np.any(g):
        raise CapbridgeInputError(
            f"--gravity {gravity!r}: give the direction along which gravity pulls as three "
            "finite numbers X,Y,Z, not all zero (e.g. 0,0,-1)")
    return bo, gravity_vector(1.0, g)
