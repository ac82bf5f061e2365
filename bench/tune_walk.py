"""Search a generalized-walking style's parameters for push survival with CMA-ES.

    pip install cma                       # or: pip install -e ".[tune]"
    python bench/tune_walk.py --out runs/tune-ipm --workers 2            # runs until stopped
    python bench/tune_walk.py --out runs/tune-ipm --workers 2            # resumes
    python bench/tune_walk.py --out runs/tune-ipm --write-best my.json   # the best as a style

A candidate is scored on what bench_walk.py measures, each part in one short run:
- each of ``--speeds`` (m/s) walked from standing for ``--speed-time`` s: 2/3 of
  ``--speed-weight`` without a fall, the other third if its speed over the last 3 s is
  within 0.1 m/s of the command;
- each of ``--slopes`` (degrees, up and down) and ``--dt-speed`` m/s at each physics step of
  ``--dts`` walked for ``--speed-time`` s without a fall: ``--speed-weight`` each;
- pushes: after ``--settle`` s of walking (a fall scores no pushes), 0.2 s chest pushes of
  each of ``--forces`` N in the 8 directions of bench_walk.py at ``--phases`` push times
  over a stride (not the bench's 8, so the bench's figure is not the one searched on):
  1 for each survived for ``--watch`` s.
The parameters searched and their ranges are
``SPACE``; CMA-ES works on them scaled to 0..1 from the starting style's values.

The search state (``es.pkl``), every candidate's score (``log.jsonl``) and the best style
so far (``best.json``) are written to ``--out`` after each generation, so a run resumes
where it stopped. Scores are noisy (walking is chaotic: a push 1/60 s later can change the
outcome), so check a winner with ``bench_walk.py survival`` and the walking tests.
"""
import argparse
import json
import math
import multiprocessing as mp
import os
import pickle
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "examples"))

# (field, index in a pair field or None, low, high): the searched parameters
SPACE = [
    ("step_time", None, 0.30, 0.50), ("min_phase", None, 0.4, 0.8),
    ("ipm_scale", 0, 0.8, 1.3), ("ipm_scale", 1, 0.8, 1.8), ("alpha", 0, 0.0, 0.2),
    ("step_width", None, 0.0, 0.1), ("min_step_width", None, 0.08, 0.16),
    ("max_step", 0, 0.35, 0.65), ("max_step", 1, 0.2, 0.5), ("freeze_phase", None, 0.6, 1.0),
    ("step_height", None, 0.06, 0.16), ("stance_knee", None, 0.0, 0.3),
    ("knee_time", None, 0.1, 0.5), ("knee_rate", None, 0.3, 4.0),
    ("knee_support", None, 0.2, 0.9), ("height_gain", 0, 0.0, 4000.0),
    ("height_gain", 1, 0.0, 600.0), ("velocity_gain", 0, 0.0, 200.0),
    ("velocity_gain", 1, 0.0, 300.0), ("max_force", 0, 50.0, 300.0),
    ("max_force", 1, 50.0, 300.0), ("torso", 0, -0.05, 0.15), ("hurry", None, 0.0, 0.4),
    ("hurry_deadband", None, 0.1, 1.0), ("min_step_time", None, 0.2, 0.35),
    ("swing_ease", None, 0.0, 1.0), ("step_time_speed", None, 0.0, 0.15),
    ("predict", None, 0.0, 0.6), ("lift_phase", None, 0.0, 0.2),
    ("speed_limit", None, 0.1, 0.4), ("speed_gain", None, 0.005, 0.08),
    ("slope_lean", None, 0.0, 2.0), ("slope_knee", None, 0.0, 6.0),
]
GAIN_SCALES = [("hip", 0.5, 1.5), ("torso", 0.5, 1.5), ("stance_knee", 0.4, 2.0)]


def _value(style, field, index):
    v = getattr(style, field)
    return float(v if index is None else v[index])


def decode(style, x):
    """The style (a Style) of the 0..1 vector ``x`` (SPACE, then GAIN_SCALES)."""
    changes = {}
    for (field, index, lo, hi), u in zip(SPACE, x):
        v = lo + float(np.clip(u, 0.0, 1.0)) * (hi - lo)
        if index is None:
            changes[field] = v
        else:
            pair = list(changes.get(field, getattr(style, field)))
            pair[index] = v
            changes[field] = tuple(pair)
    gains = dict(style.gains)
    tail = x[len(SPACE):]
    for (group, lo, hi), u in zip(GAIN_SCALES, tail):
        k = lo + float(np.clip(u, 0.0, 1.0)) * (hi - lo)
        if group == "stance_knee":
            base = style.stance_knee_gains or gains["knee"]
            changes["stance_knee_gains"] = (base[0] * k, base[1] * k)
        else:
            gains[group] = (gains[group][0] * k, gains[group][1] * k)
    changes["gains"] = gains
    changes["min_phase"] = min(changes["min_phase"], style.max_phase - 0.05)
    return style.with_(**changes)


def encode(style):
    """The 0..1 vector of ``style`` (gain scales at 1)."""
    x = [(_value(style, f, i) - lo) / (hi - lo) for f, i, lo, hi in SPACE]
    x += [(1.0 - lo) / (hi - lo) for _, lo, hi in GAIN_SCALES]
    return np.clip(np.array(x), 0.0, 1.0)


def style_dict(style):
    """``style`` as the fields of a style file."""
    out = {"controller": "generalized"}
    for k, v in vars(style).items():
        if k == "max_torque":
            v = {g: t for g, t in v.items() if math.isfinite(t)}
            if not v:
                continue
        out[k] = list(v) if isinstance(v, tuple) else v
    out["gains"] = {g: list(p) for g, p in style.gains.items()}
    return out


def score(style, opts):
    """The candidate's score (see the module docs) and the seconds it took; 0 for a style
    whose walk raises (a diverged step, a malformed style), so one candidate cannot end
    the search."""
    t0 = time.perf_counter()
    try:
        points = _points(style, opts)
    except Exception as e:
        print(f"candidate failed: {e!r}", file=sys.stderr)
        points = 0
    return points, time.perf_counter() - t0


def _points(style, opts):
    import bench_walk as B
    from tumble.character.generalized import make_generalized
    from tumble.character.terrain import Slope
    from tumble.character.walk import run_walk
    walked = 0
    for v in opts["speeds"]:
        c = make_generalized(style.with_(speed=v))
        r = run_walk(c, opts["speed_time"], settle=opts["speed_time"] - 3.0)
        if not r.fallen:
            walked += 2.0 / 3.0 + (1.0 / 3.0 if abs(r.speed - v) <= 0.1 else 0.0)
    for angle in opts["slopes"]:
        c = make_generalized(style, Slope(math.radians(angle)))
        walked += 0.0 if run_walk(c, opts["speed_time"]).fallen else 1.0
    for dt in opts["dts"]:
        c = make_generalized(style.with_(speed=opts["dt_speed"]), dt=dt)
        walked += 0.0 if run_walk(c, opts["speed_time"]).fallen else 1.0
    points = walked * opts["speed_weight"]
    args = argparse.Namespace(phases=opts["phases"], settle=opts["settle"], push_time=0.2,
                              watch=opts["watch"])
    got = B.push_snapshots(lambda: make_generalized(style), args)
    if got is None:
        return points
    c, snaps = got
    for d in B.DIRECTIONS.values():
        for f in opts["forces"]:
            points += sum(B._survives(c, s, f * np.asarray(d), args) for s in snaps)
    return points


def _job(payload):
    return score(*payload)


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder of the search state and logs")
    p.add_argument("--style", default="ipm_walk", help="starting style (name or JSON path)")
    p.add_argument("--forces", default="200,300,350")
    p.add_argument("--phases", type=int, default=5)
    p.add_argument("--settle", type=float, default=6.0)
    p.add_argument("--watch", type=float, default=5.0)
    p.add_argument("--speeds", default="-0.5,1.0,1.5",
                   help="m/s: commanded speeds each walked for --speed-time s")
    p.add_argument("--speed-time", type=float, default=20.0)
    p.add_argument("--speed-weight", type=float, default=30.0,
                   help="score of each speed walked without a fall (2/3 of it) and within 0.1 m/s "
                        "over its last 3 s (1/3)")
    p.add_argument("--slopes", default="10,-10",
                   help="degrees: slopes each walked for --speed-time s (--speed-weight each)")
    p.add_argument("--dts", default="0.008333333333333333",
                   help="s: other physics steps at which --dt-speed is walked for --speed-time s")
    p.add_argument("--dt-speed", type=float, default=1.0)
    p.add_argument("--sigma", type=float, default=0.12, help="CMA-ES step in 0..1 units")
    p.add_argument("--popsize", type=int, default=12)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--generations", type=int, default=1000)
    p.add_argument("--write-best", help="write the best style found to this JSON file and stop")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    from tumble.character.generalized import load_style
    base = load_style(a.style)
    best_path = os.path.join(a.out, "best.json")
    if a.write_best:
        with open(best_path) as f:
            best = json.load(f)
        style = decode(base, np.array(best["x"]))
        with open(a.write_best, "w") as f:
            json.dump(style_dict(style), f, indent=2)
        print(f"wrote {a.write_best}: score {best['score']}/{best['of']}")
        return
    import cma
    opts = {"forces": [float(f) for f in a.forces.split(",")],
            "phases": a.phases, "settle": a.settle, "watch": a.watch,
            "speeds": [float(v) for v in a.speeds.split(",")] if a.speeds else [],
            "speed_time": a.speed_time, "speed_weight": a.speed_weight,
            "slopes": [float(v) for v in a.slopes.split(",")] if a.slopes else [],
            "dts": [float(v) for v in a.dts.split(",")] if a.dts else [], "dt_speed": a.dt_speed}
    of = len(opts["forces"]) * a.phases * 8 + a.speed_weight * (
        len(opts["speeds"]) + len(opts["slopes"]) + len(opts["dts"]))
    state = os.path.join(a.out, "es.pkl")
    if os.path.exists(state):
        with open(state, "rb") as f:
            es, best = pickle.load(f)
        print(f"resumed at generation {es.countiter}, best {best['score']}/{of}", flush=True)
    else:
        x0 = encode(base)
        es = cma.CMAEvolutionStrategy(x0, a.sigma, {"bounds": [0.0, 1.0], "popsize": a.popsize,
                                                    "seed": 105, "verbose": -9})
        s0, _ = score(base, opts)
        best = {"score": s0, "of": of, "x": x0.tolist()}
        print(f"start: {s0}/{of}", flush=True)
    log = open(os.path.join(a.out, "log.jsonl"), "a")
    with mp.get_context("fork").Pool(a.workers) as pool:
        while es.countiter < a.generations:
            xs = es.ask()
            t0 = time.perf_counter()
            got = pool.map(_job, [(decode(base, x), opts) for x in xs])
            scores = [g[0] for g in got]
            es.tell(xs, [-float(s) for s in scores])
            for x, (s, sec) in zip(xs, got):
                log.write(json.dumps({"gen": es.countiter, "score": s, "seconds": round(sec, 1),
                                      "x": np.round(x, 4).tolist()}) + "\n")
                if s > best["score"]:
                    best = {"score": s, "of": of, "x": np.asarray(x).tolist()}
            log.flush()
            with open(best_path, "w") as f:
                json.dump(best, f)
            with open(state + ".tmp", "wb") as f:
                pickle.dump((es, best), f)
            os.replace(state + ".tmp", state)
            print(f"gen {es.countiter}: best {max(scores)}/{of}, median {np.median(scores):.0f}, "
                  f"best so far {best['score']}/{of} ({time.perf_counter() - t0:.0f} s)",
                  flush=True)


if __name__ == "__main__":
    main()
