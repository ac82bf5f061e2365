"""Core-engine benchmark: free bodies through step(n), step() call overhead, compile cost.

    python bench/bench_core.py            # prints a table, writes bench/results/core.json

Figures: wall time per body-step for 1 and 1000 free bodies stepped n at a time,
the cost of one ``world.step()`` call for a single body (Python overhead included),
and the first-call cost (import + build + first step) with Numba's cache cold and warm,
each measured in a fresh interpreter.
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

FIRST_CALL = """
import time
t0 = time.perf_counter()
import tumble
b = tumble.ModelBuilder()
b.add_body("a", mass=1.0, inertia=(1, 1, 1))
w = tumble.World(b.build())
w.step()
print(time.perf_counter() - t0)
"""


def free_bodies(n, rng):
    import tumble
    b = tumble.ModelBuilder()
    for i in range(n):
        b.add_body(f"b{i}", pos=rng.normal(size=3), mass=1.0 + rng.random(),
                   inertia=(0.1, 0.2, 0.25), angvel=rng.normal(size=3) * 5)
    return tumble.World(b.build(), dt=1 / 240)


def best_of(fn, repeats=5):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def first_call(cache_dir):
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", FIRST_CALL], env=env, check=True,
                         capture_output=True, text=True)
    return float(out.stdout.strip().splitlines()[-1])


def main():
    rng = np.random.default_rng(0)
    results = {}
    for n, steps in ((1, 100_000), (1000, 200)):
        w = free_bodies(n, rng)
        w.step(1)
        t = best_of(lambda: w.step(steps))
        results[f"ns_per_body_step_{n}"] = 1e9 * t / (steps * n)
        results[f"us_per_step_{n}"] = 1e6 * t / steps
    w = free_bodies(1, rng)
    w.step()
    calls = 20_000
    t = best_of(lambda: [w.step() for _ in range(calls)])
    results["us_per_step_call_1body"] = 1e6 * t / calls
    with tempfile.TemporaryDirectory() as cache:
        results["first_call_cold_s"] = first_call(cache)
        results["first_call_warm_s"] = first_call(cache)

    print(f"{'figure':32s} {'value':>12s}")
    for key, value in results.items():
        print(f"{key:32s} {value:12.3f}")
    out = ROOT / "bench" / "results"
    out.mkdir(exist_ok=True)
    (out / "core.json").write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
