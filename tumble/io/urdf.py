"""Load URDF robots: ``tumble.load_urdf(path_or_xml)`` -> Model.

What is read
------------
* ``<link>``: ``<inertial>`` (``origin`` xyz/rpy, ``mass``, the full ``inertia`` tensor in
  the inertial frame) and ``<collision>`` shapes (``origin``; box (full sizes), sphere,
  cylinder (radius, full length, axis z), capsule (same); a mesh becomes the convex hull
  of an STL or OBJ file when it can be found next to the URDF, else it is dropped and
  named in the warning).
* ``<joint>``: revolute and prismatic (with ``<limit lower upper>``), continuous, fixed,
  floating (the child becomes a free body) and planar (two sliders and a hinge through
  auxiliary bodies); ``origin`` (the child frame in the parent's), ``axis`` (default x),
  ``<dynamics damping friction>``.
* The root link is welded to the world with ``fixed_base=True``, else it floats free. A
  root link named ``world`` is the world itself.

Links joined by fixed joints are merged into one tumble body (see ``tumble.io._assembly``);
tumble bodies sit at their centre of mass with the URDF link's orientation. Visual
elements, materials, ``<gazebo>``, ``<transmission>``, ``mimic``, effort and velocity
limits are not simulated: one ``TumbleWarning`` per load names them.
"""
import os

import numpy as np
from scipy.spatial.transform import Rotation

from ..model import meshes
from ..model.builder import ModelBuilder
from ..model.validate import unit_quat, vector
from ._assembly import GeomSpec, JointSpec, LinkSpec, LoadReport, assemble
from ._meshfile import MeshFileError, MeshFileSkipped, read_mesh_vertices
from ._xml import floats, norm, parse_xml

__all__ = ["load_urdf", "parse_urdf"]

_JOINT_TYPES = {"revolute", "continuous", "prismatic", "fixed", "floating", "planar"}


def load_urdf(source, *, fixed_base=False, base_pos=(0.0, 0.0, 0.0),
              base_quat=(0.0, 0.0, 0.0, 1.0), gravity=(0.0, 0.0, -9.81), timestep=1.0 / 240.0):
    """Load a URDF robot (a file path, or the XML text itself) as a validated Model.

    fixed_base : weld the root link to the world (True) or let it float (False).
    base_pos, base_quat : pose of the root link frame in the world (m; x, y, z, w).
    gravity (m/s^2, world), timestep (s) : as for ``ModelBuilder`` (URDF has neither).
    Raises ModelError naming the element, attribute and line of anything malformed; warns
    once (TumbleWarning) listing what it could not simulate as written.
    """
    builder, _ = parse_urdf(source, fixed_base=fixed_base, base_pos=base_pos,
                            base_quat=base_quat, gravity=gravity, timestep=timestep,
                            _stacklevel=4)
    return builder.build()


def parse_urdf(source, *, fixed_base=False, base_pos=(0.0, 0.0, 0.0),
               base_quat=(0.0, 0.0, 0.0, 1.0), gravity=(0.0, 0.0, -9.81),
               timestep=1.0 / 240.0, _stacklevel=3):
    """Read a URDF robot into a ``ModelBuilder`` (not yet built: add a floor, say).

    Returns ``(builder, report)`` (see ``tumble.io._assembly.LoadReport``).
    """
    root, base_dir, name = parse_xml(source, "load_urdf")
    pos0 = vector(base_pos, 3, "load_urdf", "base_pos")
    rot0 = Rotation.from_quat(unit_quat(base_quat, "load_urdf", "base_quat"))
    builder = ModelBuilder(gravity=gravity, timestep=timestep)
    report = LoadReport(source=name, timestep=builder.timestep)
    links = _read(root, base_dir, report, bool(fixed_base), pos0, rot0)
    assemble(builder, links, report, collide_with_world=False)
    report.warn("load_urdf", stacklevel=_stacklevel)
    return builder, report


def _numbers(node, attr, n, default=None, required=False):
    v = node.attrib.get(attr)
    if v is None:
        if required:
            raise node.error("is required", attr)
        return None if default is None else np.array(default, float)
    return np.array(floats(node, attr, v, n=n))


def _positive(node, attr, required=True, default=None):
    v = _numbers(node, attr, 1, required=required, default=None if default is None else [default])
    if v is None:
        return None
    if not v[0] > 0.0:
        raise node.error(f"must be > 0, got '{node.attrib[attr]}'", attr)
    return float(v[0])


def _origin(parent_node):
    """(pos, Rotation) of an ``<origin xyz rpy>`` child (identity when absent)."""
    o = parent_node.find("origin")
    if o is None:
        return np.zeros(3), Rotation.identity()
    xyz = _numbers(o, "xyz", 3, (0.0, 0.0, 0.0))
    rpy = _numbers(o, "rpy", 3, (0.0, 0.0, 0.0))
    # roll, pitch, yaw about the fixed x, y, z axes: R = Rz(yaw) Ry(pitch) Rx(roll)
    return xyz, Rotation.from_euler("xyz", rpy)


def _name(node, what):
    n = node.attrib.get("name")
    if not n:
        raise node.error(f"a {what} needs a name", "name")
    return n


def _read(root, base_dir, report, fixed_base, pos0, rot0):
    if root.tag != "robot":
        raise root.error(f"the root element must be <robot>, got <{root.tag}>")
    link_nodes, joint_nodes = {}, []
    for c in root.children:
        if c.tag == "link":
            n = _name(c, "link")
            if n in link_nodes:
                raise c.error(f"a link named '{n}' already exists", "name")
            link_nodes[n] = c
        elif c.tag == "joint":
            joint_nodes.append(c)
        elif c.tag == "material":
            report.ignore("<material>", f"line {c.line}", visual=True)
        else:
            report.ignore(f"<{c.tag}>", f"line {c.line}")
    if not link_nodes:
        raise root.error("a robot needs at least one <link>")

    parent_of, children = {}, {n: [] for n in link_nodes}
    seen_joints = set()
    for j in joint_nodes:
        name = _name(j, "joint")
        if name in seen_joints:
            raise j.error(f"a joint named '{name}' already exists", "name")
        seen_joints.add(name)
        jtype = j.attrib.get("type")
        if jtype is None:
            raise j.error("is required", "type")
        if jtype not in _JOINT_TYPES:
            raise j.error(f"unknown joint type '{jtype}'; URDF joint types are "
                          f"{sorted(_JOINT_TYPES)}", "type")
        ends = []
        for tag in ("parent", "child"):
            e = j.find(tag)
            if e is None:
                raise j.error(f"a joint needs a <{tag} link='...'/>")
            ln = e.attrib.get("link")
            if not ln:
                raise e.error("is required", "link")
            if ln not in link_nodes:
                raise e.error(f"unknown link '{ln}'", "link")
            ends.append(ln)
        p, c = ends
        if c in parent_of:
            raise j.error(f"link '{c}' already has a parent joint "
                          f"('{parent_of[c][1].attrib['name']}'); URDF is a tree")
        if p == c:
            raise j.error(f"joins link '{p}' to itself")
        parent_of[c] = (p, j)
        children[p].append(c)
    roots = [n for n in link_nodes if n not in parent_of]
    if len(roots) != 1:
        raise root.error(f"a URDF tree has exactly one root link (a link that is no joint's "
                         f"child), found {len(roots)}: {roots}")

    links, index = [], {}
    # depth first from the root, children in file order (an explicit stack, so a chain
    # of any length works): (link name, parent index, parent's world pos and Rotation,
    # the joint node to the parent)
    stack = [(roots[0], -1, pos0, rot0, None)]
    while stack:
        name, parent_index, pos, rot, jnode = stack.pop()
        if jnode is not None:
            jpos, jrot = _origin(jnode)
            pos, rot = pos + rot.apply(jpos), rot * jrot
        node = link_nodes[name]
        link = LinkSpec(name=name, parent=parent_index, pos=pos, quat=rot.as_quat(),
                        where=node.where())
        _link_body(node, link, pos, rot, base_dir, report)
        if jnode is not None:
            link.joints = _joint(jnode, pos, rot, report)
        elif not fixed_base and name != "world":
            link.joints = [JointSpec(name=f"{name}:free", type="free", anchor=pos,
                                     axis=np.array([0.0, 0, 1]), where=node.where())]
        index[name] = len(links)
        links.append(link)
        stack.extend((c, index[name], pos, rot, parent_of[c][1])
                     for c in reversed(children[name]))

    unreachable = [n for n in link_nodes if n not in index]
    if unreachable:
        raise root.error(f"links {unreachable} are not connected to the root "
                         f"'{roots[0]}' (the joints form a loop)")
    return links


def _link_body(node, link, pos, rot, base_dir, report):
    """Mass properties and collision geoms of one link (world frame)."""
    for c in node.children:
        if c.tag == "visual":
            report.ignore("<link><visual>", f"line {c.line}", visual=True)
        elif c.tag not in ("inertial", "collision"):
            report.ignore(f"<link><{c.tag}>", f"line {c.line}")
    inertials = node.findall("inertial")
    if len(inertials) > 1:
        raise inertials[1].error("a link has at most one <inertial>")
    link.com = pos.copy()
    link.inertia = np.zeros((3, 3))
    if inertials:
        ine = inertials[0]
        mnode = ine.find("mass")
        if mnode is None:
            raise ine.error("an inertial needs <mass value='...'/>")
        m = float(_numbers(mnode, "value", 1, required=True)[0])
        if m < 0.0:
            raise mnode.error(f"must be >= 0, got {m}", "value")
        inode = ine.find("inertia")
        if inode is None:
            raise ine.error("an inertial needs <inertia ixx='...' .../>")
        comp = {k: float(_numbers(inode, k, 1, required=True)[0])
                for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        tensor = np.array([[comp["ixx"], comp["ixy"], comp["ixz"]],
                           [comp["ixy"], comp["iyy"], comp["iyz"]],
                           [comp["ixz"], comp["iyz"], comp["izz"]]])
        opos, orot = _origin(ine)
        r = (rot * orot).as_matrix()
        link.mass = m
        link.com = pos + rot.apply(opos)
        link.inertia = r @ tensor @ r.T
    for k, col in enumerate(node.findall("collision")):
        g = _collision(col, link, k, pos, rot, base_dir, report)
        if g is not None:
            link.geoms.append(g)


def _collision(col, link, k, pos, rot, base_dir, report):
    geo = col.find("geometry")
    if geo is None or not geo.children:
        raise col.error("a collision needs a <geometry> with a shape")
    shape = geo.children[0]
    opos, orot = _origin(col)
    name = col.attrib.get("name") or f"{link.name}/collision{k}"
    spec = GeomSpec(name=name, type=shape.tag, pos=pos + rot.apply(opos),
                    quat=(rot * orot).as_quat(), where=shape.where())
    if shape.tag == "box":
        spec.size = 0.5 * _numbers(shape, "size", 3, required=True)
        if np.any(spec.size <= 0.0):
            raise shape.error(f"sizes must be > 0, got '{shape.attrib['size']}'", "size")
    elif shape.tag == "sphere":
        spec.size = [_positive(shape, "radius")]
    elif shape.tag in ("cylinder", "capsule"):
        spec.size = [_positive(shape, "radius"), 0.5 * _positive(shape, "length")]
    elif shape.tag == "mesh":
        fn = shape.attrib.get("filename")
        if not fn:
            raise shape.error("is required", "filename")
        scale = _numbers(shape, "scale", 3, (1.0, 1.0, 1.0))
        try:
            verts, why = _mesh(fn, base_dir)
        except MeshFileError as e:
            raise shape.error(f"collision '{name}' of link '{link.name}': {e}",
                              "filename") from None
        if verts is None:
            report.ignore(f"collision mesh '{fn}' ({why})", f"line {shape.line}")
            link.dropped.append(f"collision mesh '{fn}' ({why})")
            return None
        spec.type = "convex"
        with np.errstate(over="ignore"):
            verts = verts * scale
        if not np.all(np.isfinite(verts)):
            raise shape.error(f"mesh '{fn}' scaled by {scale.tolist()} overflows", "scale")
        spec.vertices = meshes.convex_hull(verts, f"{shape.where()} (mesh file '{fn}')")
        report.notes.append(f"collision mesh '{fn}' of link '{link.name}' -> its convex hull "
                            f"({len(spec.vertices)} vertices)")
    else:
        raise shape.error(f"unknown collision shape <{shape.tag}>; URDF shapes are box, "
                          f"sphere, cylinder, capsule and mesh")
    return spec


def _mesh(filename, base_dir):
    """Vertices of a mesh file named in a URDF, or (None, reason) when it is not found or
    in a format tumble does not read. A file that is there but cannot be read raises
    MeshFileError."""
    rel = filename
    candidates = []
    if rel.startswith("file://"):
        candidates.append(rel[len("file://"):])
    elif rel.startswith("package://"):
        rest = rel[len("package://"):]
        candidates += [os.path.join(base_dir, rest),
                       os.path.join(base_dir, rest.split("/", 1)[-1])]
    else:
        candidates.append(os.path.join(base_dir, rel))
    reason = "not found"
    for path in candidates:
        if "\x00" not in path and os.path.exists(path):
            try:
                return read_mesh_vertices(path), None
            except MeshFileSkipped as e:
                reason = str(e)
    return None, reason


def _joint(j, pos, rot, report):
    """JointSpecs (world frame) of a URDF joint whose child frame is at (pos, rot)."""
    name = j.attrib["name"]
    jtype = j.attrib["type"]
    axis_node = j.find("axis")
    axis = _numbers(axis_node, "xyz", 3, (1.0, 0.0, 0.0)) if axis_node is not None \
        else np.array([1.0, 0.0, 0.0])
    if jtype in ("revolute", "continuous", "prismatic", "planar"):
        if norm(axis) < 1e-12:
            raise axis_node.error("is the zero vector", "xyz")
        big = float(np.max(np.abs(axis)))
        if big >= 1e150:                        # the squares would overflow: scale first
            axis = axis / big
        axis = rot.apply(axis / float(np.linalg.norm(axis)))
    limit = None
    lim = j.find("limit")
    if jtype in ("revolute", "prismatic"):
        if lim is None:
            raise j.error(f"a {jtype} joint needs <limit lower='...' upper='...'/>")
        lo = float(_numbers(lim, "lower", 1, (0.0,))[0])
        hi = float(_numbers(lim, "upper", 1, (0.0,))[0])
        if lo > hi:
            raise lim.error(f"lower {lo} is above upper {hi}", "lower")
        limit = (lo, hi)
    if lim is not None:
        for k in ("effort", "velocity"):
            if k in lim.attrib:
                report.ignore(f"joint limit {k}", f"line {lim.line}")
    damping = friction = 0.0
    dyn = j.find("dynamics")
    if dyn is not None:
        damping = float(_numbers(dyn, "damping", 1, (0.0,))[0])
        friction = float(_numbers(dyn, "friction", 1, (0.0,))[0])
        if damping < 0.0:
            raise dyn.error(f"must be >= 0, got {damping}", "damping")
        if friction < 0.0:
            raise dyn.error(f"must be >= 0, got {friction}", "friction")
    for c in j.children:
        if c.tag not in ("origin", "parent", "child", "axis", "limit", "dynamics"):
            report.ignore(f"<joint><{c.tag}>", f"line {c.line}")
    where = j.where()
    common = dict(anchor=pos.copy(), damping=damping, friction=friction, where=where)
    if jtype == "fixed":
        return []
    if jtype == "floating":
        return [JointSpec(name=name, type="free", axis=np.array([0.0, 0, 1]), **common)]
    if jtype in ("revolute", "continuous"):
        return [JointSpec(name=name, type="hinge", axis=axis, limit=limit, **common)]
    if jtype == "prismatic":
        return [JointSpec(name=name, type="slide", axis=axis, limit=limit, **common)]
    # planar: translation in the plane normal to the axis, rotation about it
    helper = np.array([0.0, 0, 1]) if abs(axis[2]) < 0.9 else np.array([1.0, 0, 0])
    u = np.cross(helper, axis)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    return [JointSpec(name=f"{name}:x", type="slide", axis=u, **common),
            JointSpec(name=f"{name}:y", type="slide", axis=v, **common),
            JointSpec(name=f"{name}:rot", type="hinge", axis=axis, **common)]
