"""Test-session set-up shared by every test directory: how the two workers of the README's
``pytest -n 2 --dist loadgroup --no-loadscope-reorder`` share the work.

With Numba's cache cold, the first test that steps a world compiles the whole step (about
five minutes on a 2-core machine). One worker starts on that; the other first runs the test
files that never step a world, and by the time it needs the step, much of it is in the
cache the first worker writes. Without pytest-xdist the marks and the order change nothing
but the order.
"""
import os
from pathlib import Path

import pytest

# Subprocesses the tests start (notebook kernels, the CLI, examples, Ray workers) import
# tumble from this checkout, as the tests do, not from an installed copy: one source tree,
# one Numba cache. (CI installs the package non-editable; a second tree in site-packages
# compiled every kernel again, 13 CPU minutes.)
_ROOT = str(Path(__file__).resolve().parents[1])
os.environ["PYTHONPATH"] = os.pathsep.join(
    [_ROOT] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p and p != _ROOT])

# Runs first: many tests, the first of which compiles the step.
FIRST = "tests/world/test_world.py"

# Files that never step a world (kernels, parsers, the viewer on recordings), longest first.
STEP_FREE = [
    "tests/pipeline/collision/test_collision_properties.py",
    "tests/pipeline/collision/test_collision_pairs.py",
    "tests/pipeline/collision/test_convex_heightfield.py",
    "tests/viewer/test_browser.py",
    "tests/io/test_bvh.py",
    "tests/pipeline/collision/test_collision_queries.py",
    "tests/model/test_builder.py",
    "tests/model/test_meshes.py",
    "tests/model/test_mass.py",
    "tests/character/test_skeleton.py",
    "tests/math/test_quat_np.py",
    "tests/bench/test_bench_ode.py",
    "tests/test_cache.py",
    "tests/rl/test_reference.py",
    "tests/rl/test_policy.py",
    "tests/io/test_fuzz_mjcf.py",
    "tests/io/test_fuzz_bvh.py",
    "tests/io/test_fuzz_urdf.py",
    "tests/io/test_fuzz_mesh.py",
    "tests/test_hardening.py",
    "tests/test_layers.py",
    "tests/test_jit.py",
    "tests/world/test_options.py",
]


def pytest_itemcollected(item):
    """One xdist group per test file: its kernels compile once. Marked as each item is
    collected, before pytest-xdist's ``collection_modifyitems`` turns the marks into
    groups. (The batched step's files used to share one worker too, when that step took
    two minutes more to compile than the serial one; it now takes seconds.)"""
    item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))


def pytest_collection_modifyitems(config, items):
    """Files ordered ``FIRST``, then ``STEP_FREE``, then the rest as collected."""
    by_file = {}
    for item in items:
        by_file.setdefault(item.nodeid.split("::")[0], []).append(item)
    rank = {path: i + 1 for i, path in enumerate(STEP_FREE)}
    rank[FIRST] = 0
    files = sorted(by_file, key=lambda path: rank.get(path, len(rank) + 1))   # stable
    items[:] = [item for path in files for item in by_file[path]]
