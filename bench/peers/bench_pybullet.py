"""PyBullet peer benchmark (p.DIRECT): the scenes of bench/scenes.py.

    python bench/peers/bench_pybullet.py SCENE [--variant default|maximal|motors_on] [--budget S]

Solver settings are PyBullet's defaults (recorded in the output: numSolverIterations=50, no
sub-steps); only the time step and gravity are set. Articulations (chain, ragdoll) are
Featherstone multibodies built with createMultiBody, which is what loadURDF produces. Free
bodies (stack, pyramid, spheres) are built with createMultiBody too: variant 'default' keeps
PyBullet's default (a one-link btMultiBody per body), variant 'maximal' passes
useMaximalCoordinates=True (plain btRigidBody, the classic Bullet path).

The default joint motors that PyBullet puts on every revolute and spherical joint (they act
as a velocity brake) are switched off with force 0, so the joints are free; chain variant
'motors_on' keeps them to show their effect.

Bullet multiplies the friction coefficients of the two bodies in contact, so every body gets
lateralFriction = sqrt(0.9) and every pair sees 0.9. Bullet's default per-body linear and
angular damping is switched off, so that the scenes match the other engines (no damping
anywhere). Prints one ``RESULT {json}`` line (see bench/common.py).
"""
import math
import sys
import time
from pathlib import Path

import numpy as np
import pybullet as p

if __package__ in (None, ""):          # run as a script: make `bench` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from bench import common as C  # noqa: E402
from bench import scenes as S  # noqa: E402

MU = math.sqrt(S.FRICTION)
# (x, y, z, w): a quarter turn about y, taking the capsule axis (local z) onto world x
ROT_Z_TO_X = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))


def _world(dt):
    p.connect(p.DIRECT)
    p.setGravity(0, 0, S.GRAVITY)
    p.setPhysicsEngineParameter(fixedTimeStep=dt)
    p.setTimeStep(dt)


def _solver_info():
    prm = p.getPhysicsEngineParameters()
    return dict(solver="sequential impulse (btMultiBodyConstraintSolver)",
                iterations=int(prm["numSolverIterations"]), numSubSteps=int(prm["numSubSteps"]))


def _rot(q):
    return np.array(p.getMatrixFromQuaternion(q)).reshape(3, 3)


def _dyn(body, link, inertia=None, maximal=False):
    kw = dict(lateralFriction=MU, restitution=0.0, linearDamping=0.0, angularDamping=0.0)
    if inertia is not None and not maximal:
        kw["localInertiaDiagonal"] = list(inertia)
    p.changeDynamics(body, link, **kw)
    if inertia is not None and maximal:
        # changeDynamics(localInertiaDiagonal=...) on a useMaximalCoordinates body
        # turns its state into NaN on the next step (pybullet 3.2.7), so the
        # inertia Bullet derived from the shape is kept; check it is the same.
        got = p.getDynamicsInfo(body, link)[2]
        assert max(abs(a - b) for a, b in zip(got, inertia)) < 1e-9, (got, inertia)


def _ground():
    plane = p.createCollisionShape(p.GEOM_PLANE)
    g = p.createMultiBody(0, plane, -1, [0, 0, 0])
    _dyn(g, -1)
    return g


def _max_penetration():
    """Deepest penetration (m) among the current contact points, and their number."""
    cps = p.getContactPoints()
    if not cps:
        return 0.0, 0
    return float(max(0.0, -min(c[8] for c in cps))), len(cps)


def _disable_default_motors(body):
    for j in range(p.getNumJoints(body)):
        jt = p.getJointInfo(body, j)[2]
        if jt in (p.JOINT_REVOLUTE, p.JOINT_PRISMATIC):
            p.setJointMotorControl2(body, j, p.VELOCITY_CONTROL, targetVelocity=0, force=0)
        elif jt == p.JOINT_SPHERICAL:
            p.setJointMotorControlMultiDof(body, j, p.POSITION_CONTROL, targetPosition=[0, 0, 0, 1],
                                           targetVelocity=[0, 0, 0], positionGain=0, velocityGain=0,
                                           force=[0, 0, 0])


# ----------------------------------------------------------------- chain ---

def run_chain(args):
    c = S.CHAIN
    links = S.chain_links()
    L = c["length"]
    n = len(links)
    _world(c["dt"])
    cap = p.createCollisionShape(p.GEOM_CAPSULE, radius=c["radius"], height=L,
                                 collisionFramePosition=[L / 2, 0, 0],
                                 collisionFrameOrientation=ROT_Z_TO_X)
    body = p.createMultiBody(
        baseMass=0, baseCollisionShapeIndex=-1, baseVisualShapeIndex=-1,
        basePosition=list(links[0]["joint"]),
        linkMasses=[ln["mass"] for ln in links], linkCollisionShapeIndices=[cap] * n,
        linkVisualShapeIndices=[-1] * n,
        linkPositions=[[0, 0, 0]] + [[L, 0, 0]] * (n - 1), linkOrientations=[[0, 0, 0, 1]] * n,
        linkInertialFramePositions=[[L / 2, 0, 0]] * n,
        linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
        linkParentIndices=list(range(n)), linkJointTypes=[p.JOINT_SPHERICAL] * n,
        linkJointAxis=[[0, 0, 1]] * n)
    for i, ln in enumerate(links):
        _dyn(body, i, ln["inertia"])
    _dyn(body, -1)
    if args.variant != "motors_on":
        _disable_default_motors(body)
    masses = [ln["mass"] for ln in links]
    inert = [ln["inertia"] for ln in links]
    idx = list(range(n))

    def energy():
        st = p.getLinkStates(body, idx, computeLinkVelocity=1, computeForwardKinematics=1)
        return S.rigid_energy(masses, inert, [s[0] for s in st], [_rot(s[1]) for s in st],
                              [s[6] for s in st], [s[7] for s in st])

    e0 = energy()
    scale = S.chain_energy_scale()
    worst = dict(de=0.0)

    def checkpoint(done):
        """Energy every simulated second, outside the timed region."""
        worst["de"] = max(worst["de"], abs(energy() - e0) / scale)

    steps = c["steps"]
    done, loop = C.run_loop(C.stepper(p.stepSimulation), steps, args.budget, chunk=240,
                            after_chunk=checkpoint, ramp=False)
    e1 = energy()
    st = p.getLinkStates(body, idx, computeForwardKinematics=1)
    # link frames (indices 4, 5) sit at the joint points
    sep = C.chain_separation([s[4] for s in st], [_rot(s[5]) for s in st], links[0]["joint"],
                             (L, 0, 0))
    finite = bool(np.all(np.isfinite([x for s in st for x in s[0]])))
    return S.summary_common("pybullet", "chain", args.variant, c["dt"], done, steps, loop, dict(
        joint_sep_mm=sep * 1000.0, energy_J=[e0, e1], rel_energy_change=(e1 - e0) / scale,
        max_abs_rel_energy_change_1s_checkpoints=worst["de"], finite=finite,
        coordinates="reduced (btMultiBody)", **_solver_info()))


# ----------------------------------------------- free bodies: stack, pyramid, spheres ---

def _free_bodies(args, shape, mass, inertia, positions, steps):
    """Create one free body per position, step (timed); return (final positions, steps done,
    loop s, penetration, contact count)."""
    maximal = args.variant == "maximal"
    ids = []
    for pos in positions:
        b = p.createMultiBody(mass, shape, -1, list(pos), useMaximalCoordinates=maximal)
        _dyn(b, -1, inertia, maximal)
        ids.append(b)
    done, loop = C.run_loop(C.stepper(p.stepSimulation), steps, args.budget)
    pen, ncon = _max_penetration()
    p1 = np.array([p.getBasePositionAndOrientation(b)[0] for b in ids])
    return p1, done, loop, pen, ncon


def _boxes(args, cfg, positions):
    _world(cfg["dt"])
    _ground()
    h = cfg["half"]
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, h])
    inert = S.box_inertia(cfg["mass"], h, h, h)
    p1, done, loop, pen, ncon = _free_bodies(args, shape, cfg["mass"], inert, positions,
                                             cfg["steps"])
    return np.array(positions), p1, done, cfg["steps"], loop, pen, ncon


def run_stack(args):
    cfg = S.STACK
    p0, p1, done, steps, loop, pen, ncon = _boxes(args, cfg, S.stack_positions())
    return S.summary_common("pybullet", "stack", args.variant, cfg["dt"], done, steps, loop, dict(
        **C.stack_figures(p0, p1), max_penetration_m=pen, ncon=ncon, **_solver_info()))


def run_pyramid(args):
    cfg = S.PYRAMID
    p0, p1, done, steps, loop, pen, ncon = _boxes(args, cfg, S.pyramid_positions())
    return S.summary_common("pybullet", "pyramid", args.variant, cfg["dt"], done, steps, loop, dict(
        **C.pyramid_figures(p0, p1), max_penetration_m=pen, ncon=ncon, **_solver_info()))


def run_spheres(args):
    cfg = S.SPHERES
    _world(cfg["dt"])
    _ground()
    for c, h in S.sphere_walls():
        wall = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(h))
        w = p.createMultiBody(0, wall, -1, list(c))
        _dyn(w, -1)
    r = cfg["radius"]
    shape = p.createCollisionShape(p.GEOM_SPHERE, radius=r)
    inert = S.sphere_inertia(cfg["mass"], r)
    steps = cfg["steps"]
    p1, done, loop, pen, ncon = _free_bodies(args, shape, cfg["mass"], inert,
                                             S.sphere_positions(), steps)
    return S.summary_common("pybullet", "spheres", args.variant, cfg["dt"], done, steps, loop, dict(
        max_penetration_m=pen, ncon=ncon, **C.spheres_figures(p1, cfg["inner"]), **_solver_info()))


# --------------------------------------------------------------- ragdoll ---

def _ragdoll(parts):
    masks, (gcat, gcol) = S.ragdoll_collision_masks(parts)
    idx = {q["name"]: i for i, q in enumerate(parts)}

    def shape(q, offset):
        if q["shape"] == "box":
            return p.createCollisionShape(p.GEOM_BOX, halfExtents=list(q["half"]),
                                          collisionFramePosition=list(offset))
        return p.createCollisionShape(p.GEOM_CAPSULE, radius=q["radius"], height=q["length"],
                                      collisionFramePosition=list(offset))

    root = parts[0]
    assert root["parent"] is None
    origin = {root["name"]: np.array(root["com"])}
    lm, lc, lp, li, lpi, ljt, lja = [], [], [], [], [], [], []
    for q in parts[1:]:
        o = np.array(q["joint"])
        origin[q["name"]] = o
        lm.append(q["mass"])
        lc.append(shape(q, np.array(q["com"]) - o))
        lp.append(list(o - origin[q["parent"]]))
        li.append(list(np.array(q["com"]) - o))
        # part k is multibody link k-1, so the parent's link index + 1 is its part index
        lpi.append(idx[q["parent"]])
        ljt.append(p.JOINT_SPHERICAL if q["jtype"] == "ball" else p.JOINT_REVOLUTE)
        lja.append(list(q["axis"]) if q["axis"] else [0, 0, 1])
    n = len(lm)
    body = p.createMultiBody(
        baseMass=root["mass"], baseCollisionShapeIndex=shape(root, (0, 0, 0)),
        baseVisualShapeIndex=-1,
        basePosition=list(root["com"]), baseInertialFramePosition=[0, 0, 0],
        linkMasses=lm, linkCollisionShapeIndices=lc, linkVisualShapeIndices=[-1] * n,
        linkPositions=lp, linkOrientations=[[0, 0, 0, 1]] * n,
        linkInertialFramePositions=li, linkInertialFrameOrientations=[[0, 0, 0, 1]] * n,
        linkParentIndices=lpi, linkJointTypes=ljt, linkJointAxis=lja,
        flags=p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT)
    # pybullet link index of part k is k-1 (the base is -1)
    for k, q in enumerate(parts):
        _dyn(body, k - 1, q["inertia"])
        p.setCollisionFilterGroupMask(body, k - 1, masks[k][0], masks[k][1])
    _disable_default_motors(body)
    return body, (gcat, gcol)


def _ball_rotvec(q):
    """Rotation vector (rad) of a PyBullet (x, y, z, w) quaternion, shortest rotation."""
    return S.rotvec_from_quats_wxyz([[q[3], q[0], q[1], q[2]]])[0]


def run_ragdoll(args):
    hz, pd = C.ragdoll_mode(args.scene)
    dt = 1.0 / hz
    parts = S.ragdoll_parts()
    _world(dt)
    g = _ground()
    body, (gcat, gcol) = _ragdoll(parts)
    p.setCollisionFilterGroupMask(g, -1, gcat, gcol)
    gains = S.ragdoll_pd_gains(parts, pd or "spec")
    joints = list(range(p.getNumJoints(body)))
    sph = [p.getJointInfo(body, j)[2] == p.JOINT_SPHERICAL for j in joints]
    kp = [gains[parts[j + 1]["name"]][0] for j in joints]
    kd = [gains[parts[j + 1]["name"]][1] for j in joints]
    ctrl = dict(s=0.0)

    def step_once():
        if pd:
            # Explicit PD towards the initial pose, computed in Python before every step
            # (scalar math: 14 joints are too few for NumPy to pay off).
            c0 = time.perf_counter()
            forces = []
            for j, (q, w, *_) in enumerate(p.getJointStatesMultiDof(body, joints)):
                if sph[j]:
                    x, y, z, qw = q
                    if qw < 0.0:
                        x, y, z, qw = -x, -y, -z, -qw
                    s = math.sqrt(x * x + y * y + z * z)
                    f = 2.0 * math.atan2(s, qw) / s if s > 1e-12 else 2.0
                    forces.append([-kp[j] * f * x - kd[j] * w[0],
                                   -kp[j] * f * y - kd[j] * w[1],
                                   -kp[j] * f * z - kd[j] * w[2]])
                else:
                    forces.append([-kp[j] * q[0] - kd[j] * w[0]])
            p.setJointMotorControlMultiDofArray(body, joints, p.TORQUE_CONTROL, forces=forces)
            ctrl["s"] += time.perf_counter() - c0
        p.stepSimulation()

    steps = int(round(S.RAGDOLL["duration"] * hz))
    done, loop = C.run_loop(C.stepper(step_once), steps, args.budget)
    pelvis = p.getBasePositionAndOrientation(body)[0]
    states = p.getJointStatesMultiDof(body, joints)
    jerr = C.joint_error([_ball_rotvec(st[0]) for j, st in enumerate(states) if sph[j]],
                         [st[0][0] for j, st in enumerate(states) if not sph[j]])
    finite = bool(np.all(np.isfinite(pelvis)))
    return S.summary_common("pybullet", args.scene, args.variant, dt, done, steps, loop, dict(
        pd=pd, ctrl_ms_per_step=1000.0 * ctrl["s"] / max(done, 1), pelvis_z_end=float(pelvis[2]),
        max_joint_err_rad_end=jerr, finite=finite,
        diverged=bool(not finite or abs(pelvis[2]) > 100),
        nbody=len(parts), coordinates="reduced (btMultiBody)", **_solver_info()))


def _pkg_version():
    try:
        from importlib.metadata import version
        return version("pybullet")
    except Exception:
        return "?"


def main():
    args = C.parse("pybullet", ["default", "maximal", "motors_on"])
    fn = {"chain": run_chain, "stack": run_stack, "pyramid": run_pyramid,
          "spheres": run_spheres}.get(args.scene, run_ragdoll)
    res = fn(args)
    res["version"] = "pybullet %s (API %d)" % (_pkg_version(), p.getAPIVersion())
    C.emit(res)


if __name__ == "__main__":
    main()
