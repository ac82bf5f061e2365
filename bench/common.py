"""What every engine runner shares: command line, timed stepping loop, quality figures, output.

Each runner (``bench/bench_tumble.py``, ``bench/peers/bench_mujoco.py``,
``bench/peers/bench_pybullet.py``, ``bench/peers/bench_ode.py``) is run as

    python RUNNER SCENE [--variant V] [--budget SECONDS]

and prints exactly one line ``RESULT {json}``; ``bench/run.py`` collects those lines. The
quality figures are computed here, once, so that every engine is judged by the same formula.
"""
import argparse
import json
import math
import time

import numpy as np

from tumble.apps.benchmarks import SCENES, ragdoll_mode  # noqa: F401  (the runners' names)

# Thresholds (m) of the pass/fail figures: a stack whose top box moved less than this stood.
STOOD_DRIFT = 0.1
STOOD_MOTION = 0.1


# ------------------------------------------------------------------ command line ---

def parse(engine, variants, scenes=SCENES):
    """Parse ``SCENE [--variant V] [--budget S]``; the first of ``variants`` is the default."""
    ap = argparse.ArgumentParser(description="%s benchmark runner" % engine)
    ap.add_argument("scene", choices=scenes)
    ap.add_argument("--variant", default=variants[0], choices=variants)
    ap.add_argument("--budget", type=float, default=300.0,
                    help="stop the stepping loop after this many seconds of stepping "
                         "(the result is then marked partial)")
    return ap.parse_args()


# ------------------------------------------------------------------------ output ---

def _clean(x):
    """JSON has no inf/nan: write them as strings ('inf', 'nan')."""
    if isinstance(x, float):
        return x if math.isfinite(x) else repr(x)
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    return x


def emit(result):
    """Print the one ``RESULT {json}`` line; a run cut short by the budget is marked partial."""
    result["partial"] = result.get("steps", 0) < result.get("steps_planned", 0)
    print("RESULT " + json.dumps(_clean(result)), flush=True)


# ------------------------------------------------------------------- the timed loop ---

def run_loop(advance, steps, budget, chunk=32, after_chunk=None, ramp=True):
    """Advance ``steps`` steps in chunks; only the ``advance`` calls are timed.

    With ``ramp``, chunks start at one step and double up to ``chunk``, so that a slow scene
    (seconds a step) still stops close to its budget while a fast one is stepped ``chunk`` at
    a time; without it every chunk is ``chunk`` steps (checkpoints at fixed times).

    advance(n) : steps the engine n times (control included) and returns how many steps it
        did; fewer than n means the simulation stopped (diverged) and ends the loop.
    after_chunk(done) : optional, called after every chunk outside the timed region (for
        quality checkpoints such as energy).
    budget : seconds of timed stepping after which the loop stops (checked between chunks).

    Returns (steps done, seconds spent in ``advance``).
    """
    done, loop, size = 0, 0.0, (1 if ramp else chunk)
    while done < steps:
        n = min(size, steps - done)
        size = min(2 * size, chunk)
        t0 = time.perf_counter()
        k = advance(n)
        loop += time.perf_counter() - t0
        done += k
        if after_chunk is not None:
            after_chunk(done)
        if k < n or loop > budget:
            break
    return done, loop


def stepper(step_once):
    """An ``advance(n)`` for engines that step one step per call (MuJoCo, PyBullet)."""
    def advance(n):
        for _ in range(n):
            step_once()
        return n
    return advance


# --------------------------------------------------------------- quality figures ---

def chain_separation(origins, rots, anchor, offset):
    """Largest joint separation (m) of a chain of links.

    origins (n, 3) : world position of each link's joint point (its frame origin);
    rots (n, 3, 3) : link orientations; anchor (3,) : the world point link 0 hangs from;
    offset (3,) : the next joint point in a link's frame. Joint i>0 is separated by
    |origin_i - (origin_{i-1} + R_{i-1} offset)|, joint 0 by |origin_0 - anchor|.
    """
    origins = np.asarray(origins, float)
    parents = origins[:-1] + np.einsum("nij,j->ni", np.asarray(rots, float)[:-1], offset)
    seps = np.linalg.norm(origins[1:] - parents, axis=1)
    return float(max(np.linalg.norm(origins[0] - np.asarray(anchor, float)), seps.max(initial=0.0)))


def stack_figures(p0, p1):
    """Top box of a stack: horizontal drift (m), height error (m), stood (bool)."""
    drift = float(np.linalg.norm(p1[-1, :2] - p0[-1, :2]))
    herr = float(p1[-1, 2] - p0[-1, 2])
    return dict(top_drift_m=drift, top_height_err_m=herr,
                stood=bool(drift < STOOD_DRIFT and abs(herr) < STOOD_DRIFT))


def pyramid_figures(p0, p1):
    """Largest box displacement (m) and whether the pyramid stood (all moved < 10 cm)."""
    disp = float(np.max(np.linalg.norm(p1 - p0, axis=1)))
    return dict(max_disp_m=disp, stood=bool(disp < STOOD_MOTION))


def spheres_figures(p1, inner):
    """Spheres outside the walled box (inner side ``inner`` m) or below the floor; top z (m)."""
    a = inner / 2.0
    escaped = int(np.sum((np.abs(p1[:, 0]) > a) | (np.abs(p1[:, 1]) > a) | (p1[:, 2] < 0)))
    return dict(escaped=escaped, max_z_end=float(np.max(p1[:, 2])))


def joint_error(ball_rotvecs, hinge_angles):
    """Largest deviation (rad) from the initial pose: ball rotation angles and hinge angles."""
    ball = np.linalg.norm(np.asarray(ball_rotvecs, float).reshape(-1, 3), axis=1)
    hinge = np.abs(np.asarray(hinge_angles, float).reshape(-1))
    return float(max(ball.max(initial=0.0), hinge.max(initial=0.0)))
