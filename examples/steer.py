"""A steerable character (AMP) taking commands: 90-degree turns and speed changes on a
schedule, measured and, if asked, exported as a GIF.

    python examples/steer.py                                  # the shipped policy 'steer'
    python examples/steer.py --policy runs/amp-turn/policy.npz --seconds 12
    python examples/steer.py --gif docs/steer.gif             # needs tumble[viewer]

Each command holds for ``--every`` seconds (default 4): straight on, then turns of 90
degrees left and right at speeds from 0.6 to 1.8 m/s (headings are printed from the
character's first one, positive to the left). Printed per command: the speed along
the commanded direction over the command's second half, and the angle between the
direction of travel and the command 3 s after it was given.
"""
import argparse
import math

import numpy as np

from tumble.rl.play import policy_world
from tumble.viewer import Recorder

# (turn from the heading before, degrees; speed, m/s), one per command
SCHEDULE = ((0.0, 1.0), (90.0, 1.0), (0.0, 1.6), (-90.0, 1.6), (-90.0, 0.6), (90.0, 1.2),
            (90.0, 1.8), (0.0, 0.8))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policy", default="steer", help="a shipped policy's name or a .npz")
    ap.add_argument("--seconds", type=float, default=32.0)
    ap.add_argument("--every", type=float, default=4.0, help="seconds between commands")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--gif", help="export the run to this .gif or .mp4")
    ap.add_argument("--size", default="384x216", help="WIDTHxHEIGHT of the export")
    ap.add_argument("--fps", type=float, default=8.0, help="frames per second of the export")
    args = ap.parse_args(argv)

    world, driver, env = policy_world(args.policy, seed=args.seed, fall_delay=1e9)
    heading0 = float(env.target_heading[0])
    commands = []                     # (start time, absolute heading in rad, speed)
    heading = heading0
    for k in range(int(math.ceil(args.seconds / args.every))):
        turn, speed = SCHEDULE[k % len(SCHEDULE)]
        heading += math.radians(turn)
        commands.append((k * args.every, heading, speed))

    def control(w):
        for t0, h, v in commands:
            if abs(w.time - t0) < 0.5 * w.dt:
                driver.command(h, v)
        driver(w)

    rec = Recorder(world)
    rec.run(args.seconds, fps=30, control=control, progress=False)
    recording = rec.recording()
    times = np.asarray(recording.time)
    root = np.asarray(recording.body_pos)[:, env.root, :]

    def velocity(t_from, t_to):
        """Mean horizontal velocity (3,) of the root between two times (m/s)."""
        i, j = np.searchsorted(times, t_from), np.searchsorted(times, t_to) - 1
        v = (root[j] - root[i]) / max(times[j] - times[i], 1e-9)
        v[env.up] = 0.0
        return v

    print(f"policy {args.policy}: {driver.falls} falls in {args.seconds:.0f} s")
    print(" t (s)   asked: heading, speed   speed along it   off the heading at 3 s")
    errors = []
    for t0, h, v in commands:
        t1 = min(t0 + args.every, args.seconds)
        if t1 - t0 < args.every - 1e-9:
            break
        d = env.direction(np.array([h]))[0]
        along = float(velocity(0.5 * (t0 + t1), t1) @ d)
        if driver.last_fall is not None and t0 <= driver.last_fall < t1:
            print(f"{t0:6.1f}   fell at {driver.last_fall:.1f} s")
            continue
        v3 = velocity(t0 + 2.5, t0 + 3.0)
        off = math.degrees(math.acos(np.clip(v3 @ d / max(np.linalg.norm(v3), 1e-9), -1, 1)))
        errors.append(abs(along - v))
        print(f"{t0:6.1f}   {math.degrees(h - heading0):+5.0f} deg, {v:.1f} m/s        "
              f"{along:5.2f} m/s        {off:5.1f} deg")
    if errors:
        print(f"mean speed error {np.mean(errors):.2f} m/s over {len(errors)} commands")

    if args.gif:
        from tumble.viewer import export_video

        def caption(t):
            now = [c for c in commands if c[0] <= t + 1e-9][-1]
            return (f"t = {t:4.1f} s   asked: heading {math.degrees(now[1] - heading0):+.0f} "
                    f"deg, {now[2]:.1f} m/s")

        width, height = (int(x) for x in args.size.lower().split("x"))
        n = export_video(recording, args.gif, fps=args.fps, size=(width, height),
                         follow=world.model.body_names[env.root], caption=caption)
        print(f"{n} frames written to {args.gif}")


if __name__ == "__main__":
    main()
