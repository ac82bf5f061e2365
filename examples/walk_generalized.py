"""Generalized walking control (Coros, Beaudoin and van de Panne 2010) on the GAMES-105 course
character: inverted-pendulum foot placement, swing-leg inverse kinematics, virtual forces.

    python examples/walk_generalized.py                       # 30 s at the style's speed
    python examples/walk_generalized.py --speed -0.4          # backward
    python examples/walk_generalized.py --speed 0.5 --side-speed 0.3 --turn-rate 0.3
    python examples/walk_generalized.py --terrain slope-up --angle 10
    python examples/walk_generalized.py --push 0,0,400 --push-at 8   # 400 N forward, 0.2 s
    python examples/walk_generalized.py --gif gen.gif --duration 12 --turn-at 4 --push-at 8

Prints the walk's figures (distance, speed, step length, wall-clock per simulated second).
The controller is tumble.character.generalized (read its module docs); styles are JSON files
in tumble/character/gaits/ with "controller": "generalized". bench/bench_walk.py measures
it beside SIMBICON.
"""
import argparse
import math
import os
import sys

import numpy as np

import tumble
from tumble.character import Push
from tumble.character.gait_files import style_names
from tumble.character.generalized import make_generalized
from tumble.character.walk import run_walk

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from walk import PUSH_BODY, TERRAINS, make_terrain  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--style", default="ipm_walk", help="shipped style name or JSON path")
    p.add_argument("--list", action="store_true", help="list the shipped styles")
    p.add_argument("--duration", type=float, default=30.0, help="simulated s")
    p.add_argument("--dt", type=float, default=1 / 60, help="physics step, s")
    p.add_argument("--control-dt", type=float, default=1 / 60, help="control step, s")
    p.add_argument("--speed", type=float, default=None, help="forward speed, m/s (< 0 back)")
    p.add_argument("--side-speed", type=float, default=None, help="m/s to the left")
    p.add_argument("--turn-rate", type=float, default=None, help="rad/s, > 0 turns left")
    p.add_argument("--turn-at", type=float, default=None,
                   help="start turning (--turn-rate, default 0.5) only at this time, s")
    p.add_argument("--terrain", default="flat", choices=TERRAINS)
    p.add_argument("--angle", type=float, default=5.0, help="slope angle, degrees")
    p.add_argument("--push", default=None, help="force x,y,z (N, world; +z forward, +x left)")
    p.add_argument("--push-at", type=float, default=None, help="push start, s")
    p.add_argument("--push-time", type=float, default=0.2, help="push duration, s")
    p.add_argument("--gif", default=None, help="record and export to this .gif or .mp4")
    p.add_argument("--azimuth", type=float, default=25.0, help="camera azimuth of --gif, deg")
    args = p.parse_args()
    if args.list:
        for n in style_names():
            print(f"{n:10s} {tumble.character.gait_files.load_style(n).description}")
        return
    terrain = make_terrain(args.terrain, args.angle)
    turn_later = args.turn_at is not None
    ctrl = make_generalized(args.style, terrain, dt=args.dt, control_dt=args.control_dt,
                            speed=args.speed, side_speed=args.side_speed,
                            turn_rate=None if turn_later else args.turn_rate)
    world = ctrl.world
    s = ctrl.style
    print(f"style '{s.name}' on {terrain!r}: speed {s.speed:+.2f} m/s, sideways "
          f"{s.side_speed:+.2f} m/s, turning {s.turn_rate:+.2f} rad/s; control step "
          f"{ctrl.control_dt:.4f} s, physics step {world.dt:.4f} s")
    pushes = []
    if args.push or args.push_at is not None:
        force = [float(v) for v in (args.push or "0,0,350").split(",")]
        at = 8.0 if args.push_at is None else args.push_at
        pushes = [Push(PUSH_BODY, force, world.time + at, args.push_time)]
        print(f"push {force} N at {at:g} s for {args.push_time:g} s")
    recorder = tumble.Recorder(world, capture_now=False) if args.gif else None
    rate = 0.5 if args.turn_rate is None else args.turn_rate

    def on_step(c):
        if turn_later and c.time >= args.turn_at and c.style.turn_rate != rate:
            c.gait = c.gait.with_(turn_rate=rate)
        if recorder is not None:
            recorder.capture()

    start = (0.0, -2.0) if args.terrain == "hill" else (0.0, 0.0)
    r = run_walk(ctrl, args.duration, pushes=pushes, position=start, on_step=on_step)
    print(r.summary())
    heading = math.degrees(ctrl.pelvis_heading())
    print(f"time {r.time:.1f} s, distance {r.distance:.2f} m, speed {r.speed:.3f} m/s, step "
          f"length {r.step_length:.3f} m, step time {r.step_time:.3f} s, lowest pelvis "
          f"{r.pelvis_min_height:.3f} m, heading {heading:+.0f} deg")
    com = r.com
    if len(com) > 1:
        print(f"COM moved {np.round(com[-1] - com[0], 2)} m (x left, z forward)")
    print(f"wall-clock {r.wall_time:.1f} s: {r.wall_time / r.time:.3f} s per simulated s")
    if recorder is not None:
        from tumble.viewer import export_video
        from tumble.viewer.render import Camera
        camera = Camera(follow=world.model.body_names[ctrl.pelvis], distance=3.6,
                        azimuth=args.azimuth, elevation=10.0, offset=(0.0, -0.2, 0.0))
        n = export_video(recorder.recording(), args.gif, fps=20, size=(480, 270),
                         camera=camera)
        print(f"{n} frames written to {args.gif}")


if __name__ == "__main__":
    main()
