"""Push a box sideways at its top corner and watch it fly, spin and fall.

    python examples/push_and_spin.py
"""
import numpy as np

import tumble

b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
box = b.add_body("box", pos=(0.0, 0.0, 2.0), density=600.0)
b.add_geom(box, "box", size=(0.2, 0.1, 0.3))
world = tumble.World(b.build(), dt=1.0 / 240.0)

# A 200 N shove for 0.1 s at the top front corner: it translates and starts to spin.
corner = world.body_to_world("box", (0.2, 0.0, 0.3))
world.apply_force("box", (0.0, 200.0, 0.0), point=corner)
world.step(24)

for _ in range(5):
    world.step(24)
    ke, pe = world.energy()
    print(f"t={world.time:4.2f} s  height={world.body_pos[0, 2]:5.3f} m  "
          f"spin={np.linalg.norm(world.body_angvel[0]):5.2f} rad/s  "
          f"energy={ke + pe:8.3f} J  |L|={np.linalg.norm(world.angular_momentum(world.body_pos[0])):.4f}")
