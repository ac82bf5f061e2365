"""Reliability soak: a long, rough run of the course ragdoll, checked as it goes.

    python bench/soak.py                        # 100,000 steps at 60 Hz, lcp contacts
    python bench/soak.py --steps 20000 --contact pgs --json soak.json
    python bench/soak.py --determinism          # the same run in fresh processes, 1 and 2 threads

The ragdoll, its joint servos on (kp 500, kd 50) aiming at random poses, falls, is pushed
around and lies in heaps; every 2 s it is stood up again at a random place and heading. As
it runs, the script checks and counts:

- faults: every 5,000 steps a torque of 1e16 N m makes the step diverge; the
  ``SimulationError`` must leave ``get_state()`` bit for bit as before, and the world must
  then step on exactly as a twin restored from that state;
- save and restore mid-contact: every 1,000 steps the state is saved, 30 steps run, the
  state restored and the 30 steps run again: the same bits;
- chunking: every 10,000 steps, ``step(60)`` against 60 x ``step(1)`` from the same state;
- memory: the process's resident set size every 10,000 steps (flat means no leak);
- nothing non-finite in the state at any check.

``--determinism`` runs the soak in fresh interpreters (a batch of 4 worlds, Numba on 1 and
on 2 threads, twice each) and compares the final states' hashes: one hash means the same
bits across processes and thread counts.
"""
import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tumble  # noqa: E402


def rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def state_bytes(state):
    h = hashlib.sha256()
    for name in ("body_pos", "body_quat", "body_vel", "body_angvel", "row_impulse",
                 "joint_force", "joint_torque", "applied_force", "applied_torque",
                 "pd_target_quat", "contact_count"):
        a = getattr(state, name)
        if a is not None:
            h.update(np.ascontiguousarray(a).tobytes())
    h.update(np.float64(state.time).tobytes())
    return h.hexdigest()


def same(a, b):
    return state_bytes(a) == state_bytes(b)


def soak(steps, contact, nworld, seed, log=print):
    rng = np.random.default_rng(seed)
    ragdoll = tumble.games105_ragdoll()
    world = tumble.World(ragdoll.model, dt=1 / 60, contact=contact, nworld=nworld)
    world.joint_kp = 500.0
    world.joint_kd = 50.0
    start = world.get_state()
    nj = ragdoll.model.njoint
    nb = ragdoll.model.nbody
    counts = {"faults": 0, "restores": 0, "chunkings": 0, "stand_ups": 0, "pushes": 0}
    rss = []
    t0 = time.perf_counter()
    step = 0
    while step < steps:
        if step % 120 == 0:                 # new random pose targets
            axis = rng.normal(size=(nworld, nj, 3))
            angle = rng.uniform(0, 0.8, size=(nworld, nj, 1))
            axis /= np.linalg.norm(axis, axis=2, keepdims=True)
            q = np.concatenate([np.sin(angle / 2) * axis, np.cos(angle / 2)], axis=2)
            world.pd_target_quat[...] = q if nworld > 1 else q[0]
        if step % 120 == 60:                # a push on a random body
            b = int(rng.integers(1, nb))
            f = rng.normal(size=3) * 400.0
            for w in range(nworld):
                world.apply_force(b, f, world=w) if nworld > 1 else world.apply_force(b, f)
            counts["pushes"] += 1
        if step % 5000 == 2500:             # a fault: the step must be undone exactly
            world.apply_torque(1, (1e16, 0.0, 0.0), **({"world": 0} if nworld > 1 else {}))
            before = world.get_state()          # the torque pending in it
            try:
                world.step(7)
                raise AssertionError(f"step {step}: a 1e16 N m torque did not diverge")
            except tumble.SimulationError:
                pass
            assert same(world.get_state(), before), f"step {step}: the failed step left traces"
            twin = tumble.World(ragdoll.model, dt=1 / 60, contact=contact, nworld=nworld)
            twin.joint_kp, twin.joint_kd = 500.0, 50.0
            twin.set_state(before)
            world.clear_forces()                # the failed call left the torque pending
            twin.clear_forces()
            world.step(10)
            twin.step(10)
            assert same(world.get_state(), twin.get_state()), \
                f"step {step}: the world that caught an error stepped on unlike its twin"
            counts["faults"] += 1
            step += 10
            continue
        if step % 1000 == 500:              # save and restore mid-contact
            saved = world.get_state()
            world.step(30)
            first = world.get_state()
            world.set_state(saved)
            world.step(30)
            assert same(world.get_state(), first), f"step {step}: restore did not repeat"
            counts["restores"] += 1
            step += 30
            continue
        if step % 10000 == 9000:            # chunking
            saved = world.get_state()
            world.step(60)
            whole = world.get_state()
            world.set_state(saved)
            for _ in range(60):
                world.step(1)
            assert same(world.get_state(), whole), f"step {step}: step(60) != 60 x step(1)"
            counts["chunkings"] += 1
            step += 60
            continue
        if step % 120 == 119 and rng.random() < 0.5:   # stand it up somewhere else
            s = world.get_state()
            s.body_pos[...] = start.body_pos
            s.body_quat[...] = start.body_quat
            s.body_vel[...] = 0.0
            s.body_angvel[...] = 0.0
            s.body_pos[..., 0] += rng.uniform(-3, 3)
            world.set_state(s)
            counts["stand_ups"] += 1
        world.step(1)
        step += 1
        if step % 10000 == 0:
            st = world.get_state()
            assert all(np.isfinite(getattr(st, k)).all()
                       for k in ("body_pos", "body_quat", "body_vel", "body_angvel"))
            rss.append(round(rss_mb(), 1))
            log(f"{step:7d} steps, {time.perf_counter() - t0:6.1f} s, RSS {rss[-1]:.1f} MB, "
                f"lcp fallbacks {int(np.sum(world.lcp_fallbacks))}", flush=True)
    return {"steps": step, "seconds": time.perf_counter() - t0, "rss_mb": rss, **counts,
            "lcp_fallbacks": int(np.sum(world.lcp_fallbacks)),
            "final_hash": state_bytes(world.get_state())}


def determinism(steps, contact):
    hashes = {}
    for threads in (1, 2):
        for rep in range(2):
            env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
            out = subprocess.run([sys.executable, __file__, "--steps", str(steps),
                                  "--contact", contact, "--nworld", "4", "--hash-only"],
                                 env=env, capture_output=True, text=True, check=True)
            hashes[f"{threads} thread(s), run {rep + 1}"] = out.stdout.strip().splitlines()[-1]
    return hashes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=100_000)
    ap.add_argument("--contact", default="lcp", choices=("lcp", "pgs", "penalty"))
    ap.add_argument("--nworld", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--determinism", action="store_true")
    ap.add_argument("--hash-only", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--json", metavar="FILE")
    a = ap.parse_args()
    if a.hash_only:
        print(soak(a.steps, a.contact, a.nworld, a.seed, log=lambda *x, **k: None)["final_hash"])
        return
    if a.determinism:
        hashes = determinism(min(a.steps, 20_000), a.contact)
        for k, v in hashes.items():
            print(f"{k}: {v[:16]}")
        print("identical" if len(set(hashes.values())) == 1 else "DIFFERENT")
        result = {"hashes": hashes, "identical": len(set(hashes.values())) == 1}
    else:
        result = soak(a.steps, a.contact, a.nworld, a.seed)
        print(json.dumps({k: v for k, v in result.items() if k != "final_hash"}))
    if a.json:
        Path(a.json).write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
