"""Model: everything that does not change while stepping, as read-only arrays.

Bodies are simulated in their *COM principal frame*: ``body_pos0`` is the centre of
mass and ``body_quat0`` the orientation of the principal axes, so ``body_inertia``
is diagonal. ``body_ipos`` / ``body_iquat`` give that frame in the frame the user
built the body in; geoms are stored relative to the COM principal frame.
"""
from collections import namedtuple

import numpy as np

from ..errors import ModelError

BODY_KINDS = {"dynamic": 0, "kinematic": 1, "static": 2}
DYNAMIC, KINEMATIC, STATIC = 0, 1, 2
GEOM_TYPES = {"plane": 0, "sphere": 1, "capsule": 2, "box": 3, "cylinder": 4}

# What the compiled pipeline reads of a model (one namedtuple so kernels take one argument).
ModelArrays = namedtuple("ModelArrays", [
    "gravity",            # (3,) m/s^2
    "body_kind",          # (nbody,) int32: DYNAMIC, KINEMATIC, STATIC
    "body_inv_mass",      # (nbody,) 1/kg, 0 for kinematic and static bodies
    "body_inertia",       # (nbody, 3) principal moments, kg m^2 (0 when not dynamic)
    "body_inv_inertia",   # (nbody, 3) their inverses, 0 when not dynamic
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
    geom_friction, geom_restitution, geom_contype, geom_conaffinity.
    """

    def __init__(self, *, gravity, timestep, bodies, geoms):
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
        self.geom_body = _frozen(geoms["body"])
        self.geom_type = _frozen(geoms["type"])
        self.geom_size = _frozen(geoms["size"])
        self.geom_pos = _frozen(geoms["pos"])
        self.geom_quat = _frozen(geoms["quat"])
        self.geom_friction = _frozen(geoms["friction"])
        self.geom_restitution = _frozen(geoms["restitution"])
        self.geom_contype = _frozen(geoms["contype"])
        self.geom_conaffinity = _frozen(geoms["conaffinity"])
        self.joint_names = []

        dynamic = self.body_kind == DYNAMIC
        inertia = np.where(dynamic[:, None], self.body_inertia, 0.0)
        with np.errstate(divide="ignore"):
            inv_mass = np.where(dynamic, 1.0 / self.body_mass, 0.0)
            inv_inertia = np.where(dynamic[:, None], 1.0 / self.body_inertia, 0.0)
        self.arrays = ModelArrays(gravity=self.gravity, body_kind=self.body_kind,
                                  body_inv_mass=_frozen(inv_mass),
                                  body_inertia=_frozen(inertia),
                                  body_inv_inertia=_frozen(inv_inertia))
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
        if isinstance(body, (int, np.integer)) and not isinstance(body, bool):
            if 0 <= body < self.nbody:
                return int(body)
            raise ModelError(f"body index {body} out of range: the model has {self.nbody} bodies")
        if isinstance(body, str):
            try:
                return self._body_index[body]
            except KeyError:
                raise ModelError(f"unknown body '{body}'; bodies are {self.body_names}") from None
        raise ModelError(f"a body is given by its index or name, got {body!r}")

    def __repr__(self):
        return f"<tumble.Model: {self.nbody} bodies, {self.ngeom} geoms>"
