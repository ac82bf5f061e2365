"""A free body's angular momentum and energy over a long spin, tumble's gyroscopic modes
against MuJoCo's integrators on the same body.

    python bench/bench_rotation.py                  # 6 rad/s, dt = 1/240 s, 20 s
    python bench/bench_rotation.py --speed 10 --seconds 60 --json rot.json

The body: a box of 0.08 x 0.24 x 0.5 m at 500 kg/m^3 (a tennis racket's proportions),
spun about its middle axis with 1% about the smallest, so it flips again and again. Zero
gravity. Reported per setting: the largest relative change of the angular momentum (the
engine's own measure: tumble's ``angular_momentum()``, MuJoCo's ``I w`` in the world frame)
and of the kinetic energy over the run, and the microseconds per step (a Python loop of
single steps for both).
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tumble  # noqa: E402

HALF = (0.04, 0.12, 0.25)
DENSITY = 500.0


def _initial_angvel(inertia, speed):
    order = np.argsort(inertia)
    w = np.zeros(3)
    w[order[1]], w[order[0]] = speed, 0.01 * speed
    return w


def run_tumble(mode, speed, dt, seconds):
    b = tumble.ModelBuilder(gravity=(0, 0, 0))
    b.add_body("racket", density=DENSITY)
    b.add_geom("racket", "box", size=HALF)
    w0 = _initial_angvel(b.build().body_inertia[0], speed)
    b = tumble.ModelBuilder(gravity=(0, 0, 0))
    b.add_body("racket", density=DENSITY, angvel=w0)
    b.add_geom("racket", "box", size=HALF)
    world = tumble.World(b.build(), dt=dt, gyroscopic=mode)
    world.step()                                    # compile (or load) before timing
    L0, E0 = world.angular_momentum().copy(), world.energy()[0]
    dl = de = 0.0
    n = int(round(seconds / dt))
    spent = 0.0
    for _ in range(n):
        t = time.perf_counter()
        world.step()
        spent += time.perf_counter() - t
        dl = max(dl, np.linalg.norm(world.angular_momentum() - L0) / np.linalg.norm(L0))
        de = max(de, abs(world.energy()[0] - E0) / E0)
    return {"dL": dl, "dE": de, "us_per_step": 1e6 * spent / n}


def run_mujoco(integrator, speed, dt, seconds):
    import mujoco
    xml = f"""<mujoco><option timestep="{dt}" gravity="0 0 0" integrator="{integrator}"/>
      <worldbody><body><freejoint/><geom type="box" size="{HALF[0]} {HALF[1]} {HALF[2]}"
      density="{DENSITY}"/></body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    inertia = m.body_inertia[1].copy()
    d.qvel[3:6] = _initial_angvel(inertia, speed)       # body-frame angular velocity
    mujoco.mj_forward(m, d)

    def momentum():
        R = d.xmat[1].reshape(3, 3)
        return R @ (inertia * d.qvel[3:6])

    L0 = momentum()
    E0 = 0.5 * d.qvel[3:6] @ (inertia * d.qvel[3:6])
    dl = de = 0.0
    n = int(round(seconds / dt))
    spent = 0.0
    for _ in range(n):
        t = time.perf_counter()
        mujoco.mj_step(m, d)
        spent += time.perf_counter() - t
        dl = max(dl, np.linalg.norm(momentum() - L0) / np.linalg.norm(L0))
        de = max(de, abs(0.5 * d.qvel[3:6] @ (inertia * d.qvel[3:6]) - E0) / E0)
    return {"dL": dl, "dE": de, "us_per_step": 1e6 * spent / n}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--speed", type=float, default=6.0, help="rad/s about the middle axis")
    ap.add_argument("--dt", type=float, default=1 / 240)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--json", metavar="FILE")
    a = ap.parse_args()
    results = {}
    for mode in ("implicit", "variational", "explicit"):
        results[f"tumble {mode}"] = run_tumble(mode, a.speed, a.dt, a.seconds)
    try:
        for integ in ("Euler", "implicitfast", "RK4"):
            results[f"mujoco {integ}"] = run_mujoco(integ, a.speed, a.dt, a.seconds)
    except ImportError:
        print("(MuJoCo not installed: pip install '.[peers]')")
    print(f"{a.speed:g} rad/s about the middle axis, dt = {a.dt:.6g} s, {a.seconds:g} s")
    print(f"{'setting':24s} {'max |dL|/|L|':>14s} {'max |dE|/E':>12s} {'us/step':>9s}")
    for name, r in results.items():
        print(f"{name:24s} {r['dL']:14.3g} {r['dE']:12.3g} {r['us_per_step']:9.2f}")
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
