"""MuJoCo peer benchmark: the scenes of bench/scenes.py built as MJCF strings.

    python bench/peers/bench_mujoco.py SCENE [--variant default|cg|pgs|implicit|rk4] [--budget S]

Solver settings are MuJoCo's defaults (recorded in the output): Newton solver, pyramidal
friction cones, Euler integrator, iterations=100, ls_iterations=50, soft contacts with the
default solref/solimp, margin 0. Variants change one option: 'cg' and 'pgs' the solver
(Newton is slow on the 1000-sphere scene, where CG is MuJoCo's best), 'implicit' and 'rk4'
the integrator. Prints one ``RESULT {json}`` line (see bench/common.py).
"""
import sys
import time
from pathlib import Path

import numpy as np
import mujoco

if __package__ in (None, ""):          # run as a script: make `bench` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from bench import common as C  # noqa: E402
from bench import scenes as S  # noqa: E402

FRIC = "%g 0.005 0.0001" % S.FRICTION   # sliding, torsional, rolling
VARIANTS = {"default": "", "cg": ' solver="CG"', "pgs": ' solver="PGS"',
            "implicit": ' integrator="implicit"', "rk4": ' integrator="RK4"'}
VARIANT = "default"


def _fmt(v):
    return " ".join("%.10g" % x for x in v)


def _inertial(pos, mass, inertia):
    return '<inertial pos="%s" mass="%.10g" diaginertia="%s"/>' % (_fmt(pos), mass, _fmt(inertia))


def _header(name, dt, memory=None, extra_flags=""):
    mem = '<size memory="%s"/>' % memory if memory else ""
    return ('<mujoco model="%s"><compiler angle="radian"/>%s'
            '<option timestep="%.12g" gravity="0 0 %g"%s>%s</option>'
            '<default><geom friction="%s"/></default>'
            % (name, mem, dt, S.GRAVITY, VARIANTS[VARIANT], extra_flags, FRIC))


def _solver_info(m):
    o = m.opt
    return dict(solver=["PGS", "CG", "Newton"][int(o.solver)],
                cone=["pyramidal", "elliptic"][int(o.cone)],
                integrator=["Euler", "RK4", "implicit", "implicitfast"][int(o.integrator)],
                iterations=int(o.iterations), ls_iterations=int(o.ls_iterations),
                tolerance=float(o.tolerance), jacobian=int(o.jacobian), nv=int(m.nv))


def _body_ids(m, names):
    return [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n) for n in names]


def _body_energy(m, d, body_ids, masses, inertias):
    """Energy (J) from CoM states, the same formula as the other engines."""
    pos = d.xipos[body_ids]
    rot = d.ximat[body_ids].reshape(-1, 3, 3)
    vel = np.zeros((len(body_ids), 6))
    for k, b in enumerate(body_ids):
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, vel[k], 0)
    return S.rigid_energy(masses, inertias, pos, rot, vel[:, 3:], vel[:, :3])


def _max_penetration(d):
    """Deepest penetration (m) among the contacts of the last step."""
    if d.ncon == 0:
        return 0.0
    return float(max(0.0, -np.min(d.contact.dist[:d.ncon])))


def _diverged(d):
    # MuJoCo does not stop on divergence: it warns (BADQACC) and resets the state.
    return d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0


# ----------------------------------------------------------------- chain ---

def chain_xml():
    """The chain scene as MJCF: nested bodies, each frame at its ball joint."""
    c = S.CHAIN
    links = S.chain_links()
    L = c["length"]
    xml = [_header("chain", c["dt"], extra_flags='<flag contact="disable"/>'), "<worldbody>"]
    for i, ln in enumerate(links):
        pos = ln["joint"] if i == 0 else (L, 0.0, 0.0)
        xml.append('<body name="l%d" pos="%s"><joint type="ball" pos="0 0 0"/>' % (i, _fmt(pos)))
        xml.append('<geom type="capsule" fromto="0 0 0 %g 0 0" size="%g"/>' % (L, c["radius"]))
        xml.append(_inertial((L / 2, 0, 0), ln["mass"], ln["inertia"]))
    xml.append("</body>" * len(links))
    xml.append("</worldbody></mujoco>")
    return "".join(xml)


def run_chain(args):
    c = S.CHAIN
    links = S.chain_links()
    L = c["length"]
    m = mujoco.MjModel.from_xml_string(chain_xml())
    d = mujoco.MjData(m)
    ids = _body_ids(m, ["l%d" % i for i in range(len(links))])
    masses = [ln["mass"] for ln in links]
    inert = [ln["inertia"] for ln in links]
    mujoco.mj_forward(m, d)
    e0 = _body_energy(m, d, ids, masses, inert)
    scale = S.chain_energy_scale()
    state = dict(worst_de=0.0, diverged_at=None)

    def checkpoint(done):
        """Energy every simulated second, outside the timed region."""
        if _diverged(d) and state["diverged_at"] is None:
            # MuJoCo reset the state to the initial one; d.time restarted at 0
            state["diverged_at"] = done * c["dt"] - d.time
        mujoco.mj_forward(m, d)
        if state["diverged_at"] is None:
            de = abs(_body_energy(m, d, ids, masses, inert) - e0) / scale
            state["worst_de"] = max(state["worst_de"], de)

    steps = c["steps"]
    done, loop = C.run_loop(C.stepper(lambda: mujoco.mj_step(m, d)), steps, args.budget,
                            chunk=240, after_chunk=checkpoint, ramp=False)
    mujoco.mj_forward(m, d)
    e1 = _body_energy(m, d, ids, masses, inert)
    # body frames sit at the joint points
    sep = C.chain_separation(d.xpos[ids], d.xmat[ids].reshape(-1, 3, 3), links[0]["joint"],
                             (L, 0, 0))
    diverged_at = state["diverged_at"]
    return S.summary_common("mujoco", "chain", args.variant, c["dt"], done, steps, loop, dict(
        joint_sep_mm=sep * 1000.0, energy_J=[e0, e1],
        rel_energy_change=None if diverged_at is not None else (e1 - e0) / scale,
        max_abs_rel_energy_change_1s_checkpoints=state["worst_de"],
        diverged_at_s=diverged_at,
        finite=bool(np.all(np.isfinite(d.qpos))), **_solver_info(m)))


# ------------------------------------------------------- stack / pyramid ---

def _boxes_xml(name, dt, positions, half, mass, memory=None):
    inert = S.box_inertia(mass, half, half, half)
    xml = [_header(name, dt, memory),
           '<worldbody><geom name="ground" type="plane" size="100 100 1"/>']
    for i, p in enumerate(positions):
        xml.append('<body name="b%d" pos="%s"><freejoint/>'
                   '<geom type="box" size="%g %g %g"/>%s</body>'
                   % (i, _fmt(p), half, half, half, _inertial((0, 0, 0), mass, inert)))
    xml.append("</worldbody></mujoco>")
    return "".join(xml)


def _run_free_bodies(args, xml, names, steps):
    """Build, step (timed) and return (model, data, final COM positions, steps done, loop s,
    penetration of the last step's contacts)."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    ids = _body_ids(m, names)
    done, loop = C.run_loop(C.stepper(lambda: mujoco.mj_step(m, d)), steps, args.budget)
    pen = _max_penetration(d)
    mujoco.mj_forward(m, d)
    return m, d, d.xpos[ids].copy(), done, loop, pen


def _run_boxes(args, scene, cfg, positions):
    xml = _boxes_xml(scene, cfg["dt"], positions, cfg["half"], cfg["mass"],
                     memory="256M" if len(positions) > 50 else None)
    m, d, p1, done, loop, pen = _run_free_bodies(
        args, xml, ["b%d" % i for i in range(len(positions))], cfg["steps"])
    return m, d, np.array(positions), p1, done, cfg["steps"], loop, pen


def run_stack(args):
    cfg = S.STACK
    m, d, p0, p1, done, steps, loop, pen = _run_boxes(args, "stack", cfg, S.stack_positions())
    return S.summary_common("mujoco", "stack", args.variant, cfg["dt"], done, steps, loop, dict(
        **C.stack_figures(p0, p1), max_penetration_m=pen, **_solver_info(m)))


def run_pyramid(args):
    cfg = S.PYRAMID
    m, d, p0, p1, done, steps, loop, pen = _run_boxes(args, "pyramid", cfg, S.pyramid_positions())
    return S.summary_common("mujoco", "pyramid", args.variant, cfg["dt"], done, steps, loop, dict(
        **C.pyramid_figures(p0, p1), max_penetration_m=pen, ncon=int(d.ncon), **_solver_info(m)))


# --------------------------------------------------------------- ragdoll ---

def _ragdoll_xml(parts, dt):
    """Nested MJCF bodies, each frame at its joint point (the pelvis frame at its COM)."""
    masks, (gcat, gcol) = S.ragdoll_collision_masks(parts)
    children = {}
    for i, p in enumerate(parts):
        children.setdefault(p["parent"], []).append(i)
    xml = [_header("ragdoll", dt),
           '<worldbody><geom name="ground" type="plane" size="100 100 1" '
           'contype="%d" conaffinity="%d"/>'
           % (gcat, gcol)]

    def frame_origin(p):
        return p["com"] if p["parent"] is None else p["joint"]

    def emit_body(i, parent_origin):
        p = parts[i]
        o = np.array(frame_origin(p))
        xml.append('<body name="%s" pos="%s">' % (p["name"], _fmt(o - parent_origin)))
        if p["jtype"] == "free":
            xml.append("<freejoint/>")
        elif p["jtype"] == "ball":
            xml.append('<joint name="j_%s" type="ball" pos="0 0 0"/>' % p["name"])
        else:
            xml.append('<joint name="j_%s" type="hinge" pos="0 0 0" axis="%s"/>'
                       % (p["name"], _fmt(p["axis"])))
        c = np.array(p["com"]) - o
        cat, col = masks[i]
        if p["shape"] == "box":
            xml.append('<geom type="box" pos="%s" size="%s" contype="%d" conaffinity="%d"/>'
                       % (_fmt(c), _fmt(p["half"]), cat, col))
        else:
            hl = p["length"] / 2
            xml.append('<geom type="capsule" fromto="%s %s" size="%g" '
                       'contype="%d" conaffinity="%d"/>'
                       % (_fmt(c - [0, 0, hl]), _fmt(c + [0, 0, hl]), p["radius"], cat, col))
        xml.append(_inertial(c, p["mass"], p["inertia"]))
        for k in children.get(p["name"], []):
            emit_body(k, o)
        xml.append("</body>")

    for i in children[None]:
        emit_body(i, np.zeros(3))
    xml.append("</worldbody></mujoco>")
    return "".join(xml)


def run_ragdoll(args):
    hz, pd = C.ragdoll_mode(args.scene)
    dt = 1.0 / hz
    parts = S.ragdoll_parts()
    m = mujoco.MjModel.from_xml_string(_ragdoll_xml(parts, dt))
    d = mujoco.MjData(m)
    gains = S.ragdoll_pd_gains(parts, pd or "spec")
    ball_q, ball_d, hinge_q, hinge_d = [], [], [], []
    kpb, kdb, kph, kdh = [], [], [], []
    for j in range(m.njnt):
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            continue
        qa, da = m.jnt_qposadr[j], m.jnt_dofadr[j]
        kp, kd = gains[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)[2:]]   # "j_<part>"
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            ball_q.append([qa, qa + 1, qa + 2, qa + 3])
            ball_d.append([da, da + 1, da + 2])
            kpb.append(kp)
            kdb.append(kd)
        elif m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            hinge_q.append(qa)
            hinge_d.append(da)
            kph.append(kp)
            kdh.append(kd)
    ball_q, ball_d = np.array(ball_q), np.array(ball_d)
    hinge_q, hinge_d = np.array(hinge_q), np.array(hinge_d)
    kpb, kdb = np.array(kpb)[:, None], np.array(kdb)[:, None]
    kph, kdh = np.array(kph), np.array(kdh)
    qfrc = np.zeros(m.nv)
    ctrl = dict(s=0.0)

    def step_once():
        if pd:
            # Explicit PD towards the initial pose (identity ball quaternions, zero hinge
            # angles), computed in NumPy before every step: the route a user of the Python
            # API takes. Its cost is part of the timed loop and also reported separately.
            c0 = time.perf_counter()
            err = S.rotvec_from_quats_wxyz(d.qpos[ball_q])
            qfrc[ball_d] = -kpb * err - kdb * d.qvel[ball_d]
            qfrc[hinge_d] = -kph * d.qpos[hinge_q] - kdh * d.qvel[hinge_d]
            d.qfrc_applied[:] = qfrc
            ctrl["s"] += time.perf_counter() - c0
        mujoco.mj_step(m, d)

    steps = int(round(S.RAGDOLL["duration"] * hz))
    done, loop = C.run_loop(C.stepper(step_once), steps, args.budget)
    mujoco.mj_forward(m, d)
    pelvis = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "pelvis")
    jerr = C.joint_error(S.rotvec_from_quats_wxyz(d.qpos[ball_q]), d.qpos[hinge_q])
    return S.summary_common("mujoco", args.scene, args.variant, dt, done, steps, loop, dict(
        pd=pd, diverged=bool(_diverged(d)), sim_time_end=float(d.time),
        ctrl_ms_per_step=1000.0 * ctrl["s"] / max(done, 1), pelvis_z_end=float(d.xpos[pelvis][2]),
        max_joint_err_rad_end=jerr, finite=bool(np.all(np.isfinite(d.qpos))),
        nbody=len(parts), **_solver_info(m)))


# --------------------------------------------------------------- spheres ---

def run_spheres(args):
    cfg = S.SPHERES
    pos = S.sphere_positions()
    r = cfg["radius"]
    inert = S.sphere_inertia(cfg["mass"], r)
    xml = [_header("spheres", cfg["dt"], memory="1G"),
           '<worldbody><geom type="plane" size="100 100 1"/>']
    for c, h in S.sphere_walls():
        xml.append('<geom type="box" pos="%s" size="%s"/>' % (_fmt(c), _fmt(h)))
    for i, p in enumerate(pos):
        xml.append('<body name="s%d" pos="%s"><freejoint/><geom type="sphere" size="%g"/>%s</body>'
                   % (i, _fmt(p), r, _inertial((0, 0, 0), cfg["mass"], inert)))
    xml.append("</worldbody></mujoco>")
    steps = cfg["steps"]
    m, d, p1, done, loop, pen = _run_free_bodies(
        args, "".join(xml), ["s%d" % i for i in range(len(pos))], steps)
    return S.summary_common("mujoco", "spheres", args.variant, cfg["dt"], done, steps, loop, dict(
        max_penetration_m=pen, ncon=int(d.ncon), **C.spheres_figures(p1, cfg["inner"]),
        **_solver_info(m)))


def main():
    global VARIANT
    args = C.parse("mujoco", list(VARIANTS))
    VARIANT = args.variant
    fn = {"chain": run_chain, "stack": run_stack, "pyramid": run_pyramid,
          "spheres": run_spheres}.get(args.scene, run_ragdoll)
    res = fn(args)
    res["version"] = mujoco.__version__
    C.emit(res)


if __name__ == "__main__":
    main()
