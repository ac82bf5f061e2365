"""Hold the course character in its T-pose with the root pinned: implicit vs explicit PD.

    python examples/tpose_hold.py [--seconds 2] [--kp 1000] [--kd 30]

The course runs ODE at 32 substeps per 60 Hz frame because explicit PD is unstable at a
large step. tumble's implicit PD (the servo solved as a soft constraint) holds the pose at
one step per frame; explicit PD needs the small step. Prints the joint error of each.
"""
import argparse
import time

import numpy as np

import tumble
from tumble.character import PDController


def hold(mode, dt, seconds, kp, kd):
    rd = tumble.games105_ragdoll(root="pinned")
    world = rd.make_world(dt=dt)
    pd = PDController(world, kp, kd, max_torque=200.0, mode=mode)
    pd.set_targets(np.tile([0.0, 0.0, 0.0, 1.0], (world.model.njoint, 1)))   # the T-pose
    t0 = time.perf_counter()
    try:
        world.step(int(round(seconds / dt)))
    except tumble.SimulationError as err:
        return f"diverged at step {err.step}"
    wall = time.perf_counter() - t0
    err = pd.joint_error()
    return (f"max joint error {err.max():.4f} rad, mean {err.mean():.4f} rad, "
            f"{wall / seconds:.3f} s wall per simulated second")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--kp", type=float, default=1000.0)
    ap.add_argument("--kd", type=float, default=30.0)
    a = ap.parse_args()
    hold("implicit", 1 / 60, 0.1, a.kp, a.kd)          # compile the kernels first
    for mode, hz in (("implicit", 60), ("stable", 60), ("explicit", 1920), ("explicit", 60)):
        print(f"{mode:>8} PD at {hz:4d} Hz: {hold(mode, 1 / hz, a.seconds, a.kp, a.kd)}")


if __name__ == "__main__":
    main()
