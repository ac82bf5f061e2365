"""Policy samples per second of the imitation environment, against PyBullet's DeepMimic port.

    python bench/bench_rl.py                       # N = 1, 16, 64, 256; PyBullet in the same run
    python bench/bench_rl.py --nworld 64 256 --seconds 10 --no-peer --json rl.json

A sample is one policy step of one character: ``ImitationEnv.step`` with random actions
(uniform in [-0.3, 0.3], no learning), which is ``substeps`` physics steps of every world in
one ``World.step`` call, the observation, the reward, the fall check and the reset of the
worlds whose episodes ended. Reported per N: samples per second (wall time, all of Numba's
threads) and where a step's time goes (physics, reference sampling and targets, reward and
fall check, observation, resets and the rest); ``--stages`` adds the physics step's own
stage timer, in CPU microseconds a world-step. PyBullet's DeepMimic environment (walk,
1/240 s physics, 30 Hz policy) runs on one core in a subprocess after tumble's rounds, and
the ratio is tumble's rate over it.
"""
import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tumble.rl import ImitationEnv  # noqa: E402


def _timed(fn, clock):
    t = time.perf_counter()
    out = fn()
    clock[0] += time.perf_counter() - t
    return out


def measure(nworld, seconds, contact="lcp", seed=0, projection_tolerance=None, stages=False):
    """Samples per second of ``ImitationEnv(nworld)`` and the split of a step's time; with
    ``stages``, also the physics step's own stage timer (``World(profile=True)``, which
    reads the clock in every stage and so slows the step a little): CPU microseconds per
    world and physics step in each stage, summed over the threads."""
    extra = {} if projection_tolerance is None else {"projection_tolerance": projection_tolerance}
    env = ImitationEnv(nworld, "walk", contact=contact, seed=seed, **extra)
    rng = np.random.default_rng(seed)
    env.reset()
    for _ in range(3):                       # compile and settle outside the timing
        env.step(rng.uniform(-0.3, 0.3, (nworld, env.action_size)))
    if stages:
        env.world.profile = True
        env.world.stage_times(reset=True)
    # time the stages by wrapping the env's own hooks
    clocks = {k: [0.0] for k in ("physics", "reference", "reward", "observe", "reset")}
    orig = {k: getattr(env, k) for k in ("_step_physics", "_advance", "_act", "_evaluate",
                                        "_observe", "_restart")}
    env._step_physics = lambda: _timed(orig["_step_physics"], clocks["physics"])
    env._advance = lambda: _timed(orig["_advance"], clocks["reference"])
    env._act = lambda a: _timed(lambda: orig["_act"](a), clocks["reference"])
    env._evaluate = lambda r, t: _timed(lambda: orig["_evaluate"](r, t), clocks["reward"])
    env._observe = lambda o: _timed(lambda: orig["_observe"](o), clocks["observe"])
    env._restart = lambda w, g: _timed(lambda: orig["_restart"](w, g), clocks["reset"])
    samples = 0
    ends = 0
    start = time.perf_counter()
    while time.perf_counter() - start < seconds:
        a = rng.uniform(-0.3, 0.3, (nworld, env.action_size))
        _, _, term, trunc, _ = env.step(a)
        ends += int(term.sum() + trunc.sum())
        samples += nworld
    wall = time.perf_counter() - start
    split = {k: v[0] / wall for k, v in clocks.items()}
    split["other"] = 1.0 - sum(split.values())
    out = {"nworld": nworld, "samples_per_s": samples / wall, "episodes_ended": ends,
           "contacts_per_world": float(np.mean(env.world._state.contact_count)),
           "share": split}
    if stages:
        world_steps = samples * env.substeps
        out["stage_us"] = {k: 1e6 * v / world_steps for k, v in env.world.stage_times().items()}
    return out


def peer(seconds):
    """PyBullet's DeepMimic rate from its runner in a subprocess (None if unavailable)."""
    runner = Path(__file__).resolve().parent / "peers" / "pybullet_deepmimic.py"
    try:
        out = subprocess.run([sys.executable, str(runner), str(seconds)], capture_output=True,
                             text=True, timeout=seconds * 10 + 120)
        return json.loads(out.stdout.strip().splitlines()[-1])
    except (subprocess.SubprocessError, ValueError, IndexError, OSError):
        return None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nworld", type=int, nargs="+", default=[1, 16, 64, 256])
    ap.add_argument("--seconds", type=float, default=10.0, help="wall time per N")
    ap.add_argument("--contact", default="lcp")
    ap.add_argument("--projection-tolerance", type=float, metavar="M",
                    help="the env's joint projection tolerance (default: the env's, 1 mm; "
                         "the World's default is 5e-5)")
    ap.add_argument("--no-peer", action="store_true")
    ap.add_argument("--stages", action="store_true",
                    help="also time the physics step's stages (World(profile=True))")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    rows = []
    for n in args.nworld:
        r = measure(n, args.seconds, args.contact,
                    projection_tolerance=args.projection_tolerance, stages=args.stages)
        rows.append(r)
        share = ", ".join(f"{k} {100 * v:.0f}%" for k, v in r["share"].items())
        print(f"tumble N={n:4d}: {r['samples_per_s']:8.0f} samples/s  ({share}; "
              f"{r['contacts_per_world']:.1f} contacts a world)", flush=True)
        if args.stages:
            print("  us of CPU a world-step: " + ", ".join(
                f"{k} {v:.1f}" for k, v in r["stage_us"].items() if v >= 0.05), flush=True)
    result = {"tumble": rows, "contact": args.contact,
              "projection_tolerance": args.projection_tolerance}
    if not args.no_peer:
        p = peer(args.seconds)
        result["pybullet_deepmimic"] = p
        if p is None:
            print("pybullet's DeepMimic environment: not available (pip install pybullet)")
        else:
            best = max(r["samples_per_s"] for r in rows)
            print(f"pybullet DeepMimic (1 core): {p['samples_per_s']:.0f} samples/s; tumble's "
                  f"best is {best / p['samples_per_s']:.1f}x")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
