"""Measurements of SIMBICON walking (tumble.character.simbicon) on the course character.

    python bench/bench_walk.py                      # all sections, ~10 min on 2 busy cores
    python bench/bench_walk.py distance pushes      # some of them
    python bench/bench_walk.py pushes --gaits fast --phases 8

Sections:
    distance  each style walks until 50 m (at most --max-time s): time, speed, step length
    pushes    0.2 s pushes to the chest (the 'lowerback_torso' body) forward, backward, left
              and right, searched upward in --force-step N steps: a force counts as survived
              when the character does not fall in the --watch s after it at every one of
              --phases push times spread over one stride; the table gives the largest force
              survived and how many push times survive the next force up
    slopes    5 degrees up and down for 30 s: distance, height climbed
    terrain   a heightfield hill (5 degrees up 6 m, 3 m top, down 6 m) and random bumps
              (heights up to 2 cm on a 0.3 m grid): distance walked over them
    steps     which (control, physics) steps still walk 30 s, for each hip_control

--hip-control (implicit, rule, explicit) selects the controller's torso and stance-hip form
for the other sections.

A fall is the controller's own check: the pelvis COM below 0.55 m above the terrain, or a
body other than the feet touching the ground. Every run starts from standing at rest.
"""
import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples"))
from walk import PUSH_BODY, make_controller, make_terrain  # noqa: E402

from tumble.character import Push  # noqa: E402
from tumble.character.simbicon import run_walk  # noqa: E402

DIRECTIONS = {"forward": (0.0, 0.0, 1.0), "backward": (0.0, 0.0, -1.0),
              "left": (1.0, 0.0, 0.0), "right": (-1.0, 0.0, 0.0)}


def distance(args):
    print(f"## distance: each style until {args.distance:g} m (at most {args.max_time:g} s), "
          f"control and physics step 1/60 s")
    print(f"{'gait':6s} {'time s':>7s} {'dist m':>7s} {'speed m/s':>9s} {'step m':>7s} "
          f"{'step s':>7s} {'pelvis min m':>12s}  fell  wall s/sim s")
    for g in args.gaits:
        c = make_controller(g, hip_control=args.hip_control)
        r = run_walk(c, args.max_time, stop_distance=args.distance)
        print(f"{g:6s} {r.time:7.1f} {r.distance:7.1f} {r.speed:9.3f} {r.step_length:7.3f} "
              f"{r.step_time:7.3f} {r.pelvis_min_height:12.3f}  "
              f"{r.fall_reason if r.fallen else 'no':4s}  {r.wall_time / r.time:.3f}", flush=True)


def _survives(ctrl, snap, force, args):
    """From ``snap``, push for ``args.push_time`` s now, walk ``args.watch`` s: no fall?"""
    ctrl.restore(snap)
    pushes = [Push(PUSH_BODY, force, ctrl.world.time, args.push_time)]
    t_end = ctrl.time + args.watch - 1e-9
    while ctrl.time < t_end:
        ctrl.step(pushes)
        if ctrl.fallen:
            return False
    return True


def pushes(args):
    print(f"## pushes: {args.push_time:g} s at '{PUSH_BODY}', {args.phases} push times over a "
          f"stride after {args.settle:g} s of walking, {args.watch:g} s watched, upward in "
          f"{args.force_step:g} N steps")
    print(f"{'gait':6s} " + " ".join(f"{d:>22s}" for d in DIRECTIONS))
    for g in args.gaits:
        c = make_controller(g, hip_control=args.hip_control)
        c.place()
        while c.time < args.settle - 1e-9:
            c.step()
        if c.fallen:
            print(f"{g:6s} fell before the pushes")
            continue
        times = [s[0] for s in c.strikes[-5:]]
        stride = 2.0 * float(np.mean(np.diff(times)))
        snaps = []
        for k in range(args.phases):
            while c.time < args.settle + k * stride / args.phases - 1e-9:
                c.step()
            snaps.append(c.snapshot())
        cells = []
        for d in DIRECTIONS.values():
            best, f, ok = 0.0, args.force_step, args.phases
            while f <= args.max_force + 1e-9:
                ok = sum(_survives(c, s, f * np.asarray(d), args) for s in snaps)
                if ok < len(snaps):
                    break
                best, f = f, f + args.force_step
            tail = f"({ok}/{len(snaps)} at {f:.0f})" if f <= args.max_force else "(max)"
            cells.append(f"{best:5.0f} N {tail:>14s}")
        print(f"{g:6s} " + " ".join(f"{x:>22s}" for x in cells), flush=True)


def slopes(args):
    print("## slopes: 30 s on a 5 degree slope along the walking direction")
    for g in args.gaits:
        for name in ("slope-up", "slope-down"):
            terrain = make_terrain(name, 5.0)
            c = make_controller(g, terrain, hip_control=args.hip_control)
            r = run_walk(c, 30.0)
            rise = c.ground_height(c.world.body_pos[c.pelvis])
            print(f"{g:6s} {name:10s} {r.summary()}; ground under the pelvis {rise:+.2f} m",
                  flush=True)


def terrain(args):
    print("## terrain: heightfields (stop after 25 m)")
    for g in args.gaits:
        for name in ("hill", "bumps"):
            t = make_terrain(name, 5.0)
            c = make_controller(g, t, hip_control=args.hip_control)
            start = (0.0, -2.0) if name == "hill" else (0.0, 0.0)
            r = run_walk(c, 60.0, position=start, stop_distance=25.0)
            print(f"{g:6s} {name:6s} {r.summary()}", flush=True)


def steps(args):
    print("## steps: 30 s of 'walk' at (control, physics) steps")
    for hips in ("implicit", "rule", "explicit"):
        for control, physics in ((1 / 60, 1 / 240), (1 / 60, 1 / 120), (1 / 60, 1 / 60),
                                 (1 / 30, 1 / 30), (1 / 20, 1 / 20), (1 / 15, 1 / 15)):
            c = make_controller("walk", dt=physics, control_dt=control, hip_control=hips)
            r = run_walk(c, 30.0)
            print(f"{hips:9s} control 1/{1 / control:<4.0f} physics 1/{1 / physics:<4.0f} "
                  f"{r.summary()}; {r.wall_time / r.time:.3f} s per simulated s", flush=True)


SECTIONS = {"distance": distance, "pushes": pushes, "slopes": slopes, "terrain": terrain,
            "steps": steps}


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("sections", nargs="*", help=f"any of {list(SECTIONS)} (default all)")
    p.add_argument("--gaits", default="walk,fast")
    p.add_argument("--hip-control", default="implicit", choices=("implicit", "rule", "explicit"))
    p.add_argument("--distance", type=float, default=50.0)
    p.add_argument("--max-time", type=float, default=150.0)
    p.add_argument("--push-time", type=float, default=0.2)
    p.add_argument("--phases", type=int, default=4)
    p.add_argument("--settle", type=float, default=6.0)
    p.add_argument("--watch", type=float, default=5.0)
    p.add_argument("--force-step", type=float, default=50.0)
    p.add_argument("--max-force", type=float, default=600.0)
    args = p.parse_args()
    args.gaits = args.gaits.split(",")
    unknown = [s for s in args.sections if s not in SECTIONS]
    if unknown:
        p.error(f"unknown sections {unknown}; choose from {list(SECTIONS)}")
    print(f"hip_control '{args.hip_control}' (the steps section runs all three)\n")
    for name in args.sections or SECTIONS:
        t0 = time.perf_counter()
        SECTIONS[name](args)
        print(f"({time.perf_counter() - t0:.0f} s)\n", flush=True)


if __name__ == "__main__":
    main()
