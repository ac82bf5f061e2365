"""ODE peer benchmark (ODE 0.x as shipped in panda3d.ode): the scenes of bench/scenes.py.

    pip install panda3d
    python bench/peers/bench_ode.py SCENE [--variant default|step] [--budget S]

Variants (the step function is the only difference):

* ``default``: ``world.quickStep(dt)`` with ODE's default 20 iterations (SOR w = 1.3), the
  iterative solver games and character controllers run ODE with;
* ``step``: ``world.step(dt)``, ODE's exact ``dWorldStep`` (a dense Dantzig LCP per island,
  cubic in the rows of an island; far too slow for the pyramid and the spheres, where every
  body ends up in one island of thousands of contact rows).

Settings, stated once: gravity (0, 0, scenes.GRAVITY); world ERP 0.2 and CFM 1e-5 (ODE's
defaults for its single-precision build, which is what panda3d ships: every number passes
through 32-bit floats); no damping, auto-disable off. Bodies are placed at their centre of
mass (ODE requires it) with the mass and the diagonal inertia of bench/scenes.py set
explicitly, never derived from the geoms.

Contacts are ODE's usual loop, done in C++ by panda3d's ``OdeSpace.autoCollide``: every
step the space is collided (``dSpaceCollide``, up to 16 contacts per geom pair), one contact
joint is created per contact point in a joint group, the world is stepped, and the group is
emptied. The contact surface is one entry of panda3d's surface table: mu = scenes.FRICTION
(Coulomb friction pyramid, ``dContactApprox1``), bounce 0, soft CFM 1e-3 (the GAMES-105
course's contact softness, see peers/ode_games105.py). panda3d's autoCollide always uses the
mode ``dContactBounce | dContactSoftCFM | dContactApprox1`` and never passes a soft ERP, so
contacts are corrected with the world ERP 0.2. Static geoms (ground, walls) and moving geoms
carry category/collide bits so that static-static pairs are never tested; the ragdoll uses
the bit masks of ``scenes.ragdoll_collision_masks``. Small scenes use a simple space (all
pairs), the pyramid and the spheres ODE's multi-resolution hash space.

The chain has no geoms (contacts are off in that scene, as in the other engines). The PD
ragdolls apply explicit PD torques computed in NumPy before every step, as the MuJoCo and
PyBullet runners do: a ball joint gets ``R_c (-kp rotvec(q_p^-1 q_c) - kd R_c^T (w_c - w_p))``
(MuJoCo's ball-joint coordinates: the relative rotation, and the relative angular velocity
in the child frame), a hinge ``(-kp theta - kd theta_dot) a`` about its world axis ``a``;
+torque on the child, -torque on the parent. Prints one ``RESULT {json}`` line (see
bench/common.py).
"""
import math
import sys
import time
from pathlib import Path

import numpy as np
from panda3d.core import BitMask32, Vec4
from panda3d.ode import (OdeBallJoint, OdeBody, OdeBoxGeom, OdeCappedCylinderGeom, OdeHashSpace,
                         OdeHingeJoint, OdeJointGroup, OdeMass, OdePlaneGeom, OdeSimpleSpace,
                         OdeSphereGeom, OdeUtil, OdeWorld)

if __package__ in (None, ""):          # run as a script: make `bench` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from bench import common as C  # noqa: E402
from bench import scenes as S  # noqa: E402

VARIANTS = ["default", "step"]
QUICK_ITERATIONS = 20       # ODE's default for dWorldQuickStep
WORLD_ERP = 0.2             # ODE's default
WORLD_CFM = 1e-5            # ODE's default (single precision)
CONTACT_CFM = 1e-3          # the GAMES-105 course's contact softness
MAX_CONTACTS = 16           # per geom pair, what panda3d's autoCollide asks dCollide for
# PD torque (N m) beyond which the explicit PD has diverged (stable runs stay below 1e4)
TORQUE_DIVERGED = 1e8
# category bits: static geoms never test against each other, moving ones against everything
STATIC_BIT, MOVING_BIT = 1, 2


# ------------------------------------------------------------------ building blocks ---

class OdeScene:
    """An ODE world with its collision space and contact joint group.

    world : OdeWorld; space : OdeSpace or None (no contacts); contacts : OdeJointGroup;
    bodies : list of OdeBody (frames at the centres of mass); geoms : moving geoms;
    static : static geoms; joints : list of OdeJoint. Keeps every panda3d object alive.
    """

    def __init__(self, hashed=False, contacts=True):
        self.world = OdeWorld()
        self.world.setGravity(0.0, 0.0, S.GRAVITY)
        self.world.setErp(WORLD_ERP)
        self.world.setCfm(WORLD_CFM)
        self.world.setQuickStepNumIterations(QUICK_ITERATIONS)
        # surface 0: mu, bounce, bounce_vel, soft_erp (ignored by autoCollide), soft_cfm,
        # slip, dampen
        self.world.initSurfaceTable(1)
        self.world.setSurfaceEntry(0, 0, S.FRICTION, 0.0, 0.0, 0.0, CONTACT_CFM, 0.0, 0.0)
        self.space = None
        self.contacts = OdeJointGroup()
        if contacts:
            self.space = OdeHashSpace() if hashed else OdeSimpleSpace()
            self.space.setAutoCollideWorld(self.world)
            self.space.setAutoCollideJointGroup(self.contacts)
        self.bodies, self.geoms, self.static, self.joints = [], [], [], []

    def add_body(self, com, mass, inertia):
        """A body at world point com (m), identity orientation, at rest; mass (kg) and the
        diagonal inertia (kg m^2, about the COM, body frame) set explicitly."""
        b = OdeBody(self.world)
        m = OdeMass()
        m.setParameters(float(mass), 0.0, 0.0, 0.0, *[float(x) for x in inertia], 0.0, 0.0, 0.0)
        b.setMass(m)
        b.setPosition(*[float(x) for x in com])
        self.bodies.append(b)
        return b

    def attach(self, geom, body, cat=MOVING_BIT, col=STATIC_BIT | MOVING_BIT):
        """Give a geom to a body (None: static) with its category/collide bits."""
        if body is not None:
            geom.setBody(body)
            self.geoms.append(geom)
        else:
            self.static.append(geom)
        geom.setCategoryBits(BitMask32(cat))
        geom.setCollideBits(BitMask32(col))
        return geom

    def ground(self, cat=STATIC_BIT, col=MOVING_BIT):
        """The plane z = 0, normal +z."""
        return self.attach(OdePlaneGeom(self.space, Vec4(0, 0, 1, 0)), None, cat, col)

    def stepper(self, dt, variant):
        """One step: collide the space into contact joints, step, empty the contact group."""
        world, space, group = self.world, self.space, self.contacts
        step = world.quickStep if variant == "default" else world.step
        if space is None:
            return lambda: step(dt)

        def step_once():
            space.autoCollide()
            step(dt)
            group.empty()
        return step_once

    # ---- state, as NumPy arrays ----

    def positions(self):
        """(n, 3) COM positions (m, world)."""
        return np.array([tuple(b.getPosition()) for b in self.bodies], float)

    def quats(self):
        """(n, 4) orientations, (w, x, y, z) as ODE stores them."""
        n = len(self.bodies)
        return np.fromiter((x for b in self.bodies for x in b.getQuaternion()), float,
                           4 * n).reshape(n, 4)

    def rotations(self):
        """(n, 3, 3) body-to-world rotation matrices."""
        return np.array([S.quat_to_mat_wxyz(q) for q in self.quats()])

    def velocities(self):
        """(n, 3) linear velocities of the COMs and (n, 3) angular velocities (world)."""
        v = np.array([tuple(b.getLinearVel()) for b in self.bodies], float)
        w = np.array([tuple(b.getAngularVel()) for b in self.bodies], float)
        return v, w

    def contact_depths(self):
        """Penetration depths (m) of every contact the space generates in the current state
        (the same dCollide calls as autoCollide, done from Python outside the timed loop)."""
        if self.space is None:
            return np.zeros(0)
        depths = []

        def near(_arg, g1, g2):
            e = OdeUtil.collide(g1, g2, MAX_CONTACTS)
            depths.extend(e.getContactGeom(i).getDepth() for i in range(e.getNumContacts()))
        self.space.collide(None, near)
        return np.array(depths, float)

    def penetration(self):
        """(deepest penetration in m, number of contacts) of the current state."""
        d = self.contact_depths()
        return (float(max(0.0, d.max())) if d.size else 0.0), int(d.size)


def _solver_info(variant):
    if variant == "default":
        return dict(solver="quickStep (SOR-LCP)", iterations=QUICK_ITERATIONS, sor_w=1.3,
                    erp=WORLD_ERP, cfm=WORLD_CFM, contact_soft_cfm=CONTACT_CFM)
    return dict(solver="step (dWorldStep, Dantzig LCP)", erp=WORLD_ERP, cfm=WORLD_CFM,
                contact_soft_cfm=CONTACT_CFM)


def _finite(scene):
    return bool(np.all(np.isfinite(scene.positions())) and np.all(np.isfinite(scene.quats())))


# ----------------------------------------------------------------- chain ---

def build_chain():
    """The chain: 30 bodies on ball joints, joint 0 to the world. No geoms (no contacts)."""
    c = S.CHAIN
    sc = OdeScene(contacts=False)
    prev = None
    for ln in S.chain_links():
        b = sc.add_body(ln["com"], ln["mass"], ln["inertia"])
        j = OdeBallJoint(sc.world)
        j.attach(b, prev)                       # prev None: the world
        j.setAnchor(*ln["joint"])
        sc.joints.append(j)
        prev = b
    sc.link_offset = np.array([c["length"], 0.0, 0.0])
    return sc


def chain_separation(sc):
    """Largest joint separation (m) of the chain, by the shared formula: each link's joint
    point is its COM minus R (L/2, 0, 0)."""
    half = 0.5 * sc.link_offset
    rots = sc.rotations()
    origins = sc.positions() - np.einsum("nij,j->ni", rots, half)
    return C.chain_separation(origins, rots, S.chain_links()[0]["joint"], sc.link_offset)


def chain_energy(sc):
    links = S.chain_links()
    v, w = sc.velocities()
    return S.rigid_energy([ln["mass"] for ln in links], [ln["inertia"] for ln in links],
                          sc.positions(), sc.rotations(), v, w)


def run_chain(args):
    c = S.CHAIN
    sc = build_chain()
    e0 = chain_energy(sc)
    scale = S.chain_energy_scale()
    state = dict(worst_de=0.0, diverged_at=None)
    step_once = sc.stepper(c["dt"], args.variant)

    def advance(n):
        if state["diverged_at"] is not None:
            return 0
        for _ in range(n):
            step_once()
        return n

    def checkpoint(done):
        """Energy every simulated second, outside the timed region; a non-finite state ends
        the run."""
        e = chain_energy(sc)
        if not math.isfinite(e) or not _finite(sc):
            state["diverged_at"] = done * c["dt"]
            return
        state["worst_de"] = max(state["worst_de"], abs(e - e0) / scale)

    steps = c["steps"]
    done, loop = C.run_loop(advance, steps, args.budget, chunk=240, after_chunk=checkpoint,
                            ramp=False)
    e1 = chain_energy(sc)
    at = state["diverged_at"]
    return S.summary_common("ode", "chain", args.variant, c["dt"], done, steps, loop, dict(
        joint_sep_mm=chain_separation(sc) * 1000.0, energy_J=[e0, e1],
        rel_energy_change=None if at is not None else (e1 - e0) / scale,
        max_abs_rel_energy_change_1s_checkpoints=state["worst_de"], diverged_at_s=at,
        finite=_finite(sc), coordinates="maximal (joints as constraints)",
        **_solver_info(args.variant)))


# ------------------------------------------------------- stack / pyramid ---

def build_boxes(positions, half, mass, hashed=False):
    """Free cubes of half side ``half`` (m) at the given COM positions on the ground."""
    sc = OdeScene(hashed=hashed)
    sc.ground()
    inert = S.box_inertia(mass, half, half, half)
    for p in positions:
        b = sc.add_body(p, mass, inert)
        sc.attach(OdeBoxGeom(sc.space, 2 * half, 2 * half, 2 * half), b)
    return sc


def _run_free(args, sc, dt, steps):
    step_once = sc.stepper(dt, args.variant)
    done, loop = C.run_loop(C.stepper(step_once), steps, args.budget)
    pen, ncon = sc.penetration()
    return sc.positions(), done, loop, pen, ncon


def run_stack(args):
    cfg = S.STACK
    p0 = np.array(S.stack_positions())
    sc = build_boxes(p0, cfg["half"], cfg["mass"])
    p1, done, loop, pen, ncon = _run_free(args, sc, cfg["dt"], cfg["steps"])
    return S.summary_common("ode", "stack", args.variant, cfg["dt"], done, cfg["steps"], loop,
                            dict(**C.stack_figures(p0, p1), max_penetration_m=pen, ncon=ncon,
                                 finite=_finite(sc), **_solver_info(args.variant)))


def run_pyramid(args):
    cfg = S.PYRAMID
    p0 = np.array(S.pyramid_positions())
    sc = build_boxes(p0, cfg["half"], cfg["mass"], hashed=True)
    p1, done, loop, pen, ncon = _run_free(args, sc, cfg["dt"], cfg["steps"])
    return S.summary_common("ode", "pyramid", args.variant, cfg["dt"], done, cfg["steps"], loop,
                            dict(**C.pyramid_figures(p0, p1), max_penetration_m=pen, ncon=ncon,
                                 finite=_finite(sc), **_solver_info(args.variant)))


# --------------------------------------------------------------- spheres ---

def build_spheres():
    cfg = S.SPHERES
    sc = OdeScene(hashed=True)
    sc.ground()
    for c, h in S.sphere_walls():
        g = OdeBoxGeom(sc.space, *[2.0 * x for x in h])
        g.setPosition(*c)
        sc.attach(g, None, STATIC_BIT, MOVING_BIT)
    r = cfg["radius"]
    inert = S.sphere_inertia(cfg["mass"], r)
    for p in S.sphere_positions():
        b = sc.add_body(p, cfg["mass"], inert)
        sc.attach(OdeSphereGeom(sc.space, r), b)
    return sc


def run_spheres(args):
    cfg = S.SPHERES
    sc = build_spheres()
    p1, done, loop, pen, ncon = _run_free(args, sc, cfg["dt"], cfg["steps"])
    return S.summary_common("ode", "spheres", args.variant, cfg["dt"], done, cfg["steps"], loop,
                            dict(max_penetration_m=pen, ncon=ncon,
                                 **C.spheres_figures(p1, cfg["inner"]), finite=_finite(sc),
                                 **_solver_info(args.variant)))


# --------------------------------------------------------------- ragdoll ---

def build_ragdoll(parts):
    """The 15-body ragdoll: bodies at their COMs, capsules (axis z) and boxes centred on them,
    ball joints and hinges at the joint points (child attached first), bit masks of
    scenes.ragdoll_collision_masks (no contacts between a parent and its child)."""
    masks, (gcat, gcol) = S.ragdoll_collision_masks(parts)
    sc = OdeScene()
    sc.ground(gcat, gcol)
    by_name = {}
    for i, p in enumerate(parts):
        b = sc.add_body(p["com"], p["mass"], p["inertia"])
        if p["shape"] == "box":
            g = OdeBoxGeom(sc.space, *[2.0 * x for x in p["half"]])
        else:
            g = OdeCappedCylinderGeom(sc.space, p["radius"], p["length"])
        sc.attach(g, b, *masks[i])
        if p["parent"] is not None:
            if p["jtype"] == "ball":
                j = OdeBallJoint(sc.world)
            else:
                j = OdeHingeJoint(sc.world)
            j.attach(b, by_name[p["parent"]])
            j.setAnchor(*p["joint"])
            if p["jtype"] == "hinge":
                j.setAxis(*p["axis"])
            sc.joints.append(j)
        by_name[p["name"]] = b
    return sc


def _cross(a, b):
    """Row-wise cross product of (n, 3) arrays (np.cross costs ~30 us a call on 14 rows)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


def _quat_conj_mul(a, b):
    """conj(a) * b for (n, 4) (w, x, y, z) quaternions: b's rotation relative to a."""
    aw, av = a[:, 0], -a[:, 1:]
    bw, bv = b[:, 0], b[:, 1:]
    w = aw * bw - (av * bv).sum(1)
    v = aw[:, None] * bv + bw[:, None] * av + _cross(av, bv)
    return np.concatenate([w[:, None], v], axis=1)


def _quat_rotate(q, v):
    """Rotate vectors v (n, 3) by unit quaternions q (n, 4, (w, x, y, z)):
    v + 2 u x (u x v + w v) with u the vector part."""
    w, u = q[:, :1], q[:, 1:]
    return v + 2.0 * _cross(u, _cross(u, v) + w * v)


class RagdollPD:
    """Explicit PD towards the initial pose (identity relative rotations), computed in
    NumPy from the body states and applied with OdeBody.addTorque before a step.

    parts : scenes.ragdoll_parts(); gains : {part name: (kp, kd)} (scenes.ragdoll_pd_gains).
    """

    def __init__(self, sc, parts, gains):
        idx = {p["name"]: i for i, p in enumerate(parts)}
        self.sc = sc
        kids = [i for i, p in enumerate(parts) if p["parent"] is not None]
        self.child = np.array(kids)
        self.parent = np.array([idx[parts[i]["parent"]] for i in kids])
        self.hinge = np.array([parts[i]["jtype"] == "hinge" for i in kids])
        self.axis = np.array([parts[i]["axis"] if parts[i]["axis"] else (0.0, 0.0, 0.0)
                              for i in kids], float)      # parent frame (= child frame at rest)
        self.kp = np.array([gains[parts[i]["name"]][0] for i in kids])
        self.kd = np.array([gains[parts[i]["name"]][1] for i in kids])

    def errors(self, q=None):
        """(ball rotation vectors (nb, 3), hinge angles (nh,)) in rad, from the body states."""
        q = self.sc.quats() if q is None else q
        rv = S.rotvec_from_quats_wxyz(_quat_conj_mul(q[self.parent], q[self.child]))
        return rv[~self.hinge], (rv[self.hinge] * self.axis[self.hinge]).sum(1)

    def torques(self):
        """(n joints, 3) world-frame torques (N m) on the children."""
        q = self.sc.quats()
        n = len(self.sc.bodies)
        w = np.fromiter((x for b in self.sc.bodies for x in b.getAngularVel()), float,
                        3 * n).reshape(n, 3)
        rv = S.rotvec_from_quats_wxyz(_quat_conj_mul(q[self.parent], q[self.child]))
        wrel = w[self.child] - w[self.parent]                            # world
        # The rotation vector has the same coordinates in the parent and the child frame, so
        # R_c turns it (and each hinge axis) into world coordinates with one rotation.
        h = self.hinge
        q2 = np.concatenate([q[self.child], q[self.child][h]])
        turned = _quat_rotate(q2, np.concatenate([rv, self.axis[h]]))
        nj = len(rv)
        # ball: R_c (-kp rv - kd R_c^T wrel) = -kp R_c rv - kd wrel
        tau = -self.kp[:, None] * turned[:nj] - self.kd[:, None] * wrel
        # hinge: about the world axis a, angle = rotation vector along the axis
        a = turned[nj:]
        th = (rv[h] * self.axis[h]).sum(1)
        thd = (wrel[h] * a).sum(1)
        tau[h] = (-self.kp[h] * th - self.kd[h] * thd)[:, None] * a
        return tau

    def apply(self):
        """Compute and apply the torques; False (nothing applied) once they exceed
        TORQUE_DIVERGED, i.e. the explicit PD has diverged: ODE aborts the process on the
        non-finite state that would follow a few steps later."""
        tau = self.torques()
        if not np.abs(tau).max() < TORQUE_DIVERGED:
            return False
        b = self.sc.bodies
        for k, (c, p) in enumerate(zip(self.child, self.parent)):
            t = tau[k]
            b[c].addTorque(t[0], t[1], t[2])
            b[p].addTorque(-t[0], -t[1], -t[2])
        return True


def run_ragdoll(args):
    hz, pd = C.ragdoll_mode(args.scene)
    dt = 1.0 / hz
    parts = S.ragdoll_parts()
    sc = build_ragdoll(parts)
    ctl = RagdollPD(sc, parts, S.ragdoll_pd_gains(parts, pd or "spec"))
    step_world = sc.stepper(dt, args.variant)
    pelvis = sc.bodies[0]
    state = dict(ctrl=0.0, diverged=False)

    def advance(n):
        for k in range(n):
            if state["diverged"]:
                return k
            if pd:
                c0 = time.perf_counter()
                ok = ctl.apply()
                state["ctrl"] += time.perf_counter() - c0
                if not ok:
                    state["diverged"] = True
                    return k
            step_world()
        return n

    def check(_done):
        """Outside the timed region: a NaN or a pelvis beyond 100 m ends the run."""
        z = pelvis.getPosition()[2]
        if not (math.isfinite(z) and abs(z) < 100.0) or not _finite(sc):
            state["diverged"] = True

    steps = int(round(S.RAGDOLL["duration"] * hz))
    done, loop = C.run_loop(advance, steps, args.budget, after_chunk=check)
    ball, hinge = ctl.errors()
    z = float(pelvis.getPosition()[2])
    finite = _finite(sc)
    return S.summary_common("ode", args.scene, args.variant, dt, done, steps, loop, dict(
        pd=pd, diverged=bool(state["diverged"]),
        ctrl_ms_per_step=1000.0 * state["ctrl"] / max(done, 1),
        pelvis_z_end=z, max_joint_err_rad_end=C.joint_error(ball, hinge), finite=finite,
        nbody=len(parts), coordinates="maximal (joints as constraints)",
        **_solver_info(args.variant)))


def _pkg_version():
    try:
        from importlib.metadata import version
        return "panda3d %s" % version("panda3d")
    except Exception:
        return "panda3d ?"


def main():
    args = C.parse("ode", VARIANTS)
    fn = {"chain": run_chain, "stack": run_stack, "pyramid": run_pyramid,
          "spheres": run_spheres}.get(args.scene, run_ragdoll)
    res = fn(args)
    res["version"] = _pkg_version()
    C.emit(res)


if __name__ == "__main__":
    main()
