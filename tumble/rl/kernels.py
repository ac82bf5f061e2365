"""Compiled kernels of the learning tasks (imitation, AMP), each over all N worlds of a batch
in one call.

Frames. The *heading frame* of a character is the world frame turned about the vertical
axis (index ``up``: 1 for Y up, 2 for Z up) by the root body's heading, the angle of its x
axis projected on the ground; seen in it, a character's pose does not depend on which way
it faces. Observations and the end-effector term of the reward are measured in it.
"""
import math

from numba import njit

from ..math.quat import quat_conj, quat_exp, quat_mul, quat_rotate

# Joint kinds of the action layout (see ``action_layout``).
DOF_BALL = 0
DOF_HINGE = 1
DOF_UNIVERSAL = 2

# Observation of one body: position (3), rotation as two axes (6), linear and angular
# velocity (3 + 3).
BODY_OBS = 15


@njit(cache=True, inline="always")
def heading_angle(q, up):
    """The heading (rad) of a rotation ``q`` about the vertical ``up`` (see heading_quat)."""
    x = quat_rotate(q, (1.0, 0.0, 0.0))
    if up == 1:
        return math.atan2(-x[2], x[0])
    return math.atan2(x[1], x[0])


@njit(cache=True, inline="always")
def heading_quat(q, up):
    """Rotation about the vertical axis ``up`` (1 or 2) by the heading of ``q``: the angle
    of q's x axis projected on the ground, measured about the vertical."""
    theta = heading_angle(q, up)
    if up == 1:
        return (0.0, math.sin(0.5 * theta), 0.0, math.cos(0.5 * theta))
    return (0.0, 0.0, math.sin(0.5 * theta), math.cos(0.5 * theta))


@njit(cache=True)
def observe(body_pos, body_quat, body_vel, body_angvel, root, up, phase, use_phase, obs):
    """Observations (N, D) float32 of every world, written into ``obs``.

    Per world: the root's height (m), then for every body in model order, in the heading
    frame: position relative to the root (m), the first two columns of its rotation matrix
    (the 6-D tangent-normal form), linear (m/s) and angular (rad/s) velocity; then, with
    ``use_phase``, sin and cos of 2 pi phase (phase (N,) in cycles).
    """
    N, nb = body_pos.shape[0], body_pos.shape[1]
    for w in range(N):
        hinv = quat_conj(heading_quat(body_quat[w, root], up))
        obs[w, 0] = body_pos[w, root, up]
        k = 1
        for b in range(nb):
            d = (body_pos[w, b, 0] - body_pos[w, root, 0], body_pos[w, b, 1] - body_pos[w, root, 1],
                 body_pos[w, b, 2] - body_pos[w, root, 2])
            p = quat_rotate(hinv, d)
            qb = quat_mul(hinv, body_quat[w, b])
            t = quat_rotate(qb, (1.0, 0.0, 0.0))
            n = quat_rotate(qb, (0.0, 1.0, 0.0))
            v = quat_rotate(hinv, body_vel[w, b])
            a = quat_rotate(hinv, body_angvel[w, b])
            for c in range(3):
                obs[w, k + c] = p[c]
                obs[w, k + 3 + c] = t[c]
                obs[w, k + 6 + c] = n[c]
                obs[w, k + 9 + c] = v[c]
                obs[w, k + 12 + c] = a[c]
            k += BODY_OBS
        if use_phase:
            obs[w, k] = math.sin(2.0 * math.pi * phase[w])
            obs[w, k + 1] = math.cos(2.0 * math.pi * phase[w])


@njit(cache=True, inline="always")
def _angle_sq(a, b):
    """Squared angle (rad^2) between unit quaternions, sign-blind."""
    d = abs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3])
    if d > 1.0:
        d = 1.0
    ang = 2.0 * math.acos(d)
    return ang * ang


@njit(cache=True, inline="always")
def _dist_sq(a, b):
    return (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2


@njit(cache=True)
def imitation_reward(body_pos, body_quat, body_vel, body_angvel, joint_quat, joint_qd,
                     r_body_pos, r_body_quat, r_body_vel, r_body_angvel, r_joint_quat,
                     r_joint_qd, r_com_vel, body_mass, root, up, joint_weight, root_weight,
                     end_effectors, weights, scales, reward, terms):
    """DeepMimic's imitation reward of every world (``reward`` (N,), ``terms`` (N, 5)).

    Errors, each turned into ``exp(-scale * err)`` and summed with ``weights`` (5,):
    0 pose:  sum_j w_j angle(q_j, q^_j)^2 over the joints' local rotations, plus the root
             body's orientation with ``root_weight`` (weights summing to 1);
    1 velocity: sum_j w_j |qd_j - qd^_j|^2 of the joint rates, plus the root's angular
             velocity with ``root_weight``;
    2 end effectors: the mean over ``end_effectors`` of the squared distance between their
             positions relative to the root in the heading frame, height above the ground
             (the plane through the origin) kept as it is;
    3 root: |x - x^|^2 + 0.1 angle^2 + 0.01 |v - v^|^2 + 0.001 |w - w^|^2 of the root body;
    4 centre of mass: 0.1 |v_com - v^_com|^2 (DeepMimic compares the COM's velocity).
    ``terms`` holds the five exp(-scale err) values, each 1 on the reference.
    """
    N, nb = body_pos.shape[0], body_pos.shape[1]
    nj = joint_quat.shape[1]
    total_mass = 0.0
    for b in range(nb):
        total_mass += body_mass[b]
    ne = end_effectors.shape[0]
    for w in range(N):
        pose = root_weight * _angle_sq(body_quat[w, root], r_body_quat[w, root])
        vel = root_weight * _dist_sq(body_angvel[w, root], r_body_angvel[w, root])
        for j in range(nj):
            if joint_weight[j] == 0.0:
                continue
            pose += joint_weight[j] * _angle_sq(joint_quat[w, j], r_joint_quat[w, j])
            vel += joint_weight[j] * _dist_sq(joint_qd[w, j], r_joint_qd[w, j])
        hinv = quat_conj(heading_quat(body_quat[w, root], up))
        r_hinv = quat_conj(heading_quat(r_body_quat[w, root], up))
        end = 0.0
        for e in range(ne):
            b = end_effectors[e]
            d = (body_pos[w, b, 0] - body_pos[w, root, 0], body_pos[w, b, 1] - body_pos[w, root, 1],
                 body_pos[w, b, 2] - body_pos[w, root, 2])
            rd = (r_body_pos[w, b, 0] - r_body_pos[w, root, 0],
                  r_body_pos[w, b, 1] - r_body_pos[w, root, 1],
                  r_body_pos[w, b, 2] - r_body_pos[w, root, 2])
            p = quat_rotate(hinv, d)
            rp = quat_rotate(r_hinv, rd)
            # heights above the ground, not below the root
            ph = body_pos[w, b, up]
            rph = r_body_pos[w, b, up]
            for c in range(3):
                dc = (ph - rph) if c == up else (p[c] - rp[c])
                end += dc * dc
        if ne > 0:
            end /= ne
        root_err = (_dist_sq(body_pos[w, root], r_body_pos[w, root])
                    + 0.1 * _angle_sq(body_quat[w, root], r_body_quat[w, root])
                    + 0.01 * _dist_sq(body_vel[w, root], r_body_vel[w, root])
                    + 0.001 * _dist_sq(body_angvel[w, root], r_body_angvel[w, root]))
        cv0 = 0.0
        cv1 = 0.0
        cv2 = 0.0
        for b in range(nb):
            cv0 += body_mass[b] * body_vel[w, b, 0]
            cv1 += body_mass[b] * body_vel[w, b, 1]
            cv2 += body_mass[b] * body_vel[w, b, 2]
        com = 0.1 * ((cv0 / total_mass - r_com_vel[w, 0]) ** 2
                     + (cv1 / total_mass - r_com_vel[w, 1]) ** 2
                     + (cv2 / total_mass - r_com_vel[w, 2]) ** 2)
        terms[w, 0] = math.exp(-scales[0] * pose)
        terms[w, 1] = math.exp(-scales[1] * vel)
        terms[w, 2] = math.exp(-scales[2] * end)
        terms[w, 3] = math.exp(-scales[3] * root_err)
        terms[w, 4] = math.exp(-scales[4] * com)
        r = 0.0
        for k in range(5):
            r += weights[k] * terms[w, k]
        reward[w] = r


@njit(cache=True)
def pd_targets(actions, scale, residual, dof_joint, dof_kind, dof_start, r_joint_quat,
               r_joint_q, target_quat, target_q):
    """PD targets of every world from actions (N, A) (each component in [-1, 1]).

    For actuated joint ``dof_joint[i]`` of kind ``dof_kind[i]`` whose action components start
    at ``dof_start[i]``: a ball joint turns by the rotation vector ``scale * a`` (3
    components) in its joint frame, after the reference rotation when ``residual``
    (``target = ref * exp(scale a)``) or from the identity; a hinge's angle is ``scale * a``
    (plus the reference angle when ``residual``); a universal joint's two angles likewise.
    Writes ``target_quat`` (N, nj, 4) and ``target_q`` (N, nj, 3) of the actuated joints.
    """
    N = actions.shape[0]
    for w in range(N):
        for i in range(dof_joint.shape[0]):
            j = dof_joint[i]
            s = dof_start[i]
            kind = dof_kind[i]
            if kind == DOF_BALL:
                d = quat_exp((scale[s] * actions[w, s], scale[s + 1] * actions[w, s + 1],
                              scale[s + 2] * actions[w, s + 2]))
                if residual:
                    d = quat_mul(r_joint_quat[w, j], d)
                for c in range(4):
                    target_quat[w, j, c] = d[c]
            else:
                n = 1 if kind == DOF_HINGE else 2
                for c in range(n):
                    v = scale[s + c] * actions[w, s + c]
                    if residual:
                        v += r_joint_q[w, j, c]
                    target_q[w, j, c] = v
                if residual:
                    for c in range(4):
                        target_quat[w, j, c] = r_joint_quat[w, j, c]


@njit(cache=True)
def fallen(ground, allowed, root, up, body_pos, min_root_height, out):
    """Per world: a body not in ``allowed`` (nb,) touched the ground (``ground`` (N, nb) bool
    from ``World.ground_contacts``), or the root body is below ``min_root_height`` (m)."""
    N, nb = ground.shape[0], ground.shape[1]
    for w in range(N):
        f = body_pos[w, root, up] < min_root_height
        for b in range(nb):
            if ground[w, b] and not allowed[b]:
                f = True
        out[w] = f


# -- adversarial motion priors (tumble.rl.tasks.amp) ---------------------------------------

# Per state: root height (1), root rotation as two axes (6), root linear and angular velocity
# (3 + 3), all in the heading frame; then 9 per joint and 3 per end effector.
AMP_ROOT_FEATURES = 13
AMP_JOINT_FEATURES = 9


@njit(cache=True)
def amp_features(body_pos, body_quat, body_vel, body_angvel, joint_quat, joint_qd, root, up,
                 joints, end_effectors, out):
    """The discriminator's view of one state of every world (AMP, Peng et al. 2021), written
    into ``out`` (N, F) float32, F = 13 + 9 len(joints) + 3 len(end_effectors).

    In the root's heading frame: the root's height (m), its rotation's first two columns,
    its linear (m/s) and angular (rad/s) velocity; then for each joint of ``joints``, its
    local rotation's first two columns (6) and its rates ``joint_qd`` (3, joint frame,
    rad/s); then each end effector's position relative to the root (m). Inputs as the
    world's arrays with a world axis: body_* (N, nb, 3|4), joint_quat (N, nj, 4), joint_qd
    (N, nj, 3).
    """
    N = body_pos.shape[0]
    nj = joints.shape[0]
    for w in range(N):
        hinv = quat_conj(heading_quat(body_quat[w, root], up))
        out[w, 0] = body_pos[w, root, up]
        qr = quat_mul(hinv, body_quat[w, root])
        t = quat_rotate(qr, (1.0, 0.0, 0.0))
        n = quat_rotate(qr, (0.0, 1.0, 0.0))
        v = quat_rotate(hinv, body_vel[w, root])
        a = quat_rotate(hinv, body_angvel[w, root])
        for c in range(3):
            out[w, 1 + c] = t[c]
            out[w, 4 + c] = n[c]
            out[w, 7 + c] = v[c]
            out[w, 10 + c] = a[c]
        k = AMP_ROOT_FEATURES
        for i in range(nj):
            j = joints[i]
            qj = (joint_quat[w, j, 0], joint_quat[w, j, 1], joint_quat[w, j, 2],
                  joint_quat[w, j, 3])
            t = quat_rotate(qj, (1.0, 0.0, 0.0))
            n = quat_rotate(qj, (0.0, 1.0, 0.0))
            for c in range(3):
                out[w, k + c] = t[c]
                out[w, k + 3 + c] = n[c]
                out[w, k + 6 + c] = joint_qd[w, j, c]
            k += AMP_JOINT_FEATURES
        for e in range(end_effectors.shape[0]):
            b = end_effectors[e]
            d = (body_pos[w, b, 0] - body_pos[w, root, 0], body_pos[w, b, 1] - body_pos[w, root, 1],
                 body_pos[w, b, 2] - body_pos[w, root, 2])
            p = quat_rotate(hinv, d)
            for c in range(3):
                out[w, k + c] = p[c]
            k += 3


@njit(cache=True)
def heading_command(body_quat, root, up, forward, target_heading, target_speed, obs, start):
    """The command part of every world's observation, from column ``start`` of ``obs``:
    cos and sin of the commanded heading relative to the character's (rad: the root's
    heading plus ``forward``, the angle from the root's x axis to where it walks), and the
    commanded speed (m/s)."""
    for w in range(body_quat.shape[0]):
        q = (body_quat[w, root, 0], body_quat[w, root, 1], body_quat[w, root, 2],
             body_quat[w, root, 3])
        d = target_heading[w] - heading_angle(q, up) - forward
        obs[w, start] = math.cos(d)
        obs[w, start + 1] = math.sin(d)
        obs[w, start + 2] = target_speed[w]


HEADING_REWARD_MODES = ("vector", "along", "speed")


@njit(cache=True)
def heading_reward(body_vel, body_mass, up, target_heading, target_speed, scale, mode,
                   reward, com_vel):
    """Task reward of a commanded heading and speed, with v the centre of mass's horizontal
    velocity (m/s), d* the unit horizontal direction of ``target_heading`` (rad about the
    vertical, 0 along x) and v* ``target_speed``. ``mode`` (HEADING_REWARD_MODES) 0,
    "vector": ``exp(-scale |v - v* d*|^2)``; 1, "along", AMP's form:
    ``exp(-scale max(0, v* - d*.v)^2)``, only the speed along d* counts and going faster
    than v* costs nothing; 2, "speed": ``exp(-scale (v* - d*.v)^2)``, the speed along d*
    matched both ways (sideways drift is free, as under "along"). Writes ``reward`` (N,) and
    ``com_vel`` (N, 3) (the centre of mass's velocity)."""
    N, nb = body_vel.shape[0], body_vel.shape[1]
    total = 0.0
    for b in range(nb):
        total += body_mass[b]
    for w in range(N):
        v0 = 0.0
        v1 = 0.0
        v2 = 0.0
        for b in range(nb):
            v0 += body_mass[b] * body_vel[w, b, 0]
            v1 += body_mass[b] * body_vel[w, b, 1]
            v2 += body_mass[b] * body_vel[w, b, 2]
        com_vel[w, 0], com_vel[w, 1], com_vel[w, 2] = v0 / total, v1 / total, v2 / total
        c = math.cos(target_heading[w])
        s = math.sin(target_heading[w])
        # d: the commanded direction, h: the horizontal velocity, in the ground's two axes
        if up == 1:              # heading theta turns x towards -z about y
            d0, d1, h0, h1 = c, -s, com_vel[w, 0], com_vel[w, 2]
        else:
            d0, d1, h0, h1 = c, s, com_vel[w, 0], com_vel[w, 1]
        if mode == 1:
            short = max(0.0, target_speed[w] - (d0 * h0 + d1 * h1))
            reward[w] = math.exp(-scale * short * short)
        elif mode == 2:
            miss = target_speed[w] - (d0 * h0 + d1 * h1)
            reward[w] = math.exp(-scale * miss * miss)
        else:
            e0 = h0 - target_speed[w] * d0
            e1 = h1 - target_speed[w] * d1
            reward[w] = math.exp(-scale * (e0 * e0 + e1 * e1))
