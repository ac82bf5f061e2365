"""Throughput of batched worlds: N copies of a scene stepped together, steps per second.

    python bench/bench_batch.py                              # ragdoll600 and chain, N = 64, 256
    python bench/bench_batch.py ragdoll600 --nworld 16 64 --steps 300 --json batch.json

Each world starts from the scene's initial pose with its own random velocity (the ragdoll
gets a linear velocity, the chain an angular velocity about its pin; std 0.5 m/s, rad/s),
the same draws in every engine, and all worlds are stepped ``--steps`` steps. Engines, in
one process and one run:

* tumble, serial: ``World(model, nworld=N, parallel=False).step(steps)``, one call;
* tumble, threads: the same with ``parallel=True`` (Numba's threads, one world per task);
* MuJoCo ``mujoco.rollout.rollout`` with one ``MjData`` per thread (its C++ thread pool,
  persistent), from the same initial states; it also records every state (its design);
* MuJoCo from Python: one ``MjData`` per world and ``mj_step`` on each in a Python loop,
  step by step, as an RL batch loop over environments would.

Figures are wall time (the threads are the point), so run it on a quiet machine: the
least of ``--repeat`` runs is kept. Reported per engine: microseconds per world-step and
world-steps per second; and each tumble path's time over each MuJoCo path's (above 1:
tumble is slower). Compilation is outside the timings (a throwaway batch is stepped first).
"""
import argparse
import importlib.util
import json
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import numba  # noqa: E402

import tumble  # noqa: E402
from bench import scenes as S  # noqa: E402
from bench import tumble_scenes as T  # noqa: E402

STEPS = {"ragdoll600": 600, "chain": 480}


def draws(scene, nworld, seed=0):
    """Per-world initial velocity (nworld, 3): linear for the ragdoll, angular (about the
    pin) for the chain."""
    return np.random.default_rng(seed).normal(scale=0.5, size=(nworld, 3))


def tumble_world(scene, nworld, parallel):
    model = T.build(scene)
    w = tumble.World(model, nworld=nworld, parallel=parallel)
    v = draws(scene, nworld)
    if scene == "chain":
        pin = np.asarray(S.chain_links()[0]["joint"], float)
        r = w.body_pos - pin                                   # (nworld, nbody, 3)
        w.body_angvel[:] = v[:, None, :]
        w.body_vel[:] = np.cross(v[:, None, :], r)
    else:
        w.body_vel[:] = v[:, None, :]
    return w


def time_tumble(scene, nworld, steps, parallel, repeat):
    warm = tumble_world(scene, 2, parallel)                  # compile outside the timing
    warm.step(2)
    best = np.inf
    for _ in range(repeat):
        w = tumble_world(scene, nworld, parallel)
        t0 = time.perf_counter()
        w.step(steps)
        best = min(best, time.perf_counter() - t0)
    return best, bool(np.all(np.isfinite(w.body_pos)))


def mujoco_model(scene):
    import mujoco
    from bench.peers import bench_mujoco as BM
    if scene == "chain":
        xml = BM.chain_xml()
    else:
        hz = int(scene[len("ragdoll"):])
        xml = BM._ragdoll_xml(S.ragdoll_parts(), 1.0 / hz)
    return mujoco.MjModel.from_xml_string(xml)


def mujoco_states(m, scene, nworld):
    """Full-physics initial states (nworld, nstate) with the same velocity draws."""
    import mujoco
    d = mujoco.MjData(m)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    v = draws(scene, nworld)
    out = np.zeros((nworld, mujoco.mj_stateSize(m, spec)))
    for i in range(nworld):
        mujoco.mj_resetData(m, d)
        d.qvel[:3] = v[i]        # ragdoll: the free joint's linear velocity (world frame);
        #                          chain: the first ball joint's angular velocity (its frame
        #                          is the world's in the initial pose)
        mujoco.mj_getState(m, d, out[i], spec)
    return out, spec


def time_mujoco_rollout(scene, nworld, steps, nthread, repeat):
    import mujoco
    from mujoco import rollout
    m = mujoco_model(scene)
    x0, _ = mujoco_states(m, scene, nworld)
    datas = [mujoco.MjData(m) for _ in range(nthread)]
    rollout.rollout(m, datas, x0[:2], nstep=2, persistent_pool=True)      # start the pool
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        state, _ = rollout.rollout(m, datas, x0, nstep=steps, persistent_pool=True)
        best = min(best, time.perf_counter() - t0)
    return best, bool(np.all(np.isfinite(state[:, -1])))


def time_mujoco_loop(scene, nworld, steps, repeat):
    import mujoco
    m = mujoco_model(scene)
    x0, spec = mujoco_states(m, scene, nworld)
    best = np.inf
    for _ in range(repeat):
        datas = [mujoco.MjData(m) for _ in range(nworld)]
        for d, x in zip(datas, x0):
            mujoco.mj_setState(m, d, x, spec)
        t0 = time.perf_counter()
        for _ in range(steps):
            for d in datas:
                mujoco.mj_step(m, d)
        best = min(best, time.perf_counter() - t0)
    return best, bool(all(np.all(np.isfinite(d.qpos)) for d in datas))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=["ragdoll600", "chain"])
    ap.add_argument("--nworld", type=int, nargs="+", default=[64, 256])
    ap.add_argument("--steps", type=int, default=0, help="steps per world (default per scene)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    nthread = numba.get_num_threads()
    have_mujoco = importlib.util.find_spec("mujoco") is not None
    rows = []
    print(f"threads: {nthread} (Numba and MuJoCo rollout)")
    print(f"{'scene':11s} {'N':>4s} {'engine':22s} {'us/world-step':>14s} {'world-steps/s':>14s}")
    for scene in args.scenes:
        steps = args.steps or STEPS[scene]
        for nw in args.nworld:
            res = {}
            res["tumble serial"] = time_tumble(scene, nw, steps, False, args.repeat)
            res["tumble threads"] = time_tumble(scene, nw, steps, True, args.repeat)
            if have_mujoco:
                res["mujoco rollout"] = time_mujoco_rollout(scene, nw, steps, nthread,
                                                            args.repeat)
                res["mujoco python loop"] = time_mujoco_loop(scene, nw, steps, args.repeat)
            for engine, (sec, finite) in res.items():
                us = 1e6 * sec / (nw * steps)
                print(f"{scene:11s} {nw:4d} {engine:22s} {us:14.2f} {nw * steps / sec:14.0f}"
                      + ("" if finite else "  (non-finite state)"))
                rows.append(dict(scene=scene, nworld=nw, steps=steps, engine=engine,
                                 seconds=sec, us_per_world_step=us, finite=finite,
                                 threads=nthread))
            if have_mujoco:
                for t in ("tumble serial", "tumble threads"):
                    ratios = ", ".join(f"/ {p}: {res[t][0] / res[p][0]:.2f}"
                                       for p in ("mujoco rollout", "mujoco python loop"))
                    print(f"{'':16s} ratio {t} {ratios}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
