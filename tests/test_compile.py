"""tumble._compile: kernels Numba's cache does not hold are shared between this process
and worker processes, which fill the cache; nothing is ever left uncompiled."""
import os
import subprocess
import sys

import pytest

from tumble._compile import WORKERS_VARIABLE, worker_count

_SHARE = """
import sys
import numpy as np
from numba import typeof, types
from tumble._compile import compile_all
from tumble.math.quat import quat_from_mat
from tumble.pipeline.integrate import first_bad_body
GROUPS = [{first_bad_body, quat_from_mat}] if sys.argv[1] == "grouped" else []

v, q = np.zeros((2, 3)), np.zeros((2, 4))
bad_sig = (typeof(v), typeof(q), typeof(v), typeof(v), types.float64)
mat_sig = (typeof(np.eye(3)),)
# the heavier job goes to this process, the lighter to the worker (when there is one)
compile_all([(first_bad_body, bad_sig, 10.0), (quat_from_mat, mat_sig, 1.0)],
            groups=GROUPS)
print(first_bad_body.stats.cache_misses[bad_sig], quat_from_mat.stats.cache_misses[mat_sig],
      quat_from_mat.stats.cache_hits[mat_sig], first_bad_body(v, q, v, v, 1e6))
"""


def _run(tmp_path, workers, grouped=False):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               **{WORKERS_VARIABLE: str(workers)})
    out = subprocess.run([sys.executable, "-c", _SHARE, "grouped" if grouped else "apart"],
                         capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


def test_a_worker_compiles_its_share_into_the_cache_this_process_loads(tmp_path):
    """With one worker and an empty cache: this process compiles the heavier kernel, the
    worker the lighter one, which this process then loads from the cache; both run."""
    misses_here, misses_worker_job, hits_worker_job, result = _run(tmp_path, 1)
    assert (misses_here, misses_worker_job, hits_worker_job) == ("1", "0", "1")
    assert result == "-1"


def test_kernels_grouped_together_compile_in_one_process(tmp_path):
    """Kernels that share code, given as a group, go to one process (here the heavier
    group's: this one), which compiles both; the worker gets nothing."""
    assert _run(tmp_path, 1, grouped=True)[:3] == ["1", "1", "0"]


def test_without_workers_everything_compiles_here(tmp_path):
    assert _run(tmp_path, 0)[:3] == ["1", "1", "0"]


def test_the_worker_count_is_read_from_the_environment(monkeypatch):
    monkeypatch.setenv(WORKERS_VARIABLE, "3")
    assert worker_count() == 3
    monkeypatch.setenv(WORKERS_VARIABLE, "two")
    with pytest.raises(ValueError, match=WORKERS_VARIABLE):
        worker_count()
    monkeypatch.delenv(WORKERS_VARIABLE)
    assert worker_count() >= 0
