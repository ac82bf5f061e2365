"""Numba's on-disk kernels are dropped exactly for the sources that changed and the files
that import them (tumble/_cache.py)."""
import json
import os
import time

from tumble import _cache


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def make_package(root):
    """math.py <- rows.py <- step.py (imports through ``from . import`` and a parenthesised
    list), solo.py alone, plain.py without Numba; every kernel file has cached kernels."""
    write(root / "math.py", "from numba import njit\n")
    write(root / "pipeline" / "__init__.py", "")
    write(root / "pipeline" / "rows.py", "from numba import njit\nfrom ..math import x\n")
    write(root / "pipeline" / "step.py",
          "from numba import njit\nfrom . import rows\nfrom .solo import (\n    a,\n)\n")
    write(root / "pipeline" / "solo.py", "from numba import njit\n")
    write(root / "plain.py", "import os\n")
    make_kernels(root)


def make_kernels(root):
    """Stand-ins for the kernels Numba caches beside every kernel file."""
    for rel in ("math.py", "pipeline/rows.py", "pipeline/step.py", "pipeline/solo.py"):
        src = root / rel
        cache = src.parent / "__pycache__"
        cache.mkdir(exist_ok=True)
        (cache / f"{src.stem}.kernel-1.py311.nbi").write_text("")
        (cache / f"{src.stem}.kernel-1.py311.1.nbc").write_text("")


def cached(root):
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*.nb[ic]"))


def touch(path):
    t = time.time_ns() + 10**9
    path.write_text(path.read_text() + "\n")
    os.utime(path, ns=(t, t))


def test_import_graph_follows_relative_imports(tmp_path):
    make_package(tmp_path)
    graph = _cache.import_graph(tmp_path, _cache._numba_sources(tmp_path))
    assert graph["pipeline/step.py"] == {"pipeline/__init__.py", "pipeline/rows.py",
                                         "pipeline/solo.py"}
    assert graph["pipeline/rows.py"] == {"math.py"}
    assert "plain.py" not in graph
    assert _cache.stale_files({"math.py"}, graph) == {"math.py", "pipeline/rows.py",
                                                      "pipeline/step.py"}


def test_only_changed_files_and_their_importers_lose_kernels(tmp_path):
    make_package(tmp_path)
    # no record yet: no cached kernel can be trusted
    assert _cache.invalidate_stale_kernels(tmp_path) == set(_cache._numba_sources(tmp_path))
    assert cached(tmp_path) == []
    stamp = json.loads((tmp_path / "__pycache__" / _cache._STAMP).read_text())
    assert set(stamp) == set(_cache._numba_sources(tmp_path))
    make_kernels(tmp_path)                               # compiled again
    assert _cache.invalidate_stale_kernels(tmp_path) == set()      # nothing changed
    assert len(cached(tmp_path)) == 8
    touch(tmp_path / "pipeline" / "rows.py")
    assert _cache.invalidate_stale_kernels(tmp_path) == {"pipeline/rows.py",
                                                         "pipeline/step.py"}
    left = cached(tmp_path)
    assert len(left) == 4 and not any(
        p.startswith(("pipeline/__pycache__/rows.", "pipeline/__pycache__/step.")) for p in left)
    touch(tmp_path / "plain.py")                         # not a kernel file: nothing to do
    assert _cache.invalidate_stale_kernels(tmp_path) == set()
    assert len(cached(tmp_path)) == 4
