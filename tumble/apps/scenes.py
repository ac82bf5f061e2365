"""Built-in demo scenes for ``tumble view NAME`` and ``tumble export NAME``.

Each builder returns a ready :class:`tumble.World` (z up, SI units):

* ``ragdoll`` : an 18-body ragdoll (boxes, capsules and a sphere; ball and hinge joints
  with limits) toppling from standing over a low crate, beside a taller one.
* ``stack``   : a tower of eight boxes knocked over by a heavy ball.
* ``chain``   : a hanging chain of twelve capsules on ball joints, released sideways.
* ``racket``  : the tennis-racket flip (a free box spun about its middle axis, no gravity).
"""
import numpy as np

import tumble

from . import racket

# quarter turn about y: a capsule's axis (local z) onto world x
_Z_TO_X = (0.0, np.sin(np.pi / 4), 0.0, np.cos(np.pi / 4))


def _limb(b, name, parent, top, bottom, radius, density, joint, axis=None, limit=None,
          friction=0.0):
    """A capsule body from world point ``top`` to ``bottom`` (its ends' centres), jointed to
    ``parent`` at ``top``."""
    top, bottom = np.asarray(top, float), np.asarray(bottom, float)
    body = b.add_body(name, pos=0.5 * (top + bottom), density=density)
    half = 0.5 * np.linalg.norm(top - bottom) - radius
    d = (top - bottom) / np.linalg.norm(top - bottom)
    # rotate local z onto d
    c = d[2]
    if c < -1 + 1e-9:
        q = (1.0, 0.0, 0.0, 0.0)
    else:
        ax = np.cross((0.0, 0.0, 1.0), d)
        q = tuple(np.append(ax, 1 + c) / np.linalg.norm(np.append(ax, 1 + c)))
    b.add_geom(body, "capsule", radius=radius, half_length=max(half, 1e-3), quat=q,
               friction=0.9)
    b.add_joint(name, joint, parent, body, anchor=top, axis=axis, limit=limit, damping=0.5,
                friction=friction)
    return body


def ragdoll(dt=1.0 / 240.0, contact="pgs", lean=0.15, stiffness=1.0):
    """An 18-body ragdoll standing on the ground, leaning forward by ``lean`` rad so it
    falls; its contacts are solved by ``contact``. Dry joint friction (scaled by
    ``stiffness``; 0 gives a limp doll that folds up where it stands) keeps the legs and
    spine straight until the impact."""
    fr = float(stiffness)
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81), timestep=dt)
    b.add_geom(None, "plane", friction=0.9, name="ground")
    dens = 1000.0
    Y, X = (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)
    pelvis = b.add_body("pelvis", pos=(0, 0, 1.0), density=dens)
    b.add_geom(pelvis, "box", size=(0.09, 0.15, 0.07), friction=0.9)
    abdomen = b.add_body("abdomen", pos=(0, 0, 1.16), density=dens)
    b.add_geom(abdomen, "box", size=(0.08, 0.13, 0.07), friction=0.9)
    b.add_joint("abdomen", "ball", pelvis, abdomen, anchor=(0, 0, 1.08), damping=1.0,
                friction=60.0 * fr)
    chest = b.add_body("chest", pos=(0, 0, 1.36), density=dens)
    b.add_geom(chest, "box", size=(0.10, 0.17, 0.12), friction=0.9)
    b.add_joint("chest", "ball", abdomen, chest, anchor=(0, 0, 1.24), damping=1.0,
                friction=60.0 * fr)
    head = b.add_body("head", pos=(0, 0, 1.64), density=dens)
    b.add_geom(head, "sphere", radius=0.10, friction=0.9)
    b.add_joint("neck", "ball", chest, head, anchor=(0, 0, 1.50), damping=0.5,
                friction=8.0 * fr)
    for side, s in (("l", 1.0), ("r", -1.0)):
        y = 0.23 * s
        _limb(b, f"upper_arm_{side}", chest, (0, y, 1.44), (0, y, 1.18), 0.045, dens, "ball",
              friction=4.0 * fr)
        _limb(b, f"forearm_{side}", f"upper_arm_{side}", (0, y, 1.18), (0, y, 0.94), 0.04,
              dens, "hinge", axis=Y, limit=(-2.5, 0.0), friction=2.0 * fr)
        hand = b.add_body(f"hand_{side}", pos=(0, y, 0.86), density=dens)
        b.add_geom(hand, "box", size=(0.04, 0.02, 0.06), friction=0.9)
        b.add_joint(f"wrist_{side}", "hinge", f"forearm_{side}", hand, anchor=(0, y, 0.92),
                    axis=X, limit=(-0.8, 0.8), damping=0.2)
    for side, s in (("l", 1.0), ("r", -1.0)):
        y = 0.09 * s
        _limb(b, f"thigh_{side}", pelvis, (0, y, 0.93), (0, y, 0.52), 0.065, dens, "ball",
              friction=80.0 * fr)
        _limb(b, f"shin_{side}", f"thigh_{side}", (0, y, 0.52), (0, y, 0.10), 0.05, dens,
              "hinge", axis=Y, limit=(0.0, 2.6), friction=80.0 * fr)
        foot = b.add_body(f"foot_{side}", pos=(0.05, y, 0.035), density=dens)
        b.add_geom(foot, "box", size=(0.09, 0.045, 0.03), friction=0.9)
        b.add_joint(f"ankle_{side}", "hinge", f"shin_{side}", foot, anchor=(0, y, 0.07),
                    axis=Y, limit=(-0.8, 0.8), damping=0.5)
        toe = b.add_body(f"toes_{side}", pos=(0.175, y, 0.02), density=dens)
        b.add_geom(toe, "box", size=(0.035, 0.04, 0.018), friction=0.9)
        b.add_joint(f"toes_{side}", "hinge", foot, toe, anchor=(0.14, y, 0.02), axis=Y,
                    limit=(-0.6, 0.6), damping=0.2)
    # a low crate in the way of the fall and a taller one beside it
    for i, (centre, half) in enumerate((((1.05, 0.1), (0.25, 0.3, 0.14)),
                                        ((0.55, 0.75), (0.2, 0.2, 0.25)))):
        crate = b.add_body(f"crate{i}", pos=(*centre, half[2]), density=300.0)
        b.add_geom(crate, "box", size=half, friction=0.9)
    world = tumble.World(b.build(), dt=dt, contact=contact)
    # lean the whole figure forward about the toes so it topples
    from scipy.spatial.transform import Rotation
    rot = Rotation.from_rotvec((0.0, lean, 0.0))
    pivot = np.array([0.2, 0.0, 0.0])
    figure = np.array([not n.startswith("crate") for n in world.model.body_names])
    world.body_pos[figure] = rot.apply(world.body_pos[figure] - pivot) + pivot
    world.body_quat[figure] = (rot * Rotation.from_quat(world.body_quat[figure])).as_quat()
    # and set it turning about the toes as one rigid piece (v = w x r, so no joint is jerked)
    w = np.array([0.0, 0.4, 0.0])
    world.body_angvel[figure] = w
    world.body_vel[figure] = np.cross(w, world.body_pos[figure] - pivot)
    return world


def stack(dt=1.0 / 240.0, contact="pgs"):
    """Eight boxes stacked on the ground and a heavy ball rolling into them."""
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81), timestep=dt)
    b.add_geom(None, "plane", friction=0.8, name="ground")
    h = 0.15
    for i in range(8):
        box = b.add_body(f"box{i}", pos=(0.0, 0.02 * (i % 2), h + 2 * h * i), density=400.0)
        b.add_geom(box, "box", size=(h, h, h), friction=0.8)
    ball = b.add_body("ball", pos=(-2.0, 0.0, 0.45), density=2000.0, vel=(4.5, 0.0, 0.0))
    b.add_geom(ball, "sphere", radius=0.25, friction=0.8)
    return tumble.World(b.build(), dt=dt, contact=contact)


def chain(dt=1.0 / 240.0, links=12):
    """A chain of ``links`` capsules hanging from a fixed point, released horizontal."""
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81), timestep=dt)
    b.add_geom(None, "plane", name="ground")
    length, r = 0.2, 0.03
    parent = None
    for i in range(links):
        body = b.add_body(f"link{i}", pos=((i + 0.5) * length, 0.0, 2.8), density=800.0)
        b.add_geom(body, "capsule", radius=r, half_length=length / 2 - r, quat=_Z_TO_X,
                   contype=0, conaffinity=0)
        b.add_joint(f"j{i}", "ball", parent, body, anchor=(i * length, 0.0, 2.8))
        parent = body
    return tumble.World(b.build(), dt=dt)


DEMOS = {
    "ragdoll": ragdoll,
    "stack": stack,
    "chain": chain,
    "racket": lambda: racket.build(),
}


def build(name):
    """The world of demo ``name`` (one of ``DEMOS``); ModelError for an unknown name."""
    if name not in DEMOS:
        raise tumble.ModelError(f"unknown demo {name!r}; the demos are {sorted(DEMOS)}")
    return DEMOS[name]()
