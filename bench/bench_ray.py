"""Training throughput on Ray against the single-process trainer, and a scaling model.

    python bench/bench_ray.py                          # imitation, N = 64 a worker, 6 iterations
    python bench/bench_ray.py --envs 128 --iterations 10 --json ray.json

In one run, on a local Ray cluster of 2 CPUs (``ray.init(num_cpus=2)``), the same PPO run
(the imitation task, N worlds and 32 steps a worker per iteration) is timed as:

- the single-process trainer (``Trainer``) with N worlds on all cores,
- ``RayTrainer`` with 1 worker of N worlds (1 CPU), and with 2 workers (1 CPU each).

Reported per setting: samples per second end to end (collection and PPO's update), the
collection's rate, and the learner's update time per iteration. The first iteration
(start-up, warm-up) is left out.

The scaling model. A synchronous iteration with K workers of S = N x steps samples each
takes ``S / r + K x + u K S``: every worker's rollout at its rate r (in parallel), the
learner receiving K batches (x seconds each, measured: the collection's time less the
rollout's) and PPO's update, linear in the batch (u seconds a sample, measured). So
throughput is ``K S / (S / r + K x + u K S)``, and the learner is the bottleneck once its
update takes longer than a rollout, at K* = 1 / (u r). The script prints the model's
prediction for K = 1 ... 256 from the measured r, x and u.
"""
import argparse
import json
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tumble.rl.train import TrainConfig, Trainer  # noqa: E402


def _timed_run(make, iterations):
    """Run ``iterations`` + 1 iterations; the per-iteration rows after the first."""
    out = Path(tempfile.mkdtemp(prefix="bench-ray-"))
    try:
        t = make(out)
        t.run(iterations + 1)
        if hasattr(t, "close"):
            t.close()
        import csv
        with open(out / "progress.csv", newline="") as f:
            rows = list(csv.DictReader(f))[1:]
    finally:
        shutil.rmtree(out, ignore_errors=True)
    collect = np.array([float(r["collect_s"]) for r in rows])
    learn = np.array([float(r["learn_s"]) for r in rows])
    samples = int(rows[1]["samples"]) - int(rows[0]["samples"])
    return {"samples_per_iteration": samples,
            "samples_per_s": samples * len(rows) / float((collect + learn).sum()),
            "collect_per_s": samples * len(rows) / float(collect.sum()),
            "collect_s": float(np.median(collect)), "learn_s": float(np.median(learn))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--envs", type=int, default=64, help="worlds a worker (and the single run)")
    ap.add_argument("--iterations", type=int, default=6)
    ap.add_argument("--json", metavar="FILE")
    args = ap.parse_args()
    from tumble.rl.distributed import RayTrainer, init_ray

    def config(threads):
        return TrainConfig(num_envs=args.envs, eval_every=0, save_every=10**6, threads=threads,
                           seed=0)

    init_ray(num_cpus=2)
    results = {}
    results["single"] = _timed_run(
        lambda out: Trainer(out, config(2), progress=False, log=None), args.iterations)
    for k in (1, 2):
        results[f"ray{k}"] = _timed_run(
            # the learner's PyTorch uses both cores for the update (the workers wait then);
            # each worker has one CPU for Numba and PyTorch (worker_cpus)
            lambda out: RayTrainer(out, config(2), workers=k, progress=False, log=None),
            args.iterations)
    for name, r in results.items():
        print(f"{name:7s} {r['samples_per_s']:8.0f} samples/s end to end, collection "
              f"{r['collect_per_s']:8.0f}/s, update {r['learn_s']:.2f} s an iteration "
              f"({r['samples_per_iteration']} samples)", flush=True)
    one, two, single = results["ray1"], results["ray2"], results["single"]
    print(f"2 workers / 1 worker: {two['samples_per_s'] / one['samples_per_s']:.2f}x "
          f"(collection {two['collect_per_s'] / one['collect_per_s']:.2f}x); "
          f"Ray 2 workers / single process on 2 cores: "
          f"{two['samples_per_s'] / single['samples_per_s']:.2f}x", flush=True)
    # the model's terms, from the one-worker run and the single process's rollout
    S = one["samples_per_iteration"]
    r = S / max(single["collect_s"], 1e-9) / 2.0       # a worker's rate on one core
    x = max(one["collect_s"] - S / r, 0.0)             # receiving one worker's batch
    u = one["learn_s"] / S                             # the learner's update, per sample
    model = {}
    for K in (1, 2, 4, 8, 16, 32, 64, 128, 256):
        model[K] = K * S / (S / r + K * x + u * K * S)
    kstar = 1.0 / (u * r)
    print(f"model: r = {r:.0f} samples/s a worker, x = {x:.3f} s a batch, u = {u * 1e6:.1f} us "
          f"a sample; the learner is the bottleneck from K = {kstar:.1f} workers", flush=True)
    print("  " + ", ".join(f"K={K}: {v:,.0f}/s" for K, v in model.items()), flush=True)
    results["model"] = {"r": r, "x": x, "u": u, "k_star": kstar,
                        "throughput": {str(k): v for k, v in model.items()}}
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"({time.perf_counter() - t0:.0f} s)")
