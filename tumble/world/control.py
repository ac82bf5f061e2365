"""Control: what a user writes into a world between steps and the step reads -- applied
forces and torques, joint servo gains and targets, joint torques, motor targets, MJCF
actuator controls, body servos (the hand of god).

``ControlMixin`` gives ``World`` these calls and live arrays; they read and write only
``World._control`` (``pipeline.arrays.ControlArrays``), never the physical state.
"""
import numpy as np

from ..errors import ModelError
from ..model.validate import positive


class ControlMixin:
    """The control calls and arrays of ``World`` (see the module docstring)."""

    @property
    def joint_motor_target(self):
        """Live (njoint, 3) motor target velocities (rad/s or m/s) of each degree of freedom;
        the motor pushes with at most the joint's ``motor_max_force``."""
        return self._view(self._control.motor_target)

    @property
    def joint_kp(self):
        """Live PD servo stiffness per joint (njoint,), N m/rad or N/m (0 with kd 0: off)."""
        return self._view(self._control.pd_kp)

    @joint_kp.setter
    def joint_kp(self, value):
        self._assign("pd_kp", value)

    @property
    def joint_kd(self):
        """Live PD servo damping per joint (njoint,), N m s/rad or N s/m."""
        return self._view(self._control.pd_kd)

    @joint_kd.setter
    def joint_kd(self, value):
        self._assign("pd_kd", value)

    @property
    def joint_max_torque(self):
        """Live bound on each DoF's servo torque (njoint,), N m or N (inf: none)."""
        return self._view(self._control.pd_max)

    @joint_max_torque.setter
    def joint_max_torque(self, value):
        self._assign("pd_max", value)

    @property
    def pd_target_quat(self):
        """Live servo targets of ball joints (njoint, 4): the child joint frame relative to
        the parent's (x, y, z, w), as ``joint_quat`` reports it. Starts at the built pose."""
        return self._view(self._control.pd_target_quat)

    @pd_target_quat.setter
    def pd_target_quat(self, value):
        self._assign("pd_target_quat", value)

    @property
    def pd_target_q(self):
        """Live servo targets of hinge, universal and slider joints (njoint, 3), in the
        coordinates of ``joint_q`` (rad or m). Starts at the built pose."""
        return self._view(self._control.pd_target_q)

    @pd_target_q.setter
    def pd_target_q(self, value):
        self._assign("pd_target_q", value)

    @property
    def pd_target_qd(self):
        """Live servo target rates (njoint, 3) along the axes of ``joint_qd``; default 0."""
        return self._view(self._control.pd_target_qd)

    @pd_target_qd.setter
    def pd_target_qd(self, value):
        self._assign("pd_target_qd", value)

    def set_pd_gains(self, joint, kp, kd, max_torque=None, *, world=None):
        """Set one joint's servo gains (kp N m/rad, kd N m s/rad; joint by index or name)."""
        j = self.model.joint_index(joint)
        wsl = self._world_slice(world)
        where = f"joint '{self.model.joint_names[j]}'"
        self._control.pd_kp[wsl, j] = positive(kp, where, "kp", allow_zero=True)
        self._control.pd_kd[wsl, j] = positive(kd, where, "kd", allow_zero=True)
        if max_torque is not None:
            self._control.pd_max[wsl, j] = positive(max_torque, where, "max_torque")

    def apply_joint_torque(self, joint, torque, *, world=None):
        """Add a torque (N m; force in N for sliders) per degree of freedom of ``joint``
        along the axes of ``joint_qd``: +tau on the child, -tau on the parent. Acts through
        the next ``step(n)`` call, then is cleared, like ``apply_force``."""
        j = self.model.joint_index(joint)
        wsl = self._world_slice(world)
        n = int(self.model.joint_ndof[j])
        t = np.asarray(torque, float)
        if t.ndim == 0 and n == 1:                 # a hinge or slider takes a plain number
            t = t.reshape(1)
        if t.shape not in ((n,), (self.nworld, n)) or (t.shape != (n,) and world is not None):
            raise ModelError(f"apply_joint_torque on joint '{self.model.joint_names[j]}': "
                             f"torque must have shape ({n},), got {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ModelError(f"apply_joint_torque on joint '{self.model.joint_names[j]}': "
                             f"torque is not finite: {t.tolist()}")
        self._control.joint_applied[wsl, j, :n] += t

    @property
    def joint_applied_torque(self):
        """Live (njoint, 3) torques per DoF applied through the next ``step(n)`` call."""
        return self._view(self._control.joint_applied)

    def set_body_servo(self, body, kp, kd, kp_rot=0.0, kd_rot=0.0, *, world=None):
        """Switch on (or, with all gains 0, off) the implicit PD servo pulling ``body``'s COM
        toward ``body_target_pos`` (kp N/m, kd N s/m) and its orientation toward
        ``body_target_quat`` (kp_rot N m/rad, kd_rot N m s/rad): the hand of god.

        It is an external force (from the world), solved implicitly with the joints and
        contacts, so it is stable for any gains and step. Targets default to the built pose.
        """
        b = self.model.body_index(body)
        wsl = self._world_slice(world)
        where = f"body servo of '{self.model.body_names[b]}'"
        self._control.body_servo[wsl, b] = [positive(v, where, n, allow_zero=True) for v, n in (
            (kp, "kp"), (kd, "kd"), (kp_rot, "kp_rot"), (kd_rot, "kd_rot"))]

    @property
    def body_target_pos(self):
        """Live body servo targets (nbody, 3): COM positions, m, world frame."""
        return self._view(self._control.body_target_pos)

    @body_target_pos.setter
    def body_target_pos(self, value):
        self._assign("body_target_pos", value)

    @property
    def body_target_quat(self):
        """Live body servo targets (nbody, 4): orientations as ``body_quat`` (x, y, z, w)."""
        return self._view(self._control.body_target_quat)

    @body_target_quat.setter
    def body_target_quat(self, value):
        self._assign("body_target_quat", value)

    @property
    def body_target_vel(self):
        """Live body servo target velocities (nbody, 3), m/s, world frame."""
        return self._view(self._control.body_target_vel)

    @body_target_vel.setter
    def body_target_vel(self, value):
        self._assign("body_target_vel", value)

    @property
    def body_target_angvel(self):
        """Live body servo target angular velocities (nbody, 3), rad/s, world frame."""
        return self._view(self._control.body_target_angvel)

    @body_target_angvel.setter
    def body_target_angvel(self, value):
        self._assign("body_target_angvel", value)

    @property
    def ctrl(self):
        """Live MJCF actuator controls (nactuator,) or (nworld, nactuator)."""
        return self._view(self._control.ctrl)

    @ctrl.setter
    def ctrl(self, value):
        self._assign("ctrl", value)

    def _vec3(self, value, what, world):
        """Broadcast a force-like (3,) or per-world (nworld, 3) array, refusing non-finite."""
        try:
            if isinstance(value, (str, bytes)):
                raise TypeError
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{what} must be 3 numbers"
                             + (f" or ({self.nworld}, 3)" if self.nworld > 1 else "")
                             + f", got {value!r}") from None
        ok = a.shape == (3,) or (world is None and a.shape == (self.nworld, 3))
        if not ok:
            raise ModelError(f"{what} must have shape (3,)"
                             + (f" or ({self.nworld}, 3)" if self.nworld > 1 else "")
                             + f", got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ModelError(f"{what} is not finite: {a.tolist()}")
        return a

    def apply_force(self, body, force, point=None, *, world=None):
        """Apply ``force`` (N, world frame) at world ``point`` (default: the COM).

        Adds the torque ``(point - com) x force``. Forces accumulate and act through the
        whole next ``step(n)`` call, then are cleared. On kinematic and static bodies
        they have no effect. ``world`` picks one copy of a batch (default: all).
        """
        b = self.model.body_index(body)
        wsl = self._world_slice(world)
        f = self._vec3(force, f"apply_force on body '{self.model.body_names[b]}': force", world)
        if point is not None:
            p = self._vec3(point, f"apply_force on body '{self.model.body_names[b]}': point",
                           world)
            r = p - self._state.body_pos[wsl, b]
            self._control.applied_torque[wsl, b] += np.cross(r, f)
        self._control.applied_force[wsl, b] += f

    def apply_torque(self, body, torque, *, world=None):
        """Apply ``torque`` (N m, world frame) to ``body`` through the next ``step(n)`` call."""
        b = self.model.body_index(body)
        wsl = self._world_slice(world)
        t = self._vec3(torque, f"apply_torque on body '{self.model.body_names[b]}': torque", world)
        self._control.applied_torque[wsl, b] += t

    def clear_forces(self):
        """Drop the forces and torques applied since the last step."""
        self._control.applied_force[:] = 0.0
        self._control.applied_torque[:] = 0.0

