"""MuJoCo's own best route to stiff PD on the benchmark ragdoll: the figure to beat.

    python bench/peers/mujoco_native_pd.py ragdoll600pd|ragdoll1920pd [--hz HZ] [--kp KP --kv KV]

Every ball joint of the ragdoll becomes three hinges, each driven by a position actuator
(kp, kv; default the scene's kp=300, kd=30), with integrator ``implicitfast`` (the damping
is implicit, the stiffness explicit). The step rate comes from the scene name unless --hz
is given (the shared study also ran 120 and 60 Hz). Prints one ``RESULT {json}`` line.
"""
import argparse
import re
import sys
from pathlib import Path

import numpy as np
import mujoco

if __package__ in (None, ""):          # run as a script: make `bench` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from bench import common as C  # noqa: E402
from bench import scenes as S  # noqa: E402
from bench.peers import bench_mujoco as B  # noqa: E402

PD_SCENES = [s for s in C.SCENES if s.startswith("ragdoll") and s.endswith("pd")]


def _three_hinges(match):
    n = match.group(1)
    return "".join('<joint name="j_%s_%s" type="hinge" pos="0 0 0" axis="%s"/>' % (n, a, ax)
                   for a, ax in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")))


def native_pd_model(hz, kp, kv):
    """The ragdoll MJCF of bench_mujoco with ball joints split and position actuators added."""
    xml = B._ragdoll_xml(S.ragdoll_parts(), 1.0 / hz)
    xml = re.sub(r'<joint name="j_([A-Za-z_]+)" type="ball" pos="0 0 0"/>', _three_hinges, xml)
    xml = xml.replace("<option ", '<option integrator="implicitfast" ', 1)
    m = mujoco.MjModel.from_xml_string(xml)
    acts = "".join('<position joint="%s" kp="%g" kv="%g"/>'
                   % (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j), kp, kv)
                   for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE)
    xml = xml.replace("</mujoco>", "<actuator>%s</actuator></mujoco>" % acts)
    return mujoco.MjModel.from_xml_string(xml)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", choices=PD_SCENES)
    ap.add_argument("--variant", default="default", choices=["default"])
    ap.add_argument("--hz", type=float, default=None, help="step rate (default: the scene's)")
    ap.add_argument("--kp", type=float, default=S.RAGDOLL["kp"], help="N m/rad")
    ap.add_argument("--kv", type=float, default=S.RAGDOLL["kd"], help="N m s/rad")
    ap.add_argument("--budget", type=float, default=300.0, help="seconds of stepping at most")
    args = ap.parse_args()
    hz = args.hz or C.ragdoll_mode(args.scene)[0]
    m = native_pd_model(hz, args.kp, args.kv)
    d = mujoco.MjData(m)
    hinge_q = [m.jnt_qposadr[j] for j in range(m.njnt)
               if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    steps = int(round(S.RAGDOLL["duration"] * hz))
    done, loop = C.run_loop(C.stepper(lambda: mujoco.mj_step(m, d)), steps, args.budget)
    pelvis = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "pelvis")
    figures = dict(hz=hz, kp=args.kp, kv=args.kv, integrator=int(m.opt.integrator),
                   diverged=bool(B._diverged(d)), finite=bool(np.all(np.isfinite(d.qpos))),
                   max_joint_err_rad_end=float(np.max(np.abs(d.qpos[hinge_q]))),
                   pelvis_z_end=float(d.xpos[pelvis][2]))
    res = S.summary_common("mujoco native PD", args.scene, "implicitfast", 1.0 / hz, done, steps,
                           loop, figures)
    res["version"] = mujoco.__version__
    C.emit(res)


if __name__ == "__main__":
    main()
