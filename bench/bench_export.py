"""Speed of the headless video export: a 10 s clip at 30 fps of the 20-body ragdoll demo.

    python bench/bench_export.py [--size 640x360] [--seconds 10] [--fps 30]

Simulates the ragdoll demo (18-body figure and two crates) for the clip's length, then
times ``export_video`` to MP4 and to GIF (software rendering, no display), and prints the
wall time per clip and per frame. Run on demand; timings are never asserted in tests.
"""
import argparse
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from tumble.apps import scenes  # noqa: E402
from tumble.viewer import Recorder, export_video  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="640x360")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--fps", type=float, default=30.0)
    args = ap.parse_args()
    size = tuple(int(v) for v in args.size.split("x"))

    world = scenes.ragdoll()
    world.step(1)                                    # compile (or load) the kernels first
    world = scenes.ragdoll()
    t0 = time.perf_counter()
    rec = Recorder(world, contacts=True).run(args.seconds, fps=args.fps, progress=False)
    t_sim = time.perf_counter() - t0
    recording = rec.recording()
    print(f"ragdoll demo: {world.model.nbody} bodies, {world.model.ngeom} geoms; "
          f"simulating {args.seconds:g} s took {t_sim:.2f} s")
    with tempfile.TemporaryDirectory() as tmp:
        for ext in ("mp4", "gif"):
            path = os.path.join(tmp, f"clip.{ext}")
            t0 = time.perf_counter()
            n = export_video(recording, path, fps=args.fps, size=size, progress=False)
            dt = time.perf_counter() - t0
            print(f"{ext}: {n} frames at {size[0]}x{size[1]} in {dt:.1f} s "
                  f"({1000 * dt / n:.1f} ms/frame, {os.path.getsize(path) / 1e6:.2f} MB)")


if __name__ == "__main__":
    main()
