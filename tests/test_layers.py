"""The package's layers import downward only (docs/architecture.md).

Every ``import`` in every module, lazy ones inside functions included, is read with :mod:`ast`;
an import of a module in a higher layer than the importer's is a failure naming both.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "darcyan"

# Lowest first. A module may import its own layer and the layers before it.
LAYERS = ("errors", "_version", "config", "parallel", "geometry", "io", "method", "dense", "eval", "api", "viz",
          "bench", "demo", "cli", "__init__", "__main__")


def layer_of(module: str) -> int:
    """Layer index of ``darcyan.<module>`` (a dotted path below the package)."""
    head = module.split(".")[0] or "__init__"
    if head not in LAYERS:
        raise AssertionError(f"darcyan.{module} belongs to no layer: add it to LAYERS and docs/architecture.md")
    return LAYERS.index(head)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    return ".".join(parts)


def imported_modules(source: str, name: str) -> list[tuple[int, str]]:
    """(line, darcyan module below the package) for every import in ``source``, the text of the
    module ``darcyan.<name>``."""
    package = name.split(".")[:-1]
    found = []
    for node in ast.walk(ast.parse(source, name)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)] if node.level > 1 else package
                target = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.split(".")[0] == "darcyan":
                target = node.module.split(".")[1:]
            else:
                continue
            if not target:  # "from . import x": x is a module of the package, or a name of __init__
                found += [(node.lineno, a.name) for a in node.names]
            elif len(target) == 1 and not (PACKAGE / target[0]).is_dir():
                found.append((node.lineno, target[0]))
            else:
                for a in node.names:
                    sub = ".".join(target + [a.name])
                    found.append((node.lineno, sub if (PACKAGE / "/".join(target + [a.name])).exists()
                                  or (PACKAGE / ("/".join(target + [a.name]) + ".py")).exists() else ".".join(target)))
        elif isinstance(node, ast.Import):
            found += [(node.lineno, a.name.split(".", 1)[1]) for a in node.names
                      if a.name.startswith("darcyan.")]
    return found


MODULES = sorted(PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=[module_name(p) for p in MODULES])
def test_imports_go_downward_only(path):
    importer = module_name(path)
    own = layer_of(importer)
    upward = [f"line {line}: darcyan.{target} ({LAYERS[layer_of(target)]})"
              for line, target in imported_modules(path.read_text(), importer) if layer_of(target) > own]
    assert not upward, f"darcyan.{importer} ({LAYERS[own]}) imports a higher layer: " + "; ".join(upward)


def test_the_reader_finds_lazy_and_relative_imports():
    """Imports inside functions, relative and absolute, resolve to the modules they name."""
    source = ("from ..errors import MeshError\nfrom . import operators\nimport darcyan.io.cache\n"
              "def f():\n    from ..method.pipeline import analyze_mesh\n    from ..dense import maps\n")
    found = [target for _, target in imported_modules(source, "geometry.mesh")]
    assert found == ["errors", "geometry.operators", "io.cache", "method.pipeline", "dense.maps"]
    assert layer_of("method.pipeline") > layer_of("geometry.mesh")
