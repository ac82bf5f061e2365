"""Record the ragdoll demo, replay-ready: save the recording, a GIF, an MP4 and two plots.

    python examples/record_and_export.py [--seconds 3] [--out out/]
    tumble view out/ragdoll.npz          # then scrub through it in the browser

Needs tumble[viewer] (software rendering: no display or GPU).
"""
import argparse
import os

from tumble.apps import scenes
from tumble.viewer import Recorder, export_video, plots


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--out", default="out")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)

    world = scenes.ragdoll()                          # 18-body figure and two crates
    rec = Recorder(world, contacts=True, energy=True)    # frames of poses, contacts, energy
    rec.run(args.seconds, fps=60, progress=True)      # steps the world, a frame per 1/60 s
    recording = rec.recording()
    path = recording.save(os.path.join(args.out, "ragdoll.npz"))
    print(f"{len(recording)} frames saved to {path}")

    for name, size in (("ragdoll.gif", (480, 270)), ("ragdoll.mp4", (640, 360))):
        n = export_video(recording, os.path.join(args.out, name), fps=25, size=size)
        print(f"{n} frames written to {os.path.join(args.out, name)}")

    plots.plot_energy(recording, path=os.path.join(args.out, "energy.png"),
                      title="Ragdoll: energy (joint friction and impacts dissipate it)")
    plots.plot_contact_forces(recording, bodies=["pelvis", "chest", "crate0"],
                              path=os.path.join(args.out, "contacts.png"))
    print(f"plots written to {args.out}/energy.png and {args.out}/contacts.png")


if __name__ == "__main__":
    main()
