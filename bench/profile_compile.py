"""Where a cold first step spends its compile time: per compiled function, from Numba's
compile events.

    python bench/profile_compile.py stack            # a bench scene's first step(1)
    python bench/profile_compile.py ragdoll600pd --variant pgs --top 40

Runs the scene's first ``world.step(1)`` in a fresh interpreter with Numba's cache in a new
empty directory (cold), recording every ``numba:compile`` event. For each function: how many
specialisations were compiled, its inclusive seconds (its own compile with everything it
compiled on the way: callees are compiled while their caller is typed) and its exclusive
seconds (inclusive minus the callees'), of which LLVM (Numba's LLVM lock held: optimising
and emitting machine code; the rest is typing and lowering), and the total. Exclusive time
is what compiling that function itself costs; a function with many specialisations is a
candidate for fewer.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CHILD = r"""
import json, sys, time
from collections import defaultdict
from numba.core import event
from bench.bench_tumble import make_world
from tumble.apps.benchmarks import build

stack, spans = [], []

class Profile(event.Listener):
    def on_start(self, ev):
        d = ev.data["dispatcher"]
        name = f"{d.py_func.__module__}.{d.py_func.__qualname__}"
        stack.append([name, time.perf_counter(), 0.0, 0.0])     # name, start, callees, LLVM

    def on_end(self, ev):
        name, t0, inner, llvm = stack.pop()
        dt = time.perf_counter() - t0
        if stack:
            stack[-1][2] += dt
        spans.append((name, dt, dt - inner, llvm))


# time in LLVM's calls (optimising, emitting machine code), charged to the function compiled
class LLVMTime(event.Listener):
    def on_start(self, ev):
        self.t0 = time.perf_counter()

    def on_end(self, ev):
        if stack:
            stack[-1][3] += time.perf_counter() - self.t0

model = build(SCENE)
world = make_world(model, VARIANT, SCENE)
t0 = time.perf_counter()
with event.install_listener("numba:compile", Profile()), \
        event.install_listener("numba:llvm_lock", LLVMTime()):
    world.step(1)
total = time.perf_counter() - t0
per = defaultdict(lambda: [0, 0.0, 0.0, 0.0])
for name, inc, exc, llvm in spans:
    p = per[name]
    p[0] += 1
    p[1] += inc
    p[2] += exc
    p[3] += llvm
print("PROFILE " + json.dumps(dict(total_s=total, functions=per)))
"""


def profile(scene, variant):
    with tempfile.TemporaryDirectory() as cache:
        code = _CHILD.replace("SCENE", repr(scene)).replace("VARIANT", repr(variant))
        out = subprocess.run([sys.executable, "-c", code], cwd=str(ROOT), capture_output=True,
                             text=True, env=dict(os.environ, NUMBA_CACHE_DIR=cache,
                                                 PYTHONPATH=str(ROOT)))
    if out.returncode != 0:
        raise RuntimeError(out.stderr[-3000:])
    line = next(x for x in out.stdout.splitlines() if x.startswith("PROFILE "))
    return json.loads(line[8:])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--variant", default="default")
    ap.add_argument("--top", type=int, default=30)
    ap.add_argument("--json", help="write the whole profile here")
    a = ap.parse_args()
    data = profile(a.scene, a.variant)
    funcs = data["functions"]
    print(f"{a.scene} ({a.variant}): first step(1) {data['total_s']:.1f} s cold, "
          f"{sum(v[0] for v in funcs.values())} compiles of {len(funcs)} functions")
    print(f"LLVM (optimising, emitting code): {sum(v[3] for v in funcs.values()):.1f} s")
    print(f"{'exclusive s':>11} {'of it LLVM':>10} {'inclusive s':>11} {'specs':>5}  function")
    for name, (n, inc, exc, llvm) in sorted(funcs.items(), key=lambda kv: -kv[1][2])[:a.top]:
        print(f"{exc:11.1f} {llvm:10.1f} {inc:11.1f} {n:5d}  {name}")
    if a.json:
        Path(a.json).write_text(json.dumps(data, indent=1))


if __name__ == "__main__":
    main()
