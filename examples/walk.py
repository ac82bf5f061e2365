"""SIMBICON walking on the GAMES-105 course character, with no external force.

    python examples/walk.py                         # 60 s of the normal walk, figures
    python examples/walk.py --gait high_knee        # another style (see --list)
    python examples/walk.py --speed 0.4 --turn-rate 0.2
    python examples/walk.py --terrain slope-up      # 5 degrees up (slope-down, hill, bumps)
    python examples/walk.py --push-sweep            # largest 0.2 s push survived per direction
    python examples/walk.py --record walk.npz       # body poses per control step, to render
    python examples/walk.py --step-sweep            # which control/physics steps still walk
    python examples/walk.py --terrain-sweep         # flat, 5 degrees up and down, hill, bumps

Prints distance, speed, step length, time walked, the control and physics steps and the
wall-clock per simulated second. The controller is tumble.character.simbicon (read its
module docs); gaits are JSON files in tumble/character/gaits/.
"""
import argparse
import math
import time

import numpy as np

import tumble
from tumble.character.simbicon import Push, SimbiconController, gait_names, run_walk
from tumble.character.terrain import Flat, Heightfield, Slope

PUSH_BODY = "lowerback_torso"          # the chest, the torso body pushed in the paper's tests
DIRECTIONS = {"forward": (0.0, 0.0, 1.0), "backward": (0.0, 0.0, -1.0),
              "left": (1.0, 0.0, 0.0), "right": (-1.0, 0.0, 0.0)}


def make_terrain(name, angle_deg):
    a = math.radians(angle_deg)
    if name == "flat":
        return Flat()
    if name == "slope-up":
        return Slope(a)
    if name == "slope-down":
        return Slope(-a)
    if name == "hill":
        return Heightfield.hill(a, up_length=6.0, top_length=3.0, flat_before=3.0,
                                flat_after=30.0)
    if name == "bumps":
        return Heightfield.bumps(0.02, 60.0, spacing=0.3)
    raise SystemExit(f"unknown terrain {name!r}")


def make_controller(args, terrain):
    rd = tumble.games105_ragdoll(terrain=terrain)
    world = rd.make_world(dt=args.dt, contact=args.contact)
    return SimbiconController(world, rd, args.gait, control_dt=args.control_dt,
                              hip_control=args.hip_control,
                              terrain=terrain, speed=args.speed, turn_rate=args.turn_rate)


def survives(ctrl, snap, force, duration, watch):
    """Restore ``snap``, push for ``duration`` s from now, walk ``watch`` s: no fall?"""
    ctrl.restore(snap)
    t0 = ctrl.time
    pushes = [Push(force, t0, duration, PUSH_BODY)]
    while ctrl.time < t0 + watch - 1e-9:
        ctrl.step(pushes)
        if ctrl.fallen:
            return False
    return True


def push_sweep(ctrl, args):
    """Push survival per direction over ``args.phases`` push times spread over one stride:
    the fraction survived at each force of ``args.forces``, and the largest force (by
    bisection to ``args.resolution`` N) survived at every phase."""
    ctrl.place()
    while ctrl.time < args.settle - 1e-9:
        ctrl.step()
    if ctrl.fallen:
        raise SystemExit("fell before the pushes")
    # push times spread over one stride (two steps), measured from the last foot strikes
    times = [s[0] for s in ctrl.strikes[-5:]]
    stride = 2.0 * float(np.mean(np.diff(times)))
    snaps = []
    for k in range(args.phases):
        t_next = args.settle + k * stride / args.phases
        while ctrl.time < t_next - 1e-9:
            ctrl.step()
        snaps.append(ctrl.snapshot())
    forces = [float(f) for f in args.forces.split(",")]
    print(f"  {'':8s} " + " ".join(f"{f:>6.0f} N" for f in forces) + "   all phases")
    results = {}
    for name, d in DIRECTIONS.items():
        row = []
        for f in forces:
            ok = sum(survives(ctrl, s, f * np.array(d), args.push_time, args.watch)
                     for s in snaps)
            row.append(f"{ok:>4d}/{len(snaps):<3d}")
        lo, hi = 0.0, args.max_force
        while hi - lo > args.resolution:
            f = 0.5 * (lo + hi)
            ok = all(survives(ctrl, s, f * np.array(d), args.push_time, args.watch)
                     for s in snaps)
            lo, hi = (f, hi) if ok else (lo, f)
        results[name] = lo
        print(f"  {name:8s} " + " ".join(row) + f"   {lo:5.0f} N", flush=True)
    return results


def step_sweep(args):
    """Walk ``args.duration`` s at several (control, physics) steps, both hip forms."""
    print(f"{'hips':9s} {'control':>8s} {'physics':>8s}  outcome")
    for hips in ("implicit", "explicit"):
        for control, physics in ((1 / 60, 1 / 240), (1 / 60, 1 / 120), (1 / 60, 1 / 60),
                                 (1 / 30, 1 / 30), (1 / 20, 1 / 20)):
            a = argparse.Namespace(**{**vars(args), "control_dt": control, "dt": physics,
                                      "hip_control": hips})
            ctrl = make_controller(a, Flat())
            r = run_walk(ctrl, args.duration)
            print(f"{hips:9s} 1/{1 / control:<6.0f} 1/{1 / physics:<6.0f}  {r.summary()}; "
                  f"{r.wall_time / r.time:.3f} s per simulated s", flush=True)


def terrain_sweep(args):
    """Walk ``args.duration`` s on each terrain (or until 25 m)."""
    for name in ("flat", "slope-up", "slope-down", "hill", "bumps"):
        terrain = make_terrain(name, args.angle)
        ctrl = make_controller(args, terrain)
        start = (0.0, -2.0) if name == "hill" else (0.0, 0.0)
        r = run_walk(ctrl, args.duration, position=start, stop_distance=25.0)
        climbed = ctrl.ground_height(ctrl.world.body_pos[ctrl.pelvis])
        print(f"{name:10s} {r.summary()}; ends {climbed:+.2f} m above the start level",
              flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--gait", default="walk", help="shipped gait name or JSON path")
    p.add_argument("--list", action="store_true", help="list the shipped gaits")
    p.add_argument("--duration", type=float, default=60.0, help="simulated s")
    p.add_argument("--dt", type=float, default=1 / 60, help="physics step, s")
    p.add_argument("--control-dt", type=float, default=1 / 60, help="control step, s")
    p.add_argument("--contact", default="pgs", choices=("pgs", "lcp"))
    p.add_argument("--hip-control", default="implicit", choices=("implicit", "explicit"))
    p.add_argument("--speed", type=float, default=None, help="target speed, m/s")
    p.add_argument("--turn-rate", type=float, default=None, help="rad/s, > 0 turns left")
    p.add_argument("--terrain", default="flat",
                   choices=("flat", "slope-up", "slope-down", "hill", "bumps"))
    p.add_argument("--angle", type=float, default=5.0, help="slope angle, degrees")
    p.add_argument("--record", default=None, help="save body poses to this .npz")
    p.add_argument("--push-sweep", action="store_true")
    p.add_argument("--step-sweep", action="store_true")
    p.add_argument("--terrain-sweep", action="store_true")
    p.add_argument("--push-time", type=float, default=0.2)
    p.add_argument("--phases", type=int, default=8)
    p.add_argument("--forces", default="150,200,250,300,350,400",
                   help="forces (N) of the survival table, comma separated")
    p.add_argument("--settle", type=float, default=6.0)
    p.add_argument("--watch", type=float, default=5.0)
    p.add_argument("--max-force", type=float, default=800.0)
    p.add_argument("--resolution", type=float, default=10.0)
    args = p.parse_args()
    if args.list:
        print("\n".join(gait_names()))
        return
    if args.step_sweep:
        step_sweep(args)
        return
    if args.terrain_sweep:
        terrain_sweep(args)
        return
    terrain = make_terrain(args.terrain, args.angle)
    ctrl = make_controller(args, terrain)
    print(f"gait '{ctrl.gait.name}' on {terrain!r}: control step {ctrl.control_dt:.4f} s, "
          f"physics step {ctrl.world.dt:.4f} s ({ctrl.substeps} per control step), "
          f"hips {args.hip_control}, contacts {args.contact}")
    if args.push_sweep:
        t0 = time.perf_counter()
        print(f"push sweep: {args.push_time} s pushes at the '{PUSH_BODY}' body at "
              f"{args.phases} times spread over a stride; survived = no fall in the "
              f"{args.watch} s after; phases survived per force, and the largest force "
              f"survived at all phases (bisection to {args.resolution:g} N)")
        push_sweep(ctrl, args)
        print(f"  ({time.perf_counter() - t0:.0f} s of computation)")
        return
    start = (0.0, -2.0) if args.terrain == "hill" else (0.0, 0.0)
    r = run_walk(ctrl, args.duration, record=args.record is not None, position=start)
    print(r.summary())
    print(f"time {r.time:.1f} s, distance {r.distance:.2f} m (forward {r.forward_distance:.2f} m), "
          f"speed {r.speed:.3f} m/s, step length {r.step_length:.3f} m, step time "
          f"{r.step_time:.3f} s, lowest pelvis {r.pelvis_min_height:.3f} m above the ground")
    print(f"wall-clock {r.wall_time:.1f} s: {r.wall_time / r.time:.3f} s per simulated s")
    if args.record:
        m = ctrl.model
        np.savez(args.record, poses=r.poses, dt=ctrl.control_dt, body_names=np.array(m.body_names),
                 geom_type=m.geom_type,
                 geom_size=m.geom_size, geom_body=m.geom_body, geom_pos=m.geom_pos,
                 geom_quat=m.geom_quat)
        print(f"saved {len(r.poses)} poses (position, quaternion per body) to {args.record}")


if __name__ == "__main__":
    main()
