"""Collision detection alone (broad + narrow phase, no solver) on the pyramid and spheres.

    python bench/bench_collision.py

Each scene is first stepped into its resting state, then the collision stage is timed on
that state, so the contact counts are those of a real step.
"""
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import tumble  # noqa: E402
from bench import scenes, tumble_scenes  # noqa: E402
from tumble.pipeline.collide import collide_world  # noqa: E402
from tumble.pipeline.contacts.arrays import make_contacts  # noqa: E402


def time_collision(model, dt, settle_steps, repeats=50):
    world = tumble.World(model, dt=dt, contact="pgs", iterations=30)
    world.step(settle_steps)
    m, s = model.arrays, world._state
    ng = model.ngeom
    con = make_contacts(1, world._contacts.depth.shape[1])
    view = type(con)(*(a[0] for a in con))
    prev = type(con)(*(a[0].copy() for a in con))
    buffers = (np.zeros((ng, 3)), np.zeros((ng, 4)), np.zeros((ng, 3)), np.zeros((ng, 3)),
               np.zeros((world._pairs.shape[0], 2), np.int32))
    args = (m, s.body_pos[0], s.body_quat[0], *buffers, view, 0, prev, world.contact_margin)
    collide_world(*args)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        status, count = collide_world(*args)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best, count


def main():
    for name, model, dt, settle in (
            ("pyramid", tumble_scenes.pyramid(), scenes.PYRAMID["dt"], 60),
            ("spheres", tumble_scenes.spheres(), scenes.SPHERES["dt"], 400)):
        ms, count = time_collision(model, dt, settle)
        print(f"{name:8s} {model.ngeom:5d} geoms  {count:5d} contacts  collision {ms:.3f} ms")


if __name__ == "__main__":
    main()
