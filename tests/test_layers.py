"""Imports point downward only (ARCHITECTURE.md): a module imports from its own layer and
those below, never from above."""
import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "tumble"

# Each layer with the packages and modules that may not be imported from it.
FORBIDDEN = {
    "math": ("tumble.model", "tumble.pipeline", "tumble.world", "tumble.io",
             "tumble.character", "tumble.viewer", "tumble.rl", "tumble.apps"),
    "model": ("tumble.pipeline", "tumble.world", "tumble.io", "tumble.character",
              "tumble.viewer", "tumble.rl", "tumble.apps"),
    "pipeline": ("tumble.world", "tumble.io", "tumble.character", "tumble.viewer",
                 "tumble.rl", "tumble.apps"),
    "world": ("tumble.character", "tumble.viewer", "tumble.rl", "tumble.apps"),   # io: its layer
    "io": ("tumble.character", "tumble.viewer", "tumble.rl", "tumble.apps"),
    "character": ("tumble.viewer", "tumble.rl", "tumble.apps"),
}


def imported_modules(path):
    """Absolute names of the tumble modules a file imports (relative imports resolved)."""
    package = "tumble." + ".".join(path.relative_to(PACKAGE).with_suffix("").parts[:-1])
    package = package.rstrip(".")
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module
            out.add(name)
            out.update(f"{name}.{a.name}" for a in node.names)
    return {m for m in out if m and m.startswith("tumble")}


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_no_import_points_upward(layer):
    wrong = []
    for path in sorted((PACKAGE / layer).rglob("*.py")):
        for name in imported_modules(path):
            if any(name == f or name.startswith(f + ".") for f in FORBIDDEN[layer]):
                wrong.append(f"{path.relative_to(PACKAGE)} imports {name}")
    assert wrong == []


def test_import_tumble_loads_neither_viewer_nor_learning():
    code = ("import sys, tumble; print(sorted(m for m in sys.modules "
            "if m.startswith(('tumble.viewer', 'tumble.rl'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=PACKAGE.parent)
    assert out.stdout.strip() == "[]"
    import tumble
    assert tumble.Recorder.__module__ == "tumble.viewer.recorder"
