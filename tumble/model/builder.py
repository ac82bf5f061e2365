"""ModelBuilder: collect bodies and geoms, validate each on entry, build a Model.

Every ``add_*`` call checks its arguments before it stores anything, so a refused
call leaves the builder as it was. ``build()`` does the whole-model work (mass from
geoms, principal axes, frames) and never changes the builder either.
"""
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ModelError, TumbleWarning
from . import mass as massprops
from . import meshes
from .model import Model
from .types import (ACTUATOR_KINDS, BODY_KINDS, CORE_ROWS, DOFS, GEOM_TYPES, JOINT_TYPES,
                    ROWS_PER_DOF)
from .validate import index_of, positive, unit_quat, unit_vector, vector

_MASSIVE_SHAPES = ("sphere", "box", "capsule", "cylinder", "convex")


def body_pair_key(a, b, nbody):
    """Order-free key of a body pair as used by ``Model.exclude_keys``; the world (-1)
    counts as body ``nbody``."""
    a = nbody if a < 0 else a
    b = nbody if b < 0 else b
    return min(a, b) * (nbody + 1) + max(a, b)


def _numbers(value, where, field, shape):
    """``value`` as a float array; ModelError naming the field when it is not numbers."""
    try:
        if isinstance(value, (str, bytes)):
            raise TypeError
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {field} must be numbers, {shape}, got {value!r}") from None


def _number(value, where, field):
    """``value`` (a number or a one-element array) as a float; ModelError naming the field
    when it is not one."""
    try:
        a = _numbers(value, where, field, "")
    except ModelError:
        a = np.zeros(0)
    if a.size != 1:
        raise ModelError(f"{where}: {field} must be a number, got {value!r}")
    return float(a.reshape(-1)[0])


def _quat_z_to(normal):
    """Unit quaternion (x, y, z, w) rotating +z onto the unit vector ``normal``."""
    z = np.array([0.0, 0.0, 1.0])
    c = float(z @ normal)
    if c < -1.0 + 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])         # half turn about x
    axis = np.cross(z, normal)
    q = np.array([axis[0], axis[1], axis[2], 1.0 + c])
    return q / np.linalg.norm(q)


class ModelBuilder:
    """Builds a :class:`Model` body by body.

    Parameters
    ----------
    gravity : (3,) m/s^2, world frame. Default (0, 0, -9.81): z up.
    timestep : default step of worlds made from the model, in seconds.
    """

    def __init__(self, gravity=(0.0, 0.0, -9.81), timestep=1.0 / 240.0):
        self.gravity = vector(gravity, 3, "model", "gravity")
        self.timestep = positive(timestep, "model", "timestep")
        self._bodies = []
        self._geoms = []
        self._body_index = {}
        self._geom_names = set()
        self._joints = []
        self._joint_names = set()
        self._actuators = []
        self._excluded = set()

    # ------------------------------------------------------------------ bodies
    def add_body(self, name, pos=(0.0, 0.0, 0.0), quat=(0.0, 0.0, 0.0, 1.0), *, mass=None,
                 inertia=None, density=None, vel=(0.0, 0.0, 0.0), angvel=(0.0, 0.0, 0.0),
                 kind="dynamic"):
        """Add a body; returns its index (the order of ``add_body`` calls).

        pos, quat : pose of the body frame in the world (m; unit quaternion x, y, z, w).
        mass, inertia : kg and kg m^2 about the COM in the body frame; inertia is (3,)
            principal moments or a full (3, 3) tensor, which is diagonalised at build
            (the simulated frame is then the principal frame; see ``Model.body_iquat``).
        density : kg/m^3; mass, COM and inertia then come from the body's geoms.
            Giving ``mass`` without ``inertia`` also uses the geoms' shape, scaled to that mass.
        vel, angvel : initial velocity of the centre of mass and angular velocity, world
            frame (m/s, rad/s).
        kind : 'dynamic'; 'kinematic' (infinite mass, moves with the velocity you set);
            or 'static' (infinite mass, never moves).
        """
        where = f"body '{name}'"
        if not isinstance(name, str) or not name:
            raise ModelError(f"body name must be a non-empty string, got {name!r}")
        if name in self._body_index:
            raise ModelError(f"{where}: a body with this name already exists")
        if not isinstance(kind, str) or kind not in BODY_KINDS:
            raise ModelError(f"{where}: kind must be one of {list(BODY_KINDS)}, got {kind!r}")
        body = dict(name=name, kind=kind,
                    pos=vector(pos, 3, where, "pos"), quat=unit_quat(quat, where, "quat"),
                    vel=vector(vel, 3, where, "vel"), angvel=vector(angvel, 3, where, "angvel"),
                    mass=None, inertia=None, density=None)
        if mass is not None:
            body["mass"] = positive(mass, where, "mass")
        if inertia is not None:
            if mass is None:
                raise ModelError(f"{where}: inertia given without mass")
            body["inertia"] = massprops.check_inertia(
                _numbers(inertia, where, "inertia", "(3,) principal moments or a (3, 3) "
                                                    "tensor"), where)
        if density is not None:
            if mass is not None:
                raise ModelError(f"{where}: give mass or density, not both")
            body["density"] = positive(density, where, "density")
        if kind == "dynamic" and mass is None and density is None:
            raise ModelError(f"{where}: a dynamic body needs mass (and inertia) or density")
        if kind == "static" and (np.any(body["vel"] != 0.0) or np.any(body["angvel"] != 0.0)):
            raise ModelError(f"{where}: a static body cannot move (vel, angvel); "
                             f"use kind='kinematic'")
        self._body_index[name] = len(self._bodies)
        self._bodies.append(body)
        return len(self._bodies) - 1

    def body_index(self, body):
        """Index of a body given by index or name (ModelError if unknown)."""
        return index_of(body, self._body_index, "body")

    # ------------------------------------------------------------------- geoms
    def add_geom(self, body, type, size=None, *, radius=None, half_length=None, normal=None,
                 pos=(0.0, 0.0, 0.0), quat=(0.0, 0.0, 0.0, 1.0), friction=1.0, restitution=0.0,
                 density=None, contype=1, conaffinity=1, margin=0.0, vertices=None,
                 heights=None, name=None, rolling_friction=0.0, torsional_friction=0.0,
                 stiffness=None, damping=None):
        """Attach a collision shape to ``body`` (index or name; None: the static world).

        type : 'plane', 'sphere', 'capsule', 'box', 'cylinder', 'convex' (the hull of
            ``vertices`` (n, 3), geom frame, m) or 'heightfield' (``heights`` (nrow, ncol)
            in m over ``size = (half_x, half_y, base)``; rows along y, columns along x;
            static, like planes).
        size : sphere (radius,); capsule and cylinder (radius, half_length) with the axis
            along the geom's local z; box (hx, hy, hz) half extents. ``radius`` and
            ``half_length`` may be given by keyword instead.
        normal : planes only, world-frame normal (default +z); the plane passes through
            ``pos`` and is solid below. A plane belongs to the world or a static body.
        pos, quat : pose of the geom in the body frame as given to ``add_body``
            (world frame for world geoms).
        friction, restitution : Coulomb coefficient (>= 0) and bounce (0..1).
        rolling_friction, torsional_friction : lengths (m, >= 0, default 0): a contact
            resists rolling (relative spin about its tangents) with a torque up to
            ``rolling_friction`` times its normal force, and spinning about its normal with
            up to ``torsional_friction`` times it (MuJoCo's 2nd and 3rd friction values).
            A pair uses the larger value of its two geoms, like ``friction``.
        stiffness, damping : this geom's contact spring (N/m, > 0) and damper (N s/m, >= 0);
            default: the world's. Penalty contacts use them as ``k`` and ``c``; LCP and PGS
            contacts become the soft constraint of that spring-damper (ERP = h k / (h k + c),
            CFM = 1 / (h k + c), as for soft joints, resting depth m g / k above the slop).
            A pair combines the stiffnesses given as springs in series (a geom without one
            counts as rigid) and takes the larger damping given; a pair with no stiffness
            uses the world's contact parameters, and a damping alone only affects penalty
            contacts (see ``tumble.pipeline.contacts.softness``).
        density : kg/m^3 for this geom when the body's mass comes from its geoms.
        contype, conaffinity : collision bits (MuJoCo semantics: two geoms may collide
            when ``contype_a & conaffinity_b`` or ``contype_b & conaffinity_a``); set both
            to 0 to disable the geom's collisions.
        margin : contacts are reported from this distance apart (m), so solvers see them
            coming; the pair uses the larger margin of its two geoms.
        Returns the geom index.
        """
        gname = name if name is not None else f"geom{len(self._geoms)}"
        where = f"geom '{gname}'"
        if not isinstance(gname, str) or not gname:
            raise ModelError(f"geom name must be a non-empty string, got {name!r}")
        if gname in self._geom_names:
            raise ModelError(f"{where}: a geom with this name already exists")
        if body is None:
            body_idx = -1
        else:
            try:
                body_idx = self.body_index(body)
            except ModelError as e:
                raise ModelError(f"{where}: {e}") from None
        if not isinstance(type, str) or type not in GEOM_TYPES:
            raise ModelError(f"{where}: type must be one of {list(GEOM_TYPES)}, got {type!r}")
        mesh = hfield = None
        if type == "convex":
            if vertices is None or size is not None:
                raise ModelError(f"{where}: a convex geom takes vertices=(n, 3), not size")
            mesh = meshes.convex_hull(vertices, where)
            geom_size = np.zeros(3)
        elif type == "heightfield":
            if heights is None or size is None:
                raise ModelError(f"{where}: a heightfield needs heights=(nrow, ncol) and "
                                 f"size=(half_x, half_y, base)")
            hfield, geom_size = meshes.heightfield(heights, size, where)
        elif vertices is not None or heights is not None:
            raise ModelError(f"{where}: vertices and heights apply to convex and heightfield geoms")
        else:
            geom_size = self._geom_size(type, size, radius, half_length, where)
        gpos = vector(pos, 3, where, "pos")
        gquat = unit_quat(quat, where, "quat")
        if type == "heightfield" and body_idx >= 0 and self._bodies[body_idx]["kind"] == "dynamic":
            raise ModelError(f"{where}: a heightfield may only belong to the world or a static "
                             f"body, not dynamic body '{self._bodies[body_idx]['name']}'")
        if type == "plane":
            if body_idx >= 0 and self._bodies[body_idx]["kind"] == "dynamic":
                raise ModelError(f"{where}: a plane is infinite and may only belong to the world "
                                 f"or a static body, not dynamic body "
                                 f"'{self._bodies[body_idx]['name']}'")
            if normal is not None:
                gquat = _quat_z_to(unit_vector(normal, where, "normal"))
        elif normal is not None:
            raise ModelError(f"{where}: normal applies to planes only")
        fr = positive(friction, where, "friction", allow_zero=True)
        roll = positive(rolling_friction, where, "rolling_friction", allow_zero=True)
        tors = positive(torsional_friction, where, "torsional_friction", allow_zero=True)
        kstiff = 0.0 if stiffness is None else positive(stiffness, where, "stiffness")
        cdamp = -1.0 if damping is None else positive(damping, where, "damping",
                                                      allow_zero=True)
        rest = positive(restitution, where, "restitution", allow_zero=True)
        if rest > 1.0:
            raise ModelError(f"{where}: restitution must be in [0, 1], got {restitution!r}")
        dens = None if density is None else positive(density, where, "density")
        gmargin = positive(margin, where, "margin", allow_zero=True)
        for field, bits in (("contype", contype), ("conaffinity", conaffinity)):
            if isinstance(bits, bool) or not isinstance(bits, (int, np.integer)) or not 0 <= bits < 2**32:
                raise ModelError(f"{where}: {field} must be an integer bit mask in [0, 2^32), "
                                 f"got {bits!r}")
        self._geom_names.add(gname)
        self._geoms.append(dict(name=gname, body=body_idx, type=type, size=geom_size, pos=gpos,
                                quat=gquat, friction=fr, restitution=rest, density=dens,
                                rolling=roll, torsional=tors, stiffness=kstiff, damping=cdamp,
                                contype=int(contype), conaffinity=int(conaffinity),
                                margin=gmargin, mesh=mesh, hfield=hfield))
        return len(self._geoms) - 1

    @staticmethod
    def _geom_size(type, size, radius, half_length, where):
        out = np.zeros(3)
        if type == "plane":
            if size is not None or radius is not None or half_length is not None:
                raise ModelError(f"{where}: a plane takes no size")
            return out
        if size is not None and (radius is not None or half_length is not None):
            raise ModelError(f"{where}: give size or radius/half_length, not both")
        if type == "box":
            if size is None:
                raise ModelError(f"{where}: a box needs size=(hx, hy, hz), its half extents")
            out[:] = vector(size, 3, where, "size")
            names = ("size[0] (hx)", "size[1] (hy)", "size[2] (hz)")
        elif type == "sphere":
            if size is not None:
                radius = _numbers(size, where, "size", "(radius,)").reshape(-1)
                if radius.size != 1:
                    raise ModelError(f"{where}: a sphere's size is (radius,), got {size!r}")
                radius = radius[0]
            if radius is None:
                raise ModelError(f"{where}: a sphere needs a radius")
            out[0] = _number(radius, where, "radius")
            names = ("radius",)
        else:  # capsule, cylinder
            if size is not None:
                out[:2] = vector(size, 2, where, "size")
            else:
                if radius is None or half_length is None:
                    raise ModelError(f"{where}: a {type} needs radius and half_length")
                out[0] = _number(radius, where, "radius")
                out[1] = _number(half_length, where, "half_length")
            names = ("radius", "half_length")
        for i, field in enumerate(names):
            positive(out[i], where, field)
        return out

    # ------------------------------------------------------------------ joints
    def add_joint(self, name, type, parent, child, anchor=None, axis=None, axis2=None, *,
                  limit=None, damping=0.0, friction=0.0, motor_max_force=0.0, erp=None,
                  cfm=None, spring=None, collide=False, kp=0.0, kd=0.0, max_torque=None,
                  cone=None, twist=None):
        """Join ``child`` to ``parent`` (index or name; None: the world). Returns the index.

        type : 'ball', 'hinge' (axis), 'universal' (axis on the parent, axis2 on the
            child, perpendicular), 'fixed', 'slider' (axis), or 'free' (no constraint;
            parent must be None). A ball joint may take ``axis`` (and ``axis2``,
            perpendicular) to orient its joint frame, the frame its three coordinates,
            limits and motors refer to (default: the world axes).
        anchor, axis, axis2 : world frame, in the pose the bodies were added in; the anchor
            defaults to the child's position.
        limit : (lower, upper) for hinge (rad) and slider (m) joints; for universal and
            ball joints the same bounds hold for every coordinate (the two Cardan angles,
            or the three rotation-vector components in the joint frame).
        cone, twist : ball joints only, instead of ``limit``: the swing-twist limits of the
            joint frame's x axis (the twist axis; orient it with ``axis``). The child's
            x axis may swing away from the parent's by at most ``cone`` (rad, in (0, pi)),
            or within the elliptical cone ``(swing_y, swing_z)``: swinging about the joint
            frame's y axis (tilting x toward -z) by up to swing_y, about z by up to swing_z,
            and in between on the ellipse ``(a_y / swing_y)^2 + (a_z / swing_z)^2 <= 1`` of
            the swing's rotation vector (a_y, a_z). ``twist = (lo, hi)`` (rad, within
            [-pi, pi]) bounds the rotation about the child's own x axis that remains once
            the swing is taken out (the swing-twist decomposition ``rel = swing * twist``).
            See ``tumble.pipeline.joints.ball``.
        damping, friction : viscous (N m s/rad, N s/m) and dry (N m, N) resistance on every
            degree of freedom, applied implicitly by the solver.
        motor_max_force : bound (N m or N) of the velocity motor on every degree of freedom;
            targets are set on the world (``World.joint_motor_target``). 0: no motor.
        erp, cfm : this joint's ODE error-reduction and constraint-force-mixing values
            (default: the world's).
        spring : (k, c) to make the joint soft: its rows act as a spring k and damper c at
            every step size (ERP = hk / (hk + c), CFM = 1 / (hk + c)).
        collide : whether the two joined bodies may still collide (default False).
        kp, kd, max_torque : the joint's PD servo: stiffness (N m/rad or N/m), damping
            (N m s/rad or N s/m) and the bound on each degree of freedom's torque (N m or N,
            default unbounded). Targets and gains live on the world (``World.pd_target``,
            ``World.joint_kp``); the world's ``pd`` mode applies the servo implicitly
            (default), explicitly or as stable PD. Off while kp and kd are 0.
        """
        where = f"joint '{name}'"
        if not isinstance(name, str) or not name:
            raise ModelError(f"joint name must be a non-empty string, got {name!r}")
        if name in self._joint_names:
            raise ModelError(f"{where}: a joint with this name already exists")
        if not isinstance(type, str) or type not in JOINT_TYPES:
            raise ModelError(f"{where}: type must be one of {list(JOINT_TYPES)}, got {type!r}")
        try:
            p = -1 if parent is None else self.body_index(parent)
            if child is None:
                raise ModelError("child must be a body, not None")
            c = self.body_index(child)
        except ModelError as e:
            raise ModelError(f"{where}: {e}") from None
        if p == c:
            raise ModelError(f"{where}: joins body '{self._bodies[c]['name']}' to itself")
        if type == "free" and p != -1:
            raise ModelError(f"{where}: a free joint has no parent (parent=None)")
        kinds = [self._bodies[c]["kind"]] + ([self._bodies[p]["kind"]] if p >= 0 else ["static"])
        if "dynamic" not in kinds:
            raise ModelError(f"{where}: neither body can move, so the joint does nothing")
        child_pos = self._bodies[c]["pos"]
        anchor_w = child_pos.copy() if anchor is None else vector(anchor, 3, where, "anchor")
        needs_axis = type in ("hinge", "slider", "universal")
        oriented_ball = type == "ball" and axis is not None
        if needs_axis and axis is None:
            raise ModelError(f"{where}: a {type} joint needs an axis")
        if not needs_axis and not oriented_ball and (axis is not None or axis2 is not None):
            raise ModelError(f"{where}: a {type} joint takes no axis")
        x_axis = (unit_vector(axis, where, "axis") if needs_axis or oriented_ball
                  else np.array([1.0, 0, 0]))
        if type == "universal" or (oriented_ball and axis2 is not None):
            if axis2 is None:
                raise ModelError(f"{where}: a universal joint needs axis2")
            y_axis = unit_vector(axis2, where, "axis2")
            if abs(x_axis @ y_axis) > 1e-6:
                raise ModelError(f"{where}: axis and axis2 must be perpendicular "
                                 f"(cos = {x_axis @ y_axis:.3g})")
        elif axis2 is not None:
            raise ModelError(f"{where}: axis2 applies to universal joints only")
        else:
            helper = np.array([0.0, 0, 1]) if abs(x_axis[2]) < 0.9 else np.array([1.0, 0, 0])
            y_axis = np.cross(helper, x_axis)
            y_axis /= np.linalg.norm(y_axis)
        frame = np.column_stack([x_axis, y_axis, np.cross(x_axis, y_axis)])
        if type in ("fixed", "free") or (type == "ball" and not oriented_ball):
            frame = np.eye(3)
        lim = np.array([1.0, -1.0])           # lower > upper: none
        if limit is not None:
            if type not in ("hinge", "slider", "universal", "ball"):
                raise ModelError(f"{where}: limits apply to hinge, slider, universal and "
                                 f"ball joints")
            lim = vector(limit, 2, where, "limit")
            if lim[0] > lim[1]:
                raise ModelError(f"{where}: limit lower {lim[0]} is above upper {lim[1]}")
        cone_yz, twist_lh = self._cone_twist(type, cone, twist, limit, where)
        for field, v in (("erp", erp), ("cfm", cfm)):
            if v is not None:
                positive(v, where, field, allow_zero=True)
        if erp is not None and erp > 1.0:
            raise ModelError(f"{where}: erp must be in [0, 1], got {erp}")
        k = cdamp = 0.0
        if spring is not None:
            if erp is not None or cfm is not None:
                raise ModelError(f"{where}: give spring or erp/cfm, not both")
            k_c = vector(spring, 2, where, "spring")
            k = positive(k_c[0], where, "spring stiffness", allow_zero=True)
            cdamp = positive(k_c[1], where, "spring damping", allow_zero=True)
            if k == 0.0 and cdamp == 0.0:
                raise ModelError(f"{where}: spring needs stiffness or damping > 0")
        entry = dict(name=name, type=type, parent=p, child=c, anchor=anchor_w, frame=frame,
                     limit=lim, cone=cone_yz, twist=twist_lh,
                     damping=positive(damping, where, "damping", allow_zero=True),
                     friction=positive(friction, where, "friction", allow_zero=True),
                     motor_max=positive(motor_max_force, where, "motor_max_force",
                                        allow_zero=True),
                     erp=-1.0 if erp is None else float(erp),
                     cfm=-1.0 if cfm is None else float(cfm), stiffness=k, soft_damping=cdamp,
                     kp=positive(kp, where, "kp", allow_zero=True),
                     kd=positive(kd, where, "kd", allow_zero=True),
                     max_torque=np.inf if max_torque is None else positive(
                         max_torque, where, "max_torque"))
        if (entry["kp"] > 0 or entry["kd"] > 0) and type in ("fixed", "free"):
            raise ModelError(f"{where}: a {type} joint has no degree of freedom to servo")
        far = min(np.linalg.norm(anchor_w - child_pos),
                  np.linalg.norm(anchor_w - self._bodies[p]["pos"]) if p >= 0 else np.inf)
        if far > 2.0:
            warnings.warn(f"{where}: the anchor is {far:.3g} m from both bodies' origins",
                          TumbleWarning, stacklevel=2)
        self._joint_names.add(name)
        self._joints.append(entry)
        if not collide and type != "free":      # a free joint joins nothing to filter
            self._excluded.add((min(p, c), max(p, c)))
        return len(self._joints) - 1

    @staticmethod
    def _cone_twist(type, cone, twist, limit, where):
        """Validated (swing_y, swing_z) and (twist_lo, twist_hi); (0, 0) and (1, -1) for none."""
        cone_yz, twist_lh = np.zeros(2), np.array([1.0, -1.0])
        if cone is None and twist is None:
            return cone_yz, twist_lh
        if type != "ball":
            raise ModelError(f"{where}: cone and twist limits apply to ball joints, not {type}")
        if limit is not None:
            raise ModelError(f"{where}: give limit (a box on the rotation vector) or "
                             f"cone/twist, not both")
        if cone is not None:
            try:
                c = np.array(cone, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                c = np.zeros(0)
            if c.size == 1:
                c = np.array([c[0], c[0]])
            if c.size != 2:
                raise ModelError(f"{where}: cone must be an angle or (swing_y, swing_z) in rad, "
                                 f"got {cone!r}")
            for field, v in zip(("cone swing_y", "cone swing_z"), c):
                if not (np.isfinite(v) and 0.0 < v < np.pi):
                    raise ModelError(f"{where}: {field} must be in (0, pi) rad, got {v!r}")
            cone_yz = c
        if twist is not None:
            t = vector(twist, 2, where, "twist")
            if t[0] > t[1]:
                raise ModelError(f"{where}: twist lower {t[0]} is above upper {t[1]}")
            if t[0] < -np.pi or t[1] > np.pi:
                raise ModelError(f"{where}: twist must lie within [-pi, pi] rad, got "
                                 f"{t.tolist()}")
            twist_lh = t
        return cone_yz, twist_lh

    def add_actuator(self, name, joint, kind="motor", *, axis=None, dof=None, gear=1.0, kp=0.0,
                     kv=0.0, ctrlrange=None, forcerange=None):
        """An MJCF-style actuator on ``joint``, driven by ``World.ctrl``. Returns its index.

        kind : 'motor' (force ``ctrl``) or 'position' (force ``kp (ctrl - gear q) -
            kv gear qd``); the joint feels ``gear`` times the force, along ``axis``.
        axis : world direction in the built pose (default: the joint's axis for hinges and
            sliders); or ``dof`` = 0, 1, 2 picks the joint frame's x, y, z axis.
        ctrlrange, forcerange : (lo, hi) clamps of the control and of the force (default
            none). A position actuator alone on a hinge or slider, along its axis and with a
            symmetric force range, becomes the joint's PD servo so it runs implicitly.
        """
        where = f"actuator '{name}'"
        if not isinstance(name, str) or not name:
            raise ModelError(f"actuator name must be a non-empty string, got {name!r}")
        if any(a["name"] == name for a in self._actuators):
            raise ModelError(f"{where}: an actuator with this name already exists")
        if kind not in ACTUATOR_KINDS:
            raise ModelError(f"{where}: kind must be 'motor' or 'position', got {kind!r}")
        names = [j["name"] for j in self._joints]
        try:
            j = index_of(joint, {n: i for i, n in enumerate(names)}, "joint")
        except ModelError as e:
            raise ModelError(f"{where}: {e}") from None
        jt = self._joints[j]
        if jt["type"] in ("fixed", "free"):
            raise ModelError(f"{where}: joint '{jt['name']}' is {jt['type']}: nothing to actuate")
        frame = jt["frame"]                     # columns: joint frame axes, world, built pose
        if axis is not None and dof is not None:
            raise ModelError(f"{where}: give axis or dof, not both")
        if axis is not None:
            axis_j = frame.T @ unit_vector(axis, where, "axis")
        elif dof is not None:
            if isinstance(dof, bool) or not isinstance(dof, (int, np.integer)) \
                    or dof not in (0, 1, 2):
                raise ModelError(f"{where}: dof must be 0, 1 or 2, got {dof!r}")
            axis_j = np.eye(3)[dof]
        elif jt["type"] in ("hinge", "slider"):
            axis_j = np.array([1.0, 0.0, 0.0])
        else:
            raise ModelError(f"{where}: a {jt['type']} joint needs an axis or dof")
        g = vector([gear], 1, where, "gear")[0]
        if g == 0.0:
            raise ModelError(f"{where}: gear must not be 0")
        ranges = []
        for field, r in (("ctrlrange", ctrlrange), ("forcerange", forcerange)):
            r = np.array([-np.inf, np.inf]) if r is None else vector(r, 2, where, field,
                                                                    finite=False)
            if np.isnan(r).any() or r[0] > r[1]:
                raise ModelError(f"{where}: {field} must be (lo, hi) with lo <= hi, got "
                                 f"{r.tolist()}")
            ranges.append(r)
        self._actuators.append(dict(
            name=name, joint=j, kind=kind, axis=axis_j, gear=float(g),
            kp=positive(kp, where, "kp", allow_zero=True),
            kv=positive(kv, where, "kv", allow_zero=True), ctrlrange=ranges[0],
            forcerange=ranges[1]))
        return len(self._actuators) - 1

    def exclude_collision(self, body_a, body_b):
        """Never let these two bodies (index or name; None: the world) collide."""
        a = -1 if body_a is None else self.body_index(body_a)
        b = -1 if body_b is None else self.body_index(body_b)
        if a == b:
            raise ModelError(f"exclude_collision: body {body_a!r} given twice")
        self._excluded.add((min(a, b), max(a, b)))

    # ------------------------------------------------------------------- build
    def build(self):
        """Validate the whole model and return an immutable :class:`Model`."""
        if not self._bodies and not self._geoms:
            raise ModelError("model is empty: add at least one body or geom")
        nb = len(self._bodies)
        b = dict(
            names=[d["name"] for d in self._bodies],
            kind=np.array([BODY_KINDS[d["kind"]] for d in self._bodies], dtype=np.int32),
            mass=np.full(nb, np.inf), inertia=np.full((nb, 3), np.inf),
            pos=np.zeros((nb, 3)), quat=np.zeros((nb, 4)),
            vel=np.zeros((nb, 3)), angvel=np.zeros((nb, 3)),
            ipos=np.zeros((nb, 3)), iquat=np.tile([0.0, 0.0, 0.0, 1.0], (nb, 1)),
        )
        geoms_of = [[] for _ in range(nb)]
        for gi, g in enumerate(self._geoms):
            if g["body"] >= 0:
                geoms_of[g["body"]].append(gi)

        for i, d in enumerate(self._bodies):
            if d["kind"] == "dynamic":
                m, ipos, inertia = self._body_mass(d, [self._geoms[g] for g in geoms_of[i]])
                moments, axes = massprops.principal_axes(inertia)
                b["mass"][i] = m
                b["inertia"][i] = moments
                b["ipos"][i] = ipos
                b["iquat"][i] = Rotation.from_matrix(axes).as_quat()
            r_user = Rotation.from_quat(d["quat"])
            r_body = r_user * Rotation.from_quat(b["iquat"][i])
            b["pos"][i] = d["pos"] + r_user.apply(b["ipos"][i])
            b["quat"][i] = r_body.as_quat()
            b["vel"][i] = d["vel"]
            b["angvel"][i] = d["angvel"]

        ng = len(self._geoms)
        g = dict(names=[x["name"] for x in self._geoms],
                 body=np.array([x["body"] for x in self._geoms], dtype=np.int32),
                 type=np.array([GEOM_TYPES[x["type"]] for x in self._geoms], dtype=np.int32),
                 size=np.array([x["size"] for x in self._geoms]).reshape(ng, 3),
                 pos=np.zeros((ng, 3)), quat=np.zeros((ng, 4)),
                 friction=np.array([x["friction"] for x in self._geoms], dtype=float),
                 restitution=np.array([x["restitution"] for x in self._geoms], dtype=float),
                 rolling=np.array([x["rolling"] for x in self._geoms], dtype=float),
                 torsional=np.array([x["torsional"] for x in self._geoms], dtype=float),
                 stiffness=np.array([x["stiffness"] for x in self._geoms], dtype=float),
                 damping=np.array([x["damping"] for x in self._geoms], dtype=float),
                 contype=np.array([x["contype"] for x in self._geoms], dtype=np.uint32),
                 conaffinity=np.array([x["conaffinity"] for x in self._geoms], dtype=np.uint32),
                 margin=np.array([x["margin"] for x in self._geoms], dtype=float),
                 dataid=np.full(ng, -1, np.int32))
        self._build_shape_data(g)
        g["exclude_keys"] = np.array(sorted(body_pair_key(a, c, nb) for a, c in self._excluded),
                                     dtype=np.int64)
        for gi, x in enumerate(self._geoms):
            if x["body"] < 0:
                g["pos"][gi], g["quat"][gi] = x["pos"], x["quat"]
                continue
            # Re-express the geom pose from the user's body frame in the COM principal frame.
            bi = x["body"]
            r_i = Rotation.from_quat(b["iquat"][bi])
            g["pos"][gi] = r_i.inv().apply(x["pos"] - b["ipos"][bi])
            g["quat"][gi] = (r_i.inv() * Rotation.from_quat(x["quat"])).as_quat()
        joints = self._build_joints(b)
        return Model(gravity=self.gravity.copy(), timestep=self.timestep, bodies=b, geoms=g,
                     joints=joints, actuators=self._build_actuators(joints))

    def _build_actuators(self, joints):
        """Actuator arrays; position actuators that can run as a joint servo are folded."""
        acts = self._actuators
        na = len(acts)
        out = dict(names=[a["name"] for a in acts],
                   joint=np.array([a["joint"] for a in acts], np.int32),
                   kind=np.array([ACTUATOR_KINDS[a["kind"]] for a in acts], np.int32),
                   axis=np.array([a["axis"] for a in acts], float).reshape(na, 3),
                   gear=np.array([a["gear"] for a in acts], float),
                   kp=np.array([a["kp"] for a in acts], float),
                   kv=np.array([a["kv"] for a in acts], float),
                   ctrlrange=np.array([a["ctrlrange"] for a in acts], float).reshape(na, 2),
                   forcerange=np.array([a["forcerange"] for a in acts], float).reshape(na, 2),
                   folded=np.zeros(na, bool))
        per_joint = np.bincount(out["joint"], minlength=len(self._joints))
        for i, a in enumerate(acts):
            jt = self._joints[a["joint"]]
            fr = a["forcerange"]
            if (a["kind"] == "position" and jt["type"] in ("hinge", "slider")
                    and per_joint[a["joint"]] == 1 and np.allclose(a["axis"], [1, 0, 0])
                    and fr[0] == -fr[1] and jt["kp"] == 0.0 and jt["kd"] == 0.0):
                # joint torque gear (kp (c - gear q) - kv gear qd) = servo with gains
                # kp gear^2, kv gear^2 toward q = c / gear
                g2 = a["gear"] ** 2
                j = a["joint"]
                joints["kp"][j], joints["kd"][j] = a["kp"] * g2, a["kv"] * g2
                joints["max_torque"][j] = fr[1] * abs(a["gear"])
                out["folded"][i] = True
        return out

    def _build_shape_data(self, g):
        """Convex hull vertices and heightfield samples as flat arrays, indexed by dataid."""
        verts, adr, num, hdata, hadr, nrow, ncol = [], [], [], [], [], [], []
        for gi, x in enumerate(self._geoms):
            if x["mesh"] is not None:
                g["dataid"][gi] = len(adr)
                adr.append(sum(num))
                num.append(len(x["mesh"]))
                verts.append(x["mesh"])
            elif x["hfield"] is not None:
                g["dataid"][gi] = len(hadr)
                hadr.append(sum(len(h) for h in hdata))
                nrow.append(x["hfield"].shape[0])
                ncol.append(x["hfield"].shape[1])
                hdata.append(x["hfield"].ravel())
        g["mesh_vert_adr"] = np.array(adr, np.int32)
        g["mesh_vert_num"] = np.array(num, np.int32)
        g["mesh_vert"] = np.concatenate(verts).astype(float) if verts else np.zeros((0, 3))
        g["hfield_adr"] = np.array(hadr, np.int32)
        g["hfield_nrow"] = np.array(nrow, np.int32)
        g["hfield_ncol"] = np.array(ncol, np.int32)
        g["hfield_data"] = np.concatenate(hdata).astype(float) if hdata else np.zeros(0)

    def _build_joints(self, b):
        """Joint arrays: anchors and frames re-expressed in each body's COM principal frame."""
        nj = len(self._joints)
        out = dict(names=[j["name"] for j in self._joints],
                   type_names=[j["type"] for j in self._joints],
                   type=np.array([JOINT_TYPES[j["type"]] for j in self._joints], np.int32),
                   parent=np.array([j["parent"] for j in self._joints], np.int32),
                   child=np.array([j["child"] for j in self._joints], np.int32),
                   anchor_a=np.zeros((nj, 3)), anchor_b=np.zeros((nj, 3)),
                   frame_a=np.zeros((nj, 4)), frame_b=np.zeros((nj, 4)),
                   limit=np.array([j["limit"] for j in self._joints]).reshape(nj, 2),
                   cone=np.array([j["cone"] for j in self._joints], float).reshape(nj, 2),
                   twist=np.array([j["twist"] for j in self._joints], float).reshape(nj, 2))
        for key in ("erp", "cfm", "stiffness", "soft_damping", "damping", "friction", "motor_max",
                    "kp", "kd", "max_torque"):
            out[key] = np.array([j[key] for j in self._joints], dtype=float)
        out["core_rows"] = np.array([CORE_ROWS[t] for t in out["type"]], np.int32)
        out["ndof"] = np.array([DOFS[t] for t in out["type"]], np.int32)
        out["row_count"] = out["core_rows"] + ROWS_PER_DOF * out["ndof"]
        out["row_start"] = (np.cumsum(out["row_count"]) - out["row_count"]).astype(np.int32)
        out["nrow"] = int(out["row_count"].sum())
        for i, j in enumerate(self._joints):
            frame_w = Rotation.from_matrix(j["frame"])
            for side, body in (("a", j["parent"]), ("b", j["child"])):
                if body < 0:
                    out["anchor_" + side][i] = j["anchor"]
                    out["frame_" + side][i] = frame_w.as_quat()
                    continue
                r_body = Rotation.from_quat(b["quat"][body])
                out["anchor_" + side][i] = r_body.inv().apply(j["anchor"] - b["pos"][body])
                out["frame_" + side][i] = (r_body.inv() * frame_w).as_quat()
        return out

    @staticmethod
    def _body_mass(d, geoms):
        """Mass, COM in the user body frame, inertia (3, 3) about the COM in that frame."""
        where = f"body '{d['name']}'"
        if d["inertia"] is not None:
            return d["mass"], np.zeros(3), d["inertia"]
        solids = [g for g in geoms if g["type"] in _MASSIVE_SHAPES]
        if not solids:
            raise ModelError(f"{where}: mass properties come from its geoms (density or mass "
                             f"without inertia), but it has no sphere, box, capsule or cylinder")
        default_density = d["density"] if d["density"] is not None else 1.0
        masses, coms, tensors = [], [], []
        for g in solids:
            rot = Rotation.from_quat(g["quat"]).as_matrix()
            dens = g["density"] or default_density
            if g["type"] == "convex":
                m, com_g, tensor_g = meshes.convex_mass(g["mesh"], dens, where)
            else:
                m, moments = massprops.shape_mass(g["type"], g["size"], dens)
                com_g, tensor_g = np.zeros(3), np.diag(moments)
            masses.append(m)
            coms.append(g["pos"] + rot @ com_g)
            tensors.append(rot @ tensor_g @ rot.T)
        m, com, inertia = massprops.combine(masses, coms, tensors)
        if d["mass"] is not None:                 # keep the shape, scale to the given mass
            inertia = inertia * (d["mass"] / m)
            m = d["mass"]
        massprops.check_inertia(inertia, where)
        return m, com, inertia
