"""Model: everything that does not change while stepping, as read-only arrays.

Bodies are simulated in their *COM principal frame*: ``body_pos0`` is the centre of
mass and ``body_quat0`` the orientation of the principal axes, so ``body_inertia``
is diagonal. ``body_ipos`` / ``body_iquat`` give that frame in the frame the user
built the body in; geoms are stored relative to the COM principal frame.
"""
from collections import namedtuple

import numpy as np

# Type codes live in .types; GEOM_TYPES and STATIC are also read from here by other modules.
from .types import DYNAMIC, GEOM_TYPES, STATIC  # noqa: F401
from .validate import index_of

# What the compiled pipeline reads of a model (one namedtuple so kernels take one argument).
ModelArrays = namedtuple("ModelArrays", [
    "gravity",            # (3,) m/s^2
    "body_kind",          # (nbody,) int32: DYNAMIC, KINEMATIC, STATIC
    "body_inv_mass",      # (nbody,) 1/kg, 0 for kinematic and static bodies
    "body_inertia",       # (nbody, 3) principal moments, kg m^2 (0 when not dynamic)
    "body_inv_inertia",   # (nbody, 3) their inverses, 0 when not dynamic
    "joint_type",         # (njoint,) int32 codes of model.types.JOINT_TYPES
    "joint_parent",       # (njoint,) int32 parent body, -1 for the world
    "joint_child",        # (njoint,) int32 child body
    "joint_anchor_a",     # (njoint, 3) anchor in the parent's COM frame (world if -1), m
    "joint_anchor_b",     # (njoint, 3) anchor in the child's COM frame, m
    "joint_frame_a",      # (njoint, 4) joint frame in the parent's frame (x = axis 1)
    "joint_frame_b",      # (njoint, 4) joint frame in the child's frame
    "joint_erp",          # (njoint,) ERP override, < 0: the world's
    "joint_cfm",          # (njoint,) CFM override, < 0: the world's
    "joint_stiffness",    # (njoint,) soft joint spring k (0: rigid)
    "joint_soft_damping", # (njoint,) soft joint damper c
    "joint_damping",      # (njoint,) viscous damping on each DoF, N m s/rad or N s/m
    "joint_friction",     # (njoint,) dry friction on each DoF, N m or N
    "joint_motor_max",    # (njoint,) motor force/torque bound, 0: no motor
    "joint_limit",        # (njoint, 2) lower, upper (lower > upper: no limit)
    "joint_cone",         # (njoint, 2) ball swing cone half-angles about y, z, rad (0: none)
    "joint_twist",        # (njoint, 2) ball twist lower, upper, rad (lower > upper: none)
    "joint_core_rows",    # (njoint,) rows that hold the joint together
    "joint_row_start",    # (njoint,) first row of each joint
    "joint_row_count",    # (njoint,) rows of each joint (core + 4 per DoF)
    "geom_type",          # (ngeom,) int32 codes of model.types.GEOM_TYPES
    "geom_body",          # (ngeom,) int32 owning body, -1 for the world
    "geom_size",          # (ngeom, 3) shape size
    "geom_pos",           # (ngeom, 3) position in the body's COM frame (world if -1)
    "geom_quat",          # (ngeom, 4) orientation in the body's COM frame
    "geom_friction",      # (ngeom,) Coulomb coefficient
    "geom_restitution",   # (ngeom,) coefficient of restitution
    "geom_rolling",       # (ngeom,) rolling friction, m (torque per normal force)
    "geom_torsional",     # (ngeom,) torsional friction, m (torque per normal force)
    "geom_stiffness",     # (ngeom,) contact stiffness, N/m (0: the world's)
    "geom_damping",       # (ngeom,) contact damping, N s/m (< 0: the world's)
    "geom_contype",       # (ngeom,) uint32 collision type bits
    "geom_conaffinity",   # (ngeom,) uint32 collision affinity bits
    "geom_margin",        # (ngeom,) contact margin, m
    "geom_dataid",        # (ngeom,) int32 mesh or heightfield index, -1 for primitives
    "mesh_vert_adr",      # (nmesh,) int32 first row of each convex mesh in mesh_vert
    "mesh_vert_num",      # (nmesh,) int32 vertex count
    "mesh_vert",          # (nvert, 3) hull vertices in the geom frame, m
    "hfield_adr",         # (nhfield,) int32 offset into hfield_data
    "hfield_nrow",        # (nhfield,) int32
    "hfield_ncol",        # (nhfield,) int32
    "hfield_data",        # (total,) heights, m, row-major
    "exclude_keys",       # (nexclude,) int64 sorted keys min(a,b) * (nbody+1) + max(a,b) of
                          # body pairs that never collide (world = nbody)
    "act_joint",          # (nact,) int32 joint each actuator drives
    "act_kind",           # (nact,) int32 ACT_MOTOR or ACT_POSITION (model.types)
    "act_axis",           # (nact, 3) direction in the joint's parent frame
    "act_gear",           # (nact,) joint force per actuator force
    "act_kp",             # (nact,) position gain
    "act_kv",             # (nact,) velocity gain
    "act_ctrlrange",      # (nact, 2) control clamp
    "act_forcerange",     # (nact, 2) actuator force clamp
    "act_folded",         # (nact,) bool: runs as its joint's PD servo instead
])


def _frozen(a):
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


class Model:
    """A validated, immutable model. Build one with ``ModelBuilder`` or a loader.

    Attributes (arrays are read-only; nbody bodies, ngeom geoms):

    gravity : (3,) m/s^2, world frame.        timestep : default step, s.
    body_names : list of nbody names, in the order bodies were added.
    body_kind : (nbody,) int32, 0 dynamic, 1 kinematic, 2 static.
    body_mass : (nbody,) kg, ``inf`` for kinematic and static bodies.
    body_inertia : (nbody, 3) principal moments about the COM, kg m^2 (``inf`` if not dynamic).
    body_pos0, body_quat0, body_vel0, body_angvel0 : initial COM position (m), principal-frame
        orientation (x, y, z, w), COM velocity (m/s) and angular velocity (rad/s), world frame.
    body_ipos, body_iquat : the COM principal frame in the body frame the user gave.
    geom_names, geom_body (-1 = world), geom_type (codes of GEOM_TYPES), geom_size (ngeom, 3),
    geom_pos, geom_quat (pose in the owning body's COM principal frame, or world),
    geom_friction, geom_restitution, geom_contype, geom_conaffinity,
    geom_rolling, geom_torsional (m), geom_stiffness (N/m, 0: the world's),
    geom_damping (N s/m, < 0: the world's).
    joint_names, joint_type_names, joint_parent (-1 = world), joint_child, joint_ndof,
    joint_limit (njoint, 2), joint_cone (njoint, 2: ball swing half-angles about the joint
    frame's y and z, 0: none), joint_twist (njoint, 2: lower > upper: none), joint_damping,
    joint_friction, joint_motor_max, and the frames and anchors of each joint in its bodies
    (see ``ModelArrays``).
    joint_kp, joint_kd, joint_max_torque : (njoint,) default PD servo gains and bounds.
    actuator_names, actuator_joint, actuator_kind ('motor'/'position' names in
    actuator_kind_names), actuator_gear, actuator_ctrlrange (nact, 2), ... (see
    ``ModelBuilder.add_actuator``).
    """

    def __init__(self, *, gravity, timestep, bodies, geoms, joints, actuators=None):
        self.gravity = _frozen(np.asarray(gravity, float))
        self.timestep = float(timestep)
        self.body_names = list(bodies["names"])
        self._body_index = {n: i for i, n in enumerate(self.body_names)}
        self.body_kind = _frozen(bodies["kind"])
        self.body_mass = _frozen(bodies["mass"])
        self.body_inertia = _frozen(bodies["inertia"])
        self.body_pos0 = _frozen(bodies["pos"])
        self.body_quat0 = _frozen(bodies["quat"])
        self.body_vel0 = _frozen(bodies["vel"])
        self.body_angvel0 = _frozen(bodies["angvel"])
        self.body_ipos = _frozen(bodies["ipos"])
        self.body_iquat = _frozen(bodies["iquat"])
        self.geom_names = list(geoms["names"])
        self._geom_index = {n: i for i, n in enumerate(self.geom_names)}
        self.geom_body = _frozen(geoms["body"])
        self.geom_type = _frozen(geoms["type"])
        self.geom_size = _frozen(geoms["size"])
        self.geom_pos = _frozen(geoms["pos"])
        self.geom_quat = _frozen(geoms["quat"])
        self.geom_friction = _frozen(geoms["friction"])
        self.geom_restitution = _frozen(geoms["restitution"])
        self.geom_rolling = _frozen(geoms["rolling"])
        self.geom_torsional = _frozen(geoms["torsional"])
        self.geom_stiffness = _frozen(geoms["stiffness"])
        self.geom_damping = _frozen(geoms["damping"])
        self.geom_contype = _frozen(geoms["contype"])
        self.geom_conaffinity = _frozen(geoms["conaffinity"])
        self.geom_margin = _frozen(geoms["margin"])
        self.geom_dataid = _frozen(geoms["dataid"])
        self.exclude_keys = _frozen(np.asarray(geoms["exclude_keys"], dtype=np.int64))
        self.joint_names = list(joints["names"])
        self._joint_index = {n: i for i, n in enumerate(self.joint_names)}
        self.joint_type_names = list(joints["type_names"])
        for key in ("type", "parent", "child", "anchor_a", "anchor_b", "frame_a", "frame_b",
                    "erp", "cfm", "stiffness", "soft_damping", "damping", "friction",
                    "motor_max", "limit", "cone", "twist", "core_rows", "row_start",
                    "row_count", "ndof", "kp", "kd", "max_torque"):
            setattr(self, "joint_" + key, _frozen(joints[key]))
        if actuators is None:
            actuators = dict(names=[], joint=np.zeros(0, np.int32), kind=np.zeros(0, np.int32),
                             axis=np.zeros((0, 3)), gear=np.zeros(0), kp=np.zeros(0),
                             kv=np.zeros(0), ctrlrange=np.zeros((0, 2)),
                             forcerange=np.zeros((0, 2)), folded=np.zeros(0, bool))
        self.actuator_names = list(actuators["names"])
        self._actuator_index = {n: i for i, n in enumerate(self.actuator_names)}
        for key in ("joint", "kind", "axis", "gear", "kp", "kv", "ctrlrange", "forcerange",
                    "folded"):
            setattr(self, "actuator_" + key, _frozen(actuators[key]))
        self.actuator_kind_names = ["motor" if k == 0 else "position"
                                    for k in self.actuator_kind]
        self.nrow = int(joints["nrow"])

        dynamic = self.body_kind == DYNAMIC
        inertia = np.where(dynamic[:, None], self.body_inertia, 0.0)
        with np.errstate(divide="ignore"):
            inv_mass = np.where(dynamic, 1.0 / self.body_mass, 0.0)
            inv_inertia = np.where(dynamic[:, None], 1.0 / self.body_inertia, 0.0)
        self.arrays = ModelArrays(gravity=self.gravity, body_kind=self.body_kind,
                                  body_inv_mass=_frozen(inv_mass),
                                  body_inertia=_frozen(inertia),
                                  body_inv_inertia=_frozen(inv_inertia),
                                  **{"joint_" + k: getattr(self, "joint_" + k) for k in (
                                      "type", "parent", "child", "anchor_a", "anchor_b",
                                      "frame_a", "frame_b", "erp", "cfm", "stiffness",
                                      "soft_damping", "damping", "friction", "motor_max",
                                      "limit", "cone", "twist", "core_rows", "row_start",
                                      "row_count")},
                                  **{k: getattr(self, k) for k in (
                                      "geom_type", "geom_body", "geom_size", "geom_pos",
                                      "geom_quat", "geom_friction", "geom_restitution",
                                      "geom_rolling", "geom_torsional", "geom_stiffness",
                                      "geom_damping",
                                      "geom_contype", "geom_conaffinity", "geom_margin",
                                      "geom_dataid", "exclude_keys")},
                                  **{k: _frozen(geoms[k]) for k in (
                                      "mesh_vert_adr", "mesh_vert_num", "mesh_vert",
                                      "hfield_adr", "hfield_nrow", "hfield_ncol",
                                      "hfield_data")},
                                  **{"act_" + k: getattr(self, "actuator_" + k) for k in (
                                      "joint", "kind", "axis", "gear", "kp", "kv", "ctrlrange",
                                      "forcerange", "folded")})
        self._seal()

    def __setattr__(self, name, value):
        if getattr(self, "_sealed", False):
            raise AttributeError(f"Model is immutable: cannot set '{name}'")
        super().__setattr__(name, value)

    def _seal(self):
        object.__setattr__(self, "_sealed", True)

    @property
    def nbody(self):
        return len(self.body_names)

    @property
    def ngeom(self):
        return len(self.geom_names)

    def body_index(self, body):
        """Index of a body given by index or name; ModelError names an unknown one."""
        return index_of(body, self._body_index, "body")

    def geom_index(self, geom):
        """Index of a geom given by index or name; ModelError names an unknown one."""
        return index_of(geom, self._geom_index, "geom")

    @property
    def njoint(self):
        return len(self.joint_names)

    def joint_index(self, joint):
        """Index of a joint given by index or name; ModelError names an unknown one."""
        return index_of(joint, self._joint_index, "joint")

    @property
    def nactuator(self):
        return len(self.actuator_names)

    def actuator_index(self, actuator):
        """Index of an actuator given by index or name; ModelError names an unknown one."""
        return index_of(actuator, self._actuator_index, "actuator")

    def __repr__(self):
        return f"<tumble.Model: {self.nbody} bodies, {self.njoint} joints, {self.ngeom} geoms>"
