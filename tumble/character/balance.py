"""Root and virtual-force control: hand of god, Jacobian-transpose torques, static balance.

- ``HandOfGod``: an external PD force and torque on the root body toward a target position
  and orientation (the lecture's crutch for tracking before balance is solved).
- ``jacobian_transpose_torques``: joint torques ``tau_j = r_j x F`` along a chain that
  realise a desired force F at a point (the COM, a foot, a hand) without external force.
- ``StaticBalance``: stands a character with joint torques only: PD servos hold the pose
  and a virtual force on the COM, realised through the stance legs, keeps the COM over the
  support polygon; a virtual torque on the pelvis, realised by the hips, keeps it upright.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ModelError
from ..model.validate import positive
from .pd import apply_joint_torques


def _stable_gain(kp, kd, h, inv_mass):
    """(kp, kd) that act as if evaluated at the end of a control period h (Tan et al. 2011)
    for a body of inverse mass or inertia ``inv_mass``: gains divided by 1 + h (kd + h kp) / m."""
    s = 1.0 + h * (kd + h * kp) * inv_mass
    return kp / s, kd / s


class HandOfGod:
    """External PD force and torque on ``body`` toward a target pose, world frame.

    kp (N/m), kd (N s/m), kp_rot (N m/rad), kd_rot (N m s/rad). Call ``apply(...)`` once per
    control frame before ``world.step(n)``.

    implicit (default): the World's body servo (``World.set_body_servo``), solved with the
    joints and contacts every substep: stable for any gains and step.
    implicit=False: an explicit force and torque held through the n substeps, with gains
    evaluated at the end of the period for the character's ``mass`` and ``inertia``
    (default its total mass and 10 times the root body's largest moment); stiff gains on a
    light root can still ring, which the implicit form avoids.
    """

    def __init__(self, world, body, kp=2000.0, kd=200.0, kp_rot=1000.0, kd_rot=100.0, *,
                 mass=None, inertia=None, implicit=True):
        self.world = world
        self.body = world.model.body_index(body)
        for name, v in (("kp", kp), ("kd", kd), ("kp_rot", kp_rot), ("kd_rot", kd_rot)):
            positive(v, "HandOfGod", name, allow_zero=True)
        self.kp, self.kd, self.kp_rot, self.kd_rot = kp, kd, kp_rot, kd_rot
        m = world.model
        dyn = np.isfinite(m.body_mass)
        self.mass = float(m.body_mass[dyn].sum()) if mass is None else positive(mass, "HandOfGod", "mass")
        self.inertia = (10.0 * float(m.body_inertia[self.body].max()) if inertia is None
                        else positive(inertia, "HandOfGod", "inertia"))
        self.last_force = np.zeros(3)
        self.last_torque = np.zeros(3)
        self.implicit = bool(implicit)
        if self.implicit:
            world.set_body_servo(self.body, kp, kd, kp_rot, kd_rot)

    def release(self):
        """Switch the hand of god off (no more external force on the body)."""
        if self.implicit:
            self.world.set_body_servo(self.body, 0.0, 0.0, 0.0, 0.0)
        self.kp = self.kd = self.kp_rot = self.kd_rot = 0.0

    def apply(self, target_pos, target_quat, target_vel=(0, 0, 0), target_angvel=(0, 0, 0),
              *, substeps=1):
        """Aim the PD at this target for the next ``world.step(substeps)``.

        Returns the force (N) and torque (N m) the PD asks for at the current state (for an
        implicit hand of god an estimate: the solver applies the end-of-step value).
        """
        w = self.world
        h = substeps * w.dt
        pos, quat = w.body_pos[self.body], w.body_quat[self.body]
        vel, angvel = w.body_vel[self.body], w.body_angvel[self.body]
        tp = np.asarray(target_pos, float)
        tq = np.asarray(target_quat, float)
        if tp.shape != (3,) or tq.shape != (4,) or not (np.all(np.isfinite(tp))
                                                         and np.all(np.isfinite(tq))):
            raise ModelError("HandOfGod.apply: target_pos must be (3,) and target_quat (4,), "
                             "finite")
        err = (Rotation.from_quat(tq) * Rotation.from_quat(quat).inv()).as_rotvec()
        tv, tw = np.asarray(target_vel, float), np.asarray(target_angvel, float)
        if self.implicit:
            w.body_target_pos[self.body] = tp
            w.body_target_quat[self.body] = tq
            w.body_target_vel[self.body] = tv
            w.body_target_angvel[self.body] = tw
            f = self.kp * (tp - pos) - self.kd * (vel - tv)
            t = self.kp_rot * err - self.kd_rot * (angvel - tw)
        else:
            kp, kd = _stable_gain(self.kp, self.kd, h, 1.0 / self.mass)
            f = kp * (tp - pos - h * vel) - kd * (vel - tv)
            kr, kw = _stable_gain(self.kp_rot, self.kd_rot, h, 1.0 / self.inertia)
            t = kr * (err - h * angvel) - kw * (angvel - tw)
            w.apply_force(self.body, f)
            w.apply_torque(self.body, t)
        self.last_force, self.last_torque = f, t
        return f, t


def chain_to_root(model, joint):
    """Joints from ``joint`` (index or name) up to the root, child-most first: [j, ...]."""
    j = model.joint_index(joint)
    parent_joint = {int(model.joint_child[k]): k for k in range(model.njoint)}
    chain = [j]
    while True:
        p = int(model.joint_parent[chain[-1]])
        if p < 0 or p not in parent_joint:
            return chain
        chain.append(parent_joint[p])


def _anchors(world, joints, w=0):
    """World anchors (on the child side) of ``joints``: (len, 3)."""
    m = world.model
    s = world.state_arrays
    out = np.zeros((len(joints), 3))
    for i, j in enumerate(joints):
        c = m.joint_child[j]
        out[i] = s.body_pos[w, c] + Rotation.from_quat(s.body_quat[w, c]).apply(np.array(m.joint_anchor_b[j]))
    return out


def jacobian_transpose_torques(world, joints, point, force, *, base="parent", world_index=0):
    """World joint torques (njoint, 3) that realise ``force`` (N) at world ``point``.

    joints : the chain (indices or names) between the base and the body the force acts on.
    base : 'parent' when the force acts on the child side of every joint of the chain
        (a hand, from the shoulder down); 'child' when it acts on the parent side (the COM
        above a stance foot: the chain is ankle, knee, hip and the ground is the base).
    ``tau_j = (point - anchor_j) x force`` for every joint of the chain, signed for the side
    the force acts on; apply them with ``apply_joint_torques``.
    """
    m = world.model
    if base not in ("parent", "child"):
        raise ModelError(f"jacobian_transpose_torques: base must be 'parent' or 'child', got {base!r}")
    idx = [m.joint_index(j) for j in joints]
    p = np.asarray(point, float)
    f = np.asarray(force, float)
    if p.shape != (3,) or f.shape != (3,) or not (np.all(np.isfinite(p)) and np.all(np.isfinite(f))):
        raise ModelError("jacobian_transpose_torques: point and force must be finite (3,) vectors")
    tau = np.zeros((m.njoint, 3))
    r = p - _anchors(world, idx, world_index)
    sign = 1.0 if base == "parent" else -1.0
    tau[idx] = sign * np.cross(r, f)
    return tau


def center_of_mass(world, world_index=0):
    """(position m, velocity m/s) of the dynamic bodies' centre of mass, world frame."""
    m = world.model
    s = world.state_arrays
    dyn = np.isfinite(m.body_mass)
    mass = m.body_mass[dyn]
    c = (mass[:, None] * s.body_pos[world_index, dyn]).sum(0) / mass.sum()
    v = (mass[:, None] * s.body_vel[world_index, dyn]).sum(0) / mass.sum()
    return c, v


class StaticBalance:
    """Stand still with joint torques only: pose servos + COM and pelvis virtual forces.

    world : a World whose servos (``PDController``) hold the standing pose.
    feet : names of the two stance-foot joints (e.g. ankles); each leg's chain runs from
        its foot joint up to (not including) the root body's joint.
    pelvis : the root body (index or name). up : the world up axis, (3,).
    kp_com (N/m), kd_com (N s/m), ki_com (N/(m s)): the horizontal virtual force on the COM
    toward the centre of the feet; the integral term removes the offset the pose servos
    leave, so the COM ends over the middle of the support and has the most room to
    recover from a push. kp_upright (N m/rad), kd_upright: the virtual torque keeping the
    pelvis at its initial orientation, realised by the hips.
    Call ``apply(substeps)`` once per control frame, before ``world.step(substeps)``.
    """

    def __init__(self, world, feet, pelvis, *, up=(0, 1, 0), kp_com=3000.0, kd_com=500.0,
                 ki_com=800.0, kp_upright=300.0, kd_upright=30.0, feet_bodies=None,
                 target_quat=None, max_integral=80.0):
        m = world.model
        self.world = world
        self.pelvis = m.body_index(pelvis)
        self.up = np.asarray(up, float) / np.linalg.norm(up)
        self.chains = []
        for foot in feet:
            chain = chain_to_root(m, foot)
            # the root's own joint (its pin or free joint) is not part of a leg
            chain = [j for j in chain if m.joint_child[j] != self.pelvis]
            self.chains.append(chain)
        self.hips = []
        for chain in self.chains:
            top = chain[-1]
            if m.joint_parent[top] != self.pelvis:
                raise ModelError(f"StaticBalance: the chain from '{m.joint_names[chain[0]]}' "
                                 f"does not reach the pelvis")
            self.hips.append(top)
        self.feet_bodies = ([m.joint_child[self.chains[i][0]] for i in range(len(feet))]
                            if feet_bodies is None else [m.body_index(b) for b in feet_bodies])
        self.kp_com, self.kd_com, self.ki_com = kp_com, kd_com, ki_com
        self.max_integral = max_integral
        self.integral = np.zeros(3)
        self.kp_upright, self.kd_upright = kp_upright, kd_upright
        self.target_quat = (np.array(world.body_quat[self.pelvis]) if target_quat is None
                            else np.asarray(target_quat, float))
        self.last_force = np.zeros(3)

    def support_center(self):
        """Mean of the stance feet's positions, projected on the ground plane (world)."""
        p = self.world.body_pos[self.feet_bodies].mean(0)
        return p

    def apply(self, substeps=1):
        """Add this control frame's balance torques (world frame) for ``step(substeps)``."""
        w = self.world
        c, v = center_of_mass(w)
        target = self.support_center()
        d = target - c
        d -= (d @ self.up) * self.up
        vh = v - (v @ self.up) * self.up
        # integral of the COM error (N), clamped so a fall does not wind it up
        self.integral += self.ki_com * d * substeps * w.dt
        norm = np.linalg.norm(self.integral)
        if norm > self.max_integral:
            self.integral *= self.max_integral / norm
        f = self.kp_com * d - self.kd_com * vh + self.integral
        tau = np.zeros((w.model.njoint, 3))
        for chain in self.chains:
            tau += jacobian_transpose_torques(w, chain, c, f / len(self.chains), base="child")
        q = w.body_quat[self.pelvis]
        err = (Rotation.from_quat(self.target_quat) * Rotation.from_quat(q).inv()).as_rotvec()
        t_pelvis = self.kp_upright * err - self.kd_upright * w.body_angvel[self.pelvis]
        for hip in self.hips:
            # a joint torque pushes its parent (the pelvis) by -tau
            tau[hip] -= t_pelvis / len(self.hips)
        apply_joint_torques(w, tau)
        self.last_force = f
        return tau


class Push:
    """A perturbation: ``force`` (N, world) on ``body`` at ``point`` (default its COM) from
    ``start`` for ``duration`` seconds of world time.

    Call ``apply(world)`` before every ``world.step(n)``; it applies the force when the
    coming steps fall in the window, scaled by the part of them that does.
    """

    def __init__(self, body, force, start, duration, point=None):
        self.body, self.point = body, point
        self.force = np.asarray(force, float)
        if self.force.shape != (3,) or not np.all(np.isfinite(self.force)):
            raise ModelError(f"Push: force must be a finite (3,) vector, got {force!r}")
        self.start = float(start)
        self.duration = positive(duration, "Push", "duration")

    def apply(self, world, substeps=1):
        """Apply the share of the push that falls in the next ``substeps`` steps."""
        t0, t1 = world.time, world.time + substeps * world.dt
        overlap = min(t1, self.start + self.duration) - max(t0, self.start)
        if overlap > 1e-12:
            world.apply_force(self.body, self.force * overlap / (t1 - t0), point=self.point)
            return True
        return False
