"""What a world can be asked without changing it: its contacts and the forces they carry,
rays and distances, frames of bodies, energy and momentum, joint drift.

``QueryMixin`` gives ``World`` these calls; they read the state arrays and the model and
write nothing.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..math.quat import quat_rotate, quat_rotate_inv
from ..math.quat_np import qmatrix
from ..model.types import DYNAMIC
from ..model.validate import positive
from ..pipeline.integrate import variational_spin_momenta
from ..pipeline.joints.common import joint_frames
from ..pipeline.queries import contact_wrenches, distance_between, raycast_scene


@dataclass
class Contacts:
    """Contacts of one step, as arrays over n contacts (see ``World.contacts_of``)."""
    geoms: np.ndarray
    bodies: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    force: np.ndarray
    normal_force: np.ndarray
    torque: np.ndarray

    def __len__(self):
        return len(self.depth)



class QueryMixin:
    """The queries of ``World`` (see the module docstring)."""

    @property
    def contacts(self):
        """The contacts of the last step (world 0 of a batch; see ``contacts_of``)."""
        return self.contacts_of(0)

    def contacts_of(self, world):
        """Contacts of the last step in one world, as a ``Contacts`` of arrays (n contacts):
        ``geoms`` (n, 2), ``bodies`` (n, 2) (-1 = world), ``point`` (n, 3), ``normal`` (n, 3)
        from the first geom to the second, ``depth`` (n,) m, ``force`` (n, 3) on the second
        body in the world frame, N (the first gets the opposite), ``normal_force`` (n,) N,
        ``torque`` (n, 3) the torsional and rolling friction torque on the second body,
        N m, world frame (zero without spin friction; a pure couple, acting besides
        ``force`` at ``point``)."""
        w = self._world_slice(world) if world is not None else 0
        n = int(self._state.contact_count[w])
        c = self._contacts
        point, normal = c.point[w, :n].copy(), c.normal[w, :n].copy()
        impulse = np.ascontiguousarray(c.impulse[w, :n])
        force, torque = np.empty((n, 3)), np.empty((n, 3))
        contact_wrenches(normal, impulse, float(self.dt), force, torque)
        return Contacts(c.geom[w, :n].copy(), c.body[w, :n].copy(), point, normal,
                        c.depth[w, :n].copy(), force, impulse[:, 0] / self.dt, torque)

    @property
    def lcp_fallbacks(self):
        """Steps (since the world was made) in which PGS solved the contacts instead of
        Lemke: Lemke failed, the contacts had more rows than the exact path takes
        (``solvers.mlcp.EXACT_MAX_ROWS``, 512: about 170 contacts), or the world was backing
        off after failures (after a failure a world skips Lemke for 1, 2, 4, ... up to
        ``solve.LEMKE_BACKOFF_MAX``, 1,024, steps while it keeps failing, and tries again at
        once when it has fewer contacts than on those failures; ``tumble.pipeline.solve``)."""
        return int(self._state.lcp_fallbacks.sum())

    def raycast(self, origin, direction, max_dist=1e6, *, exclude_body=None, world=None):
        """First geom hit by the ray from ``origin`` along ``direction`` (world frame).

        Returns ``(distance m, geom name, body name or None, point, normal)`` or ``None``
        when nothing is hit within ``max_dist``. ``exclude_body`` skips one body's geoms
        (a character looking for the ground under its own feet).
        """
        o = self._vec3(origin, "raycast: origin", 0)
        d = self._vec3(direction, "raycast: direction", 0)
        length = np.linalg.norm(d)
        if length == 0.0:
            raise ModelError("raycast: direction is the zero vector")
        d = d / length
        skip = -2 if exclude_body is None else self.model.body_index(exclude_body)
        w = 0 if world is None else self._world_slice(world)
        ng = self.model.ngeom
        t, g, n = raycast_scene(self.model.arrays, self._state.body_pos[w],
                                self._state.body_quat[w],
                                np.zeros((ng, 3)), np.zeros((ng, 4)), o, d,
                                float(positive(max_dist, "raycast", "max_dist")), skip)
        if g < 0:
            return None
        b = self.model.geom_body[g]
        return (float(t), self.model.geom_names[g], None if b < 0 else self.model.body_names[b],
                o + t * d, np.asarray(n))

    def geom_distance(self, geom_a, geom_b, *, world=None):
        """Signed distance (m; negative: penetration depth) between two geoms, and their
        closest (or deepest) points, world frame: ``(distance, point_a, point_b)``."""
        ga, gb = self.model.geom_index(geom_a), self.model.geom_index(geom_b)
        w = 0 if world is None else self._world_slice(world)
        ng = self.model.ngeom
        dist, pa, pb = distance_between(self.model.arrays, self._state.body_pos[w],
                                        self._state.body_quat[w], np.zeros((ng, 3)),
                                        np.zeros((ng, 4)), ga, gb)
        return float(dist), np.asarray(pa), np.asarray(pb)

    def contact_force(self, body, *, world=None):
        """Total contact force (N) and torque about the COM (N m) on ``body`` over the last
        step."""
        b = self.model.body_index(body)
        con = self.contacts_of(world)
        f, t = np.zeros(3), np.zeros(3)
        com = self._state.body_pos[0 if world is None else world, b]
        for sign, side in ((-1.0, 0), (1.0, 1)):
            mine = con.bodies[:, side] == b
            f += sign * con.force[mine].sum(0)
            t += sign * (np.cross(con.point[mine] - com, con.force[mine]).sum(0)
                         + con.torque[mine].sum(0))
        return f, t

    def ground_contacts(self, *, touching=1e-3):
        """Which bodies touched the static world (the ground, terrain, static bodies) in the
        last step: (nworld, nbody) bool, or (nbody,) for one world. A contact counts when
        its surfaces overlap or are closer than ``touching`` (m), or it carried a force."""
        s, c = self._state, self._contacts
        n = c.depth.shape[1]
        live = np.arange(n)[None, :] < s.contact_count[:, None]
        live &= (c.depth > -touching) | (c.impulse[..., 0] > 0.0)
        static = np.append(self.model.body_kind != DYNAMIC, True)    # index -1: the world
        a, b = c.body[..., 0], c.body[..., 1]
        out = np.zeros((self.nworld, self.model.nbody + 1), np.bool_)
        w = np.broadcast_to(np.arange(self.nworld)[:, None], a.shape)
        hit_a = live & static[b] & (a >= 0)
        hit_b = live & static[a] & (b >= 0)
        out[w[hit_a], a[hit_a]] = True
        out[w[hit_b], b[hit_b]] = True
        return self._view(out[:, :-1])

    def joint_separation(self):
        """Distance (m) between each joint's two anchor points: the drift; (njoint,)."""
        s = self._state
        out = np.zeros((self.nworld, self.model.njoint))
        for w in range(self.nworld):
            for j in range(self.model.njoint):
                anchor_a, anchor_b = joint_frames(self.model.arrays, s.body_pos[w],
                                                  s.body_quat[w], j)[:2]
                out[w, j] = np.linalg.norm(np.subtract(anchor_b, anchor_a))
        return self._view(out)

    def _body_state(self, body, world):
        b = self.model.body_index(body)
        w = 0 if world is None else self._world_slice(world)
        s = self._state
        return b, s.body_pos[w, b], s.body_quat[w, b], s.body_vel[w, b], s.body_angvel[w, b]

    def point_velocity(self, body, point, *, world=None):
        """Velocity (m/s, world) of the world ``point`` moving with ``body``: ``v + w x r``."""
        b, pos, _, vel, angvel = self._body_state(body, world)
        r = np.asarray(point, float) - pos
        return vel + np.cross(angvel, r)

    def body_to_world(self, body, point_b, *, world=None):
        """World position of a point given in the body's COM principal frame (m)."""
        b, pos, quat, _, _ = self._body_state(body, world)
        return pos + np.asarray(quat_rotate(quat, np.asarray(point_b, float)))

    def world_to_body(self, body, point_w, *, world=None):
        """Position in the body's COM principal frame of a world point (m)."""
        b, pos, quat, _, _ = self._body_state(body, world)
        return np.asarray(quat_rotate_inv(quat, np.asarray(point_w, float) - pos))

    def vector_to_world(self, body, vec_b, *, world=None):
        """Rotate a body-frame direction into the world frame."""
        b, _, quat, _, _ = self._body_state(body, world)
        return np.asarray(quat_rotate(quat, np.asarray(vec_b, float)))

    def vector_to_body(self, body, vec_w, *, world=None):
        """Rotate a world-frame direction into the body frame."""
        b, _, quat, _, _ = self._body_state(body, world)
        return np.asarray(quat_rotate_inv(quat, np.asarray(vec_w, float)))

    def _dynamic(self):
        return self.model.body_kind == DYNAMIC

    def _world_inertia(self, quat):
        """(..., nbody, 3, 3) world inertia R diag(I) R^T of the bodies."""
        rot = qmatrix(quat)
        moments = self.model.arrays.body_inertia
        return np.einsum("...ij,...j,...kj->...ik", rot, moments, rot)

    def energy(self):
        """(kinetic, potential) energy in J of the dynamic bodies; per world for a batch.

        Potential is gravitational, ``-m g . x``, zero at the world origin.
        """
        s, dyn = self._state, self._dynamic()
        mass = np.where(dyn, self.model.body_mass, 0.0)
        iw = self._world_inertia(s.body_quat)
        lin = 0.5 * np.einsum("b,wbi,wbi->w", mass, s.body_vel, s.body_vel)
        ang = 0.5 * np.einsum("wbi,wbij,wbj->w", s.body_angvel, iw, s.body_angvel)
        pot = -np.einsum("b,wbi,i->w", mass, s.body_pos, self.model.gravity)
        kinetic, potential = lin + ang, pot
        if self.nworld == 1:
            return float(kinetic[0]), float(potential[0])
        return kinetic, potential

    def linear_momentum(self):
        """Total linear momentum (kg m/s, world) of the dynamic bodies: (3,) or (nworld, 3)."""
        s = self._state
        mass = np.where(self._dynamic(), self.model.body_mass, 0.0)
        return self._view(np.einsum("b,wbi->wi", mass, s.body_vel))

    def angular_momentum(self, about=(0.0, 0.0, 0.0)):
        """Total angular momentum (kg m^2/s, world) about the world point ``about``.

        Sum over dynamic bodies of ``(x - about) x m v + I_w w``: (3,) or (nworld, 3). With
        ``gyroscopic='variational'`` the spin part is the discrete momentum that scheme
        conserves (``tumble.pipeline.integrate.variational_spin_momenta``).
        """
        s = self._state
        mass = np.where(self._dynamic(), self.model.body_mass, 0.0)
        r = s.body_pos - np.asarray(about, float)
        orbital = np.einsum("b,wbi->wbi", mass, np.cross(r, s.body_vel))
        if self.options.gyroscopic == "variational":
            # the momentum the variational step keeps: I w differs from it by O(h^2)
            spin = np.empty_like(s.body_angvel)
            variational_spin_momenta(self.model.body_inertia, s.body_quat, s.body_angvel,
                                     float(self.options.dt), spin)
        else:
            spin = np.einsum("wbij,wbj->wbi", self._world_inertia(s.body_quat), s.body_angvel)
        return self._view((orbital + spin).sum(axis=1))

