"""The benchmark scenes of bench/scenes.py built in tumble, from the same numbers.

    model = tumble_scenes.build("pyramid")          # a tumble Model; its timestep is the scene's
    world = tumble.World(model)                      # dt = model.timestep
    world.step(tumble_scenes.steps("pyramid"))

Conventions are those of scenes.py: z up, every body starts with the identity orientation,
masses (kg) and inertias (kg m^2, diagonal in the body frame) are given explicitly, so the
geoms only collide and never set mass. Every geom has friction 0.9 and restitution 0; tumble
combines a pair's coefficients by taking the larger, so every pair sees 0.9 (Bullet multiplies
them, which is why its runner uses sqrt(0.9)). No damping anywhere.

Scenes with contacts (all but the chain) need tumble's contact pipeline; without it their
bodies fall through the floor.

The ragdoll PD scenes hold the pose with :class:`ExplicitPD`: torques computed in NumPy
from ``world.joint_q`` / ``joint_qd`` and applied with ``world.apply_torque`` before every
single ``step()``, the route the peers' runners take too. It is the slow route (a Python
round trip per step, explicit in the damping, so it diverges once kd dt / I > 2 on the light
hands); an in-step, implicit actuator is planned and will replace it.
"""
import math

import numpy as np

import tumble

from . import common as C
from . import scenes as S

# (x, y, z, w): a quarter turn about y, taking the capsule axis (local z) onto world x
Z_TO_X = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))
NO_COLLISION = dict(contype=0, conaffinity=0)


def _builder(dt):
    return tumble.ModelBuilder(gravity=(0.0, 0.0, S.GRAVITY), timestep=dt)


def _ground(b, **bits):
    b.add_geom(None, "plane", friction=S.FRICTION, name="ground", **bits)


# ------------------------------------------------------------------------- chain ---

def chain():
    """30 capsules on ball joints, pinned at one end, released horizontal; no contacts
    (the geoms are there for completeness and collide with nothing, as in the peers)."""
    c = S.CHAIN
    b = _builder(c["dt"])
    for i, ln in enumerate(S.chain_links()):
        body = b.add_body("l%d" % i, pos=ln["com"], mass=ln["mass"], inertia=ln["inertia"])
        b.add_geom(body, "capsule", radius=c["radius"], half_length=c["length"] / 2, quat=Z_TO_X,
                   friction=S.FRICTION, **NO_COLLISION)
        parent = None if i == 0 else "l%d" % (i - 1)            # link 0 hangs from the world
        b.add_joint("j%d" % i, "ball", parent, body, anchor=ln["joint"])
    return b.build()


# ---------------------------------------------------------------- stack, pyramid ---

def boxes(cfg, positions):
    """Unit-mass cubes of half side cfg['half'] at ``positions`` on a ground plane."""
    b = _builder(cfg["dt"])
    _ground(b)
    h, mass = cfg["half"], cfg["mass"]
    inertia = S.box_inertia(mass, h, h, h)
    for i, p in enumerate(positions):
        body = b.add_body("b%d" % i, pos=p, mass=mass, inertia=inertia)
        b.add_geom(body, "box", size=(h, h, h), friction=S.FRICTION)
    return b.build()


def stack():
    """10 unit boxes stacked on a plane."""
    return boxes(S.STACK, S.stack_positions())


def pyramid():
    """210 boxes, base row 20, in the x-z plane."""
    return boxes(S.PYRAMID, S.pyramid_positions())


# ------------------------------------------------------------------------ ragdoll ---

def ragdoll(hz):
    """The 15-body ragdoll dropped from 1 m, stepped at ``hz``.

    Bodies are named after the parts and each joint after its child part. The pelvis has no
    joint: a body without joints is free (a 'free' joint would add nothing, and by default
    it would also switch off the pelvis's contacts with the world's ground plane). Contacts
    between joined parts are off twice over: add_joint excludes the pair, and the ODE-style
    masks of scenes.ragdoll_collision_masks (MuJoCo's contype/conaffinity semantics) say so.
    """
    parts = S.ragdoll_parts()
    masks, (gcat, gcol) = S.ragdoll_collision_masks(parts)
    b = _builder(1.0 / hz)
    _ground(b, contype=gcat, conaffinity=gcol)
    for p, (cat, col) in zip(parts, masks):
        body = b.add_body(p["name"], pos=p["com"], mass=p["mass"], inertia=p["inertia"])
        if p["shape"] == "box":
            b.add_geom(body, "box", size=p["half"], friction=S.FRICTION,
                       contype=cat, conaffinity=col)
        else:
            b.add_geom(body, "capsule", radius=p["radius"], half_length=p["length"] / 2,
                       friction=S.FRICTION, contype=cat, conaffinity=col)
        if p["parent"] is not None:
            b.add_joint(p["name"], p["jtype"], p["parent"], body, anchor=p["joint"], axis=p["axis"])
    return b.build()


def _quat_mul(a, b):
    """Hamilton products of (n, 4) quaternions (x, y, z, w)."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], -1)


def _quat_rotate(q, v):
    """Rotate (n, 3) vectors by (n, 4) unit quaternions (x, y, z, w)."""
    u, w = q[:, :3], q[:, 3:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


class ExplicitPD:
    """PD torques towards the initial pose, recomputed in NumPy before every step.

    For joint j with gains (kp N m/rad, kd N m s/rad), in its parent's joint frame:
    ``tau = -kp q - kd qd``, where q is the ball joint's rotation vector or the hinge angle
    and qd the relative angular velocity along the same axes (``world.joint_q``,
    ``joint_qd``). The torque acts +tau on the child and -tau on the parent (world frame).

    gains : {joint name: (kp, kd)}, e.g. ``scenes.ragdoll_pd_gains(parts, "spec")``.
    """

    def __init__(self, world, gains):
        m = world.model
        if np.any(m.joint_parent < 0):
            raise ValueError("ExplicitPD: every joint needs a parent body")
        self.world = world
        kp_kd = np.array([gains[name] for name in m.joint_names], float)
        self.kp, self.kd = kp_kd[:, :1], kp_kd[:, 1:]
        self.parent, self.child = np.asarray(m.joint_parent), np.asarray(m.joint_child)
        self.frame_a = np.asarray(m.joint_frame_a)   # joint frame in the parent's principal frame
        self.bodies = np.union1d(self.parent, self.child)
        self.torque = np.zeros((m.nbody, 3))

    def apply(self):
        """Apply this step's torques (they act through the next ``world.step`` call only)."""
        w = self.world
        # joint_q / joint_qd are zero past each joint's degrees of freedom, so one formula
        # covers ball (3 axes) and hinge (the frame's x axis) joints.
        tau_joint = -self.kp * w.joint_q - self.kd * w.joint_qd
        frame = _quat_mul(w.body_quat[self.parent], self.frame_a)
        tau = _quat_rotate(frame, tau_joint)
        self.torque[:] = 0.0
        np.add.at(self.torque, self.child, tau)
        np.add.at(self.torque, self.parent, -tau)
        for body in self.bodies:
            w.apply_torque(int(body), self.torque[body])


def joint_error(world):
    """Largest deviation (rad) of any joint from the initial pose: ball rotation angle or
    hinge angle (a row of ``joint_q`` is a ball's rotation vector or (angle, 0, 0))."""
    return C.joint_error(world.joint_q, [])


# ------------------------------------------------------------------------ spheres ---

def spheres():
    """1000 spheres poured into a 4 x 4 m box of four static walls on a ground plane."""
    cfg = S.SPHERES
    b = _builder(cfg["dt"])
    _ground(b)
    for i, (center, half) in enumerate(S.sphere_walls()):
        b.add_geom(None, "box", size=half, pos=center, friction=S.FRICTION, name="wall%d" % i)
    r, mass = cfg["radius"], cfg["mass"]
    inertia = S.sphere_inertia(mass, r)
    for i, p in enumerate(S.sphere_positions()):
        body = b.add_body("s%d" % i, pos=p, mass=mass, inertia=inertia)
        b.add_geom(body, "sphere", radius=r, friction=S.FRICTION)
    return b.build()


# ------------------------------------------------------------------------- lookup ---

def build(scene):
    """The tumble Model of any scene name of ``common.SCENES`` (ragdoll variants share one
    model per rate; their PD mode is ``common.ragdoll_mode(scene)[1]``)."""
    if scene.startswith("ragdoll"):
        return ragdoll(C.ragdoll_mode(scene)[0])
    return {"chain": chain, "stack": stack, "pyramid": pyramid, "spheres": spheres}[scene]()


def steps(scene):
    """Number of steps the scene runs."""
    if scene.startswith("ragdoll"):
        return int(round(S.RAGDOLL["duration"] * C.ragdoll_mode(scene)[0]))
    cfg = {"chain": S.CHAIN, "stack": S.STACK, "pyramid": S.PYRAMID, "spheres": S.SPHERES}
    return cfg[scene]["steps"]
