"""Start-up: how long a first run waits for Numba to compile, and how much memory it takes.

    python bench/bench_startup.py                   # the demo, then the bench scenes
    python bench/bench_startup.py --scenes stack chain --variant pgs
    python bench/bench_startup.py --suite           # also the README's test command, cold

Every measurement runs in a fresh interpreter importing this checkout, with Numba's cache in
a new empty directory (``NUMBA_CACHE_DIR``: cold) and then again in the same directory
(warm). Reported per run: seconds to the first line the demo prints with a figure in it
(the state at t = 0; the header line before it costs nothing), to its first line after a
step (when the step's compile is paid), to its end, and the interpreter's peak resident
memory; for a scene: import, model build, world, first ``step(1)``. A cold first step compiles the
step's stages partly in worker processes (``tumble._compile``): the largest worker's peak
memory is reported beside the interpreter's.

The scenes run one after another in one cache, as a user meets them: each pays only for the
kernels the runs before it did not compile, so the cold column sums to what compiling
everything they use costs. ``--alone`` gives each scene its own empty cache instead.
Figures go to ``bench/results/startup.json``.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

DEFAULT_SCENES = ["chain", "stack", "pyramid", "ragdoll600", "ragdoll600pd", "spheres"]

_REPORT_RSS = ("import atexit, resource\n"
               "atexit.register(lambda: print('MAXRSS_MB %.1f %.1f' % (resource.getrusage("
               "resource.RUSAGE_SELF).ru_maxrss / 1024.0, resource.getrusage("
               "resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0), flush=True))\n")

_DEMO = _REPORT_RSS + ("import sys\nfrom tumble.cli import main\n"
                       "sys.exit(main(['demo', '--seconds', '{seconds}']))\n")

_SCENE = _REPORT_RSS + """import json, time
t0 = time.perf_counter()
import tumble
t1 = time.perf_counter()
from bench.bench_tumble import make_world
from tumble.apps.benchmarks import build
model = build({scene!r})
t2 = time.perf_counter()
world = make_world(model, {variant!r}, {scene!r})
t3 = time.perf_counter()
world.step(1)
t4 = time.perf_counter()
print('SCENE ' + json.dumps(dict(import_s=t1 - t0, build_s=t2 - t1, world_s=t3 - t2,
                                 first_step_s=t4 - t3, total_s=t4 - t0)), flush=True)
"""


def _env(cache):
    return dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT),
                PYTHONUNBUFFERED="1")


def _run(code, cache):
    """Run ``code`` in a fresh interpreter; its stdout lines with the seconds each arrived
    at, the total seconds and the peak resident memory (MB)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", code], env=_env(cache), cwd=str(ROOT),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = []
    for line in proc.stdout:
        lines.append((time.perf_counter() - t0, line.rstrip("\n")))
    err = proc.stderr.read()
    code_ = proc.wait()
    total = time.perf_counter() - t0
    if code_ != 0:
        raise RuntimeError(f"run failed ({code_}):\n{err[-2000:]}")
    rss = next(([float(v) for v in text.split()[1:3]] for _, text in lines
                if text.startswith("MAXRSS_MB")), [float("nan")] * 2)
    return lines, total, rss


def demo(cache, seconds):
    """The demo: seconds to its first line of figures (the state at t = 0), to its first
    line after a step (the compile is paid) and to its end; peak memory."""
    lines, total, rss = _run(_DEMO.format(seconds=seconds), cache)
    rows = [t for t, text in lines if text.strip()[:1].isdigit()] + [float("nan")] * 2
    return dict(first_figures_s=rows[0], first_step_row_s=rows[1], total_s=total,
                peak_mb=rss[0], worker_peak_mb=rss[1])


def scene(name, variant, cache):
    lines, total, rss = _run(_SCENE.format(scene=name, variant=variant), cache)
    data = next(json.loads(text[6:]) for _, text in lines if text.startswith("SCENE "))
    data.update(process_s=total, peak_mb=rss[0], worker_peak_mb=rss[1])
    return data


def suite(cache):
    """The README's test command in a fresh clone of this checkout's HEAD, cold."""
    with tempfile.TemporaryDirectory() as tmp:
        clone = Path(tmp) / "tumble"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist",
                              "loadgroup", "--no-loadscope-reorder"], cwd=str(clone),
                             env=dict(_env(cache), PYTHONPATH=str(clone)),
                             capture_output=True, text=True)
        return dict(seconds=time.perf_counter() - t0, returncode=out.returncode,
                    summary=out.stdout.strip().splitlines()[-1:])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="*", default=DEFAULT_SCENES)
    ap.add_argument("--variant", default="default",
                    help="the bench_tumble.py variant the scenes run (default, pgs, penalty, "
                         "implicit-pd, ...)")
    ap.add_argument("--demo-seconds", type=float, default=20.0)
    ap.add_argument("--alone", action="store_true",
                    help="each scene cold in its own empty cache")
    ap.add_argument("--suite", action="store_true", help="also the test suite, cold")
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "startup.json"))
    args = ap.parse_args()
    results = {"variant": args.variant}
    with tempfile.TemporaryDirectory() as cache:
        results["demo"] = {"cold": demo(cache, args.demo_seconds),
                           "warm": demo(cache, args.demo_seconds)}
    d = results["demo"]
    print(f"demo: first figures {d['cold']['first_figures_s']:.1f} s cold, "
          f"{d['warm']['first_figures_s']:.2f} s warm; first stepped row "
          f"{d['cold']['first_step_row_s']:.1f} s cold; all of it {d['cold']['total_s']:.1f} s "
          f"cold, {d['warm']['total_s']:.2f} s warm; peak {d['cold']['peak_mb']:.0f} MB cold",
          flush=True)
    results["scenes"] = {}
    with tempfile.TemporaryDirectory() as shared:
        for name in args.scenes:
            with tempfile.TemporaryDirectory() as own:
                cache = own if args.alone else shared
                cold = scene(name, args.variant, cache)
                warm = scene(name, args.variant, cache)
            results["scenes"][name] = {"cold": cold, "warm": warm}
            print(f"{name:14s} first step {cold['first_step_s']:6.1f} s cold "
                  f"({cold['process_s']:6.1f} s in all, peak {cold['peak_mb']:5.0f} MB, "
                  f"compile workers' {cold['worker_peak_mb']:5.0f} MB), "
                  f"{warm['first_step_s'] * 1000:6.1f} ms warm ({warm['process_s']:.2f} s)",
                  flush=True)
    cold_total = sum(r["cold"]["process_s"] for r in results["scenes"].values())
    peak = max([r["cold"]["peak_mb"] for r in results["scenes"].values()] or [0.0])
    worker_peak = max([r["cold"]["worker_peak_mb"] for r in results["scenes"].values()]
                      or [0.0])
    results["scenes_cold_total_s"] = cold_total
    results["scenes_cold_peak_mb"] = peak
    results["scenes_cold_worker_peak_mb"] = worker_peak
    print(f"scenes cold, {'each alone' if args.alone else 'one after another'}: "
          f"{cold_total:.0f} s in all, peak {peak:.0f} MB (a compile worker's "
          f"{worker_peak:.0f} MB)", flush=True)
    if args.suite:
        with tempfile.TemporaryDirectory() as cache:
            results["suite"] = suite(cache)
        print(f"suite cold: {results['suite']['seconds'] / 60:.1f} min "
              f"({' '.join(results['suite']['summary'])})", flush=True)
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
