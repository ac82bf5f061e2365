"""Run the benchmark scenes in tumble and its peers and print one comparison table.

    python bench/run.py                                  # every scene, every installed engine
    python bench/run.py chain stack --engines tumble,mujoco
    python bench/run.py spheres --variant mujoco=default --budget 60 --json out.json

Each (scene, engine) run is a separate Python process (``python -m RUNNER SCENE``), so
engines never share a process, a crash stays contained, and every tumble run pays its
compilation outside the timed loop (see bench/bench_tumble.py). Engines whose Python package
is not installed are skipped with a note. Results go to bench/results/run.json (or --json).

Columns: ms/step is the wall time of the stepping loop divided by the steps done (control
included for the PD scenes); ratio is tumble's ms/step over the peer's (above 1: tumble is
slower); the quality column is the scene's figure of merit (see bench/README.md).
"""
import argparse
import datetime
import importlib.util
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
from bench import common as C  # noqa: E402

DEFAULT_SCENES = ["chain", "stack", "pyramid", "ragdoll600", "ragdoll600pd", "ragdoll1920",
                  "ragdoll1920pd", "spheres"]


class Engine:
    """A runner module, the package it needs, and which scenes it runs."""

    def __init__(self, module, package, scenes=None):
        self.module, self.package, self.scenes = module, package, scenes

    def available(self):
        return importlib.util.find_spec(self.package) is not None

    def runs(self, scene):
        return self.scenes is None or scene in self.scenes


ENGINES = {
    "tumble": Engine("bench.bench_tumble", "tumble"),
    "mujoco": Engine("bench.peers.bench_mujoco", "mujoco"),
    "pybullet": Engine("bench.peers.bench_pybullet", "pybullet"),
    # ODE, the engine the GAMES-105 course uses, through panda3d.ode (pip install panda3d)
    "ode": Engine("bench.peers.bench_ode", "panda3d"),
    # MuJoCo's own stable PD (position actuators, implicit damping): the figure to beat
    "mujoco_native_pd": Engine("bench.peers.mujoco_native_pd", "mujoco",
                               scenes=[s for s in C.SCENES if s.startswith("ragdoll")
                                       and s.endswith("pd")]),
}
# Each engine at its best setting for the scene (bench/README.md): MuJoCo's default Newton
# solver takes ~25x longer than CG on the 1000 spheres; tumble's default direct solver is
# dense, seconds a step with a thousand contacts, where PGS takes tens of milliseconds.
BEST_VARIANT = {("mujoco", "spheres"): "cg", ("tumble", "pyramid"): "pgs50",
                ("tumble", "spheres"): "pgs50", ("tumble", "ragdoll600pd"): "implicit-pd",
                ("tumble", "ragdoll1920pd"): "implicit-pd"}
# Steps of each scene the stage profile runs (the whole scene for the cheap ones).
PROFILE_STEPS = {"pyramid": 120, "spheres": 120}
# Time a run may take beyond its stepping budget (model building, compilation) before it is killed.
OVERHEAD_S = 900.0


def _env():
    """The environment of a runner: this checkout first on the import path."""
    return dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))


def run_one(engine, scene, variant, budget):
    """Run one (engine, scene) in a fresh interpreter; returns its RESULT dict, or a dict
    with 'error' (and the engine's last output lines) if it failed."""
    cmd = [sys.executable, "-m", ENGINES[engine].module, scene, "--budget", str(budget)]
    if variant:
        cmd += ["--variant", variant]
    env = _env()
    base = dict(engine=engine, scene=scene, variant=variant or "default")
    try:
        out = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                             timeout=budget + OVERHEAD_S)
    except subprocess.TimeoutExpired:
        return dict(base, error="timed out after %.0f s" % (budget + OVERHEAD_S))
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            res = json.loads(line[len("RESULT "):])
            res["runner"] = engine
            return res
    tail = (out.stderr or out.stdout).strip().splitlines()[-5:]
    return dict(base, error="exit code %d" % out.returncode, output=tail)


# --------------------------------------------------------------------- the table ---

def profile_one(scene, variant):
    """Per-stage times of tumble's step on ``scene`` (bench/bench_stages.py, in a fresh
    interpreter); its JSON record, or a dict with 'error'."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "stages.json"
        cmd = [sys.executable, "-m", "bench.bench_stages", scene, "--repeat", "1",
               "--json", str(out)]
        if variant:
            cmd += ["--variant", variant]
        if scene in PROFILE_STEPS:
            cmd += ["--steps", str(PROFILE_STEPS[scene])]
        try:
            run = subprocess.run(cmd, cwd=ROOT, env=_env(), capture_output=True, text=True,
                                 timeout=OVERHEAD_S)
        except subprocess.TimeoutExpired:
            return dict(scene=scene, error="timed out")
        if run.returncode != 0 or not out.exists():
            return dict(scene=scene, error=(run.stderr or run.stdout).strip().splitlines()[-1:])
        return json.loads(out.read_text())[0]


def profile_table(profiles):
    """One line per scene: microseconds per step of each stage that takes 2 % or more."""
    lines = ["tumble, where a step's time goes (us/step per stage; stages under 2 % left out):"]
    for p in profiles:
        if "error" in p:
            lines.append("  %-13s profile failed: %s" % (p["scene"], p["error"]))
            continue
        total = p["us_per_step"]
        parts = ", ".join("%s %.1f" % (k, v) for k, v in sorted(
            p["stages_us"].items(), key=lambda kv: -kv[1]) if v >= 0.02 * total)
        lines.append("  %-13s %8.1f us: %s%s" % (
            p["scene"], total, parts, " (first %d steps)" % p["steps"]
            if p["scene"] in PROFILE_STEPS else ""))
    return "\n".join(lines)


def startup():
    """Seconds to import tumble, build the stack and take its first step in a fresh
    interpreter: with an empty Numba cache (the whole step compiles), then with it warm
    (``bench_startup.scene``; a free body compiles only its own few kernels, see
    ``bench_startup.py`` for the demo)."""
    from bench.bench_startup import scene
    with tempfile.TemporaryDirectory() as cache:
        cold, warm = scene("stack", "default", cache), scene("stack", "default", cache)
    return dict(scene="stack", cold_s=cold["process_s"], warm_s=warm["process_s"],
                cold_peak_mb=cold["peak_mb"])


def _mm(x):
    return "%.3g mm" % (1000.0 * float(x))


def quality(r):
    """The scene's figures of merit, as one short string."""
    if "error" in r:
        return "FAILED: %s %s" % (r["error"], " | ".join(r.get("output", [])[-1:]))
    scene = r["scene"]
    if scene == "chain":
        at = r.get("diverged_at_s")
        s = "sep %s, |dE|max %.3g" % (_mm(r["joint_sep_mm"] / 1000.0),
                                      r["max_abs_rel_energy_change_1s_checkpoints"])
        if at is None:
            s += ", dE end %+.3g (of M g L/2), no divergence" % r["rel_energy_change"]
        else:
            s += " (of M g L/2) until it diverged at t = %.2f s" % at
    elif scene == "stack":
        s = "%s, top drift %s, pen %s" % ("stood" if r["stood"] else "FELL",
                                          _mm(r["top_drift_m"]), _mm(r["max_penetration_m"]))
    elif scene == "pyramid":
        s = "%s, max motion %.3g m, pen %s" % ("stood" if r["stood"] else "collapsed",
                                               r["max_disp_m"], _mm(r["max_penetration_m"]))
    elif scene == "spheres":
        s = "escaped %d, pen %s" % (r["escaped"], _mm(r["max_penetration_m"]))
    else:
        s = "%s%s, joint err %.3g rad, pelvis z %.2f m" % (
            "finite" if r["finite"] else "NOT finite", ", diverged" if r.get("diverged") else "",
            r["max_joint_err_rad_end"], r["pelvis_z_end"])
        if r.get("ctrl_ms_per_step"):
            s += ", ctrl %.3f ms/step" % r["ctrl_ms_per_step"]
    if r.get("partial") and not (r.get("diverged") or r.get("diverged_at_s") is not None):
        s += " [partial: %d/%d steps in the budget]" % (r["steps"], r["steps_planned"])
    elif r.get("partial"):
        s += " [stopped at step %d/%d]" % (r["steps"], r["steps_planned"])
    return s


def table(results):
    """Rows: scene, engine (variant), ms/step, tumble/peer ratio, quality."""
    # A tumble run that diverged stopped after a few (cheap) steps: no ratio from it.
    tumble_ms = {r["scene"]: r["ms_per_step"] for r in results
                 if r.get("runner") == "tumble" and "ms_per_step" in r
                 and not (r["partial"] and r.get("diverged_at_s") is not None)}
    rows = [("scene", "engine", "ms/step", "tumble/peer", "quality")]
    for r in results:
        name = r.get("runner", r["engine"])
        variant = r.get("variant", "default")
        engine = name if variant in ("default", None) else "%s (%s)" % (name, variant)
        ms = r.get("ms_per_step")
        ratio = ""
        if ms and name != "tumble" and r["scene"] in tumble_ms:
            ratio = "%.3g" % (tumble_ms[r["scene"]] / ms)
        rows.append((r["scene"], engine, "%.4g" % ms if ms is not None else "-", ratio, quality(r)))
    widths = [max(len(row[k]) for row in rows) for k in range(4)]
    lines = []
    for i, row in enumerate(rows):
        lines.append("  ".join(c.ljust(w) if k < 2 else c.rjust(w)
                               for k, (c, w) in enumerate(zip(row[:4], widths))) + "  " + row[4])
        if i == 0:
            lines.append("-" * len(lines[0].rstrip()))
    return "\n".join(lines)


def machine():
    """What the figures were measured on."""
    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return dict(cpu=cpu, cores=os.cpu_count(), python=platform.python_version(),
                platform=platform.platform(),
                date=datetime.datetime.now().isoformat(timespec="seconds"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=DEFAULT_SCENES, metavar="SCENE",
                    help="scenes to run (default: %s; also: %s)" % (
                        " ".join(DEFAULT_SCENES),
                        " ".join(s for s in C.SCENES if s not in DEFAULT_SCENES)))
    ap.add_argument("--engines", default=",".join(ENGINES),
                    help="comma-separated, from %s (default: all)" % ", ".join(ENGINES))
    ap.add_argument("--variant", action="append", default=[], metavar="ENGINE=VARIANT",
                    help="run ENGINE with this variant in every scene (repeatable); default: "
                         "each engine's default, except MuJoCo with solver CG on the spheres "
                         "and tumble with PGS on the pyramid and the spheres")
    ap.add_argument("--budget", type=float, default=300.0,
                    help="seconds of stepping per run before it is cut short (marked partial)")
    ap.add_argument("--no-profile", dest="profile", action="store_false",
                    help="skip tumble's per-stage profile of each scene")
    ap.add_argument("--no-startup", dest="startup", action="store_false",
                    help="skip timing tumble's start-up (import and first step, Numba "
                         "cache cold and warm: about two minutes)")
    ap.add_argument("--json", default=str(ROOT / "bench" / "results" / "run.json"),
                    help="where to write all results (default: bench/results/run.json)")
    args = ap.parse_args()

    bad = [s for s in args.scenes if s not in C.SCENES]
    if bad:
        ap.error("unknown scene(s) %s; choose from %s" % (", ".join(bad), " ".join(C.SCENES)))
    engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    unknown = [e for e in engines if e not in ENGINES]
    if unknown:
        ap.error("unknown engine(s) %s; choose from %s" % (", ".join(unknown), ", ".join(ENGINES)))
    variants = {}
    for item in args.variant:
        engine, _, variant = item.partition("=")
        if engine not in ENGINES or not variant:
            ap.error("--variant takes ENGINE=VARIANT, got %r" % item)
        variants[engine] = variant
    missing = [e for e in engines if not ENGINES[e].available()]
    for e in missing:
        print("note: %s is not installed (package '%s'); skipped" % (e, ENGINES[e].package),
              file=sys.stderr)

    results = []
    for scene in args.scenes:
        for engine in engines:
            if engine in missing or not ENGINES[engine].runs(scene):
                continue
            variant = variants.get(engine, BEST_VARIANT.get((engine, scene)))
            print("running %s on %s ..." % (scene, engine), file=sys.stderr, flush=True)
            results.append(run_one(engine, scene, variant, args.budget))

    print(table(results))
    profiles, start = [], None
    if "tumble" in engines and args.profile:
        for scene in args.scenes:
            print("profiling %s in tumble ..." % scene, file=sys.stderr, flush=True)
            profiles.append(profile_one(scene, variants.get(
                "tumble", BEST_VARIANT.get(("tumble", scene)))))
        print()
        print(profile_table(profiles))
    if "tumble" in engines and args.startup:
        print("timing tumble's start-up ...", file=sys.stderr, flush=True)
        start = startup()
        print("\ntumble start-up (import, build the stack, first step): %.1f s with Numba's "
              "cache cold (peak %.0f MB), %.2f s warm" % (start["cold_s"], start["cold_peak_mb"],
                                                          start["warm_s"]))
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(dict(machine=machine(), budget_s=args.budget, skipped=missing,
                                   results=results, profiles=profiles, startup=start),
                              indent=1))
    print("\nwritten: %s" % out)


if __name__ == "__main__":
    main()
