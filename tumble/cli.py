"""The ``tumble`` command: ``tumble demo`` runs the demo, ``tumble info`` shows the set-up,
``tumble view MODEL`` opens the browser viewer, ``tumble record`` and ``tumble export`` make
recordings and videos (see ``tumble.viewer.sources`` for what MODEL may be; a trained
policy file is one), ``tumble train imitate CLIP`` trains a policy (needs ``tumble[rl]``)
and ``tumble play POLICY`` shows it in the browser viewer."""
import argparse
import functools
import importlib.util
import math
import os
import sys

# training lines go out as they are written, also into a log file (--no-progress)
_say = functools.partial(print, flush=True)


def _demo(args):
    from .apps import racket
    print("(the first run compiles the few kernels a free body needs: about 20 s; later runs "
          "start at once)", flush=True)
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


def _follow(text, control=None):
    """The body the camera follows: as asked, or for a policy (not asked) its root body."""
    play = sys.modules.get("tumble.rl.play")       # loaded if MODEL was a policy
    if text is None and play is not None and isinstance(control, play.PolicyDriver):
        env = control.env
        return env.model.body_names[env.root]
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
                    speed=args.speed, control=control, follow=_follow(args.follow, control),
                    contacts=args.contacts, forces=args.forces, joints=args.joints,
                    com=args.com, lighting=args.lighting, verbose=False)
    _steering_controls(viewer, control)
    viewer.serve_forever(announce=True)
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
                     follow=_follow(args.follow, control), contacts=args.contacts,
                     com=args.com, progress=None)
    print(f"{n} frames written to {args.output}")
    return 0


def _train(args):
    missing = [name for name, module in (("PyTorch", "torch"), ("rsl-rl", "rsl_rl"))
               if importlib.util.find_spec(module) is None]
    if missing:
        print(f"tumble train: error: training needs PyTorch and rsl-rl ({' and '.join(missing)} "
              f"missing): pip install \"tumble[rl]\"", file=sys.stderr)
        return 2
    distributed = args.workers is not None or args.ray is not None
    if distributed and importlib.util.find_spec("ray") is None:
        print('tumble train: error: --workers and --ray need Ray: pip install "tumble[ray]"',
              file=sys.stderr)
        return 2
    try:
        from .rl.train import TrainConfig, Trainer
        make_trainer = Trainer
        if distributed:
            import functools
            from .rl.distributed import RayTrainer
            make_trainer = functools.partial(RayTrainer, workers=args.workers or 2,
                                             address=args.ray)
    except ImportError as exc:          # installed, but broken (e.g. a mismatched version)
        print(f"tumble train: error: {exc}", file=sys.stderr)
        return 2
    def named(clip):
        """A course clip name as it is; a BVH path made absolute (the policy's spec names
        its clips, so it plays from any directory), and its file stem for the run's name."""
        if clip.lower().endswith(".bvh"):
            return os.path.abspath(clip), os.path.splitext(os.path.basename(clip))[0]
        return clip, clip

    if args.task == "amp":
        from .rl.tasks.amp import DEFAULT_CLIPS
        pairs = [named(c) for c in (args.clips or DEFAULT_CLIPS)]
        clips = tuple(c for c, _ in pairs)
        clip, stem = ", ".join(clips), "-".join(s for _, s in pairs)
        args.clip = None
    else:
        clip, stem = named(args.clip or "walk")
    out = args.out or os.path.join("runs", f"{args.task}-{stem}")
    checkpoint = os.path.join(out, "checkpoint.pt")
    progress = not args.no_progress
    env_settings = _amp_env_settings(args) if args.task == "amp" else {}
    if args.resume:
        # the run goes on as it was configured; only its length and schedule (and the AMP
        # command settings, a curriculum) may change
        overrides = env_settings or None
        trainer = make_trainer(out, None, resume=True, progress=progress, log=_say,
                               env_overrides=overrides)
        c = trainer.config
        ignored = [f"{flag} {value}" for flag, value, kept in (
            ("CLIP", args.clip, c.clip), ("--envs", args.envs, c.num_envs),
            ("--seed", args.seed, c.seed)) if value is not None and value != kept]
        if ignored:
            kept = ", ".join(c.clips) if c.task == "amp" else repr(c.clip)
            print(f"tumble train: note: the resumed run keeps its clip {kept}, "
                  f"{c.num_envs} characters and seed {c.seed}; ignored: {', '.join(ignored)}",
                  file=sys.stderr)
        if args.iterations is not None:
            c.iterations = args.iterations
        if args.eval_every is not None:
            c.eval_every = args.eval_every
        if args.fixed_std is not None:
            trainer.fix_std(args.fixed_std)
        if args.gamma is not None:
            trainer.set_gamma(args.gamma)
    else:
        if os.path.exists(checkpoint):
            # never overwrite a run (it may be training right now): appended logs and a
            # replaced checkpoint would mix two runs
            print(f"tumble train: error: {out} already holds a run ({checkpoint}); continue it "
                  f"with --resume or choose another --out", file=sys.stderr)
            return 2
        given = {k: v for k, v in (("num_envs", args.envs), ("iterations", args.iterations),
                                   ("eval_every", args.eval_every), ("seed", args.seed))
                 if v is not None}
        if args.fixed_std is not None:
            given.update(init_std=args.fixed_std, learn_std=False)
        if args.gamma is not None:
            given["gamma"] = args.gamma
        if args.task == "amp":
            if args.init_from:
                given["init_from"] = args.init_from
            if env_settings:
                given["env_kwargs"] = env_settings
            config = TrainConfig.for_task("amp", clips=clips, **given)
        else:
            config = TrainConfig.for_task("imitate", clip=clip, **given)
        print(f"tumble train: {args.task} {clip!r} with {config.num_envs} characters, "
              f"{config.iterations} iterations, in {out}", flush=True)
        trainer = make_trainer(out, config, progress=progress, log=_say)
    try:
        trainer.run(max_hours=args.hours)
    except KeyboardInterrupt:
        # keep what was learnt: the networks as of the last finished update (a rollout
        # under way is lost), so that --resume goes on from here
        trainer.save()
        print(f"\ntumble train: interrupted at iteration {trainer.iteration}; saved, continue "
              f"with: tumble train {args.task} --out {out} --resume", file=sys.stderr)
        return 130
    finally:
        if hasattr(trainer, "close"):          # Ray workers
            trainer.close()
    policy = os.path.join(out, "policy.npz")
    print(f"tumble train: iteration {trainer.iteration}, {trainer.samples} samples, "
          f"{trainer.wall / 3600:.2f} h; policy written to {policy}", flush=True)
    print(f"watch it: tumble play {policy}", flush=True)
    return 0



def _run_options(parser, default_dir, *, envs):
    """The options every training task takes."""
    parser.add_argument("--out", metavar="DIR",
                        help=f"run directory (default: runs/{default_dir}): checkpoint.pt, "
                             f"policy.npz, best.npz, progress.csv, eval.csv")
    parser.add_argument("--envs", type=_positive(int), metavar="N",
                        help=f"characters simulated together (default {envs})")
    parser.add_argument("--iterations", type=_positive(int), metavar="K",
                        help="PPO iterations in all, counting those of a resumed run "
                             "(default 1000)")
    parser.add_argument("--hours", type=_positive(float), metavar="H",
                        help="stop (and save) after this much wall time")
    parser.add_argument("--resume", action="store_true",
                        help="continue the run in DIR from its checkpoint")
    parser.add_argument("--seed", type=int, metavar="S", help="random seed (default 0)")
    parser.add_argument("--eval-every", type=_non_negative(int), metavar="K",
                        help="evaluate every K iterations; 0: never (default 50)")
    parser.add_argument("--fixed-std", type=_positive(float), metavar="S",
                        help="hold the policy's action noise at S instead of learning it (as "
                             "the AMP paper does); with --resume it replaces the run's")
    parser.add_argument("--gamma", metavar="G",
                        type=_number(float, 0, 1, open_low=True, open_high=True),
                        help="PPO's discount, in (0, 1) (default 0.95: a horizon of 1/(1-G) "
                             "policy steps, 0.67 s at 30 Hz); with --resume it replaces the "
                             "run's and the critic alone trains for 40 iterations")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--workers", type=_positive(int), metavar="K",
                        help="collect the samples in K Ray workers of N characters each "
                             "(needs tumble[ray]; a local Ray cluster unless --ray)")
    parser.add_argument("--ray", metavar="ADDRESS",
                        help="the Ray cluster to run the workers on ('auto' or HOST:PORT; "
                             "start it with 'ray start --head')")

def _play(args):
    from .rl.play import policy_world
    from .viewer.app import Viewer
    world, driver, env = policy_world(args.policy, restart_after=args.seconds,
                                      fall_delay=args.fall_delay, seed=args.seed)
    root = env.model.body_names[env.root]
    info = driver.policy.info
    trained = ""
    if info.get("samples") is not None:
        trained = (f", trained on {int(info['samples']):,} samples "
                   f"({float(info.get('wall_hours', 0.0)):.1f} h)")
    print(f"tumble play: {driver.policy!r}{trained}", flush=True)
    viewer = Viewer(world, host=args.host, port=args.port, paused=args.paused,
                    speed=args.speed, control=driver, follow=root, contacts=args.contacts,
                    verbose=False)
    _steering_controls(viewer, driver)          # a steering policy: heading and speed
    viewer.serve_forever(announce=True)
    return 0


def _steering_controls(viewer, control):
    """A steering (AMP) policy gets heading and speed controls on the viewer's page."""
    if getattr(control, "clip_time", 0.0) is None:
        from .rl.play import add_steering_gui
        add_steering_gui(viewer, control)
        print("tumble: steer the character with the page's Command folder (speed, heading, "
              "turn buttons)", flush=True)


def _amp_env_settings(args):
    """The AMPEnv keywords the command line sets: task reward and the random commands."""
    settings = {}
    if args.task_reward:
        settings["task_reward"] = args.task_reward
    if args.task_scale is not None:
        settings["task_scale"] = args.task_scale
    if args.max_turn is not None:
        settings["max_turn"] = math.radians(args.max_turn)
    if args.command_seconds is not None:
        settings["command_seconds"] = tuple(args.command_seconds)
    if args.speed_range is not None:
        settings["speed_range"] = tuple(args.speed_range)
    return settings


def _number(kind=float, low=None, high=None, *, open_low=False, open_high=False, what=None):
    """An argparse type: a finite number of ``kind`` (int or float) in [low, high], an end
    that is None unbounded and ``open_low``/``open_high`` leaving that end out."""
    noun = what or ("an integer" if kind is int else "a number")
    if high is None:
        wanted = f"{'>' if open_low else '>='} {low:g}"
    else:
        wanted = f"in {'(' if open_low else '['}{low:g}, {high:g}{')' if open_high else ']'}"

    def parse(text):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {noun}, got {text!r}")
        inside = (math.isfinite(v) and (v > low if open_low else v >= low) and
                  (high is None or (v < high if open_high else v <= high)))
        if not inside:
            raise argparse.ArgumentTypeError(f"must be {wanted}, got {text!r}")
        return v
    return parse


def _positive(kind):
    return _number(kind, 0, open_low=True)


def _non_negative(kind):
    return _number(kind, 0)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="tumble", description="tumble rigid-body dynamics")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="the tennis-racket flip, printed as it happens")
    demo.add_argument("--seconds", type=float, default=20.0)
    demo.add_argument("--plot", metavar="PNG", help="also save a plot (needs tumble[plots])")
    demo.set_defaults(func=_demo)
    info = sub.add_parser("info", help="versions of tumble and its dependencies")
    info.set_defaults(func=_info)

    model_help = ("a .py file defining world, model or build(), a .npz recording or trained "
                  "policy, an MJCF .xml file (when tumble.load_mjcf exists) or a demo name "
                  "(ragdoll, stack, chain, racket)")
    view = sub.add_parser("view", help="the browser viewer (needs tumble[viewer])")
    view.add_argument("model", metavar="MODEL", help=model_help)
    view.add_argument("--host", default="127.0.0.1")
    view.add_argument("--port", type=int, default=8080, help="0 picks a free port")
    view.add_argument("--paused", action="store_true", help="start paused")
    view.add_argument("--speed", type=float, default=1.0, help="simulated s per wall s")
    view.add_argument("--follow", help="camera follows 'com', a body name or 'off' (default: "
                                       "off; for a policy, its character's root)")
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
    export.add_argument("--follow", help="camera follows 'com', a body name or 'off' "
                                         "(default: off; for a policy, its character's root)")
    export.add_argument("--contacts", action="store_true", help="draw contacts and forces")
    export.add_argument("--com", action="store_true", help="mark the centre of mass")
    export.add_argument("--save-recording", metavar="REC.npz")
    export.set_defaults(func=_export)

    train = sub.add_parser("train", help="train a policy with PPO (needs tumble[rl]: PyTorch "
                                         "and rsl-rl)")
    tasks = train.add_subparsers(dest="task", required=True, metavar="TASK")
    imitate = tasks.add_parser("imitate", help="DeepMimic-style imitation of a motion clip")
    imitate.add_argument("clip", metavar="CLIP", nargs="?", default=None,
                         help="a course clip name (walk, run, idle) or a BVH path "
                              "(default: walk)")
    _run_options(imitate, "imitate-CLIP", envs=128)
    imitate.set_defaults(func=_train)

    amp = tasks.add_parser("amp", help="adversarial motion priors: a character steered by "
                                       "heading and speed commands in the style of clips")
    amp.add_argument("clips", metavar="CLIPS", nargs="*",
                     help="course clip names (walk, run, idle) or BVH paths "
                          "(default: walk run idle)")
    _run_options(amp, "amp-CLIPS (runs/amp-walk-run-idle)", envs=256)
    amp.add_argument("--init-from", metavar="POLICY",
                     help="start from an imitation policy (a file or a shipped name: 'walk'), "
                          "behaviour-cloned into the steering actor; the first 40 iterations "
                          "then train only the critic")
    amp.add_argument("--task-reward", choices=("vector", "along", "speed"),
                     help="the task reward: the whole velocity against the command "
                          "('vector', the default), as AMP's paper only a shortfall of the "
                          "speed along the commanded direction ('along'), or that speed "
                          "matched both ways ('speed')")
    amp.add_argument("--task-scale", type=_positive(float), metavar="K",
                     help="the task reward's sharpness k in exp(-k error^2), error in m/s "
                          "(default 1: 0.2 m/s off still earns 0.96; 4: 0.85)")
    amp.add_argument("--max-turn", type=_number(float, 0.0, 180.0, what="degrees"), metavar="DEG",
                     help="largest heading change of a random command (default 180)")
    amp.add_argument("--command-seconds", type=_non_negative(float), nargs=2,
                     metavar=("LOW", "HIGH"),
                     help="seconds between random command changes, drawn uniformly "
                          "(default 2 5)")
    amp.add_argument("--speed-range", type=_non_negative(float), nargs=2, metavar=("LOW", "HIGH"),
                     help="commanded speeds (m/s), drawn uniformly (default 0.4 2.2); these "
                          "five settings, given with --resume, replace the run's from then on "
                          "(a curriculum)")
    amp.set_defaults(func=_train)

    play = sub.add_parser("play", help="a trained policy in the browser viewer (needs "
                                       "tumble[viewer])")
    play.add_argument("policy", metavar="POLICY",
                      help="a policy .npz (e.g. runs/imitate-walk/policy.npz) or the name "
                           "of a shipped policy")
    play.add_argument("--host", default="127.0.0.1")
    play.add_argument("--port", type=int, default=8080, help="0 picks a free port")
    play.add_argument("--seconds", type=_positive(float), metavar="S",
                      help="also start the character over every S simulated seconds "
                           "(default: only about 1 s after a fall)")
    play.add_argument("--fall-delay", type=float, default=1.0, metavar="S",
                      help="seconds a fall is shown before starting over (default 1)")
    play.add_argument("--seed", type=int, help="seed of the start phases")
    play.add_argument("--paused", action="store_true", help="start paused")
    play.add_argument("--speed", type=float, default=1.0, help="simulated s per wall s")
    play.add_argument("--contacts", action="store_true", help="show contact points")
    play.set_defaults(func=_play)

    args = parser.parse_args(argv)
    if args.command in ("view", "record", "export", "train", "play"):
        from .errors import TumbleError
        try:
            return args.func(args)
        except TumbleError as exc:
            print(f"tumble {args.command}: error: {exc}", file=sys.stderr)
            return 2
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
