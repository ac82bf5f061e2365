"""The benchmark scenes: the same scenes the published benchmark runs, in tumble.

Five scenes, each given by a dict of numbers (the specification) and built here as a tumble
:class:`~tumble.Model`:

* ``chain``   (:data:`CHAIN`)   : 30 capsules on ball joints pinned at one end, released
  horizontal; no contacts. Tests joint drift and energy.
* ``stack``   (:data:`STACK`)   : 10 unit boxes stacked on a ground plane. Tests resting contact.
* ``pyramid`` (:data:`PYRAMID`) : 210 boxes in a 2-D pyramid, base row 20. Tests many contacts.
* ``ragdoll`` (:data:`RAGDOLL`) : a 15-body ragdoll (boxes and capsules; ball and hinge joints)
  dropped from 1 m, passive or held in its pose by PD torques, at 600 or 1920 Hz.
* ``spheres`` (:data:`SPHERES`) : 1000 spheres poured into a walled 4 x 4 m box.

The scene names the benchmark runs are :data:`SCENES` (the ragdoll's variants are named by
rate and PD mode, see :func:`ragdoll_mode`); :func:`build` and :func:`steps` take any of them::

    model = benchmarks.build("pyramid")             # its timestep is the scene's dt
    world = tumble.World(model, contact="pgs")
    world.step(benchmarks.steps("pyramid"))

The specifications and their geometry helpers (``chain_links``, ``stack_positions``,
``pyramid_positions``, ``ragdoll_parts``, ``sphere_positions``, ``sphere_walls``, the inertia
helpers, ...) use NumPy only. ``bench/scenes.py`` re-exports them, and ``bench/`` and the peer
engines' runners (MuJoCo, PyBullet, ODE in ``bench/peers/``) build their scenes from these same
numbers, so masses, sizes, inertias, initial poses, time steps and step counts are the same in
every engine.

Conventions (SI units):

* z is up, gravity is (0, 0, :data:`GRAVITY`) m/s^2;
* every body starts with the identity orientation (body frame parallel to the world frame), so
  the inertia tensors are diagonal in the body frame;
* masses (kg) and inertias (kg m^2, about the centre of mass) are given explicitly, as solid
  uniform-density shapes, and every engine is told them rather than deriving its own; the
  geoms here only collide and never set mass;
* friction coefficient :data:`FRICTION` for every geom, restitution 0, no damping of any kind.
  tumble combines a pair's coefficients by taking the larger, so every pair sees 0.9 (Bullet
  multiplies them, which is why its runner uses sqrt(0.9)).

Every scene but the chain needs tumble's contact pipeline; without it the bodies fall through
the floor.
"""
import math

import numpy as np

import tumble

GRAVITY = -9.81
"""Gravity along z, m/s^2."""
FRICTION = 0.9
"""Friction coefficient of every geom."""

SCENES = ["chain", "stack", "pyramid",
          "ragdoll600", "ragdoll600pd", "ragdoll600pds",
          "ragdoll1920", "ragdoll1920pd", "ragdoll1920pds",
          "spheres"]
"""The scene names the benchmark runs (every engine runner accepts these)."""


# ------------------------------------------------------------------------ inertia ---

def capsule_inertia(mass, radius, length):
    """Solid capsule of ``mass`` kg with its axis along local z: radius ``radius`` m and a
    cylinder part ``length`` m long (between the caps' centres).

    Returns (I_axial, I_transverse) in kg m^2 about the centre of mass."""
    r, h = radius, length
    v_cyl = math.pi * r * r * h
    v_sph = 4.0 / 3.0 * math.pi * r ** 3
    m_cyl = mass * v_cyl / (v_cyl + v_sph)
    m_sph = mass * v_sph / (v_cyl + v_sph)
    i_ax = m_cyl * r * r / 2.0 + m_sph * 2.0 * r * r / 5.0
    i_tr = (m_cyl * (h * h / 12.0 + r * r / 4.0)
            + m_sph * (2.0 * r * r / 5.0 + h * h / 4.0 + 3.0 * h * r / 8.0))
    return i_ax, i_tr


def box_inertia(mass, hx, hy, hz):
    """Solid box of ``mass`` kg and half extents (hx, hy, hz) m.

    Returns (Ixx, Iyy, Izz) in kg m^2 about the centre of mass."""
    return (mass * (hy * hy + hz * hz) / 3.0,
            mass * (hx * hx + hz * hz) / 3.0,
            mass * (hx * hx + hy * hy) / 3.0)


def sphere_inertia(mass, radius):
    """Solid sphere of ``mass`` kg and ``radius`` m. Returns (I, I, I) in kg m^2."""
    i = 2.0 / 5.0 * mass * radius * radius
    return (i, i, i)


# -------------------------------------------------------------------- chain (S1) ---

CHAIN = dict(n=30, radius=0.05, length=0.3, mass=1.0, dt=1.0 / 240.0, steps=2000,
             anchor=(0.0, 0.0, 5.0))
"""n links; capsule radius (m) and cylinder length (m); mass per link (kg); time step (s);
steps; the world point (m) link 0 hangs from."""


def chain_links():
    """The chain's links, released from rest lying along +x from ``CHAIN['anchor']``.

    Link i's cylinder part spans x in [i L, (i+1) L] (the caps overhang the joint points,
    which is harmless as the chain has no contacts). Joint i is at the start of link i;
    joint 0 ties link 0 to the world.

    Returns a list of n dicts: ``com`` (3,) m, ``joint`` (3,) m (the joint to the parent, the
    world for link 0), ``mass`` kg, ``inertia`` (3,) kg m^2 (the capsule's axis is world x).
    """
    c = CHAIN
    length = c["length"]
    ax, ay, az = c["anchor"]
    i_ax, i_tr = capsule_inertia(c["mass"], c["radius"], length)
    return [dict(com=(ax + (i + 0.5) * length, ay, az),
                 joint=(ax + i * length, ay, az),
                 mass=c["mass"],
                 inertia=(i_ax, i_tr, i_tr))
            for i in range(c["n"])]


def chain_energy_scale():
    """M g L_total / 2 (J): the potential energy the chain releases between its horizontal
    start and hanging straight down. Energy drift is reported as a fraction of it."""
    c = CHAIN
    return c["n"] * c["mass"] * abs(GRAVITY) * c["n"] * c["length"] / 2.0


# -------------------------------------------------------------------- stack (S2) ---

STACK = dict(n=10, half=0.5, mass=1.0, dt=1.0 / 240.0, steps=2000)
"""n boxes; half side (m); mass per box (kg); time step (s); steps."""


def stack_positions():
    """Centres (m) of the stacked boxes, bottom first: a list of n (x, y, z)."""
    h = STACK["half"]
    return [(0.0, 0.0, h + 2.0 * h * i) for i in range(STACK["n"])]


# ------------------------------------------------------------------ pyramid (S3) ---

PYRAMID = dict(base=20, half=0.5, mass=1.0, gap=0.05, dt=1.0 / 60.0, steps=600)
"""Boxes in the base row (20 + 19 + ... + 1 = 210 boxes); half side (m); mass per box (kg);
gap (m) between neighbours in a row; time step (s); steps."""


def pyramid_positions():
    """Centres (m) of the pyramid's boxes, row by row from the bottom: a list of (x, y, z).

    The pyramid stands in the x-z plane. Boxes in a row are ``gap`` apart, so their side
    faces start out of contact; rows rest exactly on each other."""
    p = PYRAMID
    h = p["half"]
    pitch = 2.0 * h + p["gap"]
    out = []
    for row in range(p["base"]):
        n = p["base"] - row
        x0 = -0.5 * (n - 1) * pitch
        out.extend((x0 + k * pitch, 0.0, h + 2.0 * h * row) for k in range(n))
    return out


# ------------------------------------------------------------------ ragdoll (S4) ---

RAGDOLL = dict(dt=1.0 / 600.0, dt_fine=1.0 / 1920.0, duration=3.0, drop=1.0, kp=300.0, kd=30.0)
"""Time steps (s) of the two rates; simulated duration (s); height (m) of the lowest point
above the ground at the start; PD gains kp (N m/rad) and kd (N m s/rad)."""


def ragdoll_mode(scene):
    """Step rate (Hz) and PD gain mode of a ragdoll scene name.

    'ragdoll1920' -> (1920, None) (passive); 'ragdoll600pd' -> (600, 'spec');
    'ragdoll600pds' -> (600, 'scaled'). The mode is that of :func:`ragdoll_pd_gains`."""
    rest = scene[len("ragdoll"):]
    if rest.endswith("pds"):
        return int(rest[:-3]), "scaled"
    if rest.endswith("pd"):
        return int(rest[:-2]), "spec"
    return int(rest), None


def _capsule_part(name, parent, joint, jtype, axis, p0, p1, radius, mass):
    """A vertical capsule whose outer ends are at p0 (bottom) and p1 (top); its cylinder part
    is |p1 - p0| - 2 radius long."""
    x, y, z0 = p0
    z1 = p1[2]
    length = (z1 - z0) - 2.0 * radius
    i_ax, i_tr = capsule_inertia(mass, radius, length)
    return dict(name=name, parent=parent, joint=joint, jtype=jtype, axis=axis,
                shape="capsule", radius=radius, length=length,
                com=(x, y, 0.5 * (z0 + z1)), mass=mass, inertia=(i_tr, i_tr, i_ax))


def _box_part(name, parent, joint, jtype, axis, center, half, mass):
    """A box of half extents ``half`` centred at ``center``."""
    return dict(name=name, parent=parent, joint=joint, jtype=jtype, axis=axis,
                shape="box", half=tuple(half), com=tuple(center), mass=mass,
                inertia=box_inertia(mass, *half))


def ragdoll_parts():
    """The ragdoll's 15 bodies and 14 joints, parents first: standing, arms hanging, feet
    pointing +x, lifted so that its lowest point is ``RAGDOLL['drop']`` above the ground.

    Ball joints: waist, neck, shoulders, wrists, hips. Hinge joints (axis y): elbows, knees,
    ankles. The pelvis is the free root.

    Returns a list of dicts: ``name``; ``parent`` (a part's name, None for the pelvis);
    ``joint`` (3,) m, the joint point to the parent (None for the pelvis); ``jtype`` 'free',
    'ball' or 'hinge'; ``axis`` (3,) of a hinge (else None); ``shape`` 'box' (with ``half``
    (3,) m) or 'capsule' along z (with ``radius`` m and cylinder ``length`` m); ``com`` (3,) m;
    ``mass`` kg; ``inertia`` (3,) kg m^2.
    """
    Y = (0.0, 1.0, 0.0)
    parts = [
        _box_part("pelvis", None, None, "free", None, (0.0, 0.0, 0.97), (0.10, 0.15, 0.08), 8.0),
        _box_part("torso", "pelvis", (0.0, 0.0, 1.05), "ball", None,
                  (0.0, 0.0, 1.30), (0.10, 0.17, 0.25), 20.0),
        _capsule_part("head", "torso", (0.0, 0.0, 1.55), "ball", None,
                      (0.0, 0.0, 1.57), (0.0, 0.0, 1.85), 0.10, 5.0),
    ]
    for side, s in (("l", 1.0), ("r", -1.0)):
        y = 0.22 * s
        parts += [
            _capsule_part("upper_arm_" + side, "torso", (0.0, y, 1.50), "ball", None,
                          (0.0, y, 1.20), (0.0, y, 1.50), 0.045, 2.0),
            _capsule_part("lower_arm_" + side, "upper_arm_" + side, (0.0, y, 1.20), "hinge", Y,
                          (0.0, y, 0.95), (0.0, y, 1.20), 0.04, 1.5),
            _box_part("hand_" + side, "lower_arm_" + side, (0.0, y, 0.95), "ball", None,
                      (0.0, y, 0.865), (0.04, 0.02, 0.075), 0.5),
        ]
    for side, s in (("l", 1.0), ("r", -1.0)):
        y = 0.10 * s
        parts += [
            _capsule_part("thigh_" + side, "pelvis", (0.0, y, 0.92), "ball", None,
                          (0.0, y, 0.50), (0.0, y, 0.92), 0.06, 7.0),
            _capsule_part("shin_" + side, "thigh_" + side, (0.0, y, 0.50), "hinge", Y,
                          (0.0, y, 0.08), (0.0, y, 0.50), 0.05, 4.0),
            _box_part("foot_" + side, "shin_" + side, (0.0, y, 0.08), "hinge", Y,
                      (0.04, y, 0.03), (0.11, 0.045, 0.03), 1.0),
        ]
    lift = RAGDOLL["drop"]                # the feet's bottoms are at z = 0 in the pose above
    for p in parts:
        p["com"] = (p["com"][0], p["com"][1], p["com"][2] + lift)
        if p["joint"] is not None:
            p["joint"] = (p["joint"][0], p["joint"][1], p["joint"][2] + lift)
    return parts


def ragdoll_collision_masks(parts):
    """Category / collide bit masks (ODE-style; MuJoCo's contype / conaffinity) that switch
    off contacts between bodies joined by a joint and keep every other pair, and contacts with
    the ground (bit 30). Two geoms collide iff (catA & colB) or (catB & colA).

    parts : the list of :func:`ragdoll_parts`.
    Returns (a list of (cat, col) per part, the ground's (cat, col)).
    """
    index = {p["name"]: i for i, p in enumerate(parts)}
    ground_bit = 1 << 30
    all_parts = (1 << len(parts)) - 1
    masks = []
    for i, p in enumerate(parts):
        excluded = 1 << i
        if p["parent"] is not None:
            excluded |= 1 << index[p["parent"]]
        for j, q in enumerate(parts):
            if q["parent"] == p["name"]:
                excluded |= 1 << j
        masks.append((1 << i, (all_parts & ~excluded) | ground_bit))
    return masks, (ground_bit, all_parts)


def ragdoll_pd_gains(parts, mode):
    """PD gains (kp N m/rad, kd N m s/rad) of every joint: {child part's name: (kp, kd)}.

    mode 'spec'   : ``RAGDOLL['kp']``, ``RAGDOLL['kd']`` (300, 30) everywhere, the gains asked for.
    mode 'scaled' : the same ratio kp / kd = 10, with kd capped at 0.5 I_j / dt (dt of 600 Hz),
                    I_j the child body's smallest moment of inertia about the joint point
                    (about the axis for hinges). This keeps explicit (outside the step) PD
                    torques stable on the light distal links at 600 Hz; the work per step is
                    the same as for 'spec'.
    """
    out = {}
    dt = RAGDOLL["dt"]
    for p in parts:
        if p["parent"] is None:
            continue
        if mode == "spec":
            out[p["name"]] = (RAGDOLL["kp"], RAGDOLL["kd"])
            continue
        d = np.array(p["com"]) - np.array(p["joint"])
        inertia = np.diag(p["inertia"]) + p["mass"] * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
        if p["jtype"] == "hinge":
            a = np.array(p["axis"], float)
            i_joint = float(a @ inertia @ a)
        else:
            i_joint = float(np.min(np.linalg.eigvalsh(inertia)))
        kd = min(RAGDOLL["kd"], 0.5 * i_joint / dt)
        out[p["name"]] = (kd * RAGDOLL["kp"] / RAGDOLL["kd"], kd)
    return out


def ragdoll_adjacent_pairs(parts):
    """(parent index, child index) of every joint, indices into ``parts``."""
    index = {p["name"]: i for i, p in enumerate(parts)}
    return [(index[p["parent"]], i) for i, p in enumerate(parts) if p["parent"] is not None]


# ------------------------------------------------------------------ spheres (S5) ---

SPHERES = dict(n=1000, radius=0.1, mass=1.0, inner=4.0, wall_height=4.0, wall_thickness=0.2,
               dt=1.0 / 240.0, steps=1000, seed=12345)
"""n spheres; radius (m); mass per sphere (kg); inner side (m) of the walled box; wall height
and thickness (m); time step (s); steps; seed of the initial jitter."""


def sphere_positions():
    """Centres (m) of the spheres: a list of 1000 (x, y, z) on a 10 x 10 x 10 grid of pitch
    0.3 m centred over the box, the lowest layer at z = 0.5, with a fixed-seed jitter of up to
    2 cm in x and y."""
    rng = np.random.default_rng(SPHERES["seed"])
    pitch = 0.3
    out = []
    for k in range(10):
        for j in range(10):
            for i in range(10):
                jx, jy = rng.uniform(-0.02, 0.02, size=2)
                out.append(((i - 4.5) * pitch + jx, (j - 4.5) * pitch + jy, 0.5 + k * pitch))
    return out


def sphere_walls():
    """The box's four walls as static boxes: a list of (center (3,) m, half extents (3,) m)."""
    s = SPHERES
    a = s["inner"] / 2.0
    t = s["wall_thickness"] / 2.0
    h = s["wall_height"] / 2.0
    return [((a + t, 0.0, h), (t, a + 2 * t, h)),
            ((-a - t, 0.0, h), (t, a + 2 * t, h)),
            ((0.0, a + t, h), (a, t, h)),
            ((0.0, -a - t, h), (a, t, h))]


# --------------------------------------------------------------- tumble builders ---

# (x, y, z, w): a quarter turn about y, taking a capsule's axis (local z) onto world x
_Z_TO_X = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))
_NO_COLLISION = dict(contype=0, conaffinity=0)


def _builder(dt):
    return tumble.ModelBuilder(gravity=(0.0, 0.0, GRAVITY), timestep=dt)


def _ground(b, **bits):
    b.add_geom(None, "plane", friction=FRICTION, name="ground", **bits)


def chain():
    """The chain as a tumble Model: bodies ``l0`` .. ``l29``, ball joints ``j0`` .. ``j29``
    (``j0`` to the world). Its geoms collide with nothing, as in the peers."""
    c = CHAIN
    b = _builder(c["dt"])
    for i, link in enumerate(chain_links()):
        body = b.add_body("l%d" % i, pos=link["com"], mass=link["mass"], inertia=link["inertia"])
        b.add_geom(body, "capsule", radius=c["radius"], half_length=c["length"] / 2,
                   quat=_Z_TO_X, friction=FRICTION, **_NO_COLLISION)
        parent = None if i == 0 else "l%d" % (i - 1)
        b.add_joint("j%d" % i, "ball", parent, body, anchor=link["joint"])
    return b.build()


def _boxes(cfg, positions):
    """Free cubes (half side ``cfg['half']``, mass ``cfg['mass']``) ``b0``, ``b1``, ... at
    ``positions`` on a ground plane, stepped at ``cfg['dt']``."""
    b = _builder(cfg["dt"])
    _ground(b)
    h, mass = cfg["half"], cfg["mass"]
    inertia = box_inertia(mass, h, h, h)
    for i, p in enumerate(positions):
        body = b.add_body("b%d" % i, pos=p, mass=mass, inertia=inertia)
        b.add_geom(body, "box", size=(h, h, h), friction=FRICTION)
    return b.build()


def stack():
    """The stack as a tumble Model: boxes ``b0`` (bottom) .. ``b9`` on a ground plane."""
    return _boxes(STACK, stack_positions())


def pyramid():
    """The pyramid as a tumble Model: boxes ``b0`` .. ``b209`` (bottom row first)."""
    return _boxes(PYRAMID, pyramid_positions())


def ragdoll(hz):
    """The ragdoll as a tumble Model stepped at ``hz`` (its timestep is 1 / hz s).

    Bodies are named after the parts and each joint after its child part. The pelvis has no
    joint: a body without joints is free (a 'free' joint would add nothing, and by default it
    would also switch off the pelvis's contacts with the ground plane). Contacts between
    joined parts are off twice over: add_joint excludes the pair, and so do the masks of
    :func:`ragdoll_collision_masks`.
    """
    parts = ragdoll_parts()
    masks, (ground_cat, ground_col) = ragdoll_collision_masks(parts)
    b = _builder(1.0 / hz)
    _ground(b, contype=ground_cat, conaffinity=ground_col)
    for p, (cat, col) in zip(parts, masks):
        body = b.add_body(p["name"], pos=p["com"], mass=p["mass"], inertia=p["inertia"])
        if p["shape"] == "box":
            b.add_geom(body, "box", size=p["half"], friction=FRICTION,
                       contype=cat, conaffinity=col)
        else:
            b.add_geom(body, "capsule", radius=p["radius"], half_length=p["length"] / 2,
                       friction=FRICTION, contype=cat, conaffinity=col)
        if p["parent"] is not None:
            b.add_joint(p["name"], p["jtype"], p["parent"], body, anchor=p["joint"],
                        axis=p["axis"])
    return b.build()


def spheres():
    """The spheres as a tumble Model: spheres ``s0`` .. ``s999`` and static walls ``wall0`` ..
    ``wall3`` on a ground plane."""
    cfg = SPHERES
    b = _builder(cfg["dt"])
    _ground(b)
    for i, (center, half) in enumerate(sphere_walls()):
        b.add_geom(None, "box", size=half, pos=center, friction=FRICTION, name="wall%d" % i)
    r, mass = cfg["radius"], cfg["mass"]
    inertia = sphere_inertia(mass, r)
    for i, p in enumerate(sphere_positions()):
        body = b.add_body("s%d" % i, pos=p, mass=mass, inertia=inertia)
        b.add_geom(body, "sphere", radius=r, friction=FRICTION)
    return b.build()


_BUILDERS = {"chain": (chain, CHAIN), "stack": (stack, STACK), "pyramid": (pyramid, PYRAMID),
             "spheres": (spheres, SPHERES)}


def build(scene):
    """The tumble Model of a scene name of :data:`SCENES` (or any 'ragdoll<hz>[pd|pds]').

    The ragdoll's variants share one model per rate; the PD mode of a variant is
    ``ragdoll_mode(scene)[1]`` and is up to whoever steps it."""
    if scene.startswith("ragdoll"):
        return ragdoll(ragdoll_mode(scene)[0])
    return _BUILDERS[scene][0]()


def steps(scene):
    """Number of steps a scene runs (the ragdoll's: ``RAGDOLL['duration']`` at its rate)."""
    if scene.startswith("ragdoll"):
        return int(round(RAGDOLL["duration"] * ragdoll_mode(scene)[0]))
    return _BUILDERS[scene][1]["steps"]
