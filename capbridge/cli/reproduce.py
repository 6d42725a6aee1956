"""``capbridge reproduce STUDY``: rerun a published study (:mod:`capbridge.studies`).

The study writes its figures, CSV files and claims table (CLAIMS.md) into
``--output-dir``; this command prints where, as JSON.  The full run keeps resumable
Surface Evolver checkpoints by default (hours of work); ``--quick`` needs none.
"""
from __future__ import annotations

import importlib
from pathlib import Path

from capbridge.cli.output import print_json


def cmd_reproduce(args):
    """Run ``capbridge.studies.<study>.run`` and print the files it wrote."""
    study = importlib.import_module(f"capbridge.studies.{args.study}")
    ck = args.checkpoint_dir
    if ck is None and not args.quick:
        ck = f".sweep-checkpoints/{args.study}"
    s = study.run(args.output_dir, quick=args.quick, checkpoint_dir=ck,
                  progress=not args.no_progress, max_refine=args.max_refine)
    print_json({"output_dir": args.output_dir, "files": s.get("files", []),
                "claims": str(Path(args.output_dir) / "CLAIMS.md"),
                "timings_s": s.get("timings_s", {})})
    return 0
