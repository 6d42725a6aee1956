"""Nothing a user had disappears: the public surface before the layered layout still resolves.

``tests/data/public_surface_before_layout.json`` lists, as of the commit before the layout
of issue 17 (bacf4de), every public module of capbridge with the public names defined in
it, and every CLI command with its options.  Each module must still import under its old
name (the moved ones through :mod:`capbridge._legacy`, with a ``DeprecationWarning``), each
name must still be an attribute of it, and each command must still accept each option.
"""
from __future__ import annotations

import argparse
import importlib
import json
import warnings
from pathlib import Path

import pytest

from capbridge.cli import build_parser

BEFORE = json.loads((Path(__file__).parent / "data" / "public_surface_before_layout.json")
                    .read_text(encoding="utf-8"))


@pytest.mark.parametrize("module", sorted(BEFORE["modules"]))
def test_module_names_still_resolve(module):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        mod = importlib.import_module(module)
    missing = [n for n in BEFORE["modules"][module] if not hasattr(mod, n)]
    assert not missing, f"{module} lost {missing}"


def _commands(parser, path=()):
    yield " ".join(path) or "capbridge", {s for a in parser._actions for s in a.option_strings}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, path + (name,))


def test_cli_commands_and_options_still_exist():
    now = dict(_commands(build_parser()))
    lost = {c: sorted(set(opts) - now.get(c, set())) for c, opts in BEFORE["cli"].items()}
    lost = {c: o for c, o in lost.items() if o or c not in now}
    assert not lost, f"CLI commands/options lost: {lost}"
