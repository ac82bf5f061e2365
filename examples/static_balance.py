"""Stand the course character with joint torques only and push it.

    python examples/static_balance.py [--seconds 30] [--push 50]

PD servos hold the T-pose; a virtual force on the centre of mass, realised through both legs
by Jacobian-transpose torques, keeps it over the feet. No external force holds the root.
Pushes of --push newtons for 0.2 s hit the pelvis forward at 10 s and backward at 20 s.
"""
import argparse

import numpy as np

import tumble
from tumble.character import PDController, Push, StaticBalance, center_of_mass


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--push", type=float, default=50.0)
    ap.add_argument("--hz", type=float, default=60.0)
    a = ap.parse_args()
    rd = tumble.games105_ragdoll(root="floating")
    world = rd.make_world(dt=1 / a.hz)
    pd = PDController(world, 1000.0, 50.0, max_torque=200.0)
    pd.set_targets(np.tile([0.0, 0.0, 0.0, 1.0], (world.model.njoint, 1)))
    balance = StaticBalance(world, ["lAnkle", "rAnkle"], "RootJoint", up=(0, 1, 0))
    pelvis = world.model.body_index("RootJoint")
    pushes = [Push(pelvis, (0, 0, a.push), 10.0, 0.2), Push(pelvis, (0, 0, -a.push), 20.0, 0.2)]
    lowest, fell = np.inf, None
    while world.time < a.seconds - 1e-9:
        balance.apply()
        for p in pushes:
            p.apply(world)
        world.step()
        y = world.body_pos[pelvis, 1]
        lowest = min(lowest, y)
        if y < 0.6 and fell is None:
            fell = world.time
    com, vel = center_of_mass(world)
    print(f"{a.seconds:.0f} s at {a.hz:.0f} Hz, pushes of {a.push:.0f} N for 0.2 s at 10 s "
          f"(forward) and 20 s (backward)")
    print("fell at t = %.2f s" % fell if fell else
          f"stood: pelvis height min {lowest:.3f} m, end {world.body_pos[pelvis, 1]:.3f} m, "
          f"COM {100 * abs(com[2] - balance.support_center()[2]):.1f} cm from the middle "
          f"of the feet, speed {np.linalg.norm(vel):.4f} m/s")


if __name__ == "__main__":
    main()
