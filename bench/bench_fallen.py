"""A character lying on the ground: the step's cost against standing, per contact model.

    python bench/bench_fallen.py                 # lcp, pgs, penalty; about a minute warm
    python bench/bench_fallen.py --steps 600 --contacts lcp pgs

The course ragdoll (``games105_ragdoll``, 20 boxes) with every joint servo on (kp 500 N
m/rad, kd 50 N m s/rad, implicit PD) at 1/60 s, in two states:

- standing: its root held at the built pose by a body servo (the hand of god), so only the
  feet touch the ground;
- fallen: knocked over (2 m/s forwards), 4 s to land, then timed lying in a heap (about
  64 contacts: the corners of every box that lies on its face); and again, as ``at rest``,
  over ``--rest`` steps from 30 s after landing (a heap that PGS solves can creep for
  10 s or so, each step running all of PGS's sweeps, before it settles).

For each contact model: ms per step in each state (the serial step, warm cache, the mean
over three runs of ``--steps`` steps in a row; at rest, over all ``--rest`` steps), the
ratios fallen / standing (issue 26's goal: 2 or less), the contacts, and the steps on which
PGS stood in for Lemke (contact='lcp'; after a failure Lemke backs off for up to 1,024
steps, ``tumble.pipeline.solve``), and the largest body speed while lying (a heap at rest
should not jitter). No peer runs this scene yet.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):   # run as a script: this tree's tumble, not an installed one
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tumble.character.ragdoll import games105_ragdoll  # noqa: E402


def make(contact, fallen):
    """The course ragdoll (servos on) on contact model ``contact``, standing held by the
    root, or fallen and at rest."""
    w = games105_ragdoll().make_world(dt=1 / 60, contact=contact)
    for j in w.model.joint_names[1:]:
        w.set_pd_gains(j, 500.0, 50.0)
    if fallen:
        w.body_vel[:, 0] = 2.0
        w.step(240)
    else:
        w.set_body_servo(w.model.body_names[0], 1e5, 1e3, 1e4, 1e2)
        w.step(60)
    return w


def time_steps(w, steps, rounds=3):
    """Mean ms per step over ``rounds`` runs of ``steps`` steps one after another, and the
    fallbacks and the largest body speed (m/s) over all of them. The mean, not the best
    run: a heap's cost changes over time (PGS that creeps for a while after landing, the
    back-off's Lemke attempts), and the best run missed most of it."""
    total = 0.0
    fallbacks0 = w.lcp_fallbacks
    vmax = 0.0
    for _ in range(rounds):
        t0 = time.perf_counter()
        w.step(steps)
        total += time.perf_counter() - t0
        vmax = max(vmax, float(np.linalg.norm(w.body_vel, axis=-1).max()))
    return 1e3 * total / (rounds * steps), (w.lcp_fallbacks - fallbacks0) / (rounds * steps), vmax


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--rest", type=int, default=1800,
                    help="steps timed at rest, from 30 s after landing (0: skip)")
    ap.add_argument("--contacts", nargs="+", default=["lcp", "pgs", "penalty"])
    args = ap.parse_args()
    print(f"{'contact':8} {'standing ms':>12} {'fallen ms':>10} {'ratio':>6} {'at rest ms':>11} "
          f"{'ratio':>6} {'contacts':>9} {'PGS for Lemke':>14} {'max speed':>10}")
    for contact in args.contacts:
        stand = make(contact, False)
        t_stand, _, _ = time_steps(stand, args.steps)
        lying = make(contact, True)
        t_fall, fb, vmax = time_steps(lying, args.steps)
        rest_text = f"{'-':>11} {'-':>6}"
        if args.rest > 0:
            lying.step(max(1800 - 3 * args.steps, 0))
            t_rest, _, vrest = time_steps(lying, args.rest, rounds=1)
            vmax = max(vmax, vrest)
            rest_text = f"{t_rest:11.3f} {t_rest / t_stand:6.1f}"
        ncon = int(lying.state_arrays.contact_count[0])
        fb_text = f"{100 * fb:.0f}%" if contact == "lcp" else "-"
        print(f"{contact:8} {t_stand:12.3f} {t_fall:10.3f} {t_fall / t_stand:6.1f} {rest_text} "
              f"{ncon:9d} {fb_text:>14} {vmax:10.3f}", flush=True)


if __name__ == "__main__":
    main()
