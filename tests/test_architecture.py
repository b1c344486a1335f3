"""The house's rule, read from the code: every room imports only rooms below it (docs/ARCHITECTURE.md).

A room is a subpackage of ``swim_jax`` (``io``, ``envs``, ...) or one of its two single-file rooms
(``activations.py``, ``config.py``); the modules directly under ``swim_jax/`` besides those two are
the doors of the commands (``python -m swim_jax.train`` ...), above every room. Imports are read
with ``ast`` from the source, lazy ones inside functions included, so the rule cannot be kept by
hiding an import in a function.
"""

from __future__ import annotations

import ast
import os

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = os.path.join(REPO, "swim_jax")
# bottom to top: a room may import rooms before it in this list, never one after it
FLOORS = ["io", "policy", "activations", "envs", "agents", "config", "placement", "analysis", "run", "bench"]
DOORS = "doors"  # the command modules directly under swim_jax/


def _room(module: str) -> str | None:
    """The room of a dotted module name of the project, or None for anything else."""
    parts = module.split(".")
    if parts[0] != "swim_jax" or len(parts) == 1:
        return None
    return parts[1] if parts[1] in FLOORS else DOORS


def _modules() -> dict[str, str]:
    """Dotted name -> source path of every module of the package."""
    out = {}
    for folder, _, files in os.walk(PACKAGE):
        for f in files:
            if f.endswith(".py"):
                rel = os.path.relpath(os.path.join(folder, f), REPO)[:-3].replace(os.sep, ".")
                out[rel.removesuffix(".__init__")] = os.path.join(folder, f)
    return out


def _imports(path: str, module: str) -> set[str]:
    """Every project module ``path`` imports (``from a.b import c`` counts as a.b.c when that is a module)."""
    modules = _modules()
    tree = ast.parse(open(path).read(), path)
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import
                pkg = module.split(".")[: len(module.split(".")) - node.level + (path.endswith("__init__.py"))]
                base = ".".join(pkg + ([base] if base else []))
            for a in node.names:
                found.add(f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base)
    return {m for m in found if m.split(".")[0] == "swim_jax"}


def test_no_room_imports_a_room_above_it():
    wrong = []
    for module, path in sorted(_modules().items()):
        room = _room(module)
        if room is None:
            continue
        for dep in sorted(_imports(path, module)):
            other = _room(dep)
            if other is None or other == room:
                continue
            if room != DOORS and (other == DOORS or FLOORS.index(other) > FLOORS.index(room)):
                wrong.append(f"{module} ({room}) imports {dep} ({other})")
    assert not wrong, "\n".join(wrong)


def test_no_project_module_outside_the_package():
    """The generic top-level names the project once had (``envs``, ``agents``) are gone: nothing
    outside swim_jax/ is a package or is imported as one."""
    assert not [d for d in ("envs", "agents") if os.path.exists(os.path.join(REPO, d))]
    for module, path in _modules().items():
        tree = ast.parse(open(path).read(), path)
        for node in ast.walk(tree):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else []
            assert not [n for n in names if n.split(".")[0] in ("envs", "agents")], f"{module}: {names}"


@pytest.mark.parametrize("door", ["train", "sweep", "study", "report", "render", "evaluate", "plots"])
def test_each_door_hands_over_to_its_room(door):
    """A door is only ``main`` of a room's module: the command's code lives in its room."""
    path = os.path.join(PACKAGE, f"{door}.py")
    deps = _imports(path, f"swim_jax.{door}")
    assert len(deps) == 1 and _room(next(iter(deps))) in FLOORS, deps
    assert len(open(path).read().splitlines()) <= 40
