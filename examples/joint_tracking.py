"""A motor-driven arm follows a target angle: plot the hinge angle against its target.

    python examples/joint_tracking.py [--seconds 4] [--out out/]

The arm hangs from the world on a hinge with a velocity motor (at most 30 N m). Before
every step a proportional controller asks the motor for the speed
``gain * (target - angle)``; the target steps between poses. Needs matplotlib.
"""
import argparse
import os

import numpy as np

import tumble
from tumble.viewer import plots

GAIN = 8.0               # 1/s: commanded speed per radian of error


def target_angle(t):
    """The target (rad): a sequence of holds, then a sine."""
    if t < 2.0:
        return (0.0, 0.8, -0.6, 0.3)[int(t / 0.5)]
    return 0.6 * np.sin(2.0 * np.pi * 0.5 * (t - 2.0))


def build():
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    arm = b.add_body("arm", pos=(0.0, 0.0, 1.25), density=800.0)
    b.add_geom(arm, "capsule", radius=0.04, half_length=0.21)
    b.add_joint("shoulder", "hinge", None, arm, anchor=(0.0, 0.0, 1.5), axis=(0.0, 1.0, 0.0),
                motor_max_force=30.0)
    return tumble.World(b.build(), dt=1.0 / 240.0)


def control(world):
    err = target_angle(world.time) - world.joint_q[0, 0]
    world.joint_motor_target[0, 0] = GAIN * err


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--out", default="out")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    world = build()
    rec = tumble.Recorder(world, joints=True)
    rec.run(args.seconds, fps=60, control=control)
    r = rec.recording()
    target = np.array([target_angle(t) for t in r.time])
    path = os.path.join(args.out, "tracking.png")
    plots.plot_joint_tracking(r.time, r.joint_q[:, 0, 0], target, name="shoulder", path=path)
    err = np.abs(r.joint_q[:, 0, 0] - target)[r.time > 2.5]
    print(f"plot written to {path}; tracking error on the sine: max {err.max():.3f} rad")
    return err.max()


if __name__ == "__main__":
    main()
