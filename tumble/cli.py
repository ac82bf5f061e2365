"""The ``tumble`` command: ``tumble demo`` runs the demo, ``tumble info`` shows the set-up,
``tumble view MODEL`` opens the browser viewer, ``tumble record`` and ``tumble export`` make
recordings and videos (see ``tumble.viewer.sources`` for what MODEL may be)."""
import argparse
import sys


def _demo(args):
    from .apps import racket
    print("(the first run compiles tumble's kernels: several minutes on 2 cores (up to 9 seen); "
          "later runs start at once)", flush=True)
    times, omegas, summary = racket.run(seconds=args.seconds)
    if args.plot:
        racket.plot(times, omegas, args.plot)
        print(f"plot written to {args.plot}")
    return 0 if summary["flips"] > 0 else 1


def _info(args):
    import numba
    import numpy
    import scipy

    import tumble
    print(f"tumble {tumble.__version__}: numpy {numpy.__version__}, scipy {scipy.__version__}, "
          f"numba {numba.__version__}, python {sys.version.split()[0]}")
    return 0


def _size(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must be WIDTHxHEIGHT, e.g. 640x360, got {text!r}")
    return w, h


def _follow(text):
    return None if text in (None, "off") else text


def _record(source, control, seconds, fps, contacts=True):
    """A Recording of ``seconds`` of a live world (or the recording itself)."""
    from .viewer import Recorder, Recording
    if isinstance(source, Recording):
        return source
    rec = Recorder(source, contacts=contacts, energy=True, joints=True)
    rec.run(seconds, fps=fps, control=control, progress=None)
    return rec.recording()


def _view(args):
    from .viewer.app import Viewer
    from .viewer.sources import load_source
    source, control = load_source(args.model)
    viewer = Viewer(source, host=args.host, port=args.port, paused=args.paused,
                    speed=args.speed, control=control, follow=_follow(args.follow),
                    contacts=args.contacts, forces=args.forces, joints=args.joints,
                    com=args.com, lighting=args.lighting, verbose=False)
    print(f"tumble viewer: open {viewer.url} in a browser (Ctrl-C to stop)", flush=True)
    viewer.serve_forever()
    return 0


def _record_cmd(args):
    from .viewer.sources import load_source
    source, control = load_source(args.model)
    path = _record(source, control, args.seconds, args.fps).save(args.output)
    print(f"recording written to {path}")
    return 0


def _export(args):
    from .viewer.export import export_video
    from .viewer.sources import load_source
    source, control = load_source(args.model)
    rec = _record(source, control, args.seconds, max(args.fps, 30.0),
                  contacts=args.contacts)
    if args.save_recording:
        print(f"recording written to {rec.save(args.save_recording)}")
    n = export_video(rec, args.output, fps=args.fps, size=args.size, speed=args.speed,
                     follow=_follow(args.follow), contacts=args.contacts, com=args.com,
                     progress=None)
    print(f"{n} frames written to {args.output}")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(prog="tumble", description="tumble rigid-body dynamics")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the tennis-racket flip, printed as it happens")
    demo.add_argument("--seconds", type=float, default=20.0)
    demo.add_argument("--plot", metavar="PNG", help="also save a plot (needs tumble[plots])")
    demo.set_defaults(func=_demo)
    info = sub.add_parser("info", help="versions of tumble and its dependencies")
    info.set_defaults(func=_info)

    model_help = ("a .py file defining world, model or build(), a .npz recording, "
                  "an MJCF .xml file (when tumble.load_mjcf exists) or a demo name "
                  "(ragdoll, stack, chain, racket)")
    view = sub.add_parser("view", help="the browser viewer (needs tumble[viewer])")
    view.add_argument("model", metavar="MODEL", help=model_help)
    view.add_argument("--host", default="127.0.0.1")
    view.add_argument("--port", type=int, default=8080, help="0 picks a free port")
    view.add_argument("--paused", action="store_true", help="start paused")
    view.add_argument("--speed", type=float, default=1.0, help="simulated s per wall s")
    view.add_argument("--follow", help="camera follows 'com' or a body name")
    for flag, what in (("contacts", "contact points"), ("forces", "contact forces"),
                       ("joints", "joint axes"), ("com", "the centre of mass")):
        view.add_argument(f"--{flag}", action="store_true", help=f"show {what}")
    view.add_argument("--lighting", choices=("simple", "studio"), default="simple")
    view.set_defaults(func=_view)

    record = sub.add_parser("record", help="simulate MODEL and save a .npz recording")
    record.add_argument("model", metavar="MODEL", help=model_help)
    record.add_argument("output", metavar="OUT.npz")
    record.add_argument("--seconds", type=float, default=5.0)
    record.add_argument("--fps", type=float, default=60.0, help="frames kept per second")
    record.set_defaults(func=_record_cmd)

    export = sub.add_parser("export", help="render MODEL or a recording to .mp4, .gif or "
                                           ".png without a display (needs tumble[viewer])")
    export.add_argument("model", metavar="MODEL", help=model_help)
    export.add_argument("output", metavar="OUT", help="a .mp4, .gif or .png file")
    export.add_argument("--seconds", type=float, default=5.0,
                        help="simulated time when MODEL is not a recording")
    export.add_argument("--fps", type=float, default=30.0)
    export.add_argument("--size", type=_size, default=(640, 360), help="WIDTHxHEIGHT")
    export.add_argument("--speed", type=float, default=1.0, help="0.5: slow motion")
    export.add_argument("--follow", help="camera follows 'com' or a body name")
    export.add_argument("--contacts", action="store_true", help="draw contacts and forces")
    export.add_argument("--com", action="store_true", help="mark the centre of mass")
    export.add_argument("--save-recording", metavar="REC.npz")
    export.set_defaults(func=_export)

    args = parser.parse_args(argv)
    if args.command in ("view", "record", "export"):
        from .errors import TumbleError
        try:
            return args.func(args)
        except TumbleError as exc:
            print(f"tumble {args.command}: error: {exc}", file=sys.stderr)
            return 2
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
