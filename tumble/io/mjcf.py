"""Load MuJoCo MJCF models: ``tumble.load_mjcf(path_or_xml)`` -> Model.

What is read
------------
* ``<compiler>``: ``angle`` (degree, the MJCF default, or radian), ``eulerseq``,
  ``coordinate`` (local, or the old global), ``inertiafromgeom`` (auto, true, false),
  ``settotalmass``, ``boundmass``, ``boundinertia``, ``autolimits``, ``meshdir``/``assetdir``.
* ``<option>``: ``gravity`` and ``timestep`` (-> ``model.gravity``, ``model.timestep``,
  which ``World`` uses when no ``dt`` is given).
* ``<default>`` classes, nested, with ``class`` and ``childclass`` (on bodies and frames).
* ``<worldbody>``: bodies (``pos``, and ``quat``/``axisangle``/``euler``/``xyaxes``/``zaxis``;
  MJCF quaternions are w, x, y, z and are converted), ``<frame>``, ``mocap`` bodies
  (kinematic), ``<inertial>`` (``diaginertia`` or ``fullinertia``), geoms (plane, sphere,
  capsule, cylinder, box, with ``fromto``; ellipsoid -> the convex hull of 130 surface
  points with the exact ellipsoid mass; mesh -> the convex hull of an STL or OBJ file's
  vertices or of inline ``vertex`` data), ``density``/``mass``, ``friction`` (sliding
  coefficient; with ``condim`` 4 also the torsional one and with ``condim`` 6 the rolling
  one, as ``add_geom``'s ``torsional_friction``/``rolling_friction``; a pair takes the
  larger of each, as MuJoCo does), ``contype``/``conaffinity``, ``margin``; joints
  ``hinge``, ``slide``, ``ball``, ``free`` (and ``<freejoint>``) with ``range``/``limited``,
  ``ref``, ``stiffness`` (a spring toward the initial pose, run as the joint's implicit PD
  servo), ``damping``, ``frictionloss``. Planes are infinite (their MJCF size only sets
  how they are drawn).
* ``<contact><exclude body1 body2>``.
* ``<actuator>``: ``motor``, ``position`` and the ``general`` actuators equivalent to them,
  on joints, read into :class:`ActuatorSpec` (see :func:`_add_actuators`).

How the tree becomes tumble bodies and joints (welding, hinges through one point merged
into universal or ball joints, chains through light auxiliary bodies) is described in
``tumble.io._assembly``. tumble bodies sit at their centre of mass with the MJCF body's
orientation (``model.body_iquat`` then gives the principal axes in that frame); the
initial pose is the model pose (MuJoCo's ``qpos0``), and joint limits are re-expressed
relative to it (``range - ref``).

Everything the loader reads but does not simulate - elements (tendons, sensors,
equality constraints, ...), physics attributes (armature, springref, condim 1, solref,
...), and visual-only elements (lights, cameras, textures) - is named in ONE
``TumbleWarning`` per load, together with every merge. Purely cosmetic attributes
(``rgba``, ``material``, ``group``, ``user``) are skipped silently.
"""
import math
import os
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ModelError
from ..model import mass as massprops
from ..model import meshes
from ..model.builder import ModelBuilder
from ._assembly import GeomSpec, JointSpec, LinkSpec, LoadReport, assemble
from ._meshfile import MeshFileError, MeshFileSkipped, read_mesh_vertices
from ._files import read_file
from ._xml import (MAX_XML_BYTES, Budget, boolean, choice, floats, norm, parse_xml,
                   parse_xml_text)

__all__ = ["load_mjcf", "parse_mjcf", "ActuatorSpec"]

_ANGLE = {"degree": math.pi / 180.0, "radian": 1.0}
_ORIENTATIONS = ("quat", "axisangle", "euler", "xyaxes", "zaxis")
_FRAME_ATTRS = {"pos", *_ORIENTATIONS}
_COSMETIC = {"rgba", "material", "group", "user", "class"}
# Attributes the loader uses, per element.
_USED = {
    "body": {"name", "childclass", "mocap"} | _FRAME_ATTRS,
    "frame": {"name", "childclass"} | _FRAME_ATTRS,
    "geom": {"name", "type", "size", "fromto", "contype", "conaffinity", "friction", "mass",
             "density", "margin", "mesh", "condim"} | _FRAME_ATTRS,
    "joint": {"name", "type", "pos", "axis", "range", "limited", "damping", "frictionloss",
              "ref", "stiffness"},
    "freejoint": {"name"},
    "inertial": {"mass", "diaginertia", "fullinertia"} | _FRAME_ATTRS,
    "motor": {"name", "joint", "jointinparent", "gear", "ctrlrange", "forcerange",
              "ctrllimited", "forcelimited"},
    "mesh": {"name", "file", "scale", "vertex"},
    "exclude": {"name", "body1", "body2"},
}
_USED["position"] = _USED["motor"] | {"kp", "kv"}
_USED["general"] = _USED["motor"] | {"gaintype", "biastype", "gainprm", "biasprm", "dyntype"}
# Unsupported attributes whose value here means "off": not worth a mention.
_OFF = {("joint", "armature"): "0", ("joint", "springref"): "0",
        ("joint", "margin"): "0", ("geom", "condim"): "3", ("geom", "priority"): "0",
        ("geom", "gap"): "0", ("body", "gravcomp"): "0", ("geom", "solmix"): "1",
        ("freejoint", "align"): "auto"}
_COMPILER_USED = {"angle", "eulerseq", "coordinate", "inertiafromgeom", "settotalmass",
                  "boundmass", "boundinertia", "autolimits", "meshdir", "assetdir"}
# Compiler attributes with no effect on what tumble simulates.
_COMPILER_HARMLESS = {"texturedir", "strippath", "usethread", "discardvisual", "convexhull",
                      "fusestatic", "saveinertial", "fitaabb", "alignfree", "exactmeshinertia",
                      "lengthrange", "inertiagrouprange"}
_VISUAL_TOP = {"visual", "statistic", "size", "custom", "extension"}
_VISUAL_BODY = {"site", "camera", "light"}
_GEOM_TYPES = {"plane", "sphere", "capsule", "cylinder", "box", "ellipsoid", "mesh", "hfield",
               "sdf"}
# Sphere sampling for ellipsoid hulls: latitude rings x longitudes (+ 2 poles = 130 points).
_ELLIPSOID_RINGS, _ELLIPSOID_SEGMENTS = 8, 16
#: Most ``<include>`` elements one model may expand (each use of a file counts), and the
#: deepest chain of files including files. XML size, element count and nesting are capped
#: in ``tumble.io._xml`` (``MAX_XML_BYTES``, ``MAX_ELEMENTS``, ``MAX_DEPTH``).
MAX_INCLUDES = 1000
MAX_INCLUDE_DEPTH = 20


@dataclass
class ActuatorSpec:
    """An MJCF actuator on a joint, in tumble terms.

    name : actuator name. joint : tumble joint name; dof : its degree of freedom the
    actuator drives (merged hinges share one tumble joint). source_joint : the MJCF joint.
    kind : 'motor' (force = gear * ctrl) or 'position' (force = gear * kp (ctrl - q) - kv qd
    in the MJCF joint's coordinate q). gear : MJCF gear times the sign relating the MJCF
    axis to the tumble DoF. ref : the MJCF joint's ``ref`` (q = ref + sign * tumble q).
    ctrlrange, forcerange : (lo, hi) or None when not limited; ctrllimited : bool.
    where : the element's file and line, for messages.
    """
    name: str
    joint: str
    dof: int
    kind: str
    gear: float
    kp: float = 0.0
    kv: float = 0.0
    ctrlrange: object = None
    forcerange: object = None
    ctrllimited: bool = False
    source_joint: str = ""
    ref: float = 0.0
    where: str = ""


def _add_actuators(builder, specs):
    """Pass actuator specs to ``builder.add_actuator`` when the builder has it.

    Returns True when they were added (or there were none), False when the builder has
    no actuators (the caller then names them in the load warning).
    """
    if not specs:
        return True
    if not hasattr(builder, "add_actuator"):
        return False
    for s in specs:
        try:
            builder.add_actuator(name=s.name, joint=s.joint, dof=s.dof, kind=s.kind,
                                 gear=s.gear, kp=s.kp, kv=s.kv, ctrlrange=s.ctrlrange,
                                 forcerange=s.forcerange)
        except ModelError as e:
            raise ModelError(f"{s.where}: {e}" if s.where else str(e)) from None
    return True


def load_mjcf(source, *, merge_hinges=True):
    """Load an MJCF model (a file path, or the XML text itself) as a validated Model.

    merge_hinges : merge hinges through one point into universal and ball joints (default);
        False joins them through light auxiliary bodies instead (exact per-hinge limits).
    Raises ModelError naming the element, attribute and line of anything malformed; warns
    once (TumbleWarning) listing what it could not simulate as written.
    """
    builder, _ = parse_mjcf(source, merge_hinges=merge_hinges, _stacklevel=4)
    return builder.build()


def parse_mjcf(source, *, merge_hinges=True, _stacklevel=3):
    """Read an MJCF model into a ``ModelBuilder`` (not yet built, so more can be added).

    Returns ``(builder, report)``; the :class:`~tumble.io._assembly.LoadReport` maps MJCF
    body and joint names to tumble ones, holds the actuator specs and lists what was
    ignored or merged.
    """
    budget = Budget()
    root, base_dir, name = parse_xml(source, "load_mjcf", budget)
    loader = _MJCF(name, base_dir, merge_hinges, budget)
    builder = loader.load(root)
    loader.report.warn("load_mjcf", stacklevel=_stacklevel)
    return builder, loader.report


# ------------------------------------------------------------------ resolved attributes
class _Attrs:
    """An element's attributes over those of its default class; each value remembers the
    node it came from, so errors point at the right line."""

    def __init__(self, node, defaults=None):
        self.node = node
        self.vals = dict(defaults or {})
        self.vals.update({k: (v, node) for k, v in node.attrib.items()})

    def has(self, attr):
        return attr in self.vals

    def str(self, attr, default=None):
        return self.vals[attr][0] if attr in self.vals else default

    def floats(self, attr, default=None, n=None, min_n=None, max_n=None):
        if attr not in self.vals:
            return default
        v, node = self.vals[attr]
        return floats(node, attr, v, n=n, min_n=min_n, max_n=max_n)

    def float(self, attr, default=None):
        out = self.floats(attr, n=1)
        return default if out is None else out[0]

    def vec(self, attr, n, default=None):
        out = self.floats(attr, n=n)
        return (None if default is None else np.array(default, float)) if out is None \
            else np.array(out)

    def bool(self, attr, default, allow_auto=False):
        if attr not in self.vals:
            return default
        v, node = self.vals[attr]
        return boolean(node, attr, v, allow_auto)

    def choice(self, attr, default, options):
        if attr not in self.vals:
            return default
        v, node = self.vals[attr]
        return choice(node, attr, v, options)

    def int(self, attr, default):
        if attr not in self.vals:
            return default
        v, node = self.vals[attr]
        x = floats(node, attr, v, n=1)[0]
        if x != int(x) or x < 0:
            raise node.error(f"must be a non-negative integer, got '{v}'", attr)
        return int(x)

    def nonneg(self, attr, default):
        x = self.float(attr, default)
        if x < 0.0:
            v, node = self.vals[attr]
            raise node.error(f"must be >= 0, got '{v}'", attr)
        return x

    def positive(self, attr):
        """A required number > 0."""
        x = self.float(attr)
        if x is None:
            raise self.node.error("is required", attr)
        if not x > 0.0:
            raise self.error(attr, f"must be > 0, got '{self.vals[attr][0]}'")
        return x

    def error(self, attr, message):
        node = self.vals[attr][1] if attr in self.vals else self.node
        return node.error(message, attr)


def _unit(node, attr, v):
    v = np.asarray(v, float)
    big = float(np.max(np.abs(v))) if v.size else 0.0
    if big >= 1e150:                  # the squares would overflow: scale first
        v = v / big
    n = float(np.linalg.norm(v))
    if n * (big if big >= 1e150 else 1.0) < 1e-12:
        raise node.error("is the zero vector", attr)
    return v / n


def _plain_scale(v):
    """1 for vectors whose squares do not overflow (so they are used exactly as before),
    else their largest component."""
    big = float(np.max(np.abs(v)))
    return 1.0 if big < 1e150 else big


def _quat_z_to(d):
    """Rotation turning +z onto the unit vector d along the shortest arc."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ d)
    if c < -1.0 + 1e-12:
        return Rotation.from_quat([1.0, 0.0, 0.0, 0.0])
    axis = np.cross(z, d)
    return Rotation.from_quat([axis[0], axis[1], axis[2], 1.0 + c])  # normalised by scipy


# ------------------------------------------------------------------------ the loader
class _MJCF:
    def __init__(self, name, base_dir, merge_hinges, budget=None):
        self.name = name
        self.base_dir = base_dir
        self.merge_hinges = merge_hinges
        self.report = LoadReport(source=name)
        self.angle = _ANGLE["degree"]
        self.eulerseq = "xyz"
        self.global_coords = False
        self.inertiafromgeom = "auto"
        self.settotalmass = None
        self.boundmass = 0.0
        self.boundinertia = 0.0
        self.autolimits = True
        self.meshdir = base_dir
        self.gravity = np.array([0.0, 0.0, -9.81])
        self.timestep = 0.002                     # MuJoCo's default
        self.classes = {"main": {}}
        self.meshes = {}
        self.links = []
        self.link_nodes = []
        self.geom_mass = []                       # per link: [(m, com_w, I_w)]
        self.inertial = []                        # per link: (m, com_w, I_w) or None
        self.joint_nodes = {}                     # MJCF joint name -> (node, ref)
        self.world_geoms = []
        self.geom_count = 0
        self.budget = Budget() if budget is None else budget
        self.includes = 0

    def _loc(self, node):
        """Where a node is, for the warning: its line, and its file when included."""
        return f"line {node.line}" if node.source == self.name else \
            f"{node.source} line {node.line}"

    # ------------------------------------------------------------------ top level
    def load(self, root):
        if root.tag != "mujoco":
            raise root.error(f"the root element must be <mujoco>, got <{root.tag}>")
        self._expand_includes(root)
        for c in root.findall("compiler"):
            self._compiler(c)
        for c in root.children:
            tag = c.tag
            if tag in ("compiler", "worldbody", "actuator", "contact"):
                continue
            if tag == "option":
                self._option(c)
            elif tag == "default":
                self._defaults(c, None, {})
            elif tag == "asset":
                self._assets(c)
            elif tag in _VISUAL_TOP:
                self.report.ignore(f"<{tag}>", self._loc(c), visual=True)
            else:
                self.report.ignore(f"<{tag}>", self._loc(c))
        for c in root.findall("worldbody"):
            self._walk(c, -1, np.zeros(3), Rotation.identity(), None)
        self._mass_properties()
        builder = ModelBuilder(gravity=self.gravity, timestep=self.timestep)
        self.report.timestep = self.timestep
        assemble(builder, self.links, self.report, merge_hinges=self.merge_hinges,
                 collide_with_world=True, world_geoms=self.world_geoms)
        for c in root.findall("contact"):
            self._contact(c, builder)
        specs = []
        for c in root.findall("actuator"):
            specs += self._actuators(c)
        self.report.actuators = specs
        if not _add_actuators(builder, specs):
            self.report.ignore(f"<actuator> ({len(specs)} actuators: this tumble has no "
                               f"actuators in the builder yet)",
                               self._loc(root.findall("actuator")[0]))
        return builder

    def _expand_includes(self, root):
        """Replace every ``<include file>`` by the children of that file's root, in place
        (files resolve against the main file's directory). Iterative; refuses a file that
        includes itself, includes nested more than ``MAX_INCLUDE_DEPTH`` deep, more than
        ``MAX_INCLUDES`` of them, and (through the budget) more XML than the loader reads."""
        work = [(root, frozenset())]             # elements whose children to expand
        while work:
            node, chain = work.pop()
            out = []
            pending = [(c, chain) for c in reversed(node.children)]
            while pending:
                c, seen = pending.pop()
                if c.tag != "include":
                    c.parent = node
                    out.append(c)
                    if c.children:
                        work.append((c, seen))
                    continue
                f = c.attrib.get("file")
                if not f:
                    raise c.error("is required", "file")
                path = os.path.join(self.base_dir, f)
                if path in seen:
                    raise c.error(f"'{f}' includes itself", "file")
                if len(seen) >= MAX_INCLUDE_DEPTH:
                    raise c.error(f"includes nested more than {MAX_INCLUDE_DEPTH} deep "
                                  f"(tumble.io.mjcf.MAX_INCLUDE_DEPTH)", "file")
                self.includes += 1
                if self.includes > MAX_INCLUDES:
                    raise c.error(f"more than {MAX_INCLUDES} includes in one model, the most "
                                  f"tumble expands (tumble.io.mjcf.MAX_INCLUDES)", "file")
                try:
                    data = read_file(path, "include", MAX_XML_BYTES,
                                     cap_name="tumble.io._xml.MAX_XML_BYTES")
                    self.budget.add_bytes(len(data), os.path.basename(path))
                except ModelError as e:
                    raise c.error(str(e), "file") from None
                sub = parse_xml_text(data, os.path.basename(path), self.budget)
                if sub.tag != "mujoco":
                    raise sub.error(f"an included file's root must be <mujoco>, got <{sub.tag}>")
                pending.extend((k, seen | {path}) for k in reversed(sub.children))
            node.children = out

    def _compiler(self, node):
        a = _Attrs(node)
        if a.has("angle"):
            self.angle = _ANGLE[a.choice("angle", "degree", set(_ANGLE))]
        if a.has("eulerseq"):
            seq = a.str("eulerseq")
            if len(seq) != 3 or any(ch not in "xyzXYZ" for ch in seq):
                raise node.error(f"must be 3 of x, y, z, X, Y, Z, got '{seq}'", "eulerseq")
            self.eulerseq = seq
        self.global_coords = a.choice("coordinate", "local", {"local", "global"}) == "global" \
            if a.has("coordinate") else self.global_coords
        if a.has("inertiafromgeom"):
            v = a.choice("inertiafromgeom", "auto", {"true", "false", "auto"})
            self.inertiafromgeom = v
        if a.has("settotalmass"):
            v = a.float("settotalmass")
            self.settotalmass = v if v > 0.0 else None
        self.boundmass = a.nonneg("boundmass", self.boundmass)
        self.boundinertia = a.nonneg("boundinertia", self.boundinertia)
        self.autolimits = a.bool("autolimits", self.autolimits)
        for key in ("assetdir", "meshdir"):
            if a.has(key):
                self.meshdir = os.path.join(self.base_dir, a.str(key))
        for k in node.attrib:
            if k not in _COMPILER_USED and k not in _COMPILER_HARMLESS:
                if k == "balanceinertia" and node.attrib[k] == "false":
                    continue
                self.report.ignore(f"compiler {k}", self._loc(node))

    def _option(self, node):
        a = _Attrs(node)
        if a.has("timestep"):
            self.timestep = a.positive("timestep")
        if a.has("gravity"):
            self.gravity = a.vec("gravity", 3)
        for k in node.attrib:
            if k not in ("timestep", "gravity"):
                self.report.ignore(f"option {k}", self._loc(node))
        for c in node.children:
            self.report.ignore(f"<option><{c.tag}>", self._loc(c))

    def _defaults(self, node, parent, inherited):
        """Default classes of a top-level ``<default>`` and those nested in it (parents
        first, in file order; iterative, so any nesting the XML reader allows works)."""
        stack = [(node, parent, inherited)]
        while stack:
            node, parent, inherited = stack.pop()
            name = node.attrib.get("class")
            if name is None:
                if parent is not None:
                    raise node.error("a nested <default> needs a class name", "class")
                name = "main"
            if parent is not None and name in self.classes:
                raise node.error(f"default class '{name}' is defined twice", "class")
            mine = {tag: dict(attrs) for tag, attrs in inherited.items()}
            for c in node.children:
                if c.tag == "default":
                    continue
                entry = mine.setdefault(c.tag, {})
                entry.update({k: (v, c) for k, v in c.attrib.items()})
            if name == "main" and parent is None:
                for tag, attrs in self.classes["main"].items():
                    for k, v in attrs.items():
                        mine.setdefault(tag, {}).setdefault(k, v)
            self.classes[name] = mine
            stack.extend((c, name, mine) for c in reversed(node.children) if c.tag == "default")

    def _attrs(self, node, tag, childclass):
        cls = node.attrib.get("class", childclass or "main")
        if cls not in self.classes:
            raise node.error(f"unknown default class '{cls}'", "class")
        a = _Attrs(node, self.classes[cls].get(tag, {}))
        used = _USED.get(tag, set())
        for k, (v, _) in a.vals.items():
            if k in used or k in _COSMETIC:
                continue
            if _OFF.get((tag, k)) is not None and _same_number(v, _OFF[(tag, k)]):
                continue
            self.report.ignore(f"{tag} {k}", self._loc(node))
        return a

    def _assets(self, node):
        for c in node.children:
            if c.tag == "mesh":
                a = self._attrs(c, "mesh", None)
                f = a.str("file")
                name = a.str("name") or (os.path.splitext(os.path.basename(f))[0] if f else None)
                if name is None:
                    raise c.error("a mesh needs a name or a file", "name")
                self.meshes[name] = (a, f)
            elif c.tag in ("texture", "material", "skin"):
                self.report.ignore(f"<asset><{c.tag}>", self._loc(c), visual=True)
            else:
                self.report.ignore(f"<asset><{c.tag}>", self._loc(c))

    # ------------------------------------------------------------------- frames
    def _orientation(self, a):
        given = [k for k in _ORIENTATIONS if a.has(k)]
        if len(given) > 1:
            raise a.error(given[1], f"give one orientation, not {' and '.join(given)}")
        if not given:
            return Rotation.identity()
        k = given[0]
        v = a.floats(k, n={"quat": 4, "axisangle": 4, "euler": 3, "xyaxes": 6, "zaxis": 3}[k])
        node = a.vals[k][1]
        if k == "quat":
            q = np.array([v[1], v[2], v[3], v[0]])          # MJCF is w, x, y, z
            if norm(q) < 1e-12:
                raise node.error("is zero", k)
            return Rotation.from_quat(q / _plain_scale(q))
        if k == "axisangle":
            return Rotation.from_rotvec(_unit(node, k, v[:3]) * v[3] * self.angle)
        if k == "euler":
            r = Rotation.identity()
            for ax, ang in zip(self.eulerseq, v):
                step = Rotation.from_rotvec(np.eye(3)["xyz".index(ax.lower())] * ang * self.angle)
                r = r * step if ax.islower() else step * r    # lower: moving axes
            return r
        if k == "xyaxes":
            x = _unit(node, k, v[:3])
            y = np.array(v[3:]) - (np.array(v[3:]) @ x) * x
            y = _unit(node, k, y)
            return Rotation.from_matrix(np.column_stack([x, y, np.cross(x, y)]))
        return _quat_z_to(_unit(node, k, v))

    def _pose(self, a, ppos, prot):
        """World pose (pos, Rotation) of an element with pos/orientation attributes."""
        pos = a.vec("pos", 3, (0.0, 0.0, 0.0))
        rot = self._orientation(a)
        if self.global_coords:
            return pos, rot
        return ppos + prot.apply(pos), prot * rot

    # -------------------------------------------------------------------- bodies
    def _walk(self, node, link, ppos, prot, childclass):
        """Children of the world body, a body or a frame; ``link`` -1 is the world.

        Depth first in file order with an explicit stack (no recursion, so any nesting the
        XML reader allows works): each entry is an element and its parent's link, world
        pose and child class."""
        stack = [(c, link, ppos, prot, childclass) for c in reversed(node.children)]
        while stack:
            c, link, ppos, prot, childclass = stack.pop()
            tag = c.tag
            if tag == "body":
                index, pos, rot, cc = self._body(c, link, ppos, prot, childclass)
                stack.extend((k, index, pos, rot, cc) for k in reversed(c.children))
            elif tag == "frame":
                a = self._attrs(c, "frame", childclass)
                fpos, frot = self._pose(a, ppos, prot)
                cc = c.attrib.get("childclass", childclass)
                if cc is not None and cc not in self.classes:
                    raise c.error(f"unknown default class '{cc}'", "childclass")
                stack.extend((k, link, fpos, frot, cc) for k in reversed(c.children))
            elif tag == "geom":
                self._geom(c, link, ppos, prot, childclass)
            elif tag in ("joint", "freejoint"):
                if link < 0:
                    raise c.error("a joint cannot be in the world body; put it in a <body>")
                self._joint(c, link, ppos, prot, childclass)
            elif tag == "inertial":
                if link < 0:
                    raise c.error("the world body has no inertial")
                self._inertial(c, link, ppos, prot)
            elif tag in _VISUAL_BODY:
                self.report.ignore(f"<{tag}>", self._loc(c), visual=True)
            else:
                self.report.ignore(f"<{tag}>", self._loc(c))

    def _body(self, node, parent, ppos, prot, childclass):
        """Add the link of a ``<body>``; returns (its index, world pos, Rotation, the child
        class its children inherit)."""
        cc = node.attrib.get("childclass", childclass)
        if cc is not None and cc not in self.classes:
            raise node.error(f"unknown default class '{cc}'", "childclass")
        a = _Attrs(node)
        for k in node.attrib:
            if k not in _USED["body"] and k not in _COSMETIC and not (
                    k == "gravcomp" and _same_number(node.attrib[k], "0")):
                self.report.ignore(f"body {k}", self._loc(node))
        pos, rot = self._pose(a, ppos, prot)
        index = len(self.links)
        name = a.str("name") or f"body{index + 1}"
        mocap = a.bool("mocap", False)
        if mocap and parent >= 0:
            raise node.error("a mocap body must be a child of the world body", "mocap")
        self.links.append(LinkSpec(name=name, parent=parent, pos=pos, quat=rot.as_quat(),
                                   kind="kinematic" if mocap else "dynamic",
                                   where=node.where()))
        self.link_nodes.append(node)
        self.geom_mass.append([])
        self.inertial.append(None)
        return index, pos, rot, cc

    def _inertial(self, node, link, ppos, prot):
        if self.inertial[link] is not None:
            raise node.error("a body has at most one <inertial>")
        a = _Attrs(node)
        if not a.has("pos"):
            raise node.error("is required", "pos")
        if not a.has("mass"):
            raise node.error("is required", "mass")
        m = a.nonneg("mass", 0.0)
        pos, rot = self._pose(a, ppos, prot)
        if a.has("diaginertia") == a.has("fullinertia"):
            raise node.error("give diaginertia or fullinertia (exactly one)",
                             "diaginertia" if not a.has("diaginertia") else "fullinertia")
        if a.has("diaginertia"):
            d = a.floats("diaginertia", n=3)
            if min(d) < 0.0:
                raise a.error("diaginertia", f"moments must be >= 0, got {d}")
            tensor = np.diag(d)
        else:
            xx, yy, zz, xy, xz, yz = a.floats("fullinertia", n=6)
            tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        r = rot.as_matrix()
        self.inertial[link] = (m, pos, r @ tensor @ r.T)

    # --------------------------------------------------------------------- geoms
    def _geom(self, node, link, ppos, prot, childclass):
        a = self._attrs(node, "geom", childclass)
        self.geom_count += 1
        owner = self.links[link].name if link >= 0 else "world"
        name = a.str("name") or f"{owner}/geom{self.geom_count}"
        default_type = "mesh" if a.has("mesh") and not a.has("type") else "sphere"
        gtype = a.choice("type", default_type, _GEOM_TYPES)
        if gtype in ("hfield", "sdf"):
            self.report.ignore(f"geom type {gtype}", self._loc(node))
            return
        size = a.floats("size", [], min_n=1, max_n=3)
        if a.has("fromto") and gtype in ("capsule", "cylinder", "box", "ellipsoid"):
            ft = a.floats("fromto", n=6)
            p0, p1 = np.array(ft[:3]), np.array(ft[3:])
            if not self.global_coords:
                p0, p1 = ppos + prot.apply(p0), ppos + prot.apply(p1)
            d = p1 - p0
            length = float(np.linalg.norm(d))
            if length < 1e-12:
                raise a.error("fromto", "its two points coincide")
            pos, rot = 0.5 * (p0 + p1), _quat_z_to(d / length)
            half = 0.5 * length
            need = 1 if gtype in ("capsule", "cylinder") else 2
            if len(size) < need:
                raise a.error("size", f"a {gtype} with fromto needs {need} size value(s)")
            size = size[:need] + [half]
        else:
            pos, rot = self._pose(a, ppos, prot)
        fr = a.floats("friction", [1.0], min_n=1, max_n=3)
        if min(fr) < 0.0:
            raise a.error("friction", f"must be >= 0, got {' '.join(f'{x:g}' for x in fr)}")
        condim = a.int("condim", 3)
        if condim not in (1, 3, 4, 6):
            raise a.error("condim", f"must be 1, 3, 4 or 6, got {condim}")
        # MuJoCo's defaults for the torsional and rolling coefficients (lengths, m)
        spin = (fr + [0.005, 0.0001][len(fr) - 1:])[1:]
        torsional = spin[0] if condim >= 4 else 0.0
        rolling = spin[1] if condim == 6 else 0.0
        if condim == 1:
            self.report.ignore("geom condim 1 (frictionless: simulated with friction)",
                               self._loc(node))
        elif condim == 3 and not np.allclose(spin, [0.005, 0.0001]):
            self.report.ignore("geom friction (torsional, rolling) with condim 3",
                               self._loc(node))
        spec = GeomSpec(name=name, type=gtype, pos=pos, quat=rot.as_quat(),
                        friction=fr[0], torsional=torsional, rolling=rolling,
                        contype=a.int("contype", 1),
                        conaffinity=a.int("conaffinity", 1), margin=a.nonneg("margin", 0.0),
                        where=node.where())
        props = self._shape(a, spec, gtype, size, rot)       # sets type, size, vertices
        if props is None:
            if link >= 0:
                self.links[link].dropped.append(spec.dropped)
            return
        m_unit, com_g, tensor_unit = props                   # at density 1
        if link < 0:
            self.world_geoms.append(spec)
        else:
            self.links[link].geoms.append(spec)
        if gtype == "plane" or link < 0:
            return
        if a.has("mass"):
            m = a.nonneg("mass", 0.0)
            dens = m / m_unit
        else:
            dens = a.nonneg("density", 1000.0)
            m = dens * m_unit
        r = rot.as_matrix()
        self.geom_mass[link].append((m, pos + r @ com_g, r @ (dens * tensor_unit) @ r.T))

    def _shape(self, a, spec, gtype, size, rot):
        """Fill the spec's tumble type/size/vertices; return (mass, com, inertia) at density
        1 in the geom frame (None when the geom is dropped)."""
        def need(k, what):
            if len(size) < k:
                raise a.error("size", f"a {gtype} needs {what}, got {len(size)} value(s)")
            for v in size[:k]:
                if not v > 0.0:
                    raise a.error("size", f"a {gtype}'s {what} must be > 0, got {size[:k]}")
            return np.array(size[:k], float)

        if gtype == "plane":
            spec.type = "plane"
            return 0.0, np.zeros(3), np.zeros((3, 3))
        if gtype in ("sphere", "capsule", "cylinder", "box"):
            s = need({"sphere": 1, "capsule": 2, "cylinder": 2, "box": 3}[gtype],
                     {"sphere": "a radius", "capsule": "radius and half-length",
                      "cylinder": "radius and half-length", "box": "three half-sizes"}[gtype])
            spec.size = s
            m, moments = massprops.shape_mass(gtype, np.pad(s, (0, 3 - len(s))), 1.0)
            return m, np.zeros(3), np.diag(moments)
        if gtype == "ellipsoid":
            radii = need(3, "three radii")
            spec.type = "convex"
            spec.vertices = _ellipsoid_points(radii)
            self.report.notes.append(f"ellipsoid geom '{spec.name}' -> the convex hull of "
                                     f"{len(spec.vertices)} points on it (mass exact)")
            m = 4.0 / 3.0 * math.pi * radii.prod()
            x, y, z = radii ** 2
            return m, np.zeros(3), m / 5.0 * np.diag([y + z, x + z, x + y])
        # mesh
        mname = a.str("mesh")
        if mname is None:
            raise a.error("mesh", "a mesh geom needs the mesh attribute")
        if mname not in self.meshes:
            raise a.error("mesh", f"unknown mesh '{mname}'; meshes are {sorted(self.meshes)}")
        verts, skipped = self._mesh_vertices(mname, a)
        if verts is None:
            spec.dropped = f"mesh geom '{spec.name}' ({skipped})"
            return None
        spec.type = "convex"
        try:
            spec.vertices = meshes.convex_hull(verts, spec.where)
            m, com, tensor = meshes.convex_mass(spec.vertices, 1.0, spec.where)
        except ModelError as e:
            f = self.meshes[mname][1]
            raise ModelError(f"mesh '{mname}'" + (f" (file '{f}')" if f else "") + f": {e}") \
                from None
        self.report.notes.append(f"mesh geom '{spec.name}' -> the convex hull of mesh "
                                 f"'{mname}' ({len(spec.vertices)} vertices; mass from the hull)")
        return m, com, tensor

    def _mesh_vertices(self, mname, geom):
        """(vertices, None) of mesh ``mname`` used by the geom whose attributes are ``geom``;
        (None, why) when its file is missing or in a format tumble does not read (the geom
        is then dropped and named in the warning). A file that is there but cannot be read
        raises ModelError naming the geom, the mesh and the file."""
        a, f = self.meshes[mname]
        scale = a.vec("scale", 3, (1.0, 1.0, 1.0))
        if a.has("vertex"):
            v = a.floats("vertex")
            if len(v) % 3:
                raise a.error("vertex", f"needs a multiple of 3 numbers, got {len(v)}")
            verts = np.array(v).reshape(-1, 3)
        elif f is not None:
            if "\x00" in f:
                raise a.error("file", "a file name cannot hold a NUL byte")
            try:
                verts = read_mesh_vertices(os.path.join(self.meshdir, f))
            except MeshFileSkipped as e:
                self.report.ignore(f"mesh '{mname}' ({e})", self._loc(a.node))
                return None, f"mesh '{mname}': {e}"
            except MeshFileError as e:
                raise geom.error("mesh", f"mesh '{mname}' (at {self._loc(a.node)}): {e}") \
                    from None
        else:
            raise a.node.error("a mesh needs file or vertex")
        with np.errstate(over="ignore"):
            verts = verts * scale
        if not np.all(np.isfinite(verts)):
            raise a.error("scale", f"mesh '{mname}' scaled by {scale.tolist()} overflows")
        return verts, None

    # -------------------------------------------------------------------- joints
    def _joint(self, node, link, ppos, prot, childclass):
        free = node.tag == "freejoint"
        a = self._attrs(node, node.tag, childclass)
        spec_link = self.links[link]
        jtype = "free" if free else a.choice("type", "hinge", {"hinge", "slide", "ball", "free"})
        name = a.str("name") or f"{spec_link.name}/joint{len(spec_link.joints)}"
        if name in self.joint_nodes:
            raise node.error(f"a joint named '{name}' already exists", "name")
        if jtype == "free":
            if spec_link.parent >= 0:
                raise node.error(f"a free joint must be in a child of the world body, not in "
                                 f"body '{spec_link.name}' under "
                                 f"'{self.links[spec_link.parent].name}'")
            spec_link.joints.append(JointSpec(name=name, type="free", anchor=spec_link.pos,
                                              axis=np.array([0.0, 0, 1]), where=node.where()))
            self.joint_nodes[name] = (node, 0.0)
            return
        pos = a.vec("pos", 3, (0.0, 0.0, 0.0))
        axis = _unit(a.vals["axis"][1] if a.has("axis") else node, "axis",
                     a.vec("axis", 3, (0.0, 0.0, 1.0)))
        if self.global_coords:
            anchor, axis_w = pos, axis
        else:
            anchor, axis_w = ppos + prot.apply(pos), prot.apply(axis)
        ang = self.angle if jtype in ("hinge", "ball") else 1.0
        rng = a.floats("range", n=2)
        limited = a.bool("limited", "auto", allow_auto=True)
        if limited == "auto":
            limited = self.autolimits and rng is not None
        limit = None
        ref = a.float("ref", 0.0) * ang
        if limited:
            if rng is None:
                raise node.error("a limited joint needs a range", "range")
            lo, hi = rng[0] * ang, rng[1] * ang
            if jtype == "ball":
                if lo != 0.0 or hi <= 0.0:
                    raise a.error("range", f"a ball joint's range is (0, max angle), got {rng}")
                limit = (-hi, hi)
                self.report.notes.append(f"ball joint '{name}': the cone limit {rng[1]:g} "
                                         f"becomes a box on each rotation-vector coordinate")
            else:
                if lo >= hi:
                    raise a.error("range", f"lower {rng[0]} must be below upper {rng[1]}")
                limit = (lo - ref, hi - ref)
        spec_link.joints.append(JointSpec(
            name=name, type=jtype, anchor=anchor, axis=axis_w, limit=limit,
            damping=a.nonneg("damping", 0.0), friction=a.nonneg("frictionloss", 0.0),
            stiffness=a.nonneg("stiffness", 0.0) if jtype != "free" else 0.0,
            where=node.where()))
        self.joint_nodes[name] = (node, ref)

    # -------------------------------------------------------------- mass properties
    def _mass_properties(self):
        ifg = self.inertiafromgeom
        for i, link in enumerate(self.links):
            if self.inertial[i] is not None and ifg != "true":
                m, com, tensor = self.inertial[i]
            elif ifg != "false" and any(p[0] > 0.0 for p in self.geom_mass[i]):
                parts = [p for p in self.geom_mass[i] if p[0] > 0.0]
                m, com, tensor = massprops.combine(*zip(*parts))
            else:
                m, com, tensor = 0.0, link.pos.copy(), np.zeros((3, 3))
            if self.boundmass > 0.0 and 0.0 < m < self.boundmass:
                m = self.boundmass
            if self.boundinertia > 0.0 and m > 0.0:
                w, v = np.linalg.eigh(tensor)
                tensor = v @ np.diag(np.maximum(w, self.boundinertia)) @ v.T
            link.mass, link.com, link.inertia = float(m), np.asarray(com, float), tensor
        if self.settotalmass is not None:
            total = sum(link.mass for link in self.links)
            if total > 0.0:
                k = self.settotalmass / total
                for link in self.links:
                    link.mass *= k
                    link.inertia = link.inertia * k

    # ------------------------------------------------------------------ contacts
    def _contact(self, node, builder):
        for c in node.children:
            if c.tag != "exclude":
                self.report.ignore(f"<contact><{c.tag}>", self._loc(c))
                continue
            a = self._attrs(c, "exclude", None)
            bodies = []
            for key in ("body1", "body2"):
                b = a.str(key)
                if b is None:
                    raise c.error("is required", key)
                if b == "world":
                    bodies.append(None)
                    continue
                if b not in self.report.body_map:
                    raise c.error(f"unknown body '{b}'", key)
                bodies.append(self.report.body_map[b])
            if bodies[0] != bodies[1]:
                builder.exclude_collision(bodies[0], bodies[1])

    # ----------------------------------------------------------------- actuators
    def _actuators(self, node):
        specs = []
        for i, c in enumerate(node.children):
            tag = c.tag
            if tag not in ("motor", "position", "general"):
                self.report.ignore(f"<actuator><{tag}>", self._loc(c))
                continue
            a = self._attrs(c, tag, None)
            name = a.str("name") or f"actuator{i}"
            joint = a.str("joint", a.str("jointinparent"))
            if joint is None:
                others = [k for k in ("tendon", "site", "body", "cranksite") if a.has(k)]
                self.report.ignore(f"actuator '{name}' on a {others[0] if others else '?'} "
                                   f"(only joint actuators)", self._loc(c))
                continue
            if joint not in self.joint_nodes:
                raise c.error(f"unknown joint '{joint}'", "joint")
            tj, dof, sign = self.report.joint_map[joint]
            if tj is None:
                self.report.ignore(f"actuator '{name}' on free joint '{joint}'", self._loc(c))
                continue
            gear = a.floats("gear", [1.0], min_n=1, max_n=6)[0]
            kind, kp, kv = "motor", 0.0, 0.0
            if tag == "position":
                kind, kp, kv = "position", a.nonneg("kp", 1.0), a.nonneg("kv", 0.0)
            elif tag == "general":
                kind, kp, kv, scale = self._general(a, name, c)
                if kind is None:
                    continue
                gear *= scale
            crange = self._range(a, "ctrl")
            frange = self._range(a, "force")
            specs.append(ActuatorSpec(name=name, joint=tj, dof=dof, kind=kind, gear=sign * gear,
                                      kp=kp, kv=kv, ctrlrange=crange, forcerange=frange,
                                      ctrllimited=crange is not None, source_joint=joint,
                                      ref=self.joint_nodes[joint][1], where=c.where()))
        return specs

    def _general(self, a, name, node):
        """(kind, kp, kv, gain scale) of a general actuator that is a motor or a position
        servo; (None, ...) after noting it when it is neither."""
        dyn = a.str("dyntype", "none")
        gaintype = a.str("gaintype", "fixed")
        biastype = a.str("biastype", "none")
        gain = (a.floats("gainprm", [1.0]) + [0.0] * 10)[:3]
        bias = (a.floats("biasprm", [0.0]) + [0.0] * 10)[:3]
        if dyn == "none" and gaintype == "fixed":
            if biastype == "none":
                return "motor", 0.0, 0.0, gain[0]
            if biastype == "affine" and bias[0] == 0.0 and gain[0] > 0.0 \
                    and abs(bias[1] + gain[0]) <= 1e-12 * gain[0] and bias[2] <= 0.0:
                return "position", gain[0], -bias[2], 1.0
        self.report.ignore(f"general actuator '{name}' (dyntype {dyn}, gaintype {gaintype}, "
                           f"biastype {biastype}: neither a motor nor a position servo)",
                           self._loc(node))
        return None, 0.0, 0.0, 0.0

    def _range(self, a, what):
        rng = a.floats(f"{what}range", n=2)
        limited = a.bool(f"{what}limited", "auto", allow_auto=True)
        if limited == "auto":
            limited = self.autolimits and rng is not None
        if not limited:
            return None
        if rng is None:
            raise a.node.error(f"{what}limited needs {what}range", f"{what}range")
        if rng[0] > rng[1]:
            raise a.error(f"{what}range", f"lower {rng[0]} is above upper {rng[1]}")
        return (rng[0], rng[1])


def _same_number(value, ref):
    try:
        return np.allclose([float(x) for x in value.split()], float(ref))
    except ValueError:
        return value.strip() == ref


def _ellipsoid_points(radii):
    """Points on an ellipsoid with these semi-axes: rings of latitude plus the poles."""
    pts = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0)]
    for i in range(1, _ELLIPSOID_RINGS + 1):
        theta = math.pi * i / (_ELLIPSOID_RINGS + 1)
        for k in range(_ELLIPSOID_SEGMENTS):
            phi = 2.0 * math.pi * (k + 0.5 * (i % 2)) / _ELLIPSOID_SEGMENTS
            pts.append((math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                        math.cos(theta)))
    return np.array(pts) * radii
