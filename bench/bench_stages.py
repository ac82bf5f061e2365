"""Where a step's time goes: the step's own stage timer (``World(profile=True)``).

    python bench/bench_stages.py                       # chain, ragdoll600, stack
    python bench/bench_stages.py chain --steps 500 --variant pgs

With ``options.profile`` on, the step reads a cycle counter between its stages
(``tumble.pipeline.step``; ``World.stage_times``); with it off (the default) it reads
none, so the normal step pays nothing for the profile.

Prints a table per scene: microseconds per step of each stage (the least over
``--repeat`` runs, to see through a busy machine), its share of the profiled step, the
unprofiled ``world.step`` time (thread CPU time, least over the runs), and the mean
number of contacts per step.
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tumble.pipeline.arrays import STAGES  # noqa: E402


def profile_world(world, steps, chunk=32):
    """Step ``world`` ``steps`` times in calls of ``chunk`` steps with its stage timer on;
    returns (seconds per stage (len(STAGES),), contacts summed over the calls' last
    steps, calls made, steps done). The world's profile option is restored after."""
    was = world.options.profile
    world.options.profile = True
    world.stage_times(reset=True)
    done = calls = contacts = 0
    try:
        while done < steps:
            n = min(chunk, steps - done)
            world.step(n)
            done += n
            calls += 1
            contacts += int(np.sum(world.state_arrays.contact_count))
    finally:
        world.options.profile = was
    times = world.stage_times(reset=True)
    return np.array([times[name] for name in STAGES]), contacts, calls, done


def make_world(model, variant, scene):
    from bench.bench_tumble import make_world as scene_world
    return scene_world(model, variant, scene)


def reference_ms(model, scene, variant, steps, chunk=32):
    """CPU ms per step of the normal ``world.step`` on the same scene (thread time, so a
    busy machine inflates it less than wall time)."""
    world = make_world(model, variant, scene)
    done = 0
    t0 = time.thread_time()
    while done < steps:
        n = min(chunk, steps - done)
        world.step(n)
        done += n
    return 1e3 * (time.thread_time() - t0) / steps


def report(scene, variant, t_stage, contacts, calls, done, ref_ms):
    total = t_stage.sum()
    print(f"\n{scene} ({variant}): {done} steps, {1e6 * total / done:.1f} us/step profiled, "
          f"{1e3 * ref_ms:.1f} us/step by world.step")
    for name, t in zip(STAGES, t_stage):
        print(f"  {name:22s} {1e6 * t / done:9.2f} us  {100.0 * t / total:5.1f} %")
    print(f"  contacts per step: {contacts / max(calls, 1):.1f}")
    return dict(scene=scene, variant=variant, steps=done,
                us_per_step=float(1e6 * total / done), world_step_us=1e3 * ref_ms,
                stages_us={k: float(1e6 * v / done) for k, v in zip(STAGES, t_stage)},
                contacts_per_step=contacts / max(calls, 1))


def main():
    from bench import tumble_scenes as T
    from bench.bench_tumble import VARIANTS
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=["chain", "ragdoll600", "stack"])
    ap.add_argument("--variant", default="default", choices=list(VARIANTS))
    ap.add_argument("--steps", type=int, default=0, help="steps per scene (default: the scene's)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs per scene; each stage's figure is its least over the runs")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    out = []
    for scene in args.scenes:
        model = T.build(scene)
        warm = make_world(model, args.variant, scene)
        profile_world(warm, 2)                      # compile outside the figures
        steps = args.steps or T.steps(scene)
        best = None
        for _ in range(args.repeat):                # keep each stage's least time
            world = make_world(model, args.variant, scene)
            res = profile_world(world, steps)
            best = res if best is None else (np.minimum(best[0], res[0]),) + res[1:]
        ref = min(reference_ms(model, scene, args.variant, steps) for _ in range(args.repeat))
        out.append(report(scene, args.variant, *best, ref))
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
