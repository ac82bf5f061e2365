"""Measurements of walking on the course character: SIMBICON (tumble.character.simbicon) and
the generalized controller (tumble.character.generalized, after Coros, Beaudoin and van de
Panne 2010), side by side.

    python bench/bench_walk.py                       # all sections, ~1 h on 2 busy cores
    python bench/bench_walk.py speeds pushes         # some of them
    python bench/bench_walk.py pushes --controllers generalized --phases 8
    python bench/bench_walk.py speeds slopes --dt 0.008333   # physics step 1/120 s

Controllers (--controllers): 'simbicon' walks the gaits of --gaits (default walk), with
hip_control --hip-control; 'generalized' walks the styles of --styles (default ipm_walk).
Control step 1/60 s; physics step --dt (default 1/60 s).

Sections:
    distance  each controller until 50 m (at most --max-time s): time, speed, step length
    pushes    0.2 s pushes at the chest (the 'lowerback_torso' body) in 8 directions (the 4
              axes and the 4 diagonals), searched upward in --force-step N steps: a force
              counts as survived when the character does not fall in the --watch s after it
              at every one of --phases push times spread over one stride (after --settle
              s of walking); the table gives the largest force survived and how many push
              times survive the next force up
    speeds    commanded forward speeds -0.5 .. 1.5 m/s for --long s each: falls, the mean
              speed after 3 s, the largest deviation from the command of the speed over a
              stride (two steps) after 3 s, and from when on every stride stays within 0.1
              m/s; then sideways 0.3 m/s (generalized only) and turning at 0.5 rad/s
    survival  the same pushes at fixed forces (--survival-forces), every direction and push
              time: how many of them the walker survives. A smoother figure than the largest
              force survived at every push time (one fall among the push times decides
              that one), for comparing controller changes
    slopes    10 degrees up and down for 30 s: distance, height climbed
    terrain   a step up and down of 5 cm on a heightfield, random bumps up to 3 cm on a 0.3
              m grid: time and distance walked (stop after 25 m)
    terrain   also the older courses: a 5 degree hill (up 6 m, top 3 m, down 6 m) and
              bumps up to 2 cm
    steps     flat walking (own speed, 0 and 1 m/s) and the forward and backward push
              searches at physics steps 1/60 and 1/120 s, control 1/60 s, no retuning
    simbicon-steps  SIMBICON alone: which (control, physics) steps walk 30 s, for each
              hip_control (not in the default run)

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
from tumble.character.generalized import make_generalized  # noqa: E402
from tumble.character.terrain import Heightfield, Slope  # noqa: E402
from tumble.character.walk import run_walk  # noqa: E402

S = math.sqrt(0.5)
DIRECTIONS = {"fwd": (0.0, 0.0, 1.0), "back": (0.0, 0.0, -1.0), "left": (1.0, 0.0, 0.0),
              "right": (-1.0, 0.0, 0.0), "fwd-left": (S, 0.0, S), "fwd-right": (-S, 0.0, S),
              "back-left": (S, 0.0, -S), "back-right": (-S, 0.0, -S)}


def walkers(args):
    """(label, factory(terrain=None, dt=None, **commands)) of the walkers to measure."""
    out = []
    for name in args.controllers:
        if name == "simbicon":
            for g in args.gaits:
                def make(terrain=None, dt=None, speed=None, turn_rate=None, side_speed=None,
                         g=g):
                    if side_speed:
                        return None                        # SIMBICON has no sideways command
                    return make_controller(g, terrain, dt=dt or args.dt,
                                           hip_control=args.hip_control, speed=speed,
                                           turn_rate=turn_rate)
                out.append((f"simbicon/{g}", make))
        elif name == "generalized":
            for st in args.styles:
                def make(terrain=None, dt=None, speed=None, turn_rate=None, side_speed=None,
                         st=st):
                    return make_generalized(st, terrain, dt=dt or args.dt, speed=speed,
                                            side_speed=side_speed, turn_rate=turn_rate)
                out.append((f"generalized/{st}", make))
        else:
            raise SystemExit(f"unknown controller {name!r}: simbicon or generalized")
    return out


def distance(args):
    print(f"## distance: until {args.distance:g} m (at most {args.max_time:g} s)")
    print(f"{'walker':24s} {'time s':>7s} {'dist m':>7s} {'speed m/s':>9s} {'step m':>7s} "
          f"{'step s':>7s} {'pelvis min m':>12s}  fell  wall s/sim s")
    for label, make in walkers(args):
        c = make()
        r = run_walk(c, args.max_time, stop_distance=args.distance)
        print(f"{label:24s} {r.time:7.1f} {r.distance:7.1f} {r.speed:9.3f} {r.step_length:7.3f} "
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


def push_snapshots(make, args):
    """(walker, its snapshots at ``args.phases`` push times spread over a stride after
    ``args.settle`` s of walking), or None if it fell before."""
    c = make()
    c.place()
    while c.time < args.settle - 1e-9:
        c.step()
    if c.fallen:
        return None
    times = [s[0] for s in c.strikes[-5:]]
    stride = 2.0 * float(np.mean(np.diff(times)))
    snaps = []
    for k in range(args.phases):
        while c.time < args.settle + k * stride / args.phases - 1e-9:
            c.step()
        snaps.append(c.snapshot())
    return c, snaps


def push_table(make, args, directions=DIRECTIONS):
    """{direction: (largest force survived at every push time, survivors at the next force
    up, that force)} for a walker, or None if it fell before the pushes."""
    got = push_snapshots(make, args)
    if got is None:
        return None
    c, snaps = got
    out = {}
    for name, d in directions.items():
        best, f, ok = 0.0, args.force_step, args.phases
        while f <= args.max_force + 1e-9:
            ok = sum(_survives(c, s, f * np.asarray(d), args) for s in snaps)
            if ok < len(snaps):
                break
            best, f = f, f + args.force_step
        out[name] = (best, ok, f)
    return out


def pushes(args):
    print(f"## pushes: {args.push_time:g} s at '{PUSH_BODY}', {args.phases} push times over a "
          f"stride after {args.settle:g} s of walking, {args.watch:g} s watched, upward in "
          f"{args.force_step:g} N steps (N survived at every push time; in brackets the push "
          f"times survived at the next force up)")
    print(f"{'walker':24s} " + " ".join(f"{d:>14s}" for d in DIRECTIONS))
    for label, make in walkers(args):
        t = push_table(make, args)
        if t is None:
            print(f"{label:24s} fell before the pushes", flush=True)
            continue
        cells = []
        for d in DIRECTIONS:
            best, ok, f = t[d]
            tail = f"({ok}/{args.phases})" if f <= args.max_force else "(max)"
            cells.append(f"{best:4.0f} {tail:>7s}")
        print(f"{label:24s} " + " ".join(f"{x:>14s}" for x in cells), flush=True)


def survival(args):
    forces = args.survival_forces
    print(f"## survival: {args.push_time:g} s pushes at '{PUSH_BODY}' of "
          f"{', '.join(f'{f:g}' for f in forces)} N, {args.phases} push times over a stride "
          f"after {args.settle:g} s of walking, {args.watch:g} s watched: pushes survived per "
          f"direction (one count per force)")
    print(f"{'walker':24s} {'total':>9s} " + " ".join(f"{d:>10s}" for d in DIRECTIONS))
    for label, make in walkers(args):
        got = push_snapshots(make, args)
        if got is None:
            print(f"{label:24s} fell before the pushes", flush=True)
            continue
        c, snaps = got
        cells, total = [], 0
        for d in DIRECTIONS.values():
            counts = [sum(_survives(c, s, f * np.asarray(d), args) for s in snaps)
                      for f in forces]
            total += sum(counts)
            cells.append("/".join(str(n) for n in counts))
        n = len(forces) * args.phases * len(DIRECTIONS)
        print(f"{label:24s} {f'{total}/{n}':>9s} " + " ".join(f"{x:>10s}" for x in cells),
              flush=True)


def stride_speeds(c, r, settle, along=None):
    """Speeds (m/s) over each stride (two steps, strike to strike) that starts after
    ``settle`` s: along ``along`` (a unit (3,) world direction, default the heading at the
    stride) or, with along='path', the horizontal COM path length per second."""
    dt = c.control_dt
    strikes = [s for s in r.strikes if s[0] >= settle]
    out = []
    for a, b in zip(strikes[:-2:2], strikes[2::2]):
        i, j = int(round(a[0] / dt)) - 1, int(round(b[0] / dt)) - 1
        if j >= len(r.com) or i < 0:
            break
        seg = r.com[i:j + 1]
        T = b[0] - a[0]
        if isinstance(along, str) and along == "path":
            d = np.diff(seg[:, [0, 2]], axis=0)
            out.append(float(np.linalg.norm(d, axis=1).sum()) / T)
        else:
            u = along if along is not None else np.array([math.sin(a[3]), 0.0, math.cos(a[3])])
            out.append(float((seg[-1] - seg[0]) @ u) / T)
    return np.array(out)


def _speed_row(label, what, r, v, target, settle=3.0):
    if r.fallen:
        return f"{label:24s} {what:18s} FELL at {r.time:5.1f} s ({r.fall_reason})"
    ok = np.abs(v - target) <= 0.1
    bad = np.flatnonzero(~ok)
    if len(v) == 0:
        since = "-"
    elif len(bad) == 0:
        since = f"{settle:.0f} s"
    elif bad[-1] + 1 < len(v):
        since = f"{(settle + (bad[-1] + 1) * (r.time - settle) / len(v)):.0f} s"
    else:
        since = "never"
    return (f"{label:24s} {what:18s} {r.time:5.0f} s  mean {v.mean():+6.3f}  worst stride "
            f"{np.abs(v - target).max():5.3f}  within 0.1 from {since}")


def speeds(args):
    print(f"## speeds: {args.long:g} s each from standing; stride speeds (two steps) after 3 s"
          f" against the command")
    print(f"{'walker':24s} {'command':18s}  time  mean m/s  worst |error|  all strides within "
          f"0.1 m/s")
    for label, make in walkers(args):
        for v in args.speeds:
            c = make(speed=v)
            r = run_walk(c, args.long, settle=3.0)
            print(_speed_row(label, f"forward {v:+.1f} m/s", r, stride_speeds(c, r, 3.0), v),
                  flush=True)
        c = make(speed=0.0, side_speed=args.side_speed)
        if c is None:
            print(f"{label:24s} sideways {args.side_speed:+.1f} m/s: no sideways command")
        else:
            r = run_walk(c, args.long, settle=3.0)
            v = stride_speeds(c, r, 3.0, along=c.left0)
            print(_speed_row(label, f"sideways {args.side_speed:+.1f} m/s", r, v,
                             args.side_speed), flush=True)
        c = make(speed=args.turn_speed, turn_rate=args.turn_rate)
        r = run_walk(c, args.long, settle=3.0)
        turned = c.pelvis_heading() - c.heading
        turned = (turned + math.pi) % (2 * math.pi) - math.pi
        row = _speed_row(label, f"turn {args.turn_rate:+.1f} rad/s", r,
                         stride_speeds(c, r, 3.0, along="path"), c.gait.speed or 0.0)
        if not r.fallen:
            row += (f"; turned {c.heading:.1f} rad, pelvis {turned:+.2f} rad off the heading")
        print(row, flush=True)


def slopes(args):
    print(f"## slopes: 30 s on a {args.angle:g} degree slope along the walking direction")
    for label, make in walkers(args):
        for sign, name in ((1, "up"), (-1, "down")):
            c = make(Slope(sign * math.radians(args.angle)))
            r = run_walk(c, 30.0)
            rise = c.ground_height(c.world.body_pos[c.pelvis])
            print(f"{label:24s} {name:5s} {r.summary()}; ground under the pelvis {rise:+.2f} m",
                  flush=True)


def step_terrain(height=0.05, up_at=3.0, down_at=8.0, length=40.0, spacing=0.05):
    """A heightfield along +z: flat, up ``height`` m at z = up_at (over one cell), down again
    at z = down_at."""
    z0 = -2.0
    nz = int(length / spacing) + 1
    z = z0 + spacing * np.arange(nz)
    prof = np.where((z >= up_at) & (z < down_at), height, 0.0)
    return Heightfield(np.repeat(prof[:, None], int(4.0 / spacing) + 1, axis=1), spacing,
                       (-2.0, z0))


def terrain(args):
    print("## terrain: heightfields, stop after 25 m")
    for label, make in walkers(args):
        for name, t in (("step 5 cm", step_terrain(0.05)),
                        ("bumps 3 cm", Heightfield.bumps(0.03, 60.0, spacing=0.3)),
                        ("hill 5 deg", make_terrain("hill", 5.0)),
                        ("bumps 2 cm", make_terrain("bumps"))):
            c = make(t)
            start = (0.0, -2.0) if name.startswith("hill") else (0.0, 0.0)
            r = run_walk(c, 60.0, stop_distance=25.0, position=start)
            print(f"{label:24s} {name:10s} {r.summary()}", flush=True)


def steps(args):
    print("## steps: control 1/60 s, physics 1/60 and 1/120 s, no retuning")
    for label, make in walkers(args):
        for dt in (1 / 60, 1 / 120):
            for v in (None, 0.0, 1.0):
                c = make(dt=dt, speed=v)
                r = run_walk(c, args.long / 2)
                what = "own speed" if v is None else f"speed {v:+.1f}"
                print(f"{label:24s} physics 1/{1 / dt:<4.0f} {what:10s} {r.summary()}; "
                      f"{r.wall_time / r.time:.3f} s per simulated s", flush=True)
            t = push_table(lambda: make(dt=dt), args,
                           {"fwd": DIRECTIONS["fwd"], "back": DIRECTIONS["back"]})
            if t:
                print(f"{label:24s} physics 1/{1 / dt:<4.0f} pushes: fwd {t['fwd'][0]:.0f} N, "
                      f"back {t['back'][0]:.0f} N survived at all {args.phases} push times",
                      flush=True)


def simbicon_steps(args):
    print("## simbicon-steps: 30 s of SIMBICON's first gait at (control, physics) steps, each "
          "hip_control")
    for hips in ("implicit", "rule", "explicit"):
        for control, physics in ((1 / 60, 1 / 240), (1 / 60, 1 / 120), (1 / 60, 1 / 60),
                                 (1 / 30, 1 / 30), (1 / 20, 1 / 20), (1 / 15, 1 / 15)):
            c = make_controller(args.gaits[0], dt=physics, control_dt=control, hip_control=hips)
            r = run_walk(c, 30.0)
            print(f"{hips:9s} control 1/{1 / control:<4.0f} physics 1/{1 / physics:<4.0f} "
                  f"{r.summary()}; {r.wall_time / r.time:.3f} s per simulated s", flush=True)


SECTIONS = {"distance": distance, "pushes": pushes, "survival": survival, "speeds": speeds,
            "slopes": slopes, "terrain": terrain, "steps": steps,
            "simbicon-steps": simbicon_steps}


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("sections", nargs="*", help=f"any of {list(SECTIONS)} (default all)")
    p.add_argument("--controllers", default="simbicon,generalized")
    p.add_argument("--gaits", default="walk", help="SIMBICON gaits")
    p.add_argument("--styles", default="ipm_walk", help="generalized controller styles")
    p.add_argument("--hip-control", default="implicit", choices=("implicit", "rule", "explicit"))
    p.add_argument("--dt", type=float, default=1 / 60, help="physics step, s")
    p.add_argument("--distance", type=float, default=50.0)
    p.add_argument("--max-time", type=float, default=150.0)
    p.add_argument("--push-time", type=float, default=0.2)
    p.add_argument("--phases", type=int, default=8)
    p.add_argument("--settle", type=float, default=6.0)
    p.add_argument("--watch", type=float, default=5.0)
    p.add_argument("--force-step", type=float, default=50.0)
    p.add_argument("--max-force", type=float, default=800.0)
    p.add_argument("--survival-forces", default="100,200,300",
                   help="N, the survival section's forces")
    p.add_argument("--long", type=float, default=60.0, help="s of the speed runs")
    p.add_argument("--speeds", default="-0.5,0,0.5,1.0,1.5")
    p.add_argument("--side-speed", type=float, default=0.3)
    p.add_argument("--turn-rate", type=float, default=0.5)
    p.add_argument("--turn-speed", type=float, default=0.6, help="forward m/s while turning")
    p.add_argument("--angle", type=float, default=10.0, help="slope, degrees")
    args = p.parse_args()
    args.controllers = args.controllers.split(",")
    args.gaits = args.gaits.split(",")
    args.styles = args.styles.split(",")
    args.speeds = [float(v) for v in args.speeds.split(",")]
    args.survival_forces = [float(f) for f in args.survival_forces.split(",")]
    unknown = [s for s in args.sections if s not in SECTIONS]
    if unknown:
        p.error(f"unknown sections {unknown}; choose from {list(SECTIONS)}")
    print(f"controllers {args.controllers}, physics step {args.dt:.5f} s, control 1/60 s, "
          f"SIMBICON hip_control '{args.hip_control}'\n")
    default = [k for k in SECTIONS if k not in ("simbicon-steps", "survival")]
    for name in args.sections or default:
        t0 = time.perf_counter()
        SECTIONS[name](args)
        print(f"({time.perf_counter() - t0:.0f} s)\n", flush=True)


if __name__ == "__main__":
    main()
