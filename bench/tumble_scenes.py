"""The benchmark scenes in tumble for the bench scripts, and the Python-side PD of its runner.

The scenes are built by ``tumble.apps.benchmarks`` (re-exported here: ``build``, ``steps``,
``chain``, ``stack``, ``pyramid``, ``ragdoll``, ``spheres``), from the same numbers as the
peers' runners (``bench/scenes.py``).

The ragdoll PD scenes hold the pose with :class:`ExplicitPD`: torques computed in NumPy
from ``world.joint_q`` / ``joint_qd`` and applied with ``world.apply_torque`` before every
single ``step()``, the route the peers' runners take too. It is the slow route (a Python
round trip per step, explicit in the damping, so it diverges once kd dt / I > 2 on the light
hands); tumble's own route is its in-step joint servos (``World(pd=...)``, the
'implicit-pd' variants of bench_tumble.py).
"""
import numpy as np

from tumble.apps.benchmarks import (  # noqa: F401
    build, chain, pyramid, ragdoll, spheres, stack, steps)
from tumble.math.quat_np import qmul, qrot

from . import common as C


class ExplicitPD:
    """PD torques towards the initial pose, recomputed in NumPy before every step.

    For joint j with gains (kp N m/rad, kd N m s/rad), in its parent's joint frame:
    ``tau = -kp q - kd qd``, where q is the ball joint's rotation vector or the hinge angle
    and qd the relative angular velocity along the same axes (``world.joint_q``,
    ``joint_qd``). The torque acts +tau on the child and -tau on the parent (world frame).

    gains : {joint name: (kp, kd)}, e.g. ``scenes.ragdoll_pd_gains(parts, "spec")``.
    """

    def __init__(self, world, gains):
        m = world.model
        if np.any(m.joint_parent < 0):
            raise ValueError("ExplicitPD: every joint needs a parent body")
        self.world = world
        kp_kd = np.array([gains[name] for name in m.joint_names], float)
        self.kp, self.kd = kp_kd[:, :1], kp_kd[:, 1:]
        self.parent, self.child = np.asarray(m.joint_parent), np.asarray(m.joint_child)
        self.frame_a = np.asarray(m.joint_frame_a)   # joint frame in the parent's principal frame
        self.bodies = np.union1d(self.parent, self.child)
        self.torque = np.zeros((m.nbody, 3))

    def apply(self):
        """Apply this step's torques (they act through the next ``world.step`` call only)."""
        w = self.world
        # joint_q / joint_qd are zero past each joint's degrees of freedom, so one formula
        # covers ball (3 axes) and hinge (the frame's x axis) joints.
        tau_joint = -self.kp * w.joint_q - self.kd * w.joint_qd
        tau = qrot(qmul(w.body_quat[self.parent], self.frame_a), tau_joint)
        self.torque[:] = 0.0
        np.add.at(self.torque, self.child, tau)
        np.add.at(self.torque, self.parent, -tau)
        for body in self.bodies:
            w.apply_torque(int(body), self.torque[body])


def joint_error(world):
    """Largest deviation (rad) of any joint from the initial pose: ball rotation angle or
    hinge angle (a row of ``joint_q`` is a ball's rotation vector or (angle, 0, 0))."""
    return C.joint_error(world.joint_q, [])
