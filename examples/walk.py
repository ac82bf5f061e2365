"""SIMBICON walking on the GAMES-105 course character, with no external force.

    python examples/walk.py                         # 60 s of the normal walk, figures
    python examples/walk.py --gait fast             # another style (see --list)
    python examples/walk.py --speed 0.4 --turn-rate 0.2
    python examples/walk.py --terrain slope-up      # 5 degrees up (slope-down, hill, bumps)
    python examples/walk.py --push 200,0,0 --push-at 8   # 200 N to the chest for 0.2 s at 8 s
    python examples/walk.py --gif walk.gif --duration 8   # record and export (tumble[viewer])

Prints distance, speed, step length, time walked, the control and physics steps and the
wall-clock per simulated second. The controller is tumble.character.simbicon (read its
module docs); gaits are JSON files in tumble/character/gaits/. The measurements of the
README (50 m per style, the largest push per direction, slopes, heightfields, step sizes)
are made by bench/bench_walk.py.
"""
import argparse
import math

import tumble
from tumble.character import Push
from tumble.character.simbicon import SimbiconController, gait_names, run_walk
from tumble.character.terrain import Flat, Heightfield, Slope

PUSH_BODY = "lowerback_torso"          # the chest, the torso body pushed in the paper's tests
TERRAINS = ("flat", "slope-up", "slope-down", "hill", "bumps")


def make_terrain(name, angle_deg=5.0):
    """A terrain by name: flat, slope-up / slope-down (``angle_deg`` along +z), hill (up,
    flat top, down at ``angle_deg``), bumps (random heights up to 2 cm on a 0.3 m grid)."""
    a = math.radians(angle_deg)
    if name == "flat":
        return Flat()
    if name == "slope-up":
        return Slope(a)
    if name == "slope-down":
        return Slope(-a)
    if name == "hill":
        return Heightfield.hill(a, up_length=6.0, top_length=3.0, flat_before=3.0,
                                flat_after=40.0)
    if name == "bumps":
        return Heightfield.bumps(0.02, 60.0, spacing=0.3)
    raise SystemExit(f"unknown terrain {name!r}; one of {TERRAINS}")


def make_controller(gait="walk", terrain=None, *, dt=1 / 60, control_dt=1 / 60,
                    contact="pgs", hip_control="implicit", speed=None, turn_rate=None):
    """The course character on ``terrain`` in a World of physics step ``dt``, walked by a
    SimbiconController at ``control_dt``."""
    terrain = Flat() if terrain is None else terrain
    rd = tumble.games105_ragdoll(root="floating", terrain=terrain)
    world = rd.make_world(dt=dt, contact=contact)
    return SimbiconController(world, rd, gait, control_dt=control_dt, hip_control=hip_control,
                              terrain=terrain, speed=speed, turn_rate=turn_rate)


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--gait", default="walk", help="shipped gait name or JSON path")
    p.add_argument("--list", action="store_true", help="list the shipped gaits")
    p.add_argument("--duration", type=float, default=60.0, help="simulated s")
    p.add_argument("--dt", type=float, default=1 / 60, help="physics step, s")
    p.add_argument("--control-dt", type=float, default=1 / 60, help="control step, s")
    p.add_argument("--contact", default="pgs", choices=("pgs", "lcp"))
    p.add_argument("--hip-control", default="implicit", choices=("implicit", "rule", "explicit"))
    p.add_argument("--speed", type=float, default=None, help="target speed, m/s")
    p.add_argument("--turn-rate", type=float, default=None, help="rad/s, > 0 turns left")
    p.add_argument("--terrain", default="flat", choices=TERRAINS)
    p.add_argument("--angle", type=float, default=5.0, help="slope angle, degrees")
    p.add_argument("--push", default=None, help="force x,y,z (N, world; +z forward, +x left)")
    p.add_argument("--push-at", type=float, default=8.0, help="push start, s")
    p.add_argument("--push-time", type=float, default=0.2, help="push duration, s")
    p.add_argument("--gif", default=None, help="record and export to this .gif or .mp4")
    p.add_argument("--azimuth", type=float, default=25.0, help="camera azimuth of --gif, deg")
    args = p.parse_args()
    if args.list:
        for n in gait_names():
            print(f"{n:8s} {tumble.load_gait(n).description}")
        return
    terrain = make_terrain(args.terrain, args.angle)
    ctrl = make_controller(args.gait, terrain, dt=args.dt, control_dt=args.control_dt,
                           contact=args.contact, hip_control=args.hip_control,
                           speed=args.speed, turn_rate=args.turn_rate)
    world = ctrl.world
    print(f"gait '{ctrl.gait.name}' on {terrain!r}: control step {ctrl.control_dt:.4f} s, "
          f"physics step {world.dt:.4f} s ({ctrl.substeps} per control step), "
          f"hips {args.hip_control}, contacts {args.contact}")
    pushes = []
    if args.push:
        force = [float(v) for v in args.push.split(",")]
        pushes = [Push(PUSH_BODY, force, world.time + args.push_at, args.push_time)]
    recorder = tumble.Recorder(world, capture_now=False) if args.gif else None
    start = (0.0, -2.0) if args.terrain == "hill" else (0.0, 0.0)
    r = run_walk(ctrl, args.duration, pushes=pushes, position=start,
                 on_step=None if recorder is None else (lambda c: recorder.capture()))
    print(r.summary())
    print(f"time {r.time:.1f} s, distance {r.distance:.2f} m (forward {r.forward_distance:.2f} "
          f"m), speed {r.speed:.3f} m/s, step length {r.step_length:.3f} m, step time "
          f"{r.step_time:.3f} s, lowest pelvis {r.pelvis_min_height:.3f} m above the ground")
    print(f"wall-clock {r.wall_time:.1f} s: {r.wall_time / r.time:.3f} s per simulated s")
    if recorder is not None:
        from tumble.viewer import export_video
        from tumble.viewer.render import Camera
        # from the character's left and a little ahead, following the pelvis
        camera = Camera(follow=world.model.body_names[ctrl.pelvis], distance=3.6,
                        azimuth=args.azimuth, elevation=10.0, offset=(0.0, -0.2, 0.0))
        n = export_video(recorder.recording(), args.gif, fps=20, size=(480, 270),
                         camera=camera)
        print(f"{n} frames written to {args.gif}")


if __name__ == "__main__":
    main()
