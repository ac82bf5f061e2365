"""Track walk_forward.bvh with the course character: PD servos plus a hand of god.

    python examples/track_walk.py [--no-hand] [--substeps 1] [--gif out/walk.gif]

Prints the mean and worst joint error per frame and how far the root strays from the clip.
"""
import argparse
from pathlib import Path

import tumble
from tumble.character import MotionTracker

HERE = Path(__file__).resolve().parent
CLIP = HERE.parent / "tests" / "data" / "games105" / "walk_forward.bvh"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default=str(CLIP))
    ap.add_argument("--no-hand", action="store_true", help="no hand of god (it will fall)")
    ap.add_argument("--substeps", type=int, default=1)
    ap.add_argument("--kp", type=float, default=1000.0)
    ap.add_argument("--kd", type=float, default=30.0)
    ap.add_argument("--gif", help="record the run and export it (.gif or .mp4; tumble[viewer])")
    a = ap.parse_args()
    motion = tumble.load_bvh(a.clip)
    rd = tumble.games105_ragdoll(root="floating")
    world = rd.make_world()
    hand = None if a.no_hand else dict(kp=2000, kd=200, kp_rot=1000, kd_rot=100)
    tracker = MotionTracker(world, rd, motion, kp=a.kp, kd=a.kd, max_torque=200.0,
                            hand_of_god=hand, substeps=a.substeps)
    recorder = None
    if a.gif:
        recorder = tumble.Recorder(world, capture_now=False)
        result = tracker.run(on_frame=lambda w, f: recorder.capture())
    else:
        result = tracker.run()
    print(f"{len(result.time)} frames at {1 / motion.frame_time:.0f} Hz, "
          f"physics dt {world.dt:.4g} s, hand of god: {'off' if hand is None else 'on'}")
    print(f"mean joint error {result.mean_joint_error:.4f} rad, worst frame mean "
          f"{result.joint_error.max():.4f} rad, worst joint {result.max_joint_error.max():.3f} rad")
    print(f"root error mean {result.root_error.mean() * 100:.1f} cm, max "
          f"{result.root_error.max() * 100:.1f} cm; hand-of-god force mean "
          f"{result.root_force.mean():.0f} N")
    if recorder is not None:
        from tumble.viewer import export_video
        n = export_video(recorder.recording(), a.gif, fps=25, size=(560, 315),
                         follow=world.model.body_names[tracker.root_body])
        print(f"{n} frames written to {a.gif}")


if __name__ == "__main__":
    main()
