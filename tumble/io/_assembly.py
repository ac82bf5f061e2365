"""Turn a kinematic tree read from a model file (MJCF, URDF) into ModelBuilder calls.

Model files describe *links* (MJCF bodies, URDF links): a frame in a tree, with mass
properties, collision geoms and the joints that connect each link to its parent, in
reduced coordinates. tumble simulates bodies in maximal coordinates with one joint per
body pair, so the loaders first describe everything in the world frame, in the initial
pose (:class:`LinkSpec`, :class:`GeomSpec`, :class:`JointSpec`), and :func:`assemble`
then decides:

* Welding: a link with no joint moves with its parent, so it is merged into the parent's
  tumble body (masses combined by the parallel-axis theorem; its geoms move over). A link
  with no joint under the world becomes part of the static world (its geoms are world
  geoms). Merging is cheaper than a ``fixed`` joint and exact, so it is not warned about;
  ``LoadReport.body_map`` says which tumble body (or the world) each link went into.
* Joints between one link and its parent:
  one hinge -> ``hinge``; one slide -> ``slider``; one ball -> ``ball``; free -> no joint.
  Two hinges through one point with perpendicular axes -> ``universal`` (axis 1 carried
  by the parent, axis 2 by the child: exactly two hinges in series). Three mutually
  perpendicular hinges through one point -> ``ball`` whose frame is the three axes.
  A merged joint has one (lower, upper) box for all its coordinates (tumble keeps one
  limit pair per joint): the loosest box holding every hinge's range, after choosing the
  axis signs that make it tightest; and one damping and friction value (the mean).
  Anything else (a slide and a hinge, hinges through different points, ...) becomes a
  chain of single-DoF joints through light auxiliary bodies (``<link>:<joint>``), each
  with ``AUX_FRACTION`` of the link's mass and inertia, taken from the link so the total
  mass and centre of mass are unchanged. ``merge_hinges=False`` uses such chains for
  every multi-joint link (exact per-hinge limits, more bodies).

Every joint merge and approximation is written to the :class:`LoadReport`, which the
loader turns into one warning.
"""
import warnings
from dataclasses import dataclass, field
from itertools import product

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ModelError, TumbleWarning
from ..model import mass as massprops

#: Share of a link's mass and inertia given to each auxiliary body of a joint chain.
AUX_FRACTION = 0.02
# Hinge axes closer than this (|cos|) count as perpendicular; anchors closer than this (m)
# as one point.
_PERP_TOL = 1e-6
_POINT_TOL = 1e-8


@dataclass
class GeomSpec:
    """A collision shape in the world frame. ``type`` is a tumble geom type; ``size`` as
    ``ModelBuilder.add_geom`` takes it; ``vertices`` (n, 3) in the geom frame for convex."""
    name: str
    type: str
    pos: np.ndarray
    quat: np.ndarray
    size: object = None
    vertices: object = None
    friction: float = 1.0
    torsional: float = 0.0
    rolling: float = 0.0
    contype: int = 1
    conaffinity: int = 1
    margin: float = 0.0
    where: str = ""
    dropped: str = ""             # why the loader dropped it (a mesh it could not find)


@dataclass
class JointSpec:
    """One reduced-coordinate joint: 'hinge', 'slide', 'ball' or 'free'.

    anchor, axis : world frame, initial pose (m; unit vector). limit : (lower, upper) in
    rad or m relative to the initial pose, or None; for a ball a box on each rotation-
    vector coordinate. damping : N m s/rad or N s/m. friction : dry friction, N m or N.
    stiffness : spring toward the initial pose, N m/rad or N/m (the joint's PD servo).
    """
    name: str
    type: str
    anchor: np.ndarray
    axis: np.ndarray
    limit: object = None
    damping: float = 0.0
    friction: float = 0.0
    stiffness: float = 0.0
    where: str = ""


@dataclass
class LinkSpec:
    """A link of the tree. pos, quat : its frame in the world (m; x, y, z, w). mass (kg),
    com (world, m) and inertia ((3, 3) world frame about the COM, kg m^2); mass 0 is
    allowed for links that are welded to something with mass. ``joints`` in order from
    the parent side to the child side. ``parent`` is an index into the link list (-1:
    world); parents come before children."""
    name: str
    parent: int
    pos: np.ndarray
    quat: np.ndarray
    mass: float = 0.0
    com: object = None
    inertia: object = None
    geoms: list = field(default_factory=list)
    joints: list = field(default_factory=list)
    kind: str = "dynamic"
    where: str = ""
    dropped: list = field(default_factory=list)   # geoms the loader dropped, and why


@dataclass
class LoadReport:
    """What a loader did, beyond the Model.

    body_map : source link name -> tumble body name (None: merged into the static world).
    joint_map : source joint name -> (tumble joint name, DoF index, sign): the source
        joint's coordinate is ``sign *`` that DoF of the tumble joint (plus its ``ref``).
        Free joints map to (None, -1, 0).
    actuators : actuator specs read from the file (MJCF; see ``tumble.io.mjcf``).
    notes : merges and approximations, one string each.
    ignored : element or attribute -> [count, first location]: read but not simulated.
    visual : elements that only affect rendering or bookkeeping, likewise ignored.
    timestep : the file's step (s), also ``model.timestep``.
    """
    source: str
    body_map: dict = field(default_factory=dict)
    joint_map: dict = field(default_factory=dict)
    actuators: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    ignored: dict = field(default_factory=dict)
    visual: dict = field(default_factory=dict)
    timestep: float = None

    def ignore(self, what, where="", visual=False):
        """Record an unsupported element or attribute ``what`` seen at ``where``."""
        table = self.visual if visual else self.ignored
        entry = table.setdefault(what, [0, where])
        entry[0] += 1

    def message(self, loader):
        """The one warning text, or None when nothing was ignored or changed."""
        if not (self.ignored or self.visual or self.notes):
            return None

        def listing(table):
            return "; ".join(f"{k} ({n}x, first at {w})" if n > 1 else f"{k} (at {w})"
                             for k, (n, w) in table.items())

        parts = [f"{loader}({self.source}): parts of the model are not simulated as written."]
        if self.ignored:
            parts.append(f"Not supported, ignored: {listing(self.ignored)}.")
        if self.visual:
            parts.append(f"Visual or bookkeeping only, ignored: {listing(self.visual)}.")
        if self.notes:
            parts.append("Changed to fit tumble's maximal-coordinate joints: "
                         + "; ".join(self.notes) + ".")
        return " ".join(parts)

    def warn(self, loader, stacklevel=3):
        msg = self.message(loader)
        if msg is not None:
            warnings.warn(msg, TumbleWarning, stacklevel=stacklevel)


def rotation(quat):
    return Rotation.from_quat(np.asarray(quat, float))


def _at(where, err):
    """Re-raise a builder ModelError with the file location in front."""
    return ModelError(f"{where}: {err}") if where else err


@dataclass
class _Segment:
    """One tumble joint of a link: type, axes, limit, damping, and the source DoFs it
    carries as (source joint name, dof, sign)."""
    name: str
    type: str
    anchor: np.ndarray
    axis: object = None
    axis2: object = None
    limit: object = None
    damping: float = 0.0
    friction: float = 0.0
    stiffness: float = 0.0
    members: list = field(default_factory=list)
    where: str = ""


def _box(ranges, signs):
    """Loosest (lower, upper) box holding ``sign * range`` of every coordinate."""
    lo = min(s * (r[0] if s > 0 else r[1]) for r, s in zip(ranges, signs))
    hi = max(s * (r[1] if s > 0 else r[0]) for r, s in zip(ranges, signs))
    return lo, hi


def _merge_hinges(link, joints):
    """A universal or ball segment for 2 or 3 hinges through one point with mutually
    perpendicular axes; None when they cannot be merged exactly."""
    n = len(joints)
    if n not in (2, 3) or any(j.type != "hinge" for j in joints):
        return None
    a0 = joints[0].anchor
    if any(np.linalg.norm(j.anchor - a0) > _POINT_TOL * max(1.0, np.linalg.norm(a0))
           for j in joints):
        return None
    axes = [j.axis / np.linalg.norm(j.axis) for j in joints]
    if any(abs(axes[i] @ axes[k]) > _PERP_TOL for i in range(n) for k in range(i + 1, n)):
        return None
    limited = all(j.limit is not None for j in joints)
    best = None
    for s1, s2 in product((1.0, -1.0), repeat=2):
        signs = [s1, s2]
        if n == 3:
            z = np.cross(s1 * axes[0], s2 * axes[1])
            signs.append(1.0 if z @ axes[2] > 0.0 else -1.0)
        width = 0.0
        box = None
        if limited:
            box = _box([j.limit for j in joints], signs)
            width = box[1] - box[0]
        if best is None or width < best[0] - 1e-12:
            best = (width, signs, box)
    _, signs, box = best
    name = "+".join(j.name for j in joints)
    dampings = [j.damping for j in joints]
    frictions = [j.friction for j in joints]
    seg = _Segment(name=name, type="universal" if n == 2 else "ball", anchor=a0.copy(),
                   axis=signs[0] * axes[0], axis2=signs[1] * axes[1], limit=box,
                   damping=float(np.mean(dampings)), friction=float(np.mean(frictions)),
                   stiffness=float(np.mean([j.stiffness for j in joints])),
                   members=[(j.name, d, signs[d]) for d, j in enumerate(joints)],
                   where=joints[0].where)
    kind = "universal joint" if n == 2 else "ball joint (frame = the hinge axes)"
    note = (f"{link.name}: hinges {', '.join(j.name for j in joints)} through one point "
            f"-> {kind} '{name}'")
    if box is not None:
        note += (f", one limit box [{box[0]:.4g}, {box[1]:.4g}] rad on every coordinate "
                 f"(the loosest holding each hinge's range)")
    elif any(j.limit is not None for j in joints):
        note += ", limits dropped (not every hinge is limited)"
    if len(set(dampings)) > 1 or len(set(frictions)) > 1:
        note += (f", damping {seg.damping:.4g} and friction {seg.friction:.4g} per "
                 f"coordinate (the means)")
    return seg, note


def _single(j):
    kind = {"hinge": "hinge", "slide": "slider", "ball": "ball"}[j.type]
    return _Segment(name=j.name, type=kind, anchor=j.anchor.copy(),
                    axis=None if kind == "ball" else j.axis / np.linalg.norm(j.axis),
                    limit=j.limit, damping=j.damping, friction=j.friction,
                    stiffness=j.stiffness, members=[(j.name, 0, 1.0)],
                    where=j.where)


def _plan(link, merge_hinges, notes):
    """Tumble joint segments for a link's joints, parent side first."""
    joints = link.joints
    if any(j.type == "free" for j in joints):
        if len(joints) > 1:
            raise ModelError(f"{joints[0].where}: link '{link.name}' has a free joint and "
                             f"other joints; a free joint must be its body's only joint")
        return []
    if len(joints) == 1:
        return [_single(joints[0])]
    if merge_hinges:
        merged = _merge_hinges(link, joints)
        if merged is not None:
            notes.append(merged[1])
            return [merged[0]]
    segs = [_single(j) for j in joints]
    notes.append(f"{link.name}: joints {', '.join(j.name for j in joints)} -> a chain of "
                 f"{len(segs)} tumble joints through {len(segs) - 1} auxiliary bodies "
                 f"({AUX_FRACTION:g} of the link's mass and inertia each)")
    return segs


def assemble(builder, links, report, *, merge_hinges=True, collide_with_world=True,
             world_geoms=()):
    """Add ``links`` (list of LinkSpec, parents first) to ``builder``; fill ``report``.

    world_geoms : GeomSpecs of the static world itself (MJCF worldbody geoms).
    collide_with_world : whether a body jointed to the world may still touch the world's
        geoms (MuJoCo: yes; URDF robots: no). Bodies joined to each other never collide
        (MuJoCo's parent filter), also across welds and auxiliary chains.
    Builder warnings are captured into ``report.notes`` so a load warns once.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _assemble(builder, links, report, merge_hinges, collide_with_world, world_geoms)
    for w in caught:
        report.notes.append(str(w.message))


def _assemble(builder, links, report, merge_hinges, collide_with_world, world_geoms):
    n = len(links)
    root = [0] * n                # index of the link whose tumble body holds link i; -1 world
    for i, link in enumerate(links):
        if link.parent >= i:
            raise ModelError(f"{link.where}: link '{link.name}' comes before its parent")
        if link.kind == "kinematic" or link.joints:
            root[i] = i
        else:
            root[i] = -1 if link.parent < 0 else root[link.parent]
    # welds are exact (the links move as one), so they are not noted; body_map shows them
    # plan the joints first: auxiliary chains take mass from their link
    plans = {i: _plan(links[i], merge_hinges, report.notes) for i in range(n) if root[i] == i}

    body_pose = {}                 # link index -> (pos, Rotation) of its tumble body
    body_name = {}
    aux_specs = []
    members_of = {}
    for k in range(n):
        members_of.setdefault(root[k], []).append(k)
    for i in range(n):
        if root[i] != i:
            continue
        link = links[i]
        members = members_of[i]
        rot = rotation(link.quat)
        kwargs = {}
        pos = np.asarray(link.pos, float)
        if link.kind == "dynamic":
            parts = [k for k in members if links[k].mass > 0.0]
            if not parts:
                names = ", ".join(f"'{links[k].name}'" for k in members)
                dropped = [d for k in members for d in links[k].dropped]
                why = f"; dropped: {'; '.join(dropped)}" if dropped else ""
                raise ModelError(f"{link.where}: link '{link.name}' moves (it has a joint) but "
                                 f"has no mass (links {names}{why}); give it an inertial or "
                                 f"geoms with density")
            m, com, inertia_w = massprops.combine(
                [links[k].mass for k in parts], [links[k].com for k in parts],
                [links[k].inertia for k in parts])
            inertia_b = rot.as_matrix().T @ inertia_w @ rot.as_matrix()
            inertia_b = 0.5 * (inertia_b + inertia_b.T)
            naux = max(len(plans[i]) - 1, 0)
            if naux:
                aux_specs.append((i, m, inertia_b))
            keep = 1.0 - naux * AUX_FRACTION
            kwargs = dict(mass=m * keep, inertia=inertia_b * keep)
            pos = com
        try:
            builder.add_body(link.name, pos=pos, quat=rot.as_quat(), kind=link.kind, **kwargs)
        except ModelError as e:
            raise _at(link.where, e) from None
        body_pose[i] = (pos, rot)
        body_name[i] = link.name

    def owner(i):
        """Tumble body name of link i's body, None for the world."""
        r = root[i]
        return None if r < 0 else body_name[r]

    for i, link in enumerate(links):
        report.body_map[link.name] = owner(i)

    # auxiliary bodies of joint chains, after the real ones so those keep the file order
    aux_names = {}
    for i, m, inertia_b in aux_specs:
        pos, rot = body_pose[i]
        names = []
        for seg in plans[i][:-1]:
            name = f"{links[i].name}:{seg.name}"
            try:
                builder.add_body(name, pos=pos, quat=rot.as_quat(), mass=AUX_FRACTION * m,
                                 inertia=AUX_FRACTION * inertia_b)
            except ModelError as e:
                raise _at(links[i].where, e) from None
            names.append(name)
        aux_names[i] = names

    placed = [(-1, g) for g in world_geoms]
    placed += [(i, g) for i, link in enumerate(links) for g in link.geoms]
    for i, g in placed:
        body = owner(i) if i >= 0 else None
        if body is None:
            pos, quat = g.pos, g.quat
        else:
            bpos, brot = body_pose[root[i]]
            pos = brot.inv().apply(np.asarray(g.pos, float) - bpos)
            quat = (brot.inv() * rotation(g.quat)).as_quat()
        kw = dict(pos=pos, quat=quat, friction=g.friction, torsional_friction=g.torsional,
                  rolling_friction=g.rolling, contype=g.contype,
                  conaffinity=g.conaffinity, margin=g.margin, name=g.name)
        if g.type == "convex":
            kw["vertices"] = g.vertices
        elif g.type != "plane":
            kw["size"] = g.size
        try:
            builder.add_geom(body, g.type, **kw)
        except ModelError as e:
            raise _at(g.where, e) from None

    for i, segs in plans.items():
        link = links[i]
        parent = owner(link.parent) if link.parent >= 0 else None
        chain = [parent] + aux_names.get(i, []) + [link.name]
        for k, seg in enumerate(segs):
            kw = dict(limit=seg.limit, damping=seg.damping, friction=seg.friction,
                      collide=collide_with_world or chain[k] is not None)
            if seg.stiffness > 0.0:
                # a passive spring toward the initial pose: the joint's servo, whose
                # default target is the built pose; its damping stays in the damping rows
                kw["kp"] = seg.stiffness
            if seg.type == "slider":
                # a slider's anchor only sets lever arms; the child's COM keeps it near
                anchor = body_pose[i][0]
            else:
                anchor = seg.anchor
            if seg.type in ("hinge", "slider", "universal"):
                kw["axis"] = seg.axis
            if seg.type == "universal" or (seg.type == "ball" and seg.axis is not None):
                kw["axis"], kw["axis2"] = seg.axis, seg.axis2
            try:
                builder.add_joint(seg.name, seg.type, chain[k], chain[k + 1], anchor=anchor, **kw)
            except ModelError as e:
                raise _at(seg.where, e) from None
            for src, dof, sign in seg.members:
                report.joint_map[src] = (seg.name, dof, sign)
        for j in link.joints:
            if j.type == "free":
                report.joint_map[j.name] = (None, -1, 0.0)
        if len(segs) > 1 and parent is not None:
            builder.exclude_collision(parent, link.name)

    # parent filter: bodies joined to each other never collide (the world aside)
    for i, link in enumerate(links):
        if link.parent < 0:
            continue
        a, b = owner(i), owner(link.parent)
        if a is not None and b is not None and a != b:
            builder.exclude_collision(a, b)
    return body_name
