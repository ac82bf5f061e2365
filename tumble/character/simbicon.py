"""SIMBICON walking (Yin, Loken and van de Panne 2007) for a 3-D ragdoll, no external force.

The controller is a finite-state machine of target poses. Each step (one leg in stance, the
other swinging) has two states: the first ends after a fixed time, the second when the
swing foot touches the ground (or after a time-out); the stance leg then swaps and the same
two states repeat mirrored. In every state:

- knees, ankles, toes, spine, neck and arms track joint-local targets with PD servos;
- the torso (the pelvis, root of the ragdoll) and the swing thigh track orientations in the
  world, or rather in the heading frame (yaw of the desired heading, so turning is a
  heading that turns);
- the stance hip is not tracked: it carries ``tau_stance = -tau_torso - tau_swing``, the
  torque that gives the pelvis the torso's PD torque whatever the swing hip does;
- balance feedback moves the swing hip's target with the centre of mass (COM):
  ``theta_d = theta_d0 + c_d d + c_v v`` in the sagittal plane (hip flexion) and the
  coronal plane (hip abduction), with d the horizontal offset of the COM from the stance
  ankle and v the COM velocity, both in the heading frame.

The torso and stance-hip part has three forms (``hip_control``):

- 'implicit' (default): the stance hip is an implicit servo (solved in the step with the
  joints and contacts, stable at any step) whose target is the joint rotation that would
  put the pelvis at its desired world orientation given the stance thigh's current
  orientation, with a target rate that makes its damping act on the pelvis's world angular
  velocity. Its torque is thus ``tau_stance = -tau_torso``, the torso's PD torque taken at
  the end of the step; the swing hip's reaction on the pelvis is not cancelled in advance
  but rejected by that stiff servo. The swing hip is an implicit servo toward the desired
  world thigh orientation expressed in the current pelvis frame.
- 'rule': the same, plus the balance rule's second term fed forward: the stance hip also
  carries ``-tau_swing``, the torque the swing hip exerted on its thigh in the last physics
  step (``world.joint_torque``), held through the control period. Then ``tau_stance =
  -tau_torso - tau_swing`` literally, with ``tau_torso`` implicit and ``tau_swing`` one
  physics step old. It walks as well on flat ground and takes larger forward pushes, but
  the shipped gaits were tuned for 'implicit' and it is weaker on the 5 degree descent
  (bench/bench_walk.py has the figures of both).
- 'explicit': the paper's torques, ``tau_torso`` and ``tau_swing`` from world-frame PD
  laws on the pelvis and swing thigh, ``tau_stance = -tau_torso - tau_swing``, applied as
  joint torques held through the control period. The PD laws are evaluated at the end of
  the period against the inertia of the bodies they turn (stable PD, backward Euler for
  one rigid body); being explicit they see neither the contacts nor the rest of the body.
  With the shipped gaits' gains it falls within 2.5 s at every step tried (1/480 to 1/20
  s): kept to compare, not to walk.

Speed and turning are parameters: with a target speed set (``Gait.speed``) a step-to-step
integral regulator moves the swing hip's flexion by ``speed_gain`` rad per m/s of error
after every step (less flexion, a step closer under the body, speeds the walk up), bounded
by ``speed_limit``; ``turn_rate`` (rad/s) turns the desired heading, which the pelvis and
the swing thigh follow. On a slope the gait adds ``slope_lean``, ``slope_hip`` and
``slope_ankle`` times the slope angle under the stance foot to the torso pitch, the swing
hip flexion and the ankles' dorsiflexion; ``min_step_width`` keeps the swing foot from
landing across the stance foot.

Gaits are plain JSON files (``tumble/character/gaits/*.json``; ``load_gait(name or path)``
in ``gait_files``); see ``Gait`` for the fields and sign conventions. ``run_walk`` (in
``walk``) walks a controller and measures the walk.

Frames: Y up; the character's rest pose (the model's build pose) faces ``forward``
(+z for the course character) with its left along ``up x forward``. All angles are in
radians, lengths in metres, times in seconds.
"""
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..model.validate import positive
from ..math import quat_np as Q
from .balance import center_of_mass
from .feet import foot_lowest_at
from .gait_files import Gait, GaitState, gait_names, load_gait
from .pd import apply_joint_torques, targets_from_quats
from .walk import WalkResult, run_walk

# The gait files and the walk harness have their own modules; their names are also
# importable from here, where the controller's users have always found them.
__all__ = ["GaitState", "Gait", "load_gait", "gait_names", "BipedMap", "SimbiconController",
           "WalkResult", "run_walk"]

LEFT, RIGHT = 0, 1
_REGULATOR_START = 4        # steps walked before the speed regulator acts


# ----------------------------------------------------------------------------------------
# which joint is which
# ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class BipedMap:
    """Names of a biped's joints (each joint drives the body of the same name, as ragdolls
    from tumble's builders do), per side (left, right).

    pelvis : the root body. hip, knee, ankle, toe, clavicle, shoulder, elbow, wrist :
    (left, right) joint names (toe, clavicle, wrist may be (None, None)). spine : joints
    between the pelvis and the chest, neck : the head's joint (or None).
    forward, up : the rest pose's facing and up directions (world).
    """
    pelvis: str = "RootJoint"
    hip: tuple = ("lHip", "rHip")
    knee: tuple = ("lKnee", "rKnee")
    ankle: tuple = ("lAnkle", "rAnkle")
    toe: tuple = ("lToeJoint", "rToeJoint")
    spine: tuple = ("pelvis_lowerback", "lowerback_torso")
    neck: str = "torso_head"
    clavicle: tuple = ("lTorso_Clavicle", "rTorso_Clavicle")
    shoulder: tuple = ("lShoulder", "rShoulder")
    elbow: tuple = ("lElbow", "rElbow")
    wrist: tuple = ("lWrist", "rWrist")
    forward: tuple = (0.0, 0.0, 1.0)
    up: tuple = (0.0, 1.0, 0.0)


# ----------------------------------------------------------------------------------------
# the controller
# ----------------------------------------------------------------------------------------

class SimbiconController:
    """SIMBICON for a biped ragdoll in ``world`` (see the module docs).

    world : the World (``ragdoll.make_world(dt=...)``; physics step ``world.dt``).
    ragdoll : the Ragdoll of the world's model (a floating root).
    gait : a Gait, a shipped gait name or a JSON path (``load_gait``).
    control_dt : the control period (s), a whole number of physics steps.
    hip_control : 'implicit' (stance-hip servo toward the pelvis's desired orientation),
        'rule' (that servo plus ``-tau_swing`` fed forward) or 'explicit' (the paper's
        torques ``tau_stance = -tau_torso - tau_swing``); see the module docs.
    biped : a BipedMap (default: the course character's joint names).
    terrain : the Terrain under the character (heights above the ground for the fall
        check, the slope under the stance foot for the gait's slope terms; default flat
        y = 0).
    fall_height : the pelvis below this height above the ground counts as a fall (m).
    speed, turn_rate : override the gait's target speed (m/s) and turn rate (rad/s).

    Use: ``place()`` once (standing start), then ``step()`` per control period, or
    ``run_walk`` for a whole measured run. ``state`` gives the FSM state (0, 1), ``stance``
    the stance side (0 left, 1 right), ``strikes`` the foot strikes (time s, new stance
    side, its ankle position (3,) world, heading rad); ``fallen``/``fall_reason`` the fall
    check after each step (the pelvis below ``fall_height`` above the terrain, or a body
    other than the feet touching the ground). ``snapshot``/``restore`` save and return to
    a moment of the walk. The walk uses no external force: only joint servos and torques.
    """

    def __init__(self, world, ragdoll, gait="walk", *, control_dt=1.0 / 60.0,
                 hip_control="implicit", biped=None, terrain=None,
                 fall_height=0.55, speed=None, turn_rate=None):
        self.world = world
        self.ragdoll = ragdoll
        m = world.model
        self.model = m
        if ragdoll.model is not m:
            raise ModelError(f"{type(self).__name__}: the world is not of the ragdoll's model")
        self.gait = self._load_gait(gait, speed, turn_rate)
        if hip_control not in ("implicit", "rule", "explicit"):
            raise ModelError(f"{type(self).__name__}: hip_control must be 'implicit', 'rule' or "
                             f"'explicit', got {hip_control!r}")
        self.hip_control = hip_control
        positive(control_dt, type(self).__name__, "control_dt")
        n = control_dt / world.dt
        if abs(n - round(n)) > 1e-6 * max(n, 1.0) or round(n) < 1:
            raise ModelError(f"{type(self).__name__}: control_dt ({control_dt:g} s) must be a whole "
                             f"number of physics steps (world.dt = {world.dt:g} s)")
        self.substeps = int(round(n))
        self.control_dt = self.substeps * world.dt
        self.fall_height = positive(fall_height, type(self).__name__, "fall_height")
        from .terrain import Flat
        self.terrain = Flat() if terrain is None else terrain
        self.biped = biped or BipedMap()
        self._map_joints()
        self.reset()

    # ------------------------------------------------------------------ set up
    def _load_gait(self, gait, speed, turn_rate):
        """The Gait to walk (``load_gait``) with the speed and turn rate overridden."""
        g = load_gait(gait)
        if speed is not None or turn_rate is not None:
            g = g.with_(speed=g.speed if speed is None else float(speed),
                        turn_rate=g.turn_rate if turn_rate is None else float(turn_rate))
        return g

    def _map_joints(self):
        m, b = self.model, self.biped
        self.up = np.asarray(b.up, float) / np.linalg.norm(b.up)
        f = np.asarray(b.forward, float)
        f = f - (f @ self.up) * self.up
        self.fwd0 = f / np.linalg.norm(f)
        self.left0 = np.cross(self.up, self.fwd0)

        def j(name, what):
            if name is None:
                return -1
            try:
                return m.joint_index(name)
            except ModelError:
                raise ModelError(f"{type(self).__name__}: biped map: {what} joint '{name}' is not "
                                 f"a joint of the model") from None

        self.pelvis = m.body_index(b.pelvis)
        self.hip = [j(n, "hip") for n in b.hip]
        self.knee = [j(n, "knee") for n in b.knee]
        self.ankle = [j(n, "ankle") for n in b.ankle]
        self.toe = [j(n, "toe") for n in b.toe]
        self.spine = [j(n, "spine") for n in b.spine]
        self.neck = j(b.neck, "neck")
        self.clavicle = [j(n, "clavicle") for n in b.clavicle]
        self.shoulder = [j(n, "shoulder") for n in b.shoulder]
        self.elbow = [j(n, "elbow") for n in b.elbow]
        self.wrist = [j(n, "wrist") for n in b.wrist]
        for s in range(2):
            if m.joint_parent[self.hip[s]] != self.pelvis:
                raise ModelError(f"{type(self).__name__}: hip joint '{b.hip[s]}' does not hang "
                                 f"from the pelvis '{b.pelvis}'")
        self.thigh = [int(m.joint_child[self.hip[s]]) for s in range(2)]
        self.foot = [int(m.joint_child[self.ankle[s]]) for s in range(2)]
        self.feet_bodies = set(self.foot)
        for s in range(2):
            if self.toe[s] >= 0:
                self.feet_bodies.add(int(m.joint_child[self.toe[s]]))
        # Joint frames in the world at rest: a target rotation R (rest axes, parent to
        # child) becomes the joint-frame target conj(Fa) R Fb.
        q0 = m.body_quat0
        self.Fa = np.zeros((m.njoint, 4))
        self.Fb = np.zeros((m.njoint, 4))
        for k in range(m.njoint):
            p, c = m.joint_parent[k], m.joint_child[k]
            self.Fa[k] = m.joint_frame_a[k] if p < 0 else Q.qmul(q0[p], m.joint_frame_a[k])
            self.Fb[k] = Q.qmul(q0[c], m.joint_frame_b[k])
        self.group_of = {}
        for s in range(2):
            for k, g in ((self.hip[s], "hip"), (self.knee[s], "knee"), (self.ankle[s], "ankle"),
                         (self.toe[s], "toe"), (self.clavicle[s], "arm"),
                         (self.shoulder[s], "arm"), (self.elbow[s], "arm"), (self.wrist[s], "arm")):
                if k >= 0:
                    self.group_of[k] = g
        for k in self.spine:
            self.group_of[k] = "spine"
        if self.neck >= 0:
            self.group_of[self.neck] = "neck"
        # Bodies moved by the swing hip (a leg) and by the torso torque (all above the
        # hips), for the composite inertias of the explicit torques' stable PD.
        self._leg_bodies = [self._subtree(self.thigh[s]) for s in range(2)]
        self._upper_bodies = self._subtree(self.pelvis, exclude=set(self.thigh))
        # rest length hip to ankle, for the step-width bound
        self.leg_length = float(np.linalg.norm(self._anchor0(self.hip[0])
                                               - self._anchor0(self.ankle[0])))

    def _subtree(self, body, exclude=()):
        m = self.model
        out, todo = [], [body]
        while todo:
            b = todo.pop()
            if b in exclude:
                continue
            out.append(b)
            todo += [int(m.joint_child[k]) for k in range(m.njoint) if m.joint_parent[k] == b]
        return out

    def _composite_inertia(self, bodies, about):
        """World inertia tensor (3, 3) kg m^2 of ``bodies`` as one rigid body about the
        world point ``about`` (None: their COM), current pose."""
        m, w = self.model, self.world
        mass = m.body_mass[bodies]
        pos = w.body_pos[bodies]
        if about is None:
            about = (pos * mass[:, None]).sum(0) / mass.sum()
        total = np.zeros((3, 3))
        # body_quat is the principal frame, where body_inertia is diagonal
        for b, mb, p, R in zip(bodies, mass, pos, Q.qmatrix(w.body_quat[bodies])):
            total += (R * m.body_inertia[b]) @ R.T
            r = p - about
            total += mb * ((r @ r) * np.eye(3) - np.outer(r, r))
        return total

    def _anchor0(self, joint):
        m = self.model
        c = m.joint_child[joint]
        return m.body_pos0[c] + Q.qrot(m.body_quat0[c], m.joint_anchor_b[joint])

    def reset(self):
        """Back to the first state, right leg in stance, heading from the pelvis."""
        self.state = 0
        self.stance = RIGHT
        self.phase_time = 0.0
        self.time = 0.0
        self.heading = self._pelvis_yaw()
        self.speed_offset = 0.0
        self.speed_integral = 0.0
        self.strikes = []
        self.fallen = False
        self.fall_reason = ""
        self._step_start = (0.0, center_of_mass(self.world)[0])
        self.last_tau = {}
        self.slope = 0.0
        self._stand = self.standing_pose()
        self._contacts = None
        self._last_swing = None
        self._apply_gains()

    _SNAP_FIELDS = ("state", "stance", "phase_time", "time", "heading", "speed_offset",
                    "speed_integral",
                    "fallen", "fall_reason", "_step_start", "_last_swing")

    def snapshot(self):
        """The world's state and the controller's (FSM, heading, speed regulator, foot
        strikes), to go back to with ``restore`` (e.g. to push the same walk many ways)."""
        import copy
        ctrl = {k: copy.deepcopy(getattr(self, k)) for k in self._SNAP_FIELDS}
        ctrl["strikes"] = list(self.strikes)
        return self.world.get_state(), ctrl

    def restore(self, snap):
        """Return to a ``snapshot()``: world state, gains and targets, FSM."""
        import copy
        state, ctrl = snap
        self.world.set_state(state)
        for k in self._SNAP_FIELDS:
            setattr(self, k, copy.deepcopy(ctrl[k]))
        self.strikes = list(ctrl["strikes"])
        self._apply_gains()

    # ------------------------------------------------------------------ kinematics
    def _seg_rot(self, body):
        """World rotation of ``body`` relative to its rest orientation (4,)."""
        return Q.qmul_one(self.world.body_quat[body], Q.qconj_one(self.model.body_quat0[body]))

    def _yaw_quat(self, yaw):
        return Q.qaxis_angle_one(self.up, yaw)

    def pelvis_heading(self):
        """Yaw (rad, about up, 0 = the rest pose's forward) of the pelvis's forward axis."""
        return self._pelvis_yaw()

    def _pelvis_yaw(self):
        f = Q.qrot_one(self._seg_rot(self.pelvis), self.fwd0)
        f = f - (f @ self.up) * self.up
        return math.atan2(f @ self.left0, f @ self.fwd0)

    def _anchor(self, joint):
        """World position of ``joint``'s anchor (on its child body)."""
        m, w = self.model, self.world
        c = m.joint_child[joint]
        return w.body_pos[c] + Q.qrot_one(w.body_quat[c], m.joint_anchor_b[joint])

    def ground_height(self, p):
        """Height (m) of the terrain under world point ``p`` (Y up)."""
        return self.terrain.height(p[0], p[2])

    # ------------------------------------------------------------------ posing
    def standing_pose(self):
        """(njoint, 4) rest-frame joint rotations of the standing start: legs straight,
        arms lowered and elbows bent as the gait says."""
        R = np.tile(Q.IDENTITY, (self.model.njoint, 1))
        down, elbow = self.gait.arms
        for s in range(2):
            sgn = 1.0 if s == LEFT else -1.0
            if self.shoulder[s] >= 0:
                R[self.shoulder[s]] = Q.qaxis_angle_one(self.fwd0, -sgn * down)
            if self.elbow[s] >= 0:
                R[self.elbow[s]] = self._elbow_quat(s, elbow)
        return R

    def _elbow_quat(self, s, flex):
        """Rest-frame rotation bending elbow ``s`` by ``flex`` with the forearm going forward
        once the arm hangs down (about the elbow's hinge axis, signed by geometry)."""
        m = self.model
        k = self.elbow[s]
        if m.joint_type_names[k] == "hinge":
            axis = Q.qrot(self.Fa[k], np.array([1.0, 0.0, 0.0]))
        else:
            axis = self.up.copy()
        child = int(m.joint_child[k])
        bone = m.body_pos0[child] - self._anchor0(k)
        # the flexion must move the bone tip toward forward after the arm is lowered
        sgn = 1.0 if np.cross(axis, bone) @ self.fwd0 > 0 else -1.0
        return Q.qaxis_angle_one(axis / np.linalg.norm(axis), sgn * flex)

    def body_poses(self, pose):
        """Body COM positions (nbody, 3) and orientations (nbody, 4) (world, x y z w) of the
        rest-frame joint rotations ``pose`` (njoint, 4), the root at its rest place: what
        ``world.joint_quat`` then reads is ``conj(Fa) pose Fb`` (``joint_targets``)."""
        rot, pos = _forward_kinematics(self, np.asarray(pose, float))
        return pos, Q.qmul(rot, self.model.body_quat0)

    def joint_targets(self, pose):
        """Joint-frame rotations (njoint, 4) (``world.joint_quat``'s convention) of the
        rest-frame joint rotations ``pose`` (njoint, 4): ``conj(Fa) pose Fb``."""
        return Q.qmul(Q.qconj(self.Fa), Q.qmul(np.asarray(pose, float), self.Fb))

    def place(self, *, speed=0.0, pose=None, position=(0.0, 0.0), yaw=0.0, drop=0.001,
              lean=None):
        """Put the character standing on the terrain at ``position`` (x, z), facing ``yaw``,
        in ``pose`` (rest-frame joint rotations, default ``standing_pose()``), moving
        forward at ``speed`` m/s; resets the controller.

        lean : rad of forward pitch of the pelvis (the hips flexed by as much, so the legs
        stay vertical), or None for the gait's first-state torso pitch plus ``slope_lean``
        times the slope at ``position`` along ``yaw``: the torso servo then has nothing to
        correct at the start. Pitching the pelvis from upright at the first step throws the
        legs and the COM backward (reaction torque), which on an upslope the fast gait did
        not recover from.
        """
        m, w = self.model, self.world
        R = self.standing_pose() if pose is None else np.asarray(pose, float)
        x, z = position
        yq = self._yaw_quat(yaw)
        fwd = Q.qrot(yq, self.fwd0)
        if lean is None:
            slope = math.atan(self.terrain.slope_along(x, z, (fwd[0], fwd[2])))
            lean = self.gait.states[0].torso[0] + self.gait.slope_lean * slope
        if lean != 0.0:
            # hips flexed by the lean in the pelvis's rest frame (thighs stay vertical once
            # the whole pose is pitched forward by it below)
            R = R.copy()
            pq = Q.qaxis_angle_one(self.left0, lean)
            for s in range(2):
                R[self.hip[s]] = Q.qmul_one(Q.qconj_one(pq), R[self.hip[s]])
        rot, pos = _forward_kinematics(self, R)
        if lean != 0.0:
            # pitch the pose about the pelvis (its horizontal place is kept)
            pq = np.broadcast_to(Q.qaxis_angle_one(self.left0, lean), rot.shape)
            p0 = pos[self.pelvis].copy()
            rot = Q.qmul(pq, rot)
            pos = p0 + Q.qrot(pq, pos - p0)
        rot = Q.qmul(np.broadcast_to(yq, rot.shape), rot)
        pos = Q.qrot(np.broadcast_to(yq, (len(pos), 4)), pos)
        # lowest point of the feet on the ground under the feet
        low = math.inf
        ground = -math.inf
        for g in range(m.ngeom):
            b = m.geom_body[g]
            if b not in self.feet_bodies or (m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0):
                continue
            low = min(low, foot_lowest_at(m, g, pos[b], rot[b], self.up))
            p = pos[b] + np.array([x, 0.0, z])
            ground = max(ground, self.terrain.height(p[0], p[2]))
        shift = np.array([x, ground - low - drop, z])
        w.body_pos[:] = pos + shift
        w.body_quat[:] = Q.qmul(rot, m.body_quat0)
        w.body_vel[:] = speed * fwd
        w.body_angvel[:] = 0.0
        w.update_joint_coordinates()
        self.reset()
        self._set_targets(R)

    # ------------------------------------------------------------------ control
    def _gains(self, group):
        return self.gait.gains[group]

    def _apply_gains(self):
        """Servo gains for the current stance: the stance hip takes the torso's gains
        (implicit form) or none (explicit torques)."""
        m, w = self.model, self.world
        kp = np.zeros(m.njoint)
        kd = np.zeros(m.njoint)
        lim = np.full(m.njoint, np.inf)
        for k, g in self.group_of.items():
            kp[k], kd[k] = self._gains(g)
            lim[k] = self.gait.max_torque[g]
        st, sw = self.hip[self.stance], self.hip[1 - self.stance]
        if self.hip_control in ("implicit", "rule"):
            kp[st], kd[st] = self._gains("torso")
            lim[st] = self.gait.max_torque["torso"]
        else:
            kp[st] = kd[st] = kp[sw] = kd[sw] = 0.0
        w.joint_kp = kp
        w.joint_kd = kd
        w.joint_max_torque = lim

    def _set_targets(self, R, rates=None):
        """Servo targets from rest-frame joint rotations R (njoint, 4) (parent to child)."""
        w = self.world
        tq, tpos = targets_from_quats(self.model, self.joint_targets(R))
        w.pd_target_quat = tq
        w.pd_target_q = tpos
        w.pd_target_qd = 0.0 if rates is None else rates

    def _frame(self):
        """(forward, left) unit vectors of the desired heading, world."""
        yq = self._yaw_quat(self.heading)
        return Q.qrot_one(yq, self.fwd0), Q.qrot_one(yq, self.left0)

    def _update_fsm(self):
        """Advance the state machine by one control period (after the physics step)."""
        g = self.gait
        self.phase_time += self.control_dt
        st = g.states[self.state]
        if self.state == 0:
            if self.phase_time >= st.duration - 1e-9:
                self.state, self.phase_time = 1, 0.0
            return
        swing = 1 - self.stance
        if self._foot_on_ground(swing) or self.phase_time >= st.duration - 1e-9:
            self._switch_stance()

    def _foot_on_ground(self, side):
        con = self._contacts
        if len(con) == 0:
            return False
        foot = self.foot[side]
        touching = ((con.bodies[:, 0] == foot) & (con.bodies[:, 1] < 0)) | \
                   ((con.bodies[:, 1] == foot) & (con.bodies[:, 0] < 0))
        return bool(np.any(touching & (con.normal_force > 1.0)))

    def _switch_stance(self):
        c, _ = center_of_mass(self.world)
        t0, c0 = self._step_start
        self.stance = 1 - self.stance
        self.state, self.phase_time = 0, 0.0
        p = self._anchor(self.ankle[self.stance])
        self.strikes.append((self.time, self.stance, p.copy(), self.heading))
        fwd, _ = self._frame()
        dt = self.time - t0
        if dt > 0:
            v = float((c - c0) @ fwd) / dt
            g = self.gait
            if g.speed is not None and len(self.strikes) > _REGULATOR_START:
                # too slow: place the foot less far ahead (and the reverse); PI over steps,
                # from the fifth step on (the first ones start from standing)
                err = g.speed - v
                lim = g.speed_limit
                self.speed_integral = float(np.clip(self.speed_integral + g.speed_gain * err,
                                                    -lim, lim))
                self.speed_offset = float(np.clip(self.speed_integral + g.speed_p * err,
                                                  -lim, lim))
        self._step_start = (self.time, c)
        self._apply_gains()

    def _check_fall(self):
        w = self.world
        p = w.body_pos[self.pelvis]
        if p @ self.up - self.ground_height(p) < self.fall_height:
            self.fallen, self.fall_reason = True, f"pelvis below {self.fall_height} m"
            return
        con = self._contacts
        if len(con):
            for a, b in con.bodies:
                body = b if a < 0 else (a if b < 0 else None)
                if body is not None and body not in self.feet_bodies:
                    self.fallen = True
                    self.fall_reason = f"'{self.model.body_names[body]}' touched the ground"
                    return

    def control(self):
        """Compute and set this control period's servo targets and hip torques."""
        g = self.gait
        w = self.world
        st = g.states[self.state]
        stance, swing = self.stance, 1 - self.stance
        sgn_sw = 1.0 if swing == LEFT else -1.0     # +1 when the swing leg is the left
        fwd, left = self._frame()
        com, vcom = center_of_mass(w)
        ankle = self._anchor(self.ankle[stance])
        # terrain slope under the stance foot along the heading (rad, > 0 uphill)
        slope = math.atan(self.terrain.slope_along(ankle[0], ankle[2], (fwd[0], fwd[2])))
        self.slope = slope
        d = com - ankle
        d_sag, v_sag = float(d @ fwd), float(vcom @ fwd)
        d_out, v_out = float(d @ left) * sgn_sw, float(vcom @ left) * sgn_sw
        flex0, abd0 = st.swing_hip
        flex = (flex0 + st.c_d[0] * d_sag + st.c_v[0] * v_sag - self.speed_offset
                + g.slope_hip * slope)
        abd = abd0 + st.c_d[1] * d_out + st.c_v[1] * v_out
        flex = min(max(flex, g.flexion_range[0]), g.flexion_range[1])
        abd = min(max(abd, g.abduction_range[0]), g.abduction_range[1])
        if g.min_step_width is not None:
            # no crossing: the swing foot lands at least min_step_width outward of the
            # stance ankle (leg of rest length L from the swing hip)
            out = sgn_sw * left
            hip_off = float((self._anchor(self.hip[swing]) - ankle) @ out)
            sin_min = (g.min_step_width - hip_off) / self.leg_length
            abd = max(abd, math.asin(min(max(sin_min, -1.0), 1.0)))
        self.last_feedback = (d_sag, v_sag, d_out, v_out, flex, abd)
        yq = self._yaw_quat(self.heading)
        # desired world (rest-relative) orientations of the pelvis and swing thigh
        pitch, roll = st.torso
        pitch += g.slope_lean * slope
        sgn_st = -sgn_sw
        R_pd = Q.qmul_one(yq, Q.qmul_one(Q.qaxis_angle_one(self.fwd0, -sgn_st * roll),
                                 Q.qaxis_angle_one(self.left0, pitch)))
        R_thd = Q.qmul_one(yq, Q.qmul_one(Q.qaxis_angle_one(self.fwd0, sgn_sw * abd),
                                  Q.qaxis_angle_one(self.left0, -flex)))
        R = self._stand.copy()
        R[self.knee[swing]] = Q.qaxis_angle_one(self.left0, st.swing_knee)
        R[self.knee[stance]] = Q.qaxis_angle_one(self.left0, st.stance_knee)
        # on a slope the feet meet the ground tilted by the slope: dorsiflex by it
        R[self.ankle[swing]] = Q.qaxis_angle_one(self.left0, -(st.swing_ankle + g.slope_ankle * slope))
        R[self.ankle[stance]] = Q.qaxis_angle_one(self.left0, -(st.stance_ankle + g.slope_ankle * slope))
        R_p = self._seg_rot(self.pelvis)
        w_yaw = g.turn_rate * self.up
        if g.swing_foot_world:
            # foot level in the heading frame: ankle rotation = shank^-1 * heading
            R_shank = self._seg_rot(int(self.model.joint_child[self.knee[swing]]))
            R[self.ankle[swing]] = Q.qmul_one(Q.qconj_one(R_shank), Q.qmul_one(yq, Q.qaxis_angle_one(self.left0, -st.swing_ankle)))
        if g.stance_ankle_world:
            R_shank = self._seg_rot(int(self.model.joint_child[self.knee[stance]]))
            R[self.ankle[stance]] = Q.qmul_one(Q.qconj_one(R_shank), Q.qmul_one(yq, Q.qaxis_angle_one(self.left0, -st.stance_ankle)))
        rates = np.zeros((self.model.njoint, 3))
        hs, hw = self.hip[stance], self.hip[swing]
        th_st, th_sw = self.thigh[stance], self.thigh[swing]
        if self.hip_control in ("implicit", "rule"):
            # stance hip: the rotation that puts the pelvis at R_pd given the stance thigh
            R[hs] = Q.qmul_one(Q.qconj_one(R_pd), self._seg_rot(th_st))
            R[hw] = Q.qmul_one(Q.qconj_one(R_p), R_thd)
            fa_st = Q.qmul_one(w.body_quat[self.pelvis], self.model.joint_frame_a[hs])
            fa_sw = Q.qmul_one(w.body_quat[self.pelvis], self.model.joint_frame_a[hw])
            # target rates: damping on the pelvis's and the thigh's world angular velocities
            rates[hs] = Q.qrot_one(Q.qconj_one(fa_st), w.body_angvel[th_st] - w_yaw)
            rates[hw] = Q.qrot_one(Q.qconj_one(fa_sw), w_yaw - w.body_angvel[self.pelvis])
            if self.hip_control == "rule" and self._last_swing == swing:
                # -tau_swing on the stance hip: what the swing hip did to its thigh in the
                # last physics step (not across a stance switch, when it was the stance hip)
                tau = np.zeros((self.model.njoint, 3))
                tau[hs] = -np.asarray(w.joint_torque[hw])
                apply_joint_torques(w, tau)
                self.last_tau = {"swing": -tau[hs], "stance_feedforward": tau[hs]}
            self._last_swing = swing
        else:
            R[hs] = Q.qmul_one(Q.qconj_one(R_p), self._seg_rot(th_st))   # unused: servo off
            R[hw] = Q.qmul_one(Q.qconj_one(R_p), R_thd)
            h = self.control_dt
            kp_t, kd_t = self._gains("torso")
            kp_h, kd_h = self._gains("hip")
            # Each torque acts between two bodies: its stable PD sees their reduced inertia
            # (I_a^-1 + I_b^-1)^-1. The pelvis's and the thigh's own inertias, not those of
            # everything attached to them: within a step the soft servos of the spine and
            # knees let them turn nearly alone, and a larger guess diverges.
            I_pelvis = self._composite_inertia([self.pelvis], None)
            I_st = self._composite_inertia(self._leg_bodies[stance], self._anchor(hs))
            I_sw = self._composite_inertia([th_sw], self._anchor(hw))
            I_torso = _reduced(I_pelvis, I_st)
            I_leg = _reduced(I_sw, I_pelvis)
            tau_torso = _stable_pd(R_pd, R_p, w.body_angvel[self.pelvis], w_yaw, kp_t, kd_t, h,
                                   I_torso, g.max_torque["torso"])
            tau_swing = _stable_pd(R_thd, self._seg_rot(th_sw), w.body_angvel[th_sw], w_yaw,
                                   kp_h, kd_h, h, I_leg, g.max_torque["hip"])
            tau_stance = -tau_torso - tau_swing
            tau = np.zeros((self.model.njoint, 3))
            tau[hw] = tau_swing
            tau[hs] = tau_stance
            apply_joint_torques(w, tau)
            self.last_tau = {"torso": tau_torso, "swing": tau_swing, "stance": tau_stance}
        self._set_targets(R, rates)

    def step(self, pushes=()):
        """One control period: targets, ``world.step(substeps)`` (with the share of any
        :class:`~tumble.character.balance.Push` whose window, in world time, overlaps it),
        then the state machine and the fall check."""
        self.control()
        for p in pushes:
            p.apply(self.world, self.substeps)
        self.world.step(self.substeps)
        self.time += self.control_dt
        self.heading += self.gait.turn_rate * self.control_dt
        self._contacts = self.world.contacts
        self._update_fsm()
        self._check_fall()


def _reduced(Ia, Ib):
    """Reduced inertia (Ia^-1 + Ib^-1)^-1 (3, 3) of two bodies a torque acts between."""
    return np.linalg.inv(np.linalg.inv(Ia) + np.linalg.inv(Ib))


def _stable_pd(R_d, R, w, w_d, kp, kd, h, inertia, limit):
    """World PD torque (3,) toward orientation R_d, evaluated at the end of a period h for a
    rigid body of world inertia tensor ``inertia`` (3, 3) (stable PD, Tan et al. 2011, with
    the h^2 term kept so it is backward Euler): ``tau = kp (e - h w_1) - kd w_1`` with the
    end-of-period rate ``w_1 = w + h I^-1 tau``, solved for tau."""
    err = Q.qrotvec(Q.qmul_one(R_d, Q.qconj_one(R)))
    dw = w - w_d
    rhs = kp * (err - h * dw) - kd * dw
    # (1 + (h kd + h^2 kp) I^-1) tau = rhs  <=>  tau = I (I + h kd + h^2 kp)^-1 rhs
    tau = inertia @ np.linalg.solve(inertia + (h * kd + h * h * kp) * np.eye(3), rhs)
    n = np.linalg.norm(tau)
    if n > limit:
        tau *= limit / n
    return tau


def _forward_kinematics(ctrl, R):
    """Body (rest-relative rotations (nbody, 4), COM positions (nbody, 3)) of a pose given by
    rest-frame joint rotations R (njoint, 4), root at its rest place."""
    m = ctrl.model
    rot = np.tile(Q.IDENTITY, (m.nbody, 1))
    pos = np.array(m.body_pos0, float)
    joint_of_child = {int(m.joint_child[k]): k for k in range(m.njoint)}
    order = _tree_order(m, joint_of_child)
    for b in order:
        k = joint_of_child.get(b)
        if k is None or m.joint_parent[k] < 0:
            continue
        p = int(m.joint_parent[k])
        rot[b] = Q.qmul(rot[p], R[k])
        a0 = ctrl._anchor0(k)
        anchor = pos[p] + Q.qrot(rot[p], a0 - m.body_pos0[p])
        pos[b] = anchor + Q.qrot(rot[b], m.body_pos0[b] - a0)
    return rot, pos


def _tree_order(m, joint_of_child):
    """Bodies ordered parents first."""
    depth = {}

    def dep(b):
        if b in depth:
            return depth[b]
        k = joint_of_child.get(b)
        d = 0 if k is None or m.joint_parent[k] < 0 else dep(int(m.joint_parent[k])) + 1
        depth[b] = d
        return d

    bodies = [b for b in range(m.nbody) if np.isfinite(m.body_mass[b])]
    return sorted(bodies, key=dep)
