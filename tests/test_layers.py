"""The package's layers hold: no import circle between its parts, core data imports no I/O.

Every import counts, the lazy ones in functions and those under `TYPE_CHECKING` too: a
circle that only shows at run time in one code path is still one a reader must untangle.
"""

from __future__ import annotations

import ast
import graphlib
from pathlib import Path

import dresslog

PACKAGE = Path(dresslog.__file__).parent
#: The core data layer (docs/library.md): no I/O, no engines.
CORE = {"errors", "folders", "force_map", "limb", "spec", "stops", "trial"}


def _imports_between_parts() -> dict[str, set[str]]:
    """Each top-level part of dresslog (`io`, `model`, `spec`, ...) -> the others it imports."""
    edges: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        part = path.relative_to(PACKAGE).parts[0].removesuffix(".py")
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                modules = [node.module]
            elif isinstance(node, ast.Import):
                modules = [alias.name for alias in node.names]
            else:
                continue
            for module in modules:
                names = module.split(".")
                if names[0] == "dresslog" and len(names) > 1 and names[1] != part:
                    edges.setdefault(part, set()).add(names[1])
    return edges


def test_no_part_of_dresslog_imports_one_that_imports_it_back() -> None:
    edges = _imports_between_parts()
    assert "experiments" in edges and "model" in edges  # the walk found the imports
    try:
        graphlib.TopologicalSorter(edges).prepare()
    except graphlib.CycleError as err:
        raise AssertionError(f"import circle: {' -> '.join(err.args[1])}") from None


def test_core_data_imports_only_core_data() -> None:
    edges = _imports_between_parts()
    beyond = {part: sorted(edges.get(part, set()) - CORE) for part in CORE}
    assert all(not others for others in beyond.values()), beyond
