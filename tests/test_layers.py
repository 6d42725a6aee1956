"""The import contract of the layout: each layer imports only from the layers below it.

    core (dimensionless, status, validation, tabular_io, version, vtk_io) <- physics <- solvers <- tables
    <- surrogate <- dem <- yade <- studies <- cli

Read from the source (``ast``), every ``import`` counts, at module level or inside a
function: an upward import is a design error, not something to hide in a function.
Also: no module imports another module's ``_private`` names, and the modules form no
import cycle (a cycle dodged by a function-level import is still a cycle here).
``capbridge/__init__.py`` (the public API) and ``capbridge/_legacy.py`` (old import
paths) stand above the layers and are not checked.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "capbridge"
LAYERS = ("core", "physics", "solvers", "tables", "surrogate", "dem", "yade", "studies", "cli")
CORE = ("dimensionless", "status", "validation", "tabular_io", "version", "vtk_io")
EXEMPT = ("capbridge", "capbridge._legacy")


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer(module: str) -> str | None:
    parts = module.split(".")
    if len(parts) < 2:
        return None
    if parts[1] in CORE:
        return "core"
    return parts[1] if parts[1] in LAYERS else None


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def imports(path: Path, name: str):
    """(imported module, imported names, line) of every capbridge import in ``path``."""
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    known = modules()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("capbridge"):
                    yield a.name, (), node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("capbridge"):
                continue
            names = tuple(a.name for a in node.names)
            # "from capbridge.tables import sweep": the submodule is what is imported
            subs = [f"{target}.{n}" for n in names if f"{target}.{n}" in known]
            if subs:
                for s in subs:
                    yield s, (), node.lineno
                rest = tuple(n for n in names if f"{target}.{n}" not in known)
                if rest:
                    yield target, rest, node.lineno
            else:
                yield target, names, node.lineno


def graph():
    out = {}
    for name, path in modules().items():
        if name in EXEMPT:
            continue
        out[name] = list(imports(path, name))
    return out


def test_every_module_has_a_layer():
    orphans = [m for m in modules() if m not in EXEMPT and layer(m) is None]
    assert not orphans, f"modules outside the layers {LAYERS}: {orphans}"


def test_no_upward_import():
    rank = {name: k for k, name in enumerate(LAYERS)}
    bad = []
    for mod, deps in graph().items():
        for target, _, line in deps:
            if target in EXEMPT:
                bad.append(f"{mod}:{line} imports {target} (the public facade)")
                continue
            if rank[layer(target)] > rank[layer(mod)]:
                bad.append(f"{mod}:{line} ({layer(mod)}) imports {target} ({layer(target)})")
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_no_private_names_across_modules():
    bad = [f"{mod}:{line} imports {n} from {target}"
           for mod, deps in graph().items() for target, names, line in deps
           for n in names if n.startswith("_") and not n.startswith("__") and target != mod]
    assert not bad, "private names used across modules:\n" + "\n".join(bad)


def test_no_import_cycles():
    g = {m: sorted({t for t, _, _ in deps if t in modules() and t != m})
         for m, deps in graph().items()}
    cycles, state = [], {}

    def visit(m, stack):
        state[m] = 1
        stack.append(m)
        for t in g.get(m, ()):
            if state.get(t) == 1:
                cycles.append(stack[stack.index(t):] + [t])
            elif t not in state:
                visit(t, stack)
        stack.pop()
        state[m] = 2

    for m in g:
        if m not in state:
            visit(m, [])
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


@pytest.mark.parametrize("old, new", [
    ("capbridge.generator.young_laplace", "capbridge.solvers.young_laplace"),
    ("capbridge.dem_plugin.engine", "capbridge.yade.engine"),
    ("capbridge.surrogate.gravity", "capbridge.physics.gravity"),
    ("capbridge.generator.evolver.minimise", "capbridge.solvers.evolver.minimise"),
    ("capbridge.reproduce", "capbridge.studies"),
])
def test_old_import_paths_still_work(old, new):
    """Scenes, scripts and YADE restart files written for the old layout still import
    (the same module object), with a DeprecationWarning naming the new path."""
    import importlib
    import sys

    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=new.replace(".", r"\.")):
        mod = importlib.import_module(old)
    assert mod is importlib.import_module(new)
