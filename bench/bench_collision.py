"""Collision detection alone (broad + narrow phase, no solver), for each broad phase.

    python bench/bench_collision.py                      # every scene, every broad phase
    python bench/bench_collision.py spheres pyramid --broadphase grid --repeats 100

Scenes: pyramid (210 boxes), spheres (1000 spheres in a walled box), sparse (1000
spheres, boxes and capsules of varied sizes strewn over a 40 x 40 m ground) and
ragdoll (the 15-body ragdoll at 600 Hz, lying on the ground). Each scene is first
stepped into a resting state; then, on that state, the broad phase alone
(``overlapping_pairs`` on the step's AABBs) and the whole collision stage
(``collide_world``) are timed, best of ``--repeats`` calls, in ms. The methods are
checked to give the same pairs and contacts. Method ``listed`` is what a step uses on a
scene with at most ``collide.LISTED_PAIRS_MAX`` pairs that may touch: those pairs,
listed once, box-tested every call (its "pairs" are the overlapping ones among them,
so fewer); the sparse, spheres and pyramid scenes have too many for it.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import tumble  # noqa: E402
from bench import scenes, tumble_scenes  # noqa: E402
from tumble.pipeline.collide import (_listed_overlaps, collide_world,  # noqa: E402
                                     listed_pairs)
from tumble.pipeline.collision.broadphase import BROADPHASES, overlapping_pairs  # noqa: E402
from tumble.pipeline.contacts.arrays import make_contacts  # noqa: E402


def sparse(n=1000, side=40.0, seed=7):
    """``n`` bodies (half spheres, a quarter boxes, a quarter capsules; sizes 3-30 cm)
    dropped from 0.05-0.5 m over a ``side`` x ``side`` m ground plane, randomly turned."""
    rng = np.random.default_rng(seed)
    b = tumble.ModelBuilder(timestep=1.0 / 240.0)
    b.add_geom(None, "plane", friction=0.8, name="ground")
    for i in range(n):
        kind = "sphere" if i % 2 == 0 else ("box" if i % 4 == 1 else "capsule")
        s = rng.uniform(0.03, 0.3)
        xy = rng.uniform(-side / 2, side / 2, 2)
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        pos = (xy[0], xy[1], 0.35 + s + rng.uniform(0.05, 0.5))
        body = b.add_body("b%d" % i, pos=pos, quat=q, mass=1.0, inertia=(0.01, 0.01, 0.01))
        if kind == "sphere":
            b.add_geom(body, "sphere", radius=s, friction=0.8)
        elif kind == "box":
            b.add_geom(body, "box", size=(s, 0.6 * s, 0.4 * s), friction=0.8)
        else:
            b.add_geom(body, "capsule", radius=0.4 * s, half_length=s, friction=0.8)
    return b.build()


SCENES = {
    "pyramid": (tumble_scenes.pyramid, scenes.PYRAMID["dt"], 60),
    "spheres": (tumble_scenes.spheres, scenes.SPHERES["dt"], 400),
    "sparse": (sparse, 1.0 / 240.0, 240),
    "ragdoll": (lambda: tumble_scenes.ragdoll(600), 1.0 / 600.0, 600),
}


def settled(name):
    build, dt, settle = SCENES[name]
    model = build()
    world = tumble.World(model, dt=dt, contact="pgs", iterations=30)
    world.step(settle)
    return model, world


def time_scene(model, world, methods, repeats):
    """{method: (broad ms, collision ms, pairs, contacts)} on the world's current state."""
    m, s = model.arrays, world._state
    ng = model.ngeom
    out = {}
    ref = None
    listed = listed_pairs(m, model.nbody)
    none = np.zeros((0, 2), np.int32)
    for name in methods:
        if name == "listed" and listed.shape[0] == 0:
            continue
        code = BROADPHASES.get(name, 0)
        use = listed if name == "listed" else none
        con = make_contacts(1, world._contacts.depth.shape[1])
        view = type(con)(*(a[0] for a in con))
        prev = type(con)(*(a[0].copy() for a in con))
        lo, hi, pairs = np.zeros((ng, 3)), np.zeros((ng, 3)), np.zeros((world._pairs.shape[0], 2),
                                                                        np.int32)
        args = (m, s.body_pos[0], s.body_quat[0], np.zeros((ng, 3)), np.zeros((ng, 4)), lo, hi,
                pairs, view, 0, prev, world.contact_margin, code, use,
                np.zeros(world.model.nbody), 0.0)
        status, count = collide_world(*args)
        assert status == 0, "buffers too small"
        bp = np.zeros_like(pairs)

        def broad():
            if name == "listed":
                return _listed_overlaps(listed, lo, hi, bp)
            return overlapping_pairs(code, lo, hi, bp, m.geom_body)
        npair = broad()
        best_b = best_c = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            broad()
            t1 = time.perf_counter()
            collide_world(*args)
            t2 = time.perf_counter()
            best_b, best_c = min(best_b, t1 - t0), min(best_c, t2 - t1)
        got = (bp[:npair].copy(), view.geom[:count].copy(), view.depth[:count].copy())
        if ref is None:
            ref = got
        else:
            assert name == "listed" or np.array_equal(ref[0], got[0]), f"{name}: pairs differ"
            assert np.array_equal(ref[1], got[1]) and np.array_equal(ref[2], got[2]), \
                f"{name}: contacts differ"
        out[name] = (1e3 * best_b, 1e3 * best_c, npair, count)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", help="any of %s (default: all)" % ", ".join(SCENES))
    ap.add_argument("--broadphase", default=",".join(list(BROADPHASES) + ["listed"]),
                    help="comma-separated methods (default: all)")
    ap.add_argument("--repeats", type=int, default=50)
    a = ap.parse_args()
    methods = a.broadphase.split(",")
    for bad in [x for x in a.scenes if x not in SCENES] + [x for x in methods
                                                             if x not in BROADPHASES
                                                             and x != "listed"]:
        ap.error(f"unknown scene or broad phase {bad!r}")
    print(f"{'scene':8s} {'geoms':>5s} {'method':6s} {'pairs':>6s} {'contacts':>8s} "
          f"{'broad ms':>9s} {'collision ms':>12s}")
    for name in a.scenes or list(SCENES):
        model, world = settled(name)
        for meth, (tb, tc, npair, count) in time_scene(model, world, methods, a.repeats).items():
            print(f"{name:8s} {model.ngeom:5d} {meth:6s} {npair:6d} {count:8d} {tb:9.3f} "
                  f"{tc:12.3f}")


if __name__ == "__main__":
    main()
