"""What spin friction (torsional and rolling rows) costs on the contact scenes.

    python bench/bench_spin_rows.py [stack] [pyramid] [--steps N] [--contact lcp,pgs]

Each scene runs three ways, same boxes, same numbers as bench/scenes.py:

    plain    no geom has spin friction: 3 rows per contact (what the scene is)
    padded   one far static sphere has spin friction, so the model carries 6 rows per
             contact, 3 of them inactive on every real contact: the cost of the layout
    spin     every box has rolling and torsional friction 0.001 m: 6 active rows

and prints ms/step (after a throwaway world compiled the kernels) and the scene's quality
figure (stack: top-box drift; pyramid: largest box motion), so a slowdown shows beside
what the extra rows did. Timings on a shared machine vary by 10-30% between runs.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tumble  # noqa: E402
from bench import common as C  # noqa: E402
from bench import scenes as S  # noqa: E402

SCENES = {"stack": (S.STACK, S.stack_positions), "pyramid": (S.PYRAMID, S.pyramid_positions)}


def build(scene, variant):
    cfg, positions = SCENES[scene]
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, S.GRAVITY), timestep=cfg["dt"])
    b.add_geom(None, "plane", friction=S.FRICTION, name="ground")
    h, mass = cfg["half"], cfg["mass"]
    spin = dict(rolling_friction=1e-3, torsional_friction=1e-3) if variant == "spin" else {}
    for i, p in enumerate(positions()):
        body = b.add_body("b%d" % i, pos=p, mass=mass, inertia=S.box_inertia(mass, h, h, h))
        b.add_geom(body, "box", size=(h, h, h), friction=S.FRICTION, **spin)
    if variant == "padded":
        b.add_body("far", pos=(1e3, 1e3, 1e3), kind="static")
        b.add_geom("far", "sphere", radius=0.1, rolling_friction=1e-3, torsional_friction=1e-3)
    return b.build(), np.array(positions())


def run(scene, variant, contact, steps):
    model, p0 = build(scene, variant)
    warm = tumble.World(model, contact=contact)
    warm.step(2)
    w = tumble.World(model, contact=contact)
    t0 = time.perf_counter()
    w.step(steps)
    ms = 1000.0 * (time.perf_counter() - t0) / steps
    p1 = w.body_pos[:len(p0)]
    if scene == "stack":
        quality = "top drift %.2f mm" % (1000 * C.stack_figures(p0, p1)["top_drift_m"])
    else:
        quality = "largest motion %.2f mm" % (1000 * C.pyramid_figures(p0, p1)["max_disp_m"])
    return ms, quality, len(w.contacts)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=["stack", "pyramid"])
    ap.add_argument("--steps", type=int, default=None, help="default: the scene's steps")
    ap.add_argument("--contact", default="lcp,pgs")
    args = ap.parse_args()
    print("| scene | contact | variant | steps | ms/step | contacts | quality |")
    print("|---|---|---|---|---|---|---|")
    for scene in args.scenes:
        for contact in args.contact.split(","):
            steps = args.steps or SCENES[scene][0]["steps"]
            for variant in ("plain", "padded", "spin"):
                ms, quality, ncon = run(scene, variant, contact, steps)
                print(f"| {scene} | {contact} | {variant} | {steps} | {ms:.3f} | {ncon} | "
                      f"{quality} |", flush=True)


if __name__ == "__main__":
    main()
