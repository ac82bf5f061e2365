"""The ``tumble`` command: ``tumble demo`` runs the demo, ``tumble info`` shows the set-up."""
import argparse
import sys


def _demo(args):
    from .apps import racket
    print("(the first run compiles tumble's kernels, about a minute; later runs start at once)",
          flush=True)
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


def main(argv=None):
    parser = argparse.ArgumentParser(prog="tumble", description="tumble rigid-body dynamics")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the tennis-racket flip, printed as it happens")
    demo.add_argument("--seconds", type=float, default=20.0)
    demo.add_argument("--plot", metavar="PNG", help="also save a plot (needs tumble[plots])")
    demo.set_defaults(func=_demo)
    info = sub.add_parser("info", help="versions of tumble and its dependencies")
    info.set_defaults(func=_info)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
