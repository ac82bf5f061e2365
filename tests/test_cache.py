"""Numba's on-disk kernels are dropped exactly for the sources that changed and the files
that import them (tumble/_cache.py)."""
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tumble import _cache

NUMBA_USER_CACHE = _cache._user_cache_dir()      # before a test points it elsewhere

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


def touch(path, replace=("", "")):
    """Edit ``path`` (a blank line at its end, or the replacement), its time one second on."""
    t = time.time_ns() + 10**9
    path.write_text(path.read_text().replace(*replace) + "\n")
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


# --- where Numba caches: in-tree, under NUMBA_CACHE_DIR, in the user-wide cache ---------

@pytest.fixture(autouse=True)
def elsewhere(tmp_path_factory, monkeypatch):
    """Numba's NUMBA_CACHE_DIR and user-wide cache, for this test: unset and an empty
    folder, so no test reads or writes the real ones."""
    places = {"numba": "", "user": str(tmp_path_factory.mktemp("user-cache") / "numba")}
    monkeypatch.setattr(_cache, "_numba_cache_dir", lambda: places["numba"])
    monkeypatch.setattr(_cache, "_user_cache_dir", lambda: places["user"])
    return places


def make_mirrored_kernels(root, base):
    """The stand-in kernels of make_kernels, in the mirrored location under ``base``."""
    for rel in ("math.py", "pipeline/rows.py", "pipeline/step.py", "pipeline/solo.py"):
        src = root / rel
        cache = _cache.mirrored(base)(src.parent)
        cache.mkdir(parents=True, exist_ok=True)
        (cache / f"{src.stem}.kernel-1.py311.nbi").write_text("")
        (cache / f"{src.stem}.kernel-1.py311.1.nbc").write_text("")
        (cache / f"guf-{src.stem}.kernel-1.py311.nbi").write_text("")   # a library cache


def mirrored_kernels(base):
    return sorted(p.relative_to(base).as_posix() for p in Path(base).rglob("*.nb[ic]"))


def test_mirrored_locations_are_numbas(tmp_path, monkeypatch):
    """The folder a mirrored location gives a source folder is the one Numba caches in,
    under NUMBA_CACHE_DIR and in the user-wide cache."""
    from numba.core import caching, config
    root = tmp_path / "pkg"
    write(root / "sub" / "mod.py", "def f():\n    return 1\n")
    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "nc"))

    def f():
        return 1
    locator = caching.UserProvidedCacheLocator(f, str(root / "sub" / "mod.py"))
    assert Path(locator.get_cache_path()) == _cache.mirrored(tmp_path / "nc")(root / "sub")
    locator = caching.UserWideCacheLocator(f, str(root / "sub" / "mod.py"))
    assert Path(locator.get_cache_path()) == _cache.mirrored(NUMBA_USER_CACHE)(root / "sub")


def test_numba_cache_dir_loses_stale_kernels(tmp_path, elsewhere):
    root, base = tmp_path / "pkg", tmp_path / "numba-cache"
    make_package(root)
    elsewhere["numba"] = str(base)
    make_mirrored_kernels(root, base)          # cached by a tumble that left them there
    assert _cache.invalidate_stale_kernels(root) == set(_cache._numba_sources(root))
    assert mirrored_kernels(base) == []        # no record there: nothing kept
    assert (_cache.mirrored(base)(root) / _cache._STAMP).is_file()
    make_kernels(root)
    make_mirrored_kernels(root, base)
    assert _cache.invalidate_stale_kernels(root) == set()
    assert len(mirrored_kernels(base)) == 12
    touch(root / "pipeline" / "rows.py")
    assert _cache.invalidate_stale_kernels(root) == {"pipeline/rows.py", "pipeline/step.py"}
    left = mirrored_kernels(base)
    assert len(left) == 6 and not any(Path(p).name.startswith(
        ("rows.", "step.", "guf-rows.", "guf-step.")) for p in left)
    assert len(cached(root)) == 4              # in-tree too


def test_each_location_has_its_own_stamp(tmp_path, elsewhere):
    """An edit made while Numba cached elsewhere drops the stale kernels of a location
    when it is in use again."""
    root, base = tmp_path / "pkg", tmp_path / "numba-cache"
    make_package(root)
    elsewhere["numba"] = str(base)
    _cache.invalidate_stale_kernels(root)
    make_mirrored_kernels(root, base)
    elsewhere["numba"] = ""                    # a run without NUMBA_CACHE_DIR after an edit
    touch(root / "math.py")
    make_kernels(root)
    assert _cache.invalidate_stale_kernels(root) == {"math.py", "pipeline/rows.py",
                                                     "pipeline/step.py"}
    assert len(mirrored_kernels(base)) == 12   # not looked at
    elsewhere["numba"] = str(base)             # NUMBA_CACHE_DIR again
    assert _cache.invalidate_stale_kernels(root) == {"math.py", "pipeline/rows.py",
                                                     "pipeline/step.py"}
    assert sorted(Path(p).name for p in mirrored_kernels(base)) == [
        "guf-solo.kernel-1.py311.nbi", "solo.kernel-1.py311.1.nbc", "solo.kernel-1.py311.nbi"]


def test_no_stamp_until_the_stale_kernels_are_gone(tmp_path, elsewhere, monkeypatch):
    root, base = tmp_path / "pkg", tmp_path / "numba-cache"
    make_package(root)
    elsewhere["numba"] = str(base)
    _cache.invalidate_stale_kernels(root)
    stamp = _cache.mirrored(base)(root) / _cache._STAMP
    before = stamp.read_text()
    make_mirrored_kernels(root, base)
    touch(root / "pipeline" / "solo.py")
    unlink = Path.unlink

    def refuse(self, missing_ok=False):
        if base in self.parents:
            raise PermissionError(self)
        unlink(self, missing_ok=missing_ok)
    monkeypatch.setattr(Path, "unlink", refuse)
    _cache.invalidate_stale_kernels(root)      # no error on import
    assert stamp.read_text() == before and len(mirrored_kernels(base)) == 12
    monkeypatch.setattr(Path, "unlink", unlink)
    assert _cache.invalidate_stale_kernels(root) == {"pipeline/solo.py", "pipeline/step.py"}
    assert stamp.read_text() != before and len(mirrored_kernels(base)) == 6


def test_user_wide_cache(tmp_path, elsewhere):
    """The user-wide cache is looked at once it holds the package's kernels."""
    root, user = tmp_path / "pkg", Path(elsewhere["user"])
    make_package(root)
    assert _cache.invalidate_stale_kernels(root) == set(_cache._numba_sources(root))
    assert not user.exists()                   # the tree is writable: Numba caches there
    make_mirrored_kernels(root, user)
    assert _cache.invalidate_stale_kernels(root) == set(_cache._numba_sources(root))
    assert mirrored_kernels(user) == []
    make_mirrored_kernels(root, user)
    touch(root / "math.py")
    assert _cache.invalidate_stale_kernels(root) == {"math.py", "pipeline/rows.py",
                                                     "pipeline/step.py"}
    assert len(mirrored_kernels(user)) == 3


def test_user_wide_cache_of_a_read_only_tree(tmp_path, elsewhere, monkeypatch):
    """A tree Numba cannot write to: it caches in the user-wide cache, which gets a stamp
    before the first kernel is cached there."""
    root, user = tmp_path / "pkg", Path(elsewhere["user"])
    make_package(root)
    _cache.invalidate_stale_kernels(root)
    monkeypatch.setattr(_cache, "_writable", lambda folder: False)
    assert _cache.invalidate_stale_kernels(root) == set(_cache._numba_sources(root))
    assert (_cache.mirrored(user)(root) / _cache._STAMP).is_file()
    make_mirrored_kernels(root, user)
    touch(root / "pipeline" / "solo.py")
    assert _cache.invalidate_stale_kernels(root) == {"pipeline/solo.py", "pipeline/step.py"}
    assert len(mirrored_kernels(user)) == 6


# --- with Numba: an edited kernel source is recompiled, never served stale -------------

KERNELS = {
    "consts.py": "from numba import njit\n\n\n@njit(cache=True)\ndef value():\n"
                 "    return 1\n",
    # inlines consts.value: Numba alone would keep serving the cached kernel
    "kern.py": "from numba import njit\n\nfrom .consts import value\n\n\n@njit(cache=True)\n"
               "def kernel():\n    return value() * 10\n",
    "solo.py": "from numba import njit\n\n\n@njit(cache=True)\ndef other():\n    return 7\n",
}

RUN = """
import json, pathlib, sys
import pkg
from pkg import consts, kern, solo
files = sorted(p.name for p in pathlib.Path(sys.argv[1]).rglob("*.nb[ic]"))
print(json.dumps({"dropped": sorted(pkg.DROPPED), "files": files,
                  "value": consts.value(), "kernel": kern.kernel(), "other": solo.other()}))
"""


def run_package(tmp_path, where, env):
    out = subprocess.run([sys.executable, "-c", RUN, str(where)], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1])


def kernel_names(where):
    return sorted(p.name for p in where.rglob("*.nb[ic]"))


@pytest.mark.parametrize("location", ["in-tree", "NUMBA_CACHE_DIR", "user-wide"])
def test_edited_kernel_is_recompiled(tmp_path, location):
    if location == "user-wide" and not sys.platform.startswith("linux"):
        pytest.skip("the user-wide cache is put in the test's folder through XDG_CACHE_HOME")
    root = tmp_path / "pkg"
    write(root / "__init__.py", "from pathlib import Path\n\nfrom ._cache import "
          "invalidate_stale_kernels\n\n"
          "DROPPED = invalidate_stale_kernels(Path(__file__).parent)\n")
    shutil.copy(_cache.__file__, root / "_cache.py")
    for name, text in KERNELS.items():
        write(root / name, text)
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(PYTHONPATH=str(tmp_path), XDG_CACHE_HOME=str(tmp_path / "xdg"),
               PYTHONDONTWRITEBYTECODE="1")
    where = {"in-tree": root, "NUMBA_CACHE_DIR": tmp_path / "numba-cache",
             "user-wide": tmp_path / "xdg" / "numba"}[location]
    if location == "NUMBA_CACHE_DIR":
        env["NUMBA_CACHE_DIR"] = str(where)
    elif location == "user-wide":     # as when the tree cannot be written (we are root here)
        env["NUMBA_CACHE_LOCATOR_CLASSES"] = "UserWideCacheLocator"

    first = run_package(tmp_path, where, env)
    assert (first["value"], first["kernel"], first["other"]) == (1, 10, 7)
    made = kernel_names(where)
    assert {n.split(".")[0] for n in made} == {"consts", "kern", "solo"}
    if location != "in-tree":
        assert kernel_names(root) == []        # cached there only

    touch(root / "consts.py", ("return 1", "return 2"))
    second = run_package(tmp_path, where, env)
    assert (second["value"], second["kernel"], second["other"]) == (2, 20, 7)
    # at import, before anything compiled: the stale kernels are gone
    if location == "user-wide":               # first seen there: nothing kept
        assert second["files"] == []
    else:
        assert second["dropped"] == ["consts.py", "kern.py"]
        assert second["files"] == [n for n in made if n.startswith("solo.")]
    assert kernel_names(where) == made         # compiled again, solo's loaded
