"""Ragdolls: one rigid body per bone of a skeleton, joined where the bones meet.

:func:`build_ragdoll` makes a :class:`Ragdoll` from any :class:`~tumble.character.Skeleton`
(bones sized from the skeleton), :func:`ragdoll_from_motion` does it for a BVH
:class:`~tumble.Motion`, and :func:`games105_ragdoll` rebuilds the GAMES-105 course's
reference character exactly as the course does on ODE.

Conventions shared by all of them:

* The model is built in the skeleton's rest pose (every joint rotation the identity).
  Joint ``j`` of the skeleton *drives* the body of the bone that starts at ``j``; the body
  and the model joint that attaches it to its parent's body are both named after ``j``.
  End sites (leaves) own no body.
* Every model joint is anchored at its skeleton joint. The root body hangs from the world
  by a ball joint at the root (``root='pinned'``) or is free (``root='floating'``: a
  ``free`` joint, which adds no constraint but keeps the root in the joint list).
* Bodies joined by a joint never collide; gravity points down the skeleton's up axis.
* Every builder accepts ``joint_kwargs={joint name: {keyword: value}}``, passed to
  ``ModelBuilder.add_joint`` as is (limits, damping, and PD gains where the builder has them).
"""
import math

import numpy as np

from ..errors import ModelError
from ..io.bvh import Motion
from ..model.builder import ModelBuilder
from ..math import quat_np as Q
from .skeleton import CharacterModel, Skeleton, load_character_model

__all__ = ["Ragdoll", "build_ragdoll", "ragdoll_from_motion", "games105_ragdoll",
           "GAMES105_BOX_SCALES"]

ROOT_MODES = ("pinned", "floating")
_JOINT_TYPES = ("ball", "hinge", "universal", "fixed")
# Keywords the builder sets itself; joint_kwargs may not override them.
_RESERVED = {"name", "type", "parent", "child", "anchor", "axis", "axis2"}


class Ragdoll:
    """A model built from a skeleton, and which body and joint stand for which skeleton joint.

    Attributes
    ----------
    model : the :class:`~tumble.Model` (bodies of the ragdoll, then nothing else but the
        ground geom when asked for).
    skeleton : the :class:`~tumble.character.Skeleton` (rest pose = the model's build pose).
    body_of : {skeleton joint name: body name} for every joint that drives a body.
    joint_of : {skeleton joint name: model joint name} for the same joints; the root's is
        its pin (ball joint to the world) or its free joint.
    root : 'pinned' or 'floating'.
    world_options : keyword arguments recommended for ``World`` (``make_world`` uses them).
    body_joints : (nb,) skeleton joint index of each ragdoll body, in model body order.
    body_index, joint_index : (nb,) model body and model joint of each of those.
    body_offset : (nb, 3) each body's centre of mass relative to its skeleton joint in the
        rest pose (m, world = joint frame there).
    body_rest_quat : (nb, 4) each body's simulated (principal) frame in the rest pose.
    """

    def __init__(self, model, skeleton, body_joints, root, world_options):
        self.model = model
        self.skeleton = skeleton
        self.root = root
        self.world_options = dict(world_options)
        self._alignment_cache = {}          # rest alignments by motion rest skeleton (pose.py)
        names = skeleton.joint_names
        self.body_joints = np.array([skeleton.index(n) for n in body_joints], dtype=np.int64)
        self.body_of = {n: n for n in body_joints}
        self.joint_of = {n: n for n in body_joints}
        self.body_index = np.array([model.body_index(n) for n in body_joints], dtype=np.int64)
        self.joint_index = np.array([model.joint_index(n) for n in body_joints], dtype=np.int64)
        self.body_offset = model.body_pos0[self.body_index] - skeleton.rest_positions[self.body_joints]
        self.body_rest_quat = np.array(model.body_quat0[self.body_index])
        # Skeleton index -> ragdoll body slot (-1: the joint drives no body).
        self.slot_of_joint = np.full(len(names), -1, dtype=np.int64)
        self.slot_of_joint[self.body_joints] = np.arange(len(body_joints))
        if self.slot_of_joint[skeleton.root] < 0:
            raise ModelError("Ragdoll: the skeleton root must drive a body")
        for a in (self.body_joints, self.body_index, self.joint_index, self.body_offset,
                  self.body_rest_quat, self.slot_of_joint):
            a.setflags(write=False)

    @property
    def body_names(self):
        """Names of the ragdoll's bodies, in model order."""
        return [self.model.body_names[b] for b in self.body_index]

    def make_world(self, **overrides):
        """A ``World`` of this model with ``world_options``, updated by ``overrides``."""
        from ..world import World
        return World(self.model, **{**self.world_options, **overrides})

    def __repr__(self):
        return (f"<tumble.Ragdoll: {len(self.body_index)} bodies, root {self.root}, "
                f"skeleton of {self.skeleton.num_joints} joints>")


# ----------------------------------------------------------------------------------------
# shared assembly
# ----------------------------------------------------------------------------------------

def _check_names(what, mapping, allowed, where):
    """ModelError listing keys of ``mapping`` that are not among ``allowed``."""
    if mapping is None:
        return {}
    if not isinstance(mapping, dict):
        raise ModelError(f"{where}: {what} must be a dict keyed by joint name, got "
                         f"{type(mapping).__name__}")
    unknown = [k for k in mapping if k not in allowed]
    if unknown:
        raise ModelError(f"{where}: {what} names unknown joints {unknown}; the joints that "
                         f"drive bodies are {list(allowed)}")
    return dict(mapping)


def _joint_spec(name, types, axes, kwargs, default_type, where):
    """(type, axis, axis2, extra add_joint kwargs) of one skeleton joint."""
    jtype = types.get(name, default_type)
    if jtype not in _JOINT_TYPES:
        raise ModelError(f"{where}: joint '{name}': type must be one of {list(_JOINT_TYPES)}, "
                         f"got {jtype!r}")
    axis = axis2 = None
    if jtype in ("hinge", "universal"):
        if name not in axes:
            raise ModelError(f"{where}: joint '{name}' is a {jtype} and needs an axis in "
                             f"joint_axes (world frame, rest pose)")
        if jtype == "universal":
            pair = axes[name]
            if np.shape(pair) != (2, 3):
                raise ModelError(f"{where}: joint '{name}' is universal: joint_axes needs "
                                 f"(axis, axis2), got {pair!r}")
            axis, axis2 = pair
        else:
            axis = axes[name]
    elif name in axes:
        raise ModelError(f"{where}: joint '{name}' is a {jtype} joint and takes no axis")
    return jtype, axis, axis2, _extra_kwargs(name, kwargs, where)


def _extra_kwargs(name, kwargs, where):
    """The user's extra ``add_joint`` keywords of joint ``name`` (checked)."""
    extra = kwargs.get(name, {})
    if not isinstance(extra, dict):
        raise ModelError(f"{where}: joint_kwargs['{name}'] must be a dict, got "
                         f"{type(extra).__name__}")
    clash = sorted(_RESERVED & set(extra))
    if clash:
        raise ModelError(f"{where}: joint_kwargs['{name}'] may not set {clash}: the ragdoll "
                         f"builder sets them")
    return dict(extra)


def _add_joints(b, skeleton, body_joints, root, types, axes, kwargs, where):
    """Model joints: the root's pin or free joint, then one per non-root body."""
    names = skeleton.joint_names
    rest = skeleton.rest_positions
    for n in body_joints:
        j = skeleton.index(n)
        p = skeleton.parents[j]
        if p < 0:
            if root == "pinned":
                jtype, axis, axis2, extra = _joint_spec(n, types, axes, kwargs, "ball", where)
                # collide=True: a pin to the world should not switch off ground contacts.
                b.add_joint(n, jtype, None, n, anchor=rest[j], axis=axis, axis2=axis2,
                            collide=True, **extra)
            else:
                if n in types or n in axes:
                    raise ModelError(f"{where}: the root '{n}' is floating (a free joint); "
                                     f"joint_types/joint_axes do not apply to it")
                b.add_joint(n, "free", None, n, **_extra_kwargs(n, kwargs, where))
            continue
        jtype, axis, axis2, extra = _joint_spec(n, types, axes, kwargs, "ball", where)
        b.add_joint(n, jtype, names[p], n, anchor=rest[j], axis=axis, axis2=axis2, **extra)


def _add_terrain(b, terrain, friction, up, where):
    """Add a terrain's static geoms (tumble.character.terrain) to the builder."""
    from .terrain import Terrain
    if not isinstance(terrain, Terrain):
        raise ModelError(f"{where}: terrain must be a tumble.character.terrain Terrain (Flat, "
                         f"Slope, Heightfield), got {type(terrain).__name__}")
    terrain.add_to(b, friction=friction, up=up)


def _check_root(root, where):
    if root not in ROOT_MODES:
        raise ModelError(f"{where}: root must be one of {list(ROOT_MODES)}, got {root!r}")


# ----------------------------------------------------------------------------------------
# generic builder
# ----------------------------------------------------------------------------------------

def _per_joint(value, name, what, where):
    """A scalar option, or its entry for joint ``name`` when given as a dict."""
    v = value.get(name) if isinstance(value, dict) else value
    if v is None:
        return None
    v = float(v)
    if not (math.isfinite(v) and v > 0.0):
        raise ModelError(f"{where}: {what} of joint '{name}' must be a positive number, got {v}")
    return v


def _bone_geometry(skeleton, j, shape, width, width_ratio, where):
    """Body frame and geom of the bone(s) leaving joint ``j`` in the rest pose.

    Returns (centre (3,), body quat (4,), geom type, geom size, volume m^3). One child: a
    capsule or box from the joint to the child, local z along the bone. Several children:
    a box, axis-aligned in the rest pose, spanning the joint and its children.
    """
    name = skeleton.joint_names[j]
    p = skeleton.rest_positions[j]
    kids = skeleton.children(j)
    vecs = skeleton.rest_positions[kids] - p
    longest = float(np.max(np.linalg.norm(vecs, axis=1)))
    w = _per_joint(width, name, "width", where)
    if w is None:
        w = width_ratio * longest
        if not w > 0.0:
            raise ModelError(f"{where}: joint '{name}' has children at its own position; give "
                             f"it a width")
    if len(kids) > 1:
        pts = np.vstack([p, skeleton.rest_positions[kids]])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        half = 0.5 * np.maximum(hi - lo, w)
        return 0.5 * (lo + hi), Q.IDENTITY.copy(), "box", half, 8.0 * float(np.prod(half))
    length = float(np.linalg.norm(vecs[0]))
    centre = p + 0.5 * vecs[0]
    quat = Q.qarc(np.array([0.0, 0.0, 1.0]), vecs[0] / length) if length > 0.0 else Q.IDENTITY.copy()
    r = 0.5 * w
    if shape == "box":
        half = np.array([r, r, 0.5 * max(length, w)])
        return centre, quat, "box", half, 8.0 * float(np.prod(half))
    r = min(r, 0.5 * length) if length > 0.0 else r
    half_length = 0.5 * length - r
    if half_length <= 1e-9 * max(length, 1.0):
        return centre, quat, "sphere", np.array([r]), 4.0 / 3.0 * math.pi * r ** 3
    volume = math.pi * r * r * 2.0 * half_length + 4.0 / 3.0 * math.pi * r ** 3
    return centre, quat, "capsule", np.array([r, half_length]), volume


def _lowest(centre, quat, gtype, size, up):
    """Lowest coordinate along ``up`` of a geom placed at ``centre`` with ``quat``."""
    h = float(centre @ up)
    if gtype == "sphere":
        return h - size[0]
    local_up = Q.qrot(Q.qconj(quat), up)
    if gtype == "box":
        return h - float(np.abs(local_up) @ size)
    return h - abs(local_up[2]) * size[1] - size[0]


def build_ragdoll(skeleton, *, shape="capsule", width=None, width_ratio=0.3, density=1000.0,
                  total_mass=None, joint_types=None, joint_axes=None, joint_kwargs=None,
                  root="floating", ground=True, friction=1.0, restitution=0.0,
                  collide_siblings=False, place_on_ground=False, gravity=9.81,
                  timestep=1.0 / 240.0, world_options=None, terrain=None):
    """A ragdoll with one body per bone of ``skeleton``, sized from the bones.

    skeleton : :class:`~tumble.character.Skeleton`; the model is built in its rest pose.
    shape : 'capsule' or 'box' for bones with one child (a capsule whose bone is shorter
        than its width becomes a sphere); joints with several children (a pelvis, a chest)
        get a box spanning the joint and its children, axis-aligned in the rest pose.
    width : bone thickness in m (capsule diameter, box side), a number or
        {joint name: number}; joints not given use ``width_ratio`` times their (longest)
        bone length.
    density : kg/m^3 of every body (default 1000, water), or
    total_mass : kg of the whole ragdoll, shared in proportion to volume (overrides density).
    joint_types : {joint name: 'ball' | 'hinge' | 'universal' | 'fixed'}; default ball.
    joint_axes : {joint name: axis (3,)} for hinges, {name: (axis, axis2)} for universal
        joints; world frame, rest pose.
    joint_kwargs : {joint name: dict of extra ``add_joint`` keywords} (limit, damping, ...).
    root : 'floating' (free root, default) or 'pinned' (ball joint to the world at the root).
    ground : add a ground plane through the origin, normal ``skeleton.up``.
    friction, restitution : of every geom (the ground too).
    collide_siblings : let bones with the same parent joint collide (default False: such
        bones often overlap where they meet, e.g. a chest and the two clavicles).
    place_on_ground : shift the rest pose along ``up`` so that the lowest point of the
        geometry sits at height 0 (the skeleton of the result is the shifted one).
    gravity : m/s^2 along ``-skeleton.up``.
    timestep : the model's default step, s.
    world_options : recommended ``World`` keywords stored on the result.
    terrain : a :class:`~tumble.character.terrain.Terrain` (slope, heightfield; Y up) put in
        place of the ground plane, with ``friction``; ``ground`` is then ignored.

    Returns a :class:`Ragdoll`. Raises ModelError naming the joint for unknown joint names
    in any of the dicts, a hinge without an axis, or an option out of range.
    """
    where = "build_ragdoll"
    if not isinstance(skeleton, Skeleton):
        raise ModelError(f"{where}: needs a Skeleton, got {type(skeleton).__name__} "
                         f"(use ragdoll_from_motion for a Motion)")
    _check_root(root, where)
    if shape not in ("capsule", "box"):
        raise ModelError(f"{where}: shape must be 'capsule' or 'box', got {shape!r}")
    width_ratio = float(width_ratio)
    if not (math.isfinite(width_ratio) and width_ratio > 0.0):
        raise ModelError(f"{where}: width_ratio must be a positive number, got {width_ratio}")
    names = skeleton.joint_names
    body_joints = [names[j] for j in skeleton.order if skeleton.children(j)]
    if not body_joints:
        raise ModelError(f"{where}: the skeleton has no bones (a single joint)")
    allowed = tuple(body_joints)
    types = _check_names("joint_types", joint_types, allowed, where)
    axes = _check_names("joint_axes", joint_axes, allowed, where)
    kwargs = _check_names("joint_kwargs", joint_kwargs, allowed, where)
    if isinstance(width, dict):
        _check_names("width", width, allowed, where)

    geo = {n: _bone_geometry(skeleton, skeleton.index(n), shape, width, width_ratio, where)
           for n in body_joints}
    if place_on_ground:
        low = min(_lowest(c, q, t, s, skeleton.up) for c, q, t, s, _ in geo.values())
        shift = -low * skeleton.up
        skeleton = Skeleton(names, skeleton.parents, skeleton.rest_positions + shift,
                            up=skeleton.up)
        geo = {n: (c + shift, q, t, s, v) for n, (c, q, t, s, v) in geo.items()}
    if total_mass is not None:
        total = float(total_mass)
        if not (math.isfinite(total) and total > 0.0):
            raise ModelError(f"{where}: total_mass must be a positive number, got {total_mass}")
        rho = total / sum(v for *_, v in geo.values())
    else:
        rho = float(density)
        if not (math.isfinite(rho) and rho > 0.0):
            raise ModelError(f"{where}: density must be a positive number, got {density}")
    g = float(gravity)
    if not (math.isfinite(g) and g >= 0.0):
        raise ModelError(f"{where}: gravity must be a number >= 0, got {gravity}")

    b = ModelBuilder(gravity=-g * skeleton.up, timestep=timestep)
    for n in body_joints:
        centre, quat, gtype, size, _ = geo[n]
        b.add_body(n, pos=centre, quat=quat, density=rho)
        b.add_geom(n, gtype, size=size, friction=friction, restitution=restitution,
                   name=f"{n}_geom")
    _add_joints(b, skeleton, body_joints, root, types, axes, kwargs, where)
    if not collide_siblings:
        for j in range(len(names)):
            kids = [names[k] for k in skeleton.children(j) if names[k] in geo]
            for a in range(len(kids)):
                for c in range(a + 1, len(kids)):
                    b.exclude_collision(kids[a], kids[c])
    if terrain is not None:
        _add_terrain(b, terrain, friction, skeleton.up, where)
    elif ground:
        b.add_geom(None, "plane", normal=skeleton.up, friction=friction,
                   restitution=restitution, name="ground")
    return Ragdoll(b.build(), skeleton, body_joints, root, world_options or {})


def ragdoll_from_motion(motion, *, root_position=None, up="y", **options):
    """A ragdoll of the skeleton of a BVH :class:`~tumble.Motion` (see :func:`build_ragdoll`).

    The rest pose is the motion's offsets with identity rotations. root_position : (3,)
    where the root stands in it; by default the skeleton is placed so that its lowest
    geometry touches the ground plane (height 0 along ``up``). up : the motion's up axis
    ('y' for BVH). Other keywords go to :func:`build_ragdoll`.
    """
    if not isinstance(motion, Motion):
        raise ModelError(f"ragdoll_from_motion needs a tumble Motion, got {type(motion).__name__}")
    skeleton = Skeleton.from_motion(motion, root_position=root_position, up=up)
    options.setdefault("place_on_ground", root_position is None)
    return build_ragdoll(skeleton, **options)


# ----------------------------------------------------------------------------------------
# the GAMES-105 reference character
# ----------------------------------------------------------------------------------------

# The course's box size vector s (m) per joint; collision boxes have full sides 1.5 s, the
# mass is that of a box of full sides 10 s. Joints not listed use 0.03 on each axis.
GAMES105_BOX_SCALES = {
    "RootJoint": (0.06, 0.06, 0.04), "torso_head": (0.05, 0.08, 0.04),
    "lowerback_torso": (0.03, 0.04, 0.04), "pelvis_lowerback": (0.03, 0.035, 0.04),
    **{s + k: v for s in "lr" for k, v in (
        ("Hip", (0.03, 0.15, 0.03)), ("Knee", (0.03, 0.16, 0.03)),
        ("Ankle", (0.045, 0.024, 0.07)), ("ToeJoint", (0.045, 0.018, 0.02)),
        ("Torso_Clavicle", (0.05, 0.03, 0.03)), ("Shoulder", (0.07, 0.03, 0.03)),
        ("Elbow", (0.07, 0.03, 0.03)), ("Wrist", (0.05, 0.018, 0.033)))},
}
_GAMES105_DEFAULT_SCALE = (0.03, 0.03, 0.03)
_GAMES105_DENSITY, _GAMES105_TOE_DENSITY = 50.0, 100.0     # kg/m^3 of the 10 s mass box
_GAMES105_MASS_SCALE, _GAMES105_COLLISION_SCALE = 10.0, 1.5
_GAMES105_TOE_RAISE = 0.01                                 # m, toe body centre raised in y
_GAMES105_FRICTION = 1.5
_GAMES105_DT = 1.0 / 1920.0                                # 60 frames/s x 32 substeps


def _is_toe(name):
    return "Toe" in name


def _games105_joint_type(name):
    """(type, axis) of the course: hinges about x (knees, toes) and y (elbows), else ball."""
    if "Knee" in name or _is_toe(name):
        return "hinge", (1.0, 0.0, 0.0)
    if "Elbow" in name:
        return "hinge", (0.0, 1.0, 0.0)
    return "ball", None


def games105_ragdoll(root="floating", *, character=None, ground=True, joint_kwargs=None,
                     terrain=None):
    """The GAMES-105 course's reference ragdoll, as the course builds it on ODE.

    root : 'floating' (free root, default) or 'pinned' (ball joint to the world at
        ``joint_pos[0]``).
    character : a ``character_model.npy`` path, a loaded :class:`CharacterModel`, or None
        for the copy shipped with tumble.
    ground : add the ground plane y = 0 (friction 1.5, no bounce).
    joint_kwargs : {joint name: dict of extra ``add_joint`` keywords}, e.g. PD gains.
    terrain : a :class:`~tumble.character.terrain.Terrain` (a slope, a heightfield) put in
        place of the flat ground (friction 1.5 like the ground); ``ground`` is then ignored.

    From the course facts (README of the data): one body per joint i < 20 centred at
    ``body_pos[i]`` (toes raised 0.01 m in y), axis-aligned in the T-pose; mass and inertia
    of a uniform box of full sides ``10 s`` at 50 kg/m^3 (toes 100), about 78.5 kg in all;
    a collision box of full sides ``1.5 s`` (toes collide with nothing), friction 1.5,
    restitution 0; hinges about x for knees and toes and about y for elbows, ball joints
    elsewhere, each anchored at ``joint_pos[i]`` between body i and body ``parent[i]``;
    bodies joined by a joint do not collide (ODE's rule), other pairs do; gravity
    (0, -9.81, 0); model timestep 1/1920 s.

    Contact softness: the course's contact ERP 0.9 and CFM 0.001 are ODE's, which tumble's
    contact rows use in the same units (``J v + cfm f = erp/h depth``, f the force), so they
    map one to one onto ``World(contact_erp=0.9, contact_cfm=0.001)``; they are in
    ``world_options`` (with ``dt=1/1920``) and ``Ragdoll.make_world()`` applies them.

    The skeleton of the result holds all 25 joints of the file (end sites included), so
    course BVH files map onto it by name.
    """
    where = "games105_ragdoll"
    _check_root(root, where)
    cm = character if isinstance(character, CharacterModel) else load_character_model(character)
    skeleton, body_pos = cm.skeleton, cm.body_pos
    if np.linalg.norm(skeleton.up - (0.0, 1.0, 0.0)) > 1e-12:
        raise ModelError(f"{where}: the course character is Y up")
    names = skeleton.joint_names
    body_joints = [names[i] for i in range(len(body_pos))]
    kwargs = _check_names("joint_kwargs", joint_kwargs, tuple(body_joints), where)
    b = ModelBuilder(gravity=(0.0, -9.81, 0.0), timestep=_GAMES105_DT)
    for i, n in enumerate(body_joints):
        s = np.array(GAMES105_BOX_SCALES.get(n, _GAMES105_DEFAULT_SCALE))
        toe = _is_toe(n)
        centre = np.array(body_pos[i], dtype=float)
        if toe:
            centre[1] += _GAMES105_TOE_RAISE
        # Mass box: full sides 10 s, i.e. half extents 5 s (inertia m (b^2 + c^2) / 12).
        density = _GAMES105_TOE_DENSITY if toe else _GAMES105_DENSITY
        full = _GAMES105_MASS_SCALE * s
        mass = density * float(np.prod(full))
        inertia = mass / 12.0 * np.array([full[1] ** 2 + full[2] ** 2, full[0] ** 2 + full[2] ** 2,
                                          full[0] ** 2 + full[1] ** 2])
        b.add_body(n, pos=centre, mass=mass, inertia=inertia)
        bits = 0 if toe else 1
        b.add_geom(n, "box", size=0.5 * _GAMES105_COLLISION_SCALE * s,
                   friction=_GAMES105_FRICTION, restitution=0.0, contype=bits, conaffinity=bits,
                   name=f"{n}_geom")
    types, axes = {}, {}
    for n in body_joints[1:]:
        types[n], axis = _games105_joint_type(n)
        if axis is not None:
            axes[n] = axis
    for n in body_joints:
        p = skeleton.parents[skeleton.index(n)]
        if p >= len(body_joints):
            raise ModelError(f"{where}: joint '{n}' has a parent without a body")
    _add_joints(b, skeleton, body_joints, root, types, axes, kwargs, where)
    if terrain is not None:
        _add_terrain(b, terrain, _GAMES105_FRICTION, skeleton.up, where)
    elif ground:
        b.add_geom(None, "plane", normal=(0.0, 1.0, 0.0), friction=_GAMES105_FRICTION,
                   restitution=0.0, name="ground")
    options = dict(dt=_GAMES105_DT, contact_erp=0.9, contact_cfm=0.001)
    return Ragdoll(b.build(), skeleton, body_joints, root, options)
