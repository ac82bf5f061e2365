"""Where a step's time goes: every pipeline stage timed inside one compiled loop.

    python bench/bench_stages.py                       # chain, ragdoll600, stack
    python bench/bench_stages.py chain --steps 500 --variant pgs

``profiled_steps`` below is ``tumble.pipeline.step.step_worlds`` for one world with a
monotonic clock read (``clock_gettime`` through ctypes, ~20 ns a read) between the
stages, so the normal step pays nothing for the profile. It must call the same stage
kernels in the same order as ``step_worlds``; ``tests/bench/test_bench_stages.py`` checks
that it ends in the bit-identical state. Inside the solve, the same state is also handed
to the solver's parts (dense assembly of ``J M^-1 J^T``, the sparse factorisation, the
mixed-LCP set-up and Lemke), each on copies of its inputs and timed alone, to split the
solve further; those extra calls are not part of the step total.

Prints a table per scene: microseconds per step of each stage (the least over
``--repeat`` runs, to see through a busy machine), its share of the profiled step, the
unprofiled ``world.step`` time (thread CPU time, least over the runs); plus the mean
number of rows (all, active) and contacts per step.
"""
import argparse
import ctypes
import ctypes.util
import json
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tumble  # noqa: E402
from tumble.pipeline import step as P  # noqa: E402
from tumble.pipeline.collide import (COLLIDE_OK, collide_listed, collide_world,  # noqa: E402
                                     listed_pairs, listed_primitives)
from tumble.pipeline.actuators import (PD_EXPLICIT, PD_IMPLICIT, PD_STABLE,  # noqa: E402
                                       actuator_forces, body_servo_rows, servoed_bodies,
                                       stable_servo_forces)
from tumble.pipeline.contacts.arrays import ContactArrays, make_contacts_nb  # noqa: E402
from tumble.pipeline.contacts.pairs import ROWS_SPIN, rows_per_contact  # noqa: E402
from tumble.pipeline.contacts.penalty import penalty_forces  # noqa: E402
from tumble.pipeline.contacts.rows import build_contact_rows, store_contact_impulses  # noqa: E402
from tumble.pipeline.forces import accumulate_forces  # noqa: E402
from tumble.pipeline.integrate import (first_bad_body, integrate_positions,  # noqa: E402
                                       integrate_velocities)
from tumble.pipeline.joints.rows import (build_joint_rows, joint_coordinates,  # noqa: E402
                                         joint_reactions)
from tumble.pipeline.joints.servo import JointDrive  # noqa: E402
from tumble.pipeline.solvers.common import (make_rows_nb, row_active,  # noqa: E402
                                            world_inverse_inertia)
from tumble.pipeline.solvers.direct import assemble  # noqa: E402
from tumble.pipeline.solvers.mlcp import make_fast_scratch  # noqa: E402
from tumble.pipeline.stabilize import project_joints, projection_setup  # noqa: E402

_libc = ctypes.CDLL(ctypes.util.find_library("c"))
_clock_gettime = _libc.clock_gettime
_clock_gettime.argtypes = [ctypes.c_int, ctypes.c_void_p]
_clock_gettime.restype = ctypes.c_int
_CLOCK_MONOTONIC = 1

STAGES = ["collide", "forces_and_actuators", "integrate_velocities", "joint_and_servo_rows",
          "contact_rows",
          "inverse_inertia", "solve", "reactions", "integrate_positions", "project_joints",
          "divergence_check", "joint_coordinates"]
# parts of the solve, timed separately on copies of the same inputs (not in the total)
PARTS = ["dense_assembly"]
# counters: sums over steps
COUNTS = ["rows", "active_rows", "joint_rows", "active_joint_rows", "contacts"]


@njit
def _now(buf):
    _clock_gettime(_CLOCK_MONOTONIC, buf.ctypes)
    return buf[0] * 1000000000 + buf[1]


@njit
def _dense_assembly(m, rows, nrow, inv_inertia, vel, angvel):
    """The dense ``J M^-1 J^T`` of the active rows, as the direct and Lemke solvers make it."""
    idx = np.empty(nrow, np.int64)
    n = 0
    for r in range(nrow):
        if row_active(rows, r):
            idx[n] = r
            n += 1
    dv = np.zeros((n, 12))
    A = np.zeros((n, n))
    b = np.zeros(n)
    assemble(rows, idx, n, m.body_inv_mass, inv_inertia, vel, angvel, dv, A, b)
    return n


@njit
def profiled_steps(m, s, con, pairs, n, o, t_stage, t_part, counts):
    """``step_worlds`` for world 0 of ``s``, with stage times (ns) added to ``t_stage``,
    part times to ``t_part`` and per-step counters to ``counts``. Returns (status, step)."""
    buf = np.zeros(2, np.int64)
    nb = s.body_pos.shape[1]
    ng = m.geom_type.shape[0]
    njrow = s.row_impulse.shape[1]
    cap = con.depth.shape[1]
    h = o.dt
    force = np.empty((nb, 3))
    torque = np.empty((nb, 3))
    inv_inertia = np.zeros((nb, 3, 3))
    servoed = servoed_bodies(s.body_servo)
    nfix = njrow + 6 * servoed.shape[0]
    nper = rows_per_contact(m)
    ncap = nfix + (nper * cap if o.contact != P.CONTACT_PENALTY else 0)
    rows = make_rows_nb(ncap)
    imp = np.zeros(ncap)
    gpos = np.zeros((ng, 3))
    gquat = np.zeros((ng, 4))
    aabb_lo = np.zeros((ng, 3))
    aabb_hi = np.zeros((ng, 3))
    prev = make_contacts_nb(cap)
    vel_pred = np.empty((nb, 3))
    angvel_pred = np.empty((nb, 3))
    projection = projection_setup(m, rows, nb, njrow > 0 and o.projection > 0)
    caches = P.make_solver_caches(m, servoed, nb)
    fast = make_fast_scratch(ncap, nb, caches[1])
    listed = listed_pairs(m, nb)
    all_primitive = listed_primitives(m, listed)
    has_servo = np.any(s.pd_kp > 0.0) or np.any(s.pd_kd > 0.0)
    has_drives = m.act_joint.shape[0] > 0 or np.any(s.joint_applied != 0.0) or (
        o.pd_mode == PD_EXPLICIT and has_servo)
    w = 0
    pos, quat = s.body_pos[w], s.body_quat[w]
    vel, angvel = s.body_vel[w], s.body_angvel[w]
    cw = ContactArrays(con.geom[w], con.body[w], con.point[w], con.normal[w], con.depth[w],
                       con.feature[w], con.friction[w], con.restitution[w], con.impulse[w])
    drive = JointDrive(s.motor_target[w], s.pd_kp[w], s.pd_kd[w], s.pd_max[w],
                       s.pd_target_quat[w], s.pd_target_q[w], s.pd_target_qd[w],
                       s.joint_applied[w])
    for k in range(n):
        t0 = _now(buf)
        ncon = 0
        if ng > 1:
            nprev = s.contact_count[w]
            for c in range(nprev):
                prev.geom[c, 0], prev.geom[c, 1] = cw.geom[c, 0], cw.geom[c, 1]
                prev.feature[c] = cw.feature[c]
                for q in range(cw.impulse.shape[1]):
                    prev.impulse[c, q] = cw.impulse[c, q]
            if all_primitive:
                code, ncon = collide_listed(m, pos, quat, gpos, gquat, aabb_lo, aabb_hi, pairs,
                                            cw, nprev, prev, o.contact_margin, listed)
            else:
                code, ncon = collide_world(m, pos, quat, gpos, gquat, aabb_lo, aabb_hi, pairs,
                                           cw, nprev, prev, o.contact_margin, o.broadphase,
                                           listed)
            if code != COLLIDE_OK:
                return -1, k
            s.contact_count[w] = ncon
        t1 = _now(buf)
        t_stage[0] += t1 - t0
        accumulate_forces(m, s.applied_force[w], s.applied_torque[w], force, torque)
        if has_drives:
            actuator_forces(m, pos, quat, vel, angvel, drive, s.ctrl[w], o.pd_mode,
                            force, torque)
        if has_servo and o.pd_mode == PD_STABLE:
            world_inverse_inertia(m, quat, inv_inertia)
            stable_servo_forces(m, pos, quat, vel, angvel, drive, h, o.erp, o.cfm,
                                o.gyroscopic, o.tolerance, rows, imp, vel_pred,
                                angvel_pred, inv_inertia, force, torque, caches[0])
        if o.contact == P.CONTACT_PENALTY and ncon > 0:
            penalty_forces(m, pos, quat, vel, angvel, cw, ncon, o.penalty_k, o.penalty_c,
                           o.v_slip, h, nper == ROWS_SPIN, force, torque)
        t0 = _now(buf)
        t_stage[1] += t0 - t1
        integrate_velocities(m, quat, vel, angvel, force, torque, h, o.gyroscopic)
        t1 = _now(buf)
        t_stage[2] += t1 - t0
        nrow = nfix + (nper * ncon if o.contact != P.CONTACT_PENALTY else 0)
        counts[4] += ncon
        if nrow > 0:
            if njrow > 0:
                build_joint_rows(m, pos, quat, vel, angvel, drive, h, o.erp, o.cfm, rows,
                                 o.pd_mode == PD_IMPLICIT)
                imp[:njrow] = s.row_impulse[w]
            if nfix > njrow:
                body_servo_rows(pos, quat, servoed, s.body_servo[w], s.body_target_pos[w],
                                s.body_target_quat[w], s.body_target_vel[w],
                                s.body_target_angvel[w], h, rows, njrow)
                imp[njrow:nfix] = 0.0
            t0 = _now(buf)
            t_stage[3] += t0 - t1
            if nrow > nfix:
                build_contact_rows(m, pos, vel, angvel, cw, ncon, nfix, nper, h,
                                   o.contact_erp, o.contact_cfm, o.slop,
                                   o.bounce_threshold, rows, imp)
            t1 = _now(buf)
            t_stage[4] += t1 - t0
            world_inverse_inertia(m, quat, inv_inertia)
            t0 = _now(buf)
            t_stage[5] += t0 - t1
            # parts of the solve on copies (outside the step total)
            na = _dense_assembly(m, rows, nrow, inv_inertia, vel, angvel)
            t1 = _now(buf)
            t_part[0] += t1 - t0
            counts[0] += nrow
            counts[1] += na
            counts[2] += njrow
            for r in range(njrow):
                if row_active(rows, r):
                    counts[3] += 1
            t0 = _now(buf)
            if not P.solve_fast(m, rows, nrow, ncon, inv_inertia, vel, angvel, imp, o, caches,
                                fast):
                s.lcp_fallbacks[w] += P.solve_rows(m, rows, nrow, nfix, ncon, inv_inertia, vel,
                                                   angvel, imp, o, caches)
            t1 = _now(buf)
            t_stage[6] += t1 - t0
            if njrow > 0:
                s.row_impulse[w] = imp[:njrow]
                if k == n - 1:
                    joint_reactions(m, pos, quat, rows, s.row_impulse[w], h, s.joint_force[w],
                                    s.joint_torque[w])
            if nrow > nfix:
                store_contact_impulses(cw, ncon, nfix, nper, imp)
            t0 = _now(buf)
            t_stage[7] += t0 - t1
        else:
            t0 = _now(buf)
        integrate_positions(m, pos, quat, vel, angvel, h, o.quat_integration)
        t1 = _now(buf)
        t_stage[8] += t1 - t0
        if njrow > 0 and o.projection > 0:
            project_joints(m, pos, quat, rows, inv_inertia, o.projection,
                           o.projection_tolerance, projection)
        t0 = _now(buf)
        t_stage[9] += t0 - t1
        bad = first_bad_body(pos, quat, vel, angvel, o.divergence_limit)
        t1 = _now(buf)
        t_stage[10] += t1 - t0
        if bad >= 0:
            return 1, k
    t0 = _now(buf)
    joint_coordinates(m, pos, quat, vel, angvel, s.joint_q[w], s.joint_qd[w], s.joint_qrel[w])
    t_stage[11] += _now(buf) - t0
    return 0, n


def profile_world(world, steps, chunk=32):
    """Step ``world`` (nworld == 1) ``steps`` times in chunks of ``chunk`` through the
    profiled loop; returns (stage ns, part ns, counters, steps done)."""
    if world.nworld != 1:
        raise ValueError("profile_world profiles one world")
    t_stage = np.zeros(len(STAGES), np.int64)
    t_part = np.zeros(len(PARTS), np.int64)
    counts = np.zeros(len(COUNTS), np.int64)
    done = 0
    o = world._options()
    while done < steps:
        n = min(chunk, steps - done)
        status, k = profiled_steps(world.model.arrays, world._state, world._contacts,
                                   world._pairs, n, o, t_stage, t_part, counts)
        done += k
        if status != 0:
            break
        world.time += n * world.dt
    return t_stage, t_part, counts, done


def make_world(model, variant, scene):
    from bench.bench_tumble import make_world as scene_world
    return scene_world(model, variant, scene)


def reference_ms(model, scene, variant, steps, chunk=32):
    """CPU ms per step of the normal ``world.step`` on the same scene (thread time, so a
    busy machine inflates it less than wall time)."""
    world = make_world(model, variant, scene)
    done = 0
    t0 = time.thread_time()
    while done < steps:
        n = min(chunk, steps - done)
        world.step(n)
        done += n
    return 1e3 * (time.thread_time() - t0) / steps


def report(scene, variant, t_stage, t_part, counts, done, ref_ms):
    total = t_stage.sum()
    print(f"\n{scene} ({variant}): {done} steps, {total / done / 1e3:.1f} us/step profiled, "
          f"{1e3 * ref_ms:.1f} us/step by world.step")
    for name, t in zip(STAGES, t_stage):
        print(f"  {name:22s} {t / done / 1e3:9.2f} us  {100.0 * t / total:5.1f} %")
    for name, t in zip(PARTS, t_part):
        print(f"  (part) {name:15s} {t / done / 1e3:9.2f} us")
    print("  per step: " + ", ".join(f"{c} {v / done:.1f}" for c, v in zip(COUNTS, counts)))
    return dict(scene=scene, variant=variant, steps=done,
                us_per_step=float(total / done / 1e3), world_step_us=1e3 * ref_ms,
                stages_us={k: float(v / done / 1e3) for k, v in zip(STAGES, t_stage)},
                parts_us={k: float(v / done / 1e3) for k, v in zip(PARTS, t_part)},
                counts_per_step={k: float(v / done) for k, v in zip(COUNTS, counts)})


def main():
    from bench import tumble_scenes as T
    from bench.bench_tumble import VARIANTS
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=["chain", "ragdoll600", "stack"])
    ap.add_argument("--variant", default="default", choices=list(VARIANTS))
    ap.add_argument("--steps", type=int, default=0, help="steps per scene (default: the scene's)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs per scene; each stage's figure is its least over the runs")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    out = []
    for scene in args.scenes:
        model = T.build(scene)
        warm = make_world(model, args.variant, scene)
        profile_world(warm, 2)                      # compile outside the figures
        warm.step(2)
        steps = args.steps or T.steps(scene)
        best = None
        for _ in range(args.repeat):                # keep each stage's least time
            world = make_world(model, args.variant, scene)
            res = profile_world(world, steps)
            best = res if best is None else (np.minimum(best[0], res[0]),
                                             np.minimum(best[1], res[1]), res[2], res[3])
        ref = min(reference_ms(model, scene, args.variant, steps) for _ in range(args.repeat))
        out.append(report(scene, args.variant, *best, ref))
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
