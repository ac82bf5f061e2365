"""Test-session set-up shared by every test directory."""
import pytest

# Files whose first tests compile the same large kernel (the batched, threaded step):
# run by one worker, the second file finds that kernel in Numba's cache instead of
# compiling it at the same time in another process.
_SHARED_WORKER = {
    "tests/test_world.py": "batched-step",
    "tests/pipeline/test_parallel.py": "batched-step",
}


def pytest_collection_modifyitems(config, items):
    """Under ``pytest -n 2 --dist loadgroup`` (the README's command) each test file runs on
    one worker, so the kernels a file compiles compile once; the files of
    ``_SHARED_WORKER`` share one. Without pytest-xdist the marks do nothing."""
    for item in items:
        path = item.nodeid.split("::")[0]
        item.add_marker(pytest.mark.xdist_group(_SHARED_WORKER.get(path, path)))
