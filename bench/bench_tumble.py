"""tumble's benchmark runner: the scenes of bench/tumble_scenes.py, timed like the peers.

    python bench/bench_tumble.py SCENE [--variant default|pgs|penalty|sleep|...] [--budget S]

Variants pick World options: 'default' (direct joint solver, exact 'lcp' contacts), 'pgs'
(projected Gauss-Seidel for joints and contacts), 'penalty' (spring-damper contacts;
'penalty-explicit' with the lecture's explicit springs on every body);
'sleep' and 'pgs-sleep' are 'default' and 'pgs' with islands at rest put to sleep after
0.5 s (``World(sleep_time=0.5)``; the peers' runs do not sleep); 'pgs50' is 'pgs' with 50
sweeps instead of 300.
On the ragdoll PD scenes, 'implicit-pd', 'stable-pd' and 'explicit-pd' hold the pose with
tumble's in-step joint servos (same gains, ``World(pd=...)``) instead of the Python-side
:class:`ExplicitPD` of the other variants; ``ragdoll60pd`` and ``ragdoll120pd`` run the
PD scene at those rates (the rates of ``peers/mujoco_native_pd.py --hz``).

Compilation is excluded from the timing: a throwaway world of the same model is stepped
first, which compiles every kernel the timed world uses (Numba compiles per type signature,
not per world); its cost is reported as ``warmup_s``. The timed loop calls ``world.step(n)``
32 steps at a time (240 for the chain, whose energy is checked every simulated second), or
one step at a time with the explicit PD control of the ragdoll PD scenes. Prints one
``RESULT {json}`` line with the same figures as the peers' runners (see bench/common.py).
"""
import sys
import time
from pathlib import Path

import numpy as np

if __package__ in (None, ""):          # run as a script: make `bench` and `tumble` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tumble  # noqa: E402
from bench import common as C  # noqa: E402
from bench import scenes as S  # noqa: E402
from bench import tumble_scenes as T  # noqa: E402

VARIANTS = {"default": {}, "pgs": dict(solver="pgs", contact="pgs"),
            "penalty": dict(contact="penalty"),
            "penalty-explicit": dict(contact="penalty", penalty_integration="explicit"),
            "implicit-pd": dict(pd="implicit"),
            "stable-pd": dict(pd="stable"), "explicit-pd": dict(pd="explicit"),
            # islands at rest for 0.5 s sleep (Box2D's default time; off by default)
            "sleep": dict(sleep_time=0.5),
            "pgs-sleep": dict(solver="pgs", contact="pgs", sleep_time=0.5),
            # PGS held to 50 sweeps (the default is 300), as PyBullet's 50 and below
            # MuJoCo's 100 iterations: the pyramid's motion says what it costs in quality
            "pgs50": dict(solver="pgs", contact="pgs", iterations=50)}
EXTRA_SCENES = ["ragdoll60pd", "ragdoll120pd"]


def make_world(model, variant, scene=None):
    """The world of a scene; for a PD ragdoll under an in-step variant (``*-pd``) its
    joints get the scene's gains as servos toward the built pose."""
    world = tumble.World(model, dt=model.timestep, **VARIANTS[variant])
    pd = C.ragdoll_mode(scene)[1] if scene and scene.startswith("ragdoll") else None
    if pd and variant.endswith("-pd"):
        for name, (kp, kd) in S.ragdoll_pd_gains(S.ragdoll_parts(), pd).items():
            world.set_pd_gains(name, kp, kd)
    return world


def warm_up(model, variant):
    """Compile everything the timed run calls, on a throwaway world; returns seconds spent."""
    t0 = time.perf_counter()
    w = make_world(model, variant)
    w.step(2)
    w.energy()
    w.joint_separation()
    w.contacts
    return time.perf_counter() - t0


class Stepper:
    """``advance(n)`` for ``common.run_loop``: n steps of ``world``, stopping at a divergence.

    control : optional callable run before every single step (explicit PD); then the world
        is stepped one step per ``step()`` call, since applied torques last one call.
    """

    def __init__(self, world, control=None):
        self.world = world
        self.control = control
        self.ctrl_s = 0.0
        self.diverged = None          # the SimulationError, if any

    def __call__(self, n):
        w = self.world
        try:
            if self.control is None:
                w.step(n)
                return n
            for i in range(n):
                c0 = time.perf_counter()
                self.control()
                self.ctrl_s += time.perf_counter() - c0
                w.step(1)
            return n
        except tumble.SimulationError as e:
            # the world is left as it was before the failing call: count the steps done
            self.diverged = e
            return 0 if self.control is None else i

    @property
    def diverged_at_s(self):
        return None if self.diverged is None else float(self.diverged.time)


def _penetration(world):
    """Deepest penetration (m) among the contacts of the last step, and their number."""
    con = world.contacts
    return (float(max(0.0, con.depth.max())) if len(con) else 0.0), len(con)


def _result(args, world, done, steps, loop, extra):
    extra.update(solver=world.solver, contact=world.contact, nbody=world.model.nbody)
    return S.summary_common("tumble", args.scene, args.variant, world.dt, done, steps, loop, extra)


# ------------------------------------------------------------------------- chain ---

def run_chain(args, model, warm):
    world = make_world(model, args.variant)
    e0 = sum(world.energy())
    scale = S.chain_energy_scale()
    worst = dict(de=0.0, sep=0.0)
    stepper = Stepper(world)

    def checkpoint(done):
        """Energy and joint separation every simulated second, outside the timed region."""
        if stepper.diverged is None:
            worst["de"] = max(worst["de"], abs(sum(world.energy()) - e0) / scale)
            worst["sep"] = max(worst["sep"], float(world.joint_separation().max()))

    steps = T.steps("chain")
    done, loop = C.run_loop(stepper, steps, args.budget, chunk=240, after_chunk=checkpoint,
                            ramp=False)
    e1 = sum(world.energy())
    return _result(args, world, done, steps, loop, dict(
        joint_sep_mm=1000.0 * float(world.joint_separation().max()),
        max_joint_sep_mm_1s_checkpoints=1000.0 * worst["sep"],
        energy_J=[e0, e1], rel_energy_change=None if stepper.diverged else (e1 - e0) / scale,
        max_abs_rel_energy_change_1s_checkpoints=worst["de"],
        diverged_at_s=stepper.diverged_at_s,
        finite=bool(stepper.diverged is None and np.all(np.isfinite(world.body_pos))),
        warmup_s=warm))


# ------------------------------------------------------------- free-body scenes ---

def _run_free(args, model):
    world = make_world(model, args.variant)
    stepper = Stepper(world)
    steps = T.steps(args.scene)
    done, loop = C.run_loop(stepper, steps, args.budget)
    pen, ncon = _penetration(world)
    return world, stepper, world.body_pos.copy(), done, steps, loop, dict(
        max_penetration_m=pen, ncon=ncon, diverged_at_s=stepper.diverged_at_s)


def run_stack(args, model, warm):
    world, _, p1, done, steps, loop, extra = _run_free(args, model)
    return _result(args, world, done, steps, loop, dict(
        **C.stack_figures(np.array(S.stack_positions()), p1), **extra, warmup_s=warm))


def run_pyramid(args, model, warm):
    world, _, p1, done, steps, loop, extra = _run_free(args, model)
    return _result(args, world, done, steps, loop, dict(
        **C.pyramid_figures(np.array(S.pyramid_positions()), p1), **extra, warmup_s=warm))


def run_spheres(args, model, warm):
    world, _, p1, done, steps, loop, extra = _run_free(args, model)
    return _result(args, world, done, steps, loop, dict(
        **C.spheres_figures(p1, S.SPHERES["inner"]), **extra, warmup_s=warm))


# ------------------------------------------------------------------------ ragdoll ---

def run_ragdoll(args, model, warm):
    _, pd = C.ragdoll_mode(args.scene)
    world = make_world(model, args.variant, args.scene)
    control = None
    if pd and not args.variant.endswith("-pd"):
        control = T.ExplicitPD(world, S.ragdoll_pd_gains(S.ragdoll_parts(), pd)).apply
        c0 = time.perf_counter()
        control()                     # warm the control path too (NumPy, first-call costs)
        world.clear_forces()
        warm += time.perf_counter() - c0
    stepper = Stepper(world, control)
    steps = T.steps(args.scene)
    done, loop = C.run_loop(stepper, steps, args.budget)
    pelvis = world.model.body_index("pelvis")
    return _result(args, world, done, steps, loop, dict(
        pd=pd, diverged=stepper.diverged is not None, diverged_at_s=stepper.diverged_at_s,
        sim_time_end=float(world.time), ctrl_ms_per_step=1000.0 * stepper.ctrl_s / max(done, 1),
        pelvis_z_end=float(world.body_pos[pelvis][2]), max_joint_err_rad_end=T.joint_error(world),
        finite=bool(stepper.diverged is None and np.all(np.isfinite(world.body_pos))),
        warmup_s=warm))


def main():
    args = C.parse("tumble", list(VARIANTS), C.SCENES + EXTRA_SCENES)
    model = T.build(args.scene)
    warm = warm_up(model, args.variant)
    fn = {"chain": run_chain, "stack": run_stack, "pyramid": run_pyramid,
          "spheres": run_spheres}.get(args.scene, run_ragdoll)
    res = fn(args, model, warm)
    res["version"] = tumble.__version__
    C.emit(res)


if __name__ == "__main__":
    main()
