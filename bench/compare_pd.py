"""tumble's implicit PD against MuJoCo's native PD on the PD ragdoll, in one process.

    python bench/compare_pd.py [--hz 60] [--rounds 40]

The separate runners (``bench_tumble.py ragdoll60pd --variant implicit-pd`` and
``peers/mujoco_native_pd.py ragdoll600pd --hz 60``) time one episode each, so on a
shared machine whose speed drifts by tens of percent from minute to minute two runs
minutes apart compare the machine as much as the engines. Here both engines live in one
process and take turns: each round runs the whole 3 s episode (fresh state, same loop
as ``common.run_loop``: chunks of up to 32 steps through ``world.step(n)`` for tumble,
one ``mj_step`` call per step for MuJoCo, as its runner does) once per engine, in
alternating order. Prints each engine's least and median ms per step, the median of
the rounds' ratios (tumble / MuJoCo: below 1 is tumble faster), in how many rounds
tumble was faster, and both engines' largest joint error at the end (rad), and one
``RESULT {json}`` line.
"""
import argparse
import json
import statistics
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):          # run as a script: make `bench` and `tumble` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from bench import common as C  # noqa: E402
from bench import scenes as S  # noqa: E402
from bench import tumble_scenes as T  # noqa: E402
from bench.bench_tumble import make_world, warm_up  # noqa: E402


def tumble_episode(model, scene, steps):
    """(ms per step, largest joint error at the end in rad) of one fresh episode."""
    world = make_world(model, "implicit-pd", scene)
    done, loop = C.run_loop(lambda n: (world.step(n), n)[1], steps, 1e9)
    err = float(np.max(np.abs(world.joint_q)))
    return 1e3 * loop / done, err


def mujoco_episode(hz, steps):
    import mujoco
    from bench.peers.mujoco_native_pd import native_pd_model
    m = native_pd_model(hz, S.RAGDOLL["kp"], S.RAGDOLL["kd"])
    d = mujoco.MjData(m)
    hinge_q = [m.jnt_qposadr[j] for j in range(m.njnt)
               if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    done, loop = C.run_loop(C.stepper(lambda: mujoco.mj_step(m, d)), steps, 1e9)
    return 1e3 * loop / done, float(np.max(np.abs(d.qpos[hinge_q])))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hz", type=int, default=60, choices=[60, 120, 600])
    ap.add_argument("--rounds", type=int, default=40)
    args = ap.parse_args()
    scene = {60: "ragdoll60pd", 120: "ragdoll120pd", 600: "ragdoll600pd"}[args.hz]
    model = T.build(scene)
    steps = T.steps(scene)
    warm_up(model, "implicit-pd")
    tumble_episode(model, scene, steps)           # first episodes outside the figures
    mujoco_episode(args.hz, steps)
    tu, mj, ratios = [], [], []
    for r in range(args.rounds):
        if r % 2 == 0:
            a, err_t = tumble_episode(model, scene, steps)
            b, err_m = mujoco_episode(args.hz, steps)
        else:
            b, err_m = mujoco_episode(args.hz, steps)
            a, err_t = tumble_episode(model, scene, steps)
        tu.append(a)
        mj.append(b)
        ratios.append(a / b)
    res = dict(scene=scene, hz=args.hz, rounds=args.rounds, steps=steps,
               tumble_ms_min=min(tu), tumble_ms_median=statistics.median(tu),
               mujoco_ms_min=min(mj), mujoco_ms_median=statistics.median(mj),
               ratio_median=statistics.median(ratios), ratio_of_minima=min(tu) / min(mj),
               tumble_faster_rounds=sum(x < 1.0 for x in ratios),
               tumble_max_joint_err_rad=err_t, mujoco_max_joint_err_rad=err_m)
    print(f"{scene}: tumble {res['tumble_ms_min']:.4f} ms/step least, "
          f"{res['tumble_ms_median']:.4f} median; MuJoCo native PD {res['mujoco_ms_min']:.4f} "
          f"least, {res['mujoco_ms_median']:.4f} median")
    print(f"  tumble / MuJoCo: {res['ratio_median']:.3f} (median of {args.rounds} rounds), "
          f"{res['ratio_of_minima']:.3f} (least over least); tumble faster in "
          f"{res['tumble_faster_rounds']} of {args.rounds}")
    print(f"  joint error at the end: tumble {err_t:.2g} rad, MuJoCo {err_m:.2g} rad")
    print("RESULT " + json.dumps(res))


if __name__ == "__main__":
    main()
