"""Generalized biped walking control (Coros, Beaudoin and van de Panne 2010) for a 3-D
ragdoll: inverted-pendulum foot placement, swing-leg inverse kinematics, virtual forces.

It shares SIMBICON's parts (tumble.character.simbicon): the joint map, the standing start,
the stance/swing alternation and foot-strike detection, the torso and stance-hip servo,
the fall check, snapshots, and the run harness ``run_walk``. What differs is how the swing
foot is placed and how the body is helped along:

- A step has a planned duration (``Style.step_time``, less ``step_time_speed`` per m/s of
  commanded speed, less ``hurry`` per m/s that the COM's velocity is off the command: a
  pushed character steps sooner); its phase runs 0 to 1 and the stance swaps when the
  swing foot touches the ground after ``min_phase`` (or at ``max_phase``).
- Foot placement: every control period the inverted pendulum of the COM over the stance
  foot says where to step to come to rest, ``d = v sqrt(h/g + v^2 / (4 g^2))``, in the
  sagittal and coronal directions of the heading frame (``ipm.plan_step``), ``h`` the
  COM's height above the landing point (a step down a slope reaches further); the step is
  shortened by ``alpha v_desired`` (so the walk goes on), put ``step_width`` outward (so
  the COM sways back toward the next stance), bounded, kept from crossing the stance foot,
  and corrected step to step by integrals of the speed errors (``speed_gain``,
  ``side_gain``: the commanded speeds are walked whatever the pendulum's errors). From
  ``freeze_phase`` on the step is held in the world, so the foot lands still.
- Early touch-down (beyond the paper): after a push toward the stance side the coronal
  capture point ``x + v sqrt(h/g)`` lies beyond the stance ankle, and the step the
  pendulum wants is across the stance foot, which the no-crossing rule refuses. The swing
  foot, if it is near the stance foot, is then put down at once (its phase jumps ahead, the
  rest of the step is short, the step ends when it bears weight), so that the other leg,
  on the pushed side, swings now and takes the wide step. Not when the COM is much faster
  forward than the command: that step must reach forward, and a short step lands behind.
- The swing ankle follows a trajectory from its lift-off place to that step (a horizontal
  blend, eased by ``swing_ease`` so the leg is not thrown forward at lift-off, whose
  reaction the stance hip would pass to the ground as a push forward; a height profile;
  ``ipm.swing_target``; the whole path outward of the stance leg),
  realised by analytic two-link inverse kinematics of the swing leg (``ipm.two_link_ik``):
  the swing hip servo tracks the thigh's world orientation and the knee servo the knee
  angle, with target rates from the trajectory's derivative. The servos are implicit (they
  pull toward the state at the end of the control period), so the targets are taken a
  period ahead. The swing foot is held level in the heading frame (tilted by the slope).
- Virtual forces by Jacobian-transpose torques: each body of the swing leg and of the upper
  body gets an upward force of its weight at its COM, ``tau_j = (p_b - a_j) x m_b g`` on
  every joint between it and the pelvis; the stance hip carries what those put on the
  pelvis, so the stance leg bears them. A force on the COM, ``tau_j = -(c - a_j) x F``
  from the ground up (the ground is the base), is carried by the stance leg: its
  horizontal part tunes the velocity, ``F = k_v (v_desired - v)``, through the ankle and
  knee, with the ankle's torque bounded so that the centre of pressure stays on the sole;
  its vertical part, ``knee_support`` of the weight plus a PD on the COM height, through
  the knee (the leg does not fold under the body nor bounce it off the ground).
- Torso and stance hip as SIMBICON's 'implicit' form: the stance hip is a servo toward the
  rotation that puts the pelvis at its desired world orientation (heading, pitch, roll).
  The stance knee's target goes from its bend at the strike to ``stance_knee`` over
  ``knee_time`` (at most ``knee_rate`` rad/s: a leg that lands deeply bent and
  straightens at once launches the body into the air), and down a slope bends further
  over the step (``slope_knee``: the knee yields, absorbing what the descent gives).

Commands: ``speed`` (m/s along the heading, negative walks backward), ``side_speed`` (m/s
to the left), ``turn_rate`` (rad/s). Styles are JSON files like the gaits (``Style``,
``load_style``; shipped: ``style_names()``).

Frames and units as in tumble.character.simbicon: Y up, the rest pose faces ``forward``;
m, s, rad, N.
"""
import math

import numpy as np

from ..math import quat_np as Q
from .balance import center_of_mass
from .feet import foot_lowest_at
from .gait_files import Style, load_style, style_names
from .ipm import cross, plan_step, reachable_target, swing_target, two_link_ik
from .pd import apply_joint_torques
from .simbicon import LEFT, RIGHT, SimbiconController

__all__ = ["GeneralizedController", "Style", "load_style", "style_names"]

_PREDICT = 0.02         # s ahead for the swing trajectory's target rates (finite difference)


def _rotvec_quat(v):
    """Unit quaternion (4,) of the rotation vector ``v`` (3,)."""
    a = float(np.linalg.norm(v))
    if a < 1e-12:
        return np.array([0.5 * v[0], 0.5 * v[1], 0.5 * v[2], 1.0])
    return Q.qaxis_angle_one(v / a, a)


class GeneralizedController(SimbiconController):
    """Generalized walking control of a biped ragdoll in ``world`` (see the module docs).

    world, ragdoll, control_dt, biped, terrain, fall_height : as SimbiconController's.
    style : a Style, a shipped style name (``style_names()``) or a JSON path.
    speed, side_speed, turn_rate : override the style's commands (m/s, m/s, rad/s).
    early_cross, early_after, early_near, early_ahead, early_phase, early_time, early_load :
    the early touch-down after a push toward the stance side (see the module docs): it
    starts when the coronal capture point is more than ``early_cross`` m beyond the stance
    ankle (toward the stance side; None: never), at least ``early_after`` s into the step
    and before the phase ``early_phase``, with the swing ankle less than ``early_near`` m
    outward of the stance ankle and the COM less than ``early_ahead`` m/s faster forward
    than the command; the phase jumps to ``early_phase``, the step's duration becomes at
    most ``early_time`` s, and the step ends when the swing foot bears ``early_load`` of the
    body's weight.

    Use as SimbiconController: ``place()`` then ``step()``, or ``run_walk``. After each
    ``control()``: ``last_plan`` (the ``ipm.StepPlan``), ``last_target`` (the swing ankle's
    target, world), ``last_ik`` (``ipm.IKResult``), ``last_force`` (the velocity-tuning
    force, world N), ``last_tau`` ({'gravity', 'velocity', 'stance_feedforward'}: the
    virtual-force joint torques, (njoint, 3) world N m), ``phase``, ``cp_out`` (m, the
    coronal capture point beyond the stance ankle toward the stance side), ``early`` (this
    step is an early touch-down).
    """

    def __init__(self, world, ragdoll, style="ipm_walk", *, control_dt=1.0 / 60.0,
                 biped=None, terrain=None, fall_height=0.55, speed=None, side_speed=None,
                 turn_rate=None, early_cross=0.05, early_phase=0.75, early_time=0.2,
                 early_after=0.1, early_near=0.2, early_load=0.6, early_ahead=0.3):
        self._overrides = {"speed": speed, "side_speed": side_speed, "turn_rate": turn_rate}
        # step timing for recovery (see control()); early_cross None turns early
        # touch-down off
        self.early_cross = math.inf if early_cross is None else float(early_cross)
        self.early_phase = float(early_phase)
        self.early_time = float(early_time)
        self.early_after = float(early_after)
        self.early_near = float(early_near)
        self.early_load = float(early_load)
        self.early_ahead = float(early_ahead)
        super().__init__(world, ragdoll, style, control_dt=control_dt, hip_control="implicit",
                         biped=biped, terrain=terrain, fall_height=fall_height)

    # ------------------------------------------------------------------ set up
    def _load_gait(self, style, speed, turn_rate):
        st = load_style(style)
        changes = {k: float(v) for k, v in self._overrides.items() if v is not None}
        return st.with_(**changes) if changes else st

    @property
    def style(self):
        """The Style walked (also ``gait``, the name the shared code uses)."""
        return self.gait

    def _map_joints(self):
        super()._map_joints()
        m = self.model
        up = self.up
        hip0, knee0, ankle0 = (self._anchor0(self.hip[0]), self._anchor0(self.knee[0]),
                               self._anchor0(self.ankle[0]))
        self.l1 = float(np.linalg.norm(knee0 - hip0))
        self.l2 = float(np.linalg.norm(ankle0 - knee0))
        self._thigh0 = (knee0 - hip0) / self.l1          # rest thigh axis, hip to knee
        # rest frame of the thigh: hinge axis (left), up along the thigh, forward
        x0 = self.left0 - (self.left0 @ self._thigh0) * self._thigh0
        x0 /= np.linalg.norm(x0)
        y0 = -self._thigh0
        self._thigh_frame0 = np.stack([x0, y0, cross(x0, y0)], axis=1)
        # knee hinge: flexion about left0 in the rest frame; its joint angle's sign
        self.knee_sign = []
        for s in range(2):
            k = self.knee[s]
            if m.joint_type_names[k] == "hinge":
                axis = Q.qrot(self.Fa[k], np.array([1.0, 0.0, 0.0]))
                self.knee_sign.append(1.0 if axis @ self.left0 > 0 else -1.0)
            else:
                self.knee_sign.append(0.0)
        # ankle above the sole at rest
        low = math.inf
        for g in range(m.ngeom):
            b = m.geom_body[g]
            if b in self.feet_bodies and (m.geom_contype[g] or m.geom_conaffinity[g]):
                low = min(low, foot_lowest_at(m, g, m.body_pos0[b], m.body_quat0[b], up))
        self.ankle_height = float(ankle0 @ up - low)
        # bodies of each side's foot (foot and toe) for the contact test
        self._side_feet = []
        for s in range(2):
            feet = {self.foot[s]}
            if self.toe[s] >= 0:
                feet.add(int(m.joint_child[self.toe[s]]))
            self._side_feet.append(feet)
        # gravity compensation: for each side as the swing side, the (body, joint) pairs of
        # the swing leg's and the upper body's bodies with every joint between each body
        # and the pelvis
        joint_of = {int(m.joint_child[k]): k for k in range(m.njoint)}
        upper = [b for b in self._upper_bodies if b != self.pelvis]
        self._gc_pairs = []
        for s in range(2):
            bodies, joints = [], []
            for b in upper + self._leg_bodies[s]:
                c = b
                while c != self.pelvis:
                    k = joint_of[c]
                    bodies.append(b)
                    joints.append(k)
                    c = int(m.joint_parent[k])
            self._gc_pairs.append((np.array(bodies), np.array(joints)))
        self._pelvis_children = [k for k in range(m.njoint) if m.joint_parent[k] == self.pelvis]
        dyn = np.isfinite(m.body_mass)
        self._weight = 9.81 * float(m.body_mass[dyn].sum())
        # the sole of the foot body (not the toes) around the ankle at rest: (heel, front)
        # along forward, half-width along left (m), for the bounds of the ankle's torque
        pts = []
        from .feet import foot_points
        for g in range(m.ngeom):
            if m.geom_body[g] == self.foot[0] and (m.geom_contype[g] or m.geom_conaffinity[g]):
                p, r = foot_points(m, g)
                b = m.geom_body[g]
                q = Q.qmul(m.body_quat0[b], m.geom_quat[g])
                c = m.body_pos0[b] + Q.qrot(m.body_quat0[b], m.geom_pos[g])
                pts.append(c + Q.qrot(np.broadcast_to(q, (len(p), 4)), p) - ankle0)
        pts = np.concatenate(pts)
        self.sole = (float((pts @ self.fwd0).min()), float((pts @ self.fwd0).max()),
                     float(np.abs(pts @ self.left0).max()))

    def reset(self):
        """Back to the first step, right leg in stance, heading from the pelvis."""
        super().reset()
        self.phase = 0.0
        self.step_duration = self.gait.step_time
        self.adjust = np.zeros(2)
        self.command = np.zeros(2)
        swing = 1 - self.stance
        self.swing_start = self._anchor(self.ankle[swing]).copy()
        self.swing_start_ground = self.ground_height(self.swing_start)
        self._stride_start = self._step_start
        self.last_plan = None
        self.frozen_plan = None
        self.strike_knee = self.gait.stance_knee
        c0, _ = center_of_mass(self.world)
        a0 = self._anchor(self.ankle[self.stance])
        self.com_height = float((c0 - a0) @ self.up) - self.gait.height_drop
        self.last_target = None
        self._anchors_now = None
        self.last_ik = None
        self.last_force = np.zeros(3)
        self.early = False
        self.cp_out = 0.0

    _SNAP_FIELDS = SimbiconController._SNAP_FIELDS + (
        "phase", "adjust", "command", "frozen_plan", "strike_knee", "swing_start",
        "swing_start_ground", "_stride_start", "early")

    def place(self, *, speed=0.0, pose=None, position=(0.0, 0.0), yaw=0.0, drop=0.001,
              lean=None):
        """As SimbiconController.place; the default lean is the style's torso pitch (plus
        its lean per speed and per slope)."""
        if lean is None:
            fwd = Q.qrot(self._yaw_quat(yaw), self.fwd0)
            slope = math.atan(self.terrain.slope_along(position[0], position[1],
                                                       (fwd[0], fwd[2])))
            lean = self._pitch(slope)
        super().place(speed=speed, pose=pose, position=position, yaw=yaw, drop=drop, lean=lean)

    def _apply_gains(self):
        """SIMBICON's gains (the stance hip takes the torso's), and the stance knee the
        style's ``stance_knee_gains`` when it has them."""
        super()._apply_gains()
        g = self.gait.stance_knee_gains
        if g is not None:
            w = self.world
            kp, kd = np.array(w.joint_kp), np.array(w.joint_kd)
            k = self.knee[self.stance]
            kp[k], kd[k] = g
            w.joint_kp = kp
            w.joint_kd = kd

    def _pitch(self, slope):
        s = self.gait
        return s.torso[0] + s.lean_speed * s.speed + s.slope_lean * slope

    # ------------------------------------------------------------------ kinematics
    def _anchors(self):
        """World anchors (child side) of every joint (njoint, 3)."""
        m, w = self.model, self.world
        c = m.joint_child
        return w.body_pos[c] + Q.qrot(w.body_quat[c], m.joint_anchor_b)

    def thigh_rotation(self, thigh_dir, bend_axis):
        """Rest-relative world rotation (4,) of a thigh along ``thigh_dir`` (hip to knee)
        with its knee hinge along ``bend_axis`` (both unit, perpendicular)."""
        y = -np.asarray(thigh_dir, float)
        x = np.asarray(bend_axis, float)
        M = np.stack([x, y, cross(x, y)], axis=1)
        return Q.qfrom_matrix(M @ self._thigh_frame0.T)

    def foot_load(self, side):
        """Normal force (N) of the ground on the foot and toes of ``side`` in the last
        physics step."""
        con = self._contacts
        if con is None or len(con) == 0:
            return 0.0
        feet = self._side_feet[side]
        total = 0.0
        for (a, b), f in zip(con.bodies, con.normal_force):
            body = b if a < 0 else (a if b < 0 else None)
            if body in feet:
                total += float(f)
        return total

    def _knee_flex(self, side):
        """Flexion (rad) of the knee of ``side`` now (> 0 bent)."""
        k = self.knee[side]
        if self.model.joint_type_names[k] == "hinge":
            return float(self.knee_sign[side] * self.world.joint_q[k][0])
        t = Q.qmul_one(self.Fa[k], Q.qmul_one(self.world.joint_quat[k], Q.qconj_one(self.Fb[k])))
        return float(Q.qrotvec(t) @ self.left0)

    def _foot_on_ground(self, side):
        return self.foot_load(side) > self.gait.strike_load * self._weight

    # ------------------------------------------------------------------ state machine
    def _update_fsm(self):
        s = self.gait
        self.phase_time += self.control_dt
        self.phase += self.control_dt / self.step_duration
        # an early touch-down ends the step when the foot bears early_load of the weight
        # (a foot that only grazes the ground would leave the body on no leg)
        landed = (self.foot_load(1 - self.stance) > self.early_load * self._weight
                  if self.early else self._foot_on_ground(1 - self.stance))
        if (self.phase >= s.min_phase and landed) or self.phase >= s.max_phase:
            self._switch_stance()

    def _switch_stance(self):
        s = self.gait
        c, _ = center_of_mass(self.world)
        t0, c0 = self._step_start
        ts, cs = self._stride_start
        old_swing = 1 - self.stance
        self.stance = old_swing
        self.state, self.phase_time, self.phase = 0, 0.0, 0.0
        p = self._anchor(self.ankle[self.stance])
        self.strikes.append((self.time, self.stance, p.copy(), self.heading))
        fwd, left = self._frame()
        if self.time - t0 > 0 and len(self.strikes) > 2:
            # the step's mean velocity along the heading: too slow -> shorter steps
            v = float((c - c0) @ fwd) / (self.time - t0)
            lim = s.speed_limit
            self.adjust[0] = min(max(self.adjust[0] - s.speed_gain * (s.speed - v), -lim), lim)
            if len(self.strikes) % 2 == 0 and self.time - ts > 0:
                # sideways over a stride (the sway cancels): too slow to the left -> both
                # feet land further right
                vc = float((c - cs) @ left) / (self.time - ts)
                self.adjust[1] = min(max(self.adjust[1] - s.side_gain * (s.side_speed - vc),
                                         -lim), lim)
        if len(self.strikes) % 2 == 0:
            self._stride_start = (self.time, c)
        self._step_start = (self.time, c)
        swing = 1 - self.stance
        self.swing_start = self._anchor(self.ankle[swing]).copy()
        self.swing_start_ground = self.ground_height(self.swing_start)
        self.frozen_plan = None
        self.early = False
        self.strike_knee = self._knee_flex(self.stance)
        self._apply_gains()

    # ------------------------------------------------------------------ control
    def _swing_ankle_target(self, com, vcom, stance_ankle, fwd, left, phase, h, swing_sign,
                            plan=None):
        s = self.gait
        if plan is None:
            plan = self._plan(com, vcom, stance_ankle, fwd, left, phase, h, swing_sign)
        ground = self.ground_height(plan.target)
        target = swing_target(phase, self.swing_start, plan.target, height=s.step_height,
                              landing=s.landing, ground_start=self.swing_start_ground,
                              ground_step=ground, up=self.up, ankle_height=self.ankle_height,
                              peak=s.step_peak, lift=s.lift_phase, ease=s.swing_ease)
        # the whole path, not only the landing, stays min_step_width outward of the stance
        # ankle: the swing foot does not strike the stance leg on its way
        out = swing_sign * left
        side = float((target - stance_ankle) @ out)
        # measured from the stance knee where the stance leg leans toward the swing side
        stance = RIGHT if swing_sign > 0 else LEFT
        knee = (self._anchors_now[self.knee[stance]] if self._anchors_now is not None
                else stance_ankle)
        side -= max(float((knee - stance_ankle) @ out), 0.0)
        if side < s.min_step_width:
            target = target + (s.min_step_width - side) * out
        return plan, target

    def _plan(self, com, vcom, stance_ankle, fwd, left, phase, h, swing_sign):
        s = self.gait
        if s.predict > 0.0:
            # the COM where it will be at the end of the step, moving on at its velocity
            tau = s.predict * max(1.0 - phase, 0.0) * self.step_duration
            vh = vcom - (vcom @ self.up) * self.up
            com = com + tau * vh
        def plan_at(height):
            return plan_step(com, vcom, stance_ankle, fwd, left, self.up, swing_sign, h=height,
                             v_des=tuple(self.command), alpha=s.alpha, scale=s.ipm_scale,
                             step_width=s.step_width, max_step=s.max_step,
                             min_width=s.min_step_width, foot_center=s.foot_center,
                             adjust=tuple(self.adjust))
        plan = plan_at(h)
        # the pendulum pivots on the landing point: a step down a slope (or off a ledge)
        # lands lower, so the COM stands higher above it and the step reaches further
        drop = self.ground_height(stance_ankle) - self.ground_height(plan.target)
        if abs(drop) > 1e-4:
            plan = plan_at(max(h + drop, 0.1))
        return plan

    def gravity_torques(self, swing, anchors=None, fraction=1.0):
        """Joint torques (njoint, 3) world N m compensating the weight of the swing leg
        (``swing`` side) and of the upper body: for each of their bodies b and each joint j
        between b and the pelvis, ``tau_j += (p_b - a_j) x (fraction m_b g up)`` (a
        Jacobian-transpose force at b's COM, the pelvis the base)."""
        m, w = self.model, self.world
        a = self._anchors() if anchors is None else anchors
        bodies, joints = self._gc_pairs[swing]
        f = (fraction * 9.81 * m.body_mass[bodies])[:, None] * self.up
        r = w.body_pos[bodies] - a[joints]
        tau = np.zeros((m.njoint, 3))
        np.add.at(tau, joints, cross(r, f))
        return tau

    def com_force_torques(self, stance, force, point, anchors=None):
        """Joint torques (njoint, 3) realising ``force`` at ``point`` (the COM) from the
        ``stance`` foot: ``tau_j = -(point - a_j) x force`` on its ankle and knee (the ground
        is the base; the stance hip is the torso's)."""
        a = self._anchors() if anchors is None else anchors
        tau = np.zeros((self.model.njoint, 3))
        for k in (self.ankle[stance], self.knee[stance]):
            tau[k] = -cross(point - a[k], force)
        return tau

    def _bound_ankle(self, side, tau):
        """The ankle torque ``tau`` (on the foot, world) with its components about the foot's
        left and forward axes bounded to centres of pressure on the sole (its heel and front
        and half-width, less ``cop_margin``) under the body's weight."""
        R = self._seg_rot(self.foot[side])
        fl = Q.qrot_one(R, self.left0)
        ff = Q.qrot_one(R, self.fwd0)
        heel, front, half = self.sole
        mg = self.gait.cop_margin
        N = self._weight
        t_l = float(tau @ fl)
        t_f = float(tau @ ff)
        # a centre of pressure x ahead of the ankle needs x N about left; y to the left,
        # -y N about forward
        b_l = min(max(t_l, (heel + mg) * N), (front - mg) * N)
        b_f = min(max(t_f, -(half - mg) * N), (half - mg) * N)
        return tau + (b_l - t_l) * fl + (b_f - t_f) * ff

    def control(self):
        """Compute and set this control period's servo targets, target rates and the
        virtual-force torques."""
        s = self.gait
        w, m = self.world, self.model
        up = self.up
        stance, swing = self.stance, 1 - self.stance
        sgn_sw = 1.0 if swing == LEFT else -1.0
        fwd, left = self._frame()
        yq = self._yaw_quat(self.heading)
        anchors = self._anchors()
        self._anchors_now = anchors
        com, vcom = center_of_mass(w)
        ankle = anchors[self.ankle[stance]]
        slope = math.atan(self.terrain.slope_along(ankle[0], ankle[2], (fwd[0], fwd[2])))
        self.slope = slope
        h = float((com - ankle) @ up) + self.ankle_height
        # the step's duration: shorter at a faster command, and the further the COM's
        # velocity is off the command
        v_heading = np.array([vcom @ fwd, vcom @ left])       # sagittal, coronal
        v_off = float(np.linalg.norm(self.command - v_heading))
        base = s.step_time - s.step_time_speed * abs(float(self.command[0]))
        self.step_duration = max(base - s.hurry * max(v_off - s.hurry_deadband, 0.0),
                                 min(s.min_step_time, s.step_time))
        phase = self.phase
        # the commanded velocity, reached at a bounded acceleration
        goal = np.array([s.speed, s.side_speed])
        dv = goal - self.command
        n = float(np.linalg.norm(dv))
        lim = s.accel * self.control_dt
        self.command = goal if n <= lim else self.command + dv * (lim / n)
        # the coronal capture point beyond the stance ankle, toward the stance side (m): > 0,
        # the pendulum falls over the stance foot's outer side and will not swing back
        xi = com + vcom * math.sqrt(max(h, 0.1) / 9.81)
        self.cp_out = -sgn_sw * float((xi - ankle) @ left)
        # how far outward of the stance ankle the swing ankle is now (m)
        near = sgn_sw * float((anchors[self.ankle[swing]] - ankle) @ left)
        # (only before early_phase: a step nearly done lands anyway, and one past its end is
        # looking for a late ground, where a loaded landing is not to be waited for)
        if (not self.early and self.cp_out > self.early_cross and phase < self.early_phase
                and self.phase_time >= self.early_after and near < self.early_near
                and float(v_heading[0] - self.command[0]) < self.early_ahead):
            # Early touch-down: the pendulum wants the step across the stance foot (a push
            # toward the stance side), which the swing foot may not take. Put it down now,
            # outward of the stance foot, so that the other leg, on the pushed side, swings
            # at once and takes the wide step, instead of after the rest of this swing.
            self.early = True
            phase = self.phase = self.early_phase
        if self.early:
            self.step_duration = min(self.step_duration, self.early_time)
        # ---- foot placement and the swing trajectory
        # the step is replanned every period until ``freeze_phase``, then held in the world
        # until the phase ends (a late ground: replanned again)
        frozen = self.frozen_plan if phase >= s.freeze_phase else None
        plan, target = self._swing_ankle_target(com, vcom, ankle, fwd, left, phase, h, sgn_sw,
                                                frozen)
        if phase >= s.freeze_phase and self.frozen_plan is None:
            self.frozen_plan = plan
        hw, hs = self.hip[swing], self.hip[stance]
        pel = self.pelvis
        hip = anchors[hw]
        v_hip = w.body_vel[pel] + cross(w.body_angvel[pel], hip - w.body_pos[pel])
        yaw_rate = s.turn_rate * up
        # The servos are implicit: they pull toward their targets as the state is at the end
        # of the period. A moving target is therefore taken where it will be then (a
        # period ahead, the COM and the hip moving on at their velocities), with the rate
        # it has there (a finite difference over _PREDICT s).
        ik = two_link_ik(hip, target, self.l1, self.l2, fwd)
        iks, R_ths = [], []
        for ahead in (self.control_dt, self.control_dt + _PREDICT):
            fwd_a = Q.qrot_one(self._yaw_quat(self.heading + s.turn_rate * ahead), self.fwd0)
            _, tg = self._swing_ankle_target(com + ahead * vcom, vcom, ankle, fwd, left,
                                             phase + ahead / self.step_duration, h, sgn_sw,
                                             frozen)
            hip_a = hip + ahead * v_hip
            if s.reach > 0.0:
                tg, _ = reachable_target(hip_a, tg, s.reach * (self.l1 + self.l2), up)
            ik_a = two_link_ik(hip_a, tg, self.l1, self.l2, fwd_a)
            iks.append(ik_a)
            R_ths.append(self.thigh_rotation(ik_a.thigh_dir, ik_a.bend_axis))
        R_thd = R_ths[0]
        w_thigh = Q.qrotvec(Q.qmul_one(R_ths[1], Q.qconj_one(R_thd))) / _PREDICT
        flex = iks[0].flex
        swing_knee_rate = (iks[1].flex - flex) / _PREDICT
        self.last_plan, self.last_target, self.last_ik = plan, target, ik
        self._ahead_ankle = iks[0].ankle
        # ---- targets
        R = self._stand.copy()
        # the pelvis a period ahead at its angular velocity
        w_p = w.body_angvel[pel]
        R_p = Q.qmul_one(_rotvec_quat(w_p * self.control_dt), self._seg_rot(pel))
        pitch = self._pitch(slope)
        roll = s.torso[1]
        R_pd = Q.qmul_one(yq, Q.qmul_one(Q.qaxis_angle_one(self.fwd0, sgn_sw * roll),
                                         Q.qaxis_angle_one(self.left0, pitch)))
        R[hw] = Q.qmul_one(Q.qconj_one(R_p), R_thd)
        R[self.knee[swing]] = Q.qaxis_angle_one(self.left0, flex)
        # the stance knee goes from its bend at the strike to the style's over knee_time s
        # (at most knee_rate rad/s)
        # (straightening a bent landing leg at once would throw the body up)
        k0 = self.strike_knee
        t_knee = s.knee_time
        if s.knee_rate > 0.0:
            t_knee = max(t_knee, abs(s.stance_knee - k0) / s.knee_rate)
        u = min(self.phase_time / t_knee, 1.0) if t_knee > 0 else 1.0
        u = u * u * (3.0 - 2.0 * u)
        knee_st = k0 + u * (s.stance_knee - k0)
        # down a slope the stance knee yields over the step: the negative work that keeps
        # the walk from gaining the speed the descent gives it
        knee_st += s.slope_knee * max(-slope, 0.0) * min(phase, 1.0)
        R[self.knee[stance]] = Q.qaxis_angle_one(self.left0, knee_st)
        th_st = self.thigh[stance]
        R[hs] = Q.qmul_one(Q.qconj_one(R_pd), self._seg_rot(th_st))
        rates = np.zeros((m.njoint, 3))
        fa = Q.qmul(w.body_quat[m.joint_parent[[hs, hw]]], m.joint_frame_a[[hs, hw]])
        rates[hs] = Q.qrot_one(Q.qconj_one(fa[0]), w.body_angvel[th_st] - yaw_rate)
        rates[hw] = Q.qrot_one(Q.qconj_one(fa[1]), w_thigh - w_p)
        rates[self.knee[swing], 0] = self.knee_sign[swing] * swing_knee_rate
        # feet level in the heading frame, tilted with the slope, dorsiflexed by the style:
        # the swing foot relative to the shank its leg's targets give, the stance foot to
        # the present shank; the rate target damps the foot's world angular velocity
        R_shank_sw = Q.qmul_one(R_thd, Q.qaxis_angle_one(self.left0, flex))
        for side, dorsi in ((swing, s.swing_ankle), (stance, s.stance_ankle)):
            k = self.ankle[side]
            shank = int(m.joint_child[self.knee[side]])
            R_sh = R_shank_sw if side == swing else self._seg_rot(shank)
            R[k] = Q.qmul_one(Q.qconj_one(R_sh),
                              Q.qmul_one(yq, Q.qaxis_angle_one(self.left0, -(dorsi + slope))))
            fa_k = Q.qmul_one(w.body_quat[shank], m.joint_frame_a[k])
            rates[k] = Q.qrot_one(Q.qconj_one(fa_k), yaw_rate - w.body_angvel[shank])
            if side == stance and not s.stance_ankle_world:
                R[k] = Q.qaxis_angle_one(self.left0, -dorsi)
                rates[k] = 0.0
        self._set_targets(R, rates)
        # ---- virtual forces
        tau_g = self.gravity_torques(swing, anchors, s.gravity_compensation)
        ff = -sum(tau_g[k] for k in self._pelvis_children if k != hs)
        tau_g[hs] += ff
        v_err = self.command - v_heading
        f2 = np.clip(np.asarray(s.velocity_gain) * v_err, -np.asarray(s.max_force),
                     np.asarray(s.max_force))
        force = f2[0] * fwd + f2[1] * left
        tau_v = self.com_force_torques(stance, force, com, anchors)
        # the stance knee carries the body's weight at the COM (the vertical virtual force,
        # Jacobian transpose from the ground): the leg does not fold under it
        if s.knee_support > 0.0 or s.height_gain[0] > 0.0:
            kk = self.knee[stance]
            hgt = float((com - ankle) @ up)
            fz = s.knee_support * self._weight + s.height_gain[0] * (self.com_height - hgt) \
                - s.height_gain[1] * float(vcom @ up)
            fz = min(max(fz, 0.0), 2.0 * self._weight)
            tau_v[kk] += -cross(com - anchors[kk], fz * up)
        # the stance ankle holds the ground's support at the foot's pivot, foot_center ahead
        # of the ankle (the ground reaction of the body's weight there, -(p - a) x M g up),
        # and the whole ankle torque is bounded so that the centre of pressure stays on the
        # sole, ``cop_margin`` inside its edges (the foot stays flat)
        ka = self.ankle[stance]
        tau_v[ka] += -cross(s.foot_center * fwd, self._weight * up)
        tau_v[ka] = self._bound_ankle(stance, tau_v[ka])
        apply_joint_torques(w, tau_g + tau_v)
        self.last_force = force
        self.last_tau = {"gravity": tau_g, "velocity": tau_v, "stance_feedforward": ff}


def make_generalized(style="ipm_walk", terrain=None, *, dt=1.0 / 60.0, control_dt=1.0 / 60.0,
                     contact="pgs", **kw):
    """The course character (``games105_ragdoll``) on ``terrain`` in a World of physics
    step ``dt``, walked by a GeneralizedController at ``control_dt`` (keywords: speed,
    side_speed, turn_rate, fall_height, ...)."""
    from .ragdoll import games105_ragdoll
    from .terrain import Flat
    terrain = Flat() if terrain is None else terrain
    rd = games105_ragdoll(root="floating", terrain=terrain)
    world = rd.make_world(dt=dt, contact=contact)
    return GeneralizedController(world, rd, style, control_dt=control_dt, terrain=terrain, **kw)


