"""Compiling independent kernels in parallel processes on a cold start.

The step is one compiled function per stage, each called through the address of its
code (``pipeline/step.py``), so the stages compile independently of each other and of
the step around them. On a cold cache, one process compiling them one after another
spends minutes on one core; ``compile_all`` hands the kernels Numba's on-disk cache does
not hold yet to worker processes (``python -m tumble._compile``), which compile them into
that cache, while this process compiles its own share, then loads theirs from the cache.

It only ever speeds things up: a worker that fails, or a cache another process cannot
fill (caching off, no writable location), leaves this process to compile what is
missing itself, exactly as it would have without workers. ``TUMBLE_COMPILE_WORKERS``
sets how many worker processes may run (default: the cores this process may use, less
one for itself; 0 compiles everything here).
"""
import os
import pickle
import subprocess
import sys
from pathlib import Path

from ._jit import caches_to_disk, load_cached

#: Environment variable: how many worker processes ``compile_all`` may start.
WORKERS_VARIABLE = "TUMBLE_COMPILE_WORKERS"


def worker_count():
    """How many worker processes ``compile_all`` may start (``WORKERS_VARIABLE``, or the
    cores this process may use less one)."""
    value = os.environ.get(WORKERS_VARIABLE)
    if value is not None:
        try:
            return max(0, int(value))
        except ValueError:
            raise ValueError(f"{WORKERS_VARIABLE} must be a whole number of processes, "
                             f"got {value!r}") from None
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:           # pragma: no cover - not Linux
        cores = os.cpu_count() or 1
    return max(0, cores - 1)


def compile_all(jobs, local=(), groups=()):
    """Compile every ``(dispatcher, argtypes, weight)`` of ``jobs`` and of ``local`` in
    this process, the ``jobs`` Numba's cache does not hold spread over worker processes
    (``worker_count``) and this one by ``weight`` (a rough cost, e.g. seconds), ``local``
    always here. ``groups``: sets of dispatchers that share much compiled code (a stage
    and its branches), each kept in one process, which then compiles what they share
    once. Returns when all are compiled in this process (loaded from the cache the
    workers filled, or compiled here if a worker failed)."""
    missing = [(d, tuple(sig), w) for d, sig, w in jobs
               if not load_cached(d, sig)]
    nworker = min(worker_count(), len(missing))
    if nworker == 0 or not all(caches_to_disk(d) for d, _, _ in missing):
        for d, sig, _ in list(local) + missing:
            d.compile(tuple(sig))
        return
    bundles = {}                     # the missing jobs by group (a job of none: its own)
    for job in missing:
        key = next((i for i, g in enumerate(groups) if job[0] in g), None)
        bundles.setdefault(key if key is not None else ("alone", id(job)), []).append(job)
    # longest first, each to the least loaded process; process 0 is this one
    loads = [sum(w for _, _, w in local)] + [0.0] * nworker
    shares = [[] for _ in loads]
    for bundle in sorted(bundles.values(), key=lambda b: -sum(j[2] for j in b)):
        i = loads.index(min(loads))
        shares[i].extend(bundle)
        loads[i] += sum(j[2] for j in bundle)
    workers = []
    for share in filter(None, shares[1:]):
        try:
            workers.append(_start_worker(share))
        except OSError:              # no process to be had: this one compiles it all
            shares[0].extend(share)
    try:
        for d, sig, _ in list(local) + shares[0]:
            d.compile(tuple(sig))
    except BaseException:
        for proc in workers:
            proc.kill()
        raise
    finally:
        for proc in workers:
            proc.wait()
    for d, sig, _ in missing:        # from the cache the workers filled, or compiled here
        d.compile(sig)


def _start_worker(share):
    """A worker process compiling ``share`` (jobs) into Numba's cache."""
    payload = pickle.dumps([(d.py_func.__module__, d.py_func.__qualname__, sig)
                            for d, sig, _ in share])
    package_parent = str(Path(__file__).resolve().parents[1])
    path = os.environ.get("PYTHONPATH")
    env = dict(os.environ, PYTHONPATH=package_parent + (os.pathsep + path if path else ""))
    proc = subprocess.Popen([sys.executable, "-m", "tumble._compile"], stdin=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    proc.stdin.write(payload)
    proc.stdin.close()
    return proc


def _work(jobs):
    """Compile each (module, qualified name, argtypes) of ``jobs`` (a worker's share)."""
    import importlib
    for module, qualname, sig in jobs:
        target = importlib.import_module(module)
        for part in qualname.split("."):
            target = getattr(target, part)
        target.compile(sig)


if __name__ == "__main__":
    _work(pickle.loads(sys.stdin.buffer.read()))
