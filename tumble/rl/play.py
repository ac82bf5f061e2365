"""Playing a trained policy where something else steps the world: the viewer, the recorder.

``tumble play POLICY``, ``tumble view POLICY.npz`` and ``tumble export POLICY.npz out.gif``
all come down to::

    policy = load_policy("walk")                  # a shipped policy, or a .npz path
    world, driver, env = policy_world(policy)     # one character, at a random clip phase
    Recorder(world).run(5.0, control=driver)      # or Viewer(world, control=driver)

:class:`PolicyDriver` is a controller ``control(world)``, called before every physics step
(as ``Viewer``, ``Recorder.run`` and ``tumble.viewer.simulate`` do). Every ``env.substeps``
calls -- one policy step, 1/30 s by default -- it does what ``ImitationEnv.step`` does
around the physics, in the same order: judge the last policy step (a fall?), observe, ask the
policy, move the clip time on and write the servo targets. The physics steps in between are
the caller's.

After a fall the character is left to fall for ``fall_delay`` seconds (1 s; a viewer shows
what went wrong) and then starts over at a random phase of the clip, as a training episode
does; with ``restart_after`` it also starts over after that many seconds on its feet.

The clip time lives in the driver, the body state in the world; when the world's time jumps
(the viewer's reset button, or playing on from a frame scrubbed back to) the driver puts the
clip time back where it was at that moment, so the policy sees the phase it saw then.
"""
import json
import os
import zipfile
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .policy import Policy

__all__ = ["PolicyDriver", "load_policy", "policy_world", "shipped_policies", "is_policy_file",
           "add_steering_gui", "POLICY_DIR"]

# Policies that ship with tumble: tumble/rl/policies/imitate_<name>.npz is "<name>".
POLICY_DIR = Path(__file__).resolve().parent / "policies"
_SHIPPED_PREFIX = "imitate_"


def shipped_policies():
    """{name: path} of the policies in ``tumble/rl/policies`` (``imitate_walk.npz`` is
    'walk'; another ``.npz`` there goes by its file name without the suffix)."""
    if not POLICY_DIR.is_dir():
        return {}
    out = {}
    for p in sorted(POLICY_DIR.glob("*.npz")):
        name = p.stem[len(_SHIPPED_PREFIX):] if p.stem.startswith(_SHIPPED_PREFIX) else p.stem
        out.setdefault(name, p)
    return out


def is_policy_file(path):
    """True if ``path`` is an ``.npz`` holding a policy (a ``meta`` entry whose JSON has a
    ``spec`` and ``layers``), False for anything else: a recording (it has a ``format``
    entry instead), another archive, a missing or unreadable file. Reads only ``meta``."""
    try:
        with np.load(path, allow_pickle=False) as z:
            if "meta" not in z.files:
                return False
            meta = json.loads(str(z["meta"]))
    except (OSError, ValueError, TypeError, zipfile.BadZipFile):
        return False
    return isinstance(meta, dict) and isinstance(meta.get("spec"), dict) and "layers" in meta


def load_policy(spec):
    """A :class:`Policy` from a policy file path, or the name of a shipped policy ('walk' is
    ``tumble/rl/policies/imitate_walk.npz``); a Policy is returned as it is. ModelError if
    there is no such file or name, naming the shipped policies."""
    if isinstance(spec, Policy):
        return spec
    text = os.fspath(spec)
    if os.path.isfile(text):
        return Policy.load(text)
    shipped = shipped_policies()
    if text in shipped:
        return Policy.load(shipped[text])
    names = ", ".join(sorted(shipped)) if shipped else "none yet"
    looks_like_path = text.endswith(".npz") or os.sep in text or (os.altsep or os.sep) in text
    what = f"no policy file {text!r}" if looks_like_path else \
        f"{text!r} is neither a policy file nor a shipped policy"
    raise ModelError(f"{what}; shipped policies ({POLICY_DIR}): {names}. Train one with "
                     f"'tumble train imitate CLIP' and give its policy.npz")


class _FixedStart:
    """Stands in for the env's random generator in ``_restart`` so that a world starts at a
    given clip time: ``uniform`` is how ``ImitationEnv._restart`` draws the start phase."""

    def __init__(self, t0):
        self.t0 = float(t0)

    def uniform(self, low, high, size):
        return np.full(size, self.t0)


class PolicyDriver:
    """Runs ``policy`` on ``env`` (an ImitationEnv of one world) as a controller
    ``driver(world)`` called before every physics step of ``env.world``.

    policy : a :class:`Policy` trained for ``env`` (checked with ``policy.check``).
    env : the ImitationEnv; its world is the one the caller steps, one step at a time.
    fall_delay : seconds (simulated) between a detected fall and the restart.
    restart_after : also start over after this many seconds (None: only after a fall).
    seed : seed of the restart phases (default: the env's generator).

    The character is put at a random clip phase when the driver is made. Counters:
    ``steps`` (policy steps taken), ``falls``, ``restarts`` (falls and time-outs that led to
    a fresh start); ``last_fall`` is the world time (s) of the last fall (None before one),
    ``reward`` the last policy step's imitation reward (0..1) and ``episode_start`` the
    world time (s) the current episode began.
    """

    def __init__(self, policy, env, *, fall_delay=1.0, restart_after=None, seed=None):
        if not isinstance(policy, Policy):
            raise ModelError(f"PolicyDriver: policy must be a tumble.rl Policy, got "
                             f"{type(policy).__name__}")
        if env.num_envs != 1:
            raise ModelError(f"PolicyDriver: drives one world; this env has {env.num_envs}")
        policy.check(env.spec())
        if not (np.isfinite(fall_delay) and fall_delay >= 0):
            raise ModelError(f"PolicyDriver: fall_delay must be >= 0 s, got {fall_delay!r}")
        if restart_after is not None and not (np.isfinite(restart_after) and restart_after > 0):
            raise ModelError(f"PolicyDriver: restart_after must be > 0 s or None, got "
                             f"{restart_after!r}")
        self.policy, self.env, self.world = policy, env, env.world
        # an imitation follows a clip in time; a steering task (AMP) follows commands
        self._follows_clip = hasattr(env, "ref_time")
        self._commanded = False
        self.fall_delay = float(fall_delay)
        self.restart_after = None if restart_after is None else float(restart_after)
        if seed is not None:
            env.seed(seed)
        self.steps = self.falls = self.restarts = 0
        self.reward = float("nan")
        self.last_fall = None
        self._obs = np.zeros((1, env.observation_size), np.float32)
        self._reward = np.zeros(1)
        self._terminated = np.zeros(1, np.bool_)
        # (world time, clip time) at the start of every episode so far: within an episode
        # the clip time runs with the world's, so these place any earlier moment on the clip
        self._episodes = []
        self._fallen_at = None      # world time of the fall being shown, or None
        self._substep = 0           # physics steps into the current policy step
        self._acted = False         # targets were written for the state now in the world
        self._start(None)
        self._expected = self.world.time    # the world time of the next call

    # -- the controller ------------------------------------------------------------------
    def __call__(self, world):
        """One physics step's control; a policy step every ``env.substeps`` calls."""
        if world is not self.world:
            raise ModelError("PolicyDriver: called with another world than its env's")
        t = float(world.time)
        half = 0.5 * world.dt
        if abs(t - self._expected) > half:
            self._resync(t)
        if self._substep == 0:
            self._policy_step(t)
        self._substep = (self._substep + 1) % self.env.substeps
        self._expected = t + world.dt       # what world.step(1) will make of world.time

    def _policy_step(self, t):
        env = self.env
        if self._acted:
            # the last policy step is over: the state in the world against the reference at
            # its end (sampled by _advance), as ImitationEnv.step judges it
            env._evaluate(self._reward, self._terminated)
            self.reward = float(self._reward[0])
            if self._terminated[0] and self._fallen_at is None:
                self._fallen_at = self.last_fall = t
                self.falls += 1
        eps = 1e-9
        if self._fallen_at is not None and t - self._fallen_at >= self.fall_delay - eps:
            self._start(t)
            self.restarts += 1
        elif self.restart_after is not None and self._fallen_at is None and \
                t - self._episodes[-1][0] >= self.restart_after - eps:
            self._start(t)
            self.restarts += 1
        env._observe(self._obs)
        actions = env.check_actions(self.policy.act(self._obs))
        env._advance()
        env._act(actions)
        self._acted = True
        self.steps += 1

    # -- starts and jumps in time ----------------------------------------------------------
    def _start(self, t, clip_time=None):
        """Put the character in the clip's state at ``clip_time`` (None: a random phase)
        and begin an episode at world time ``t`` (None: the world's). A steering task's
        character starts in a random clip frame and keeps the command it was given."""
        env = self.env
        t = float(self.world.time) if t is None else t
        if not self._follows_clip:
            command = env.target_heading.copy(), env.target_speed.copy()
            env._restart(np.array([0]), env.rng)
            if self._commanded:
                env.target_heading[:], env.target_speed[:] = command
            self._episodes.append((t, None))
        else:
            rng = env.rng if clip_time is None else _FixedStart(clip_time)
            env._restart(np.array([0]), rng)
            self._episodes.append((t, float(env.ref_time[0])))
        self._fallen_at = None
        self._substep = 0

    def _resync(self, t):
        """The world's time is not the one after our last call: it was reset or set to an
        earlier (or later) state. Forget the episodes that began after ``t``; at the start
        of an episode (or before the first) start it again as it started, else put the
        clip time where it was at ``t`` and begin a policy step here."""
        half = 0.5 * self.world.dt
        eps = self._episodes
        while eps and eps[-1][0] > t + half:
            eps.pop()
        self._acted = False
        if not eps or abs(t - eps[-1][0]) <= half or not self._follows_clip:
            # time 0 after the viewer's reset (the world is in the model's built pose, not
            # on the clip), or the frame an episode began at: begin it as it began
            clip_time = eps.pop()[1] if eps else None
            self._start(t, clip_time)
            return
        t0, clip0 = eps[-1]
        env = self.env
        env.ref_time[0] = clip0 + (t - t0)
        self._fallen_at = None      # a fall still in the state is seen again at the next step
        self._substep = 0

    # -- reading -------------------------------------------------------------------------
    @property
    def clip_time(self):
        """The clip time (s) of the reference the character is following (None for a
        steering task)."""
        return float(self.env.ref_time[0]) if self._follows_clip else None

    def command(self, heading=None, speed=None, *, relative=False):
        """Steer a steering task's character: a heading (rad, about the vertical; with
        ``relative`` turned from the character's own) and a speed (m/s); None keeps the
        current one. Kept across restarts."""
        if self._follows_clip:
            raise ModelError("PolicyDriver.command: this policy imitates a clip; only a "
                             "steering (amp) policy takes commands")
        self.env.set_command(heading, speed, relative=relative)
        self._commanded = True

    @property
    def episode_start(self):
        return self._episodes[-1][0]

    @property
    def fallen(self):
        """True while a fall is shown (between the fall and the restart)."""
        return self._fallen_at is not None

    def __repr__(self):
        what = self.policy.spec.get("clip") or ", ".join(self.policy.spec.get("clips", ()))
        return (f"<tumble.rl.PolicyDriver: {what}, {self.steps} policy "
                f"steps, {self.falls} falls, {self.restarts} restarts>")


def policy_world(policy, *, fall_delay=1.0, restart_after=None, seed=None, **overrides):
    """One character running ``policy``: ``(world, driver, env)``.

    policy : a :class:`Policy`, a policy file path or a shipped policy's name.
    The ImitationEnv is built from ``policy.spec`` (clip, control and physics rates, contact
    model, residual actions and their scale) with ``overrides`` (more ImitationEnv keywords,
    e.g. ``contact``, ``clip`` for a clip moved since training) on top, and checked with
    ``policy.check``. ``fall_delay``, ``restart_after`` and ``seed`` go to
    :class:`PolicyDriver`. Step ``world`` with ``driver`` as the controller, e.g.
    ``Recorder(world).run(5.0, control=driver)``.
    """
    from .tasks.imitation import ImitationEnv

    policy = load_policy(policy)
    spec = policy.spec
    task = spec.get("task", "imitate")
    if task == "amp":
        return _steering_world(policy, fall_delay=fall_delay, restart_after=restart_after,
                               seed=seed, **overrides)
    if task != "imitate":
        raise ModelError(f"policy_world: the policy is for the task {spec.get('task')!r}; "
                         f"this tumble plays 'imitate' and 'amp' policies")
    kwargs = _env_settings(spec, ("control_hz", "physics_hz", "contact", "residual",
                                   "projection_tolerance"))
    clip = overrides.pop("clip", spec.get("clip", "walk"))
    kwargs.update(overrides)
    kwargs.setdefault("seed", seed)
    try:
        env = ImitationEnv(1, clip, autoreset=False, **kwargs)
    except (FileNotFoundError, OSError) as exc:
        raise ModelError(f"policy_world: the policy was trained on the clip {clip!r}, which "
                         f"cannot be read here ({exc}); pass clip=... with its new path") \
            from None
    driver = PolicyDriver(policy, env, fall_delay=fall_delay, restart_after=restart_after)
    return env.world, driver, env


def _env_settings(spec, keys):
    """The environment keywords a policy's spec fixes: ``keys`` and the action scale."""
    kwargs = {k: spec[k] for k in keys if k in spec}
    if "action_scale" in spec:
        kwargs["action_scale"] = np.asarray(spec["action_scale"], float)
    return kwargs


def _steering_world(policy, *, fall_delay, restart_after, seed, **overrides):
    """policy_world for a steering (AMP) policy: an AMPEnv of one world whose commands
    change only when told (``driver.command``)."""
    from .tasks.amp import AMPEnv

    spec = policy.spec
    kwargs = _env_settings(spec, ("control_hz", "physics_hz", "contact",
                                   "projection_tolerance"))
    clips = overrides.pop("clips", spec.get("clips"))
    kwargs.update(overrides)
    kwargs.setdefault("seed", seed)
    try:
        env = AMPEnv(1, clips, autoreset=False, **kwargs)
    except (FileNotFoundError, OSError) as exc:
        raise ModelError(f"policy_world: the policy was trained on the clips {clips!r}, one "
                         f"of which cannot be read here ({exc}); pass clips=[...]") from None
    env.commands_change = False
    driver = PolicyDriver(policy, env, fall_delay=fall_delay, restart_after=restart_after)
    driver.command(0.0, 1.0, relative=True)
    return env.world, driver, env


def add_steering_gui(viewer, driver):
    """Heading and speed controls for a steering policy in a :class:`~tumble.viewer.Viewer`
    page: a speed slider, a heading slider (degrees) and buttons that turn by 90 degrees."""
    import math

    gui = viewer.server.gui
    env = driver.env
    with gui.add_folder("Command"):
        speed = gui.add_slider("Speed (m/s)", min=0.0, max=2.5, step=0.05,
                               initial_value=float(env.target_speed[0]))
        heading = gui.add_slider("Heading (deg)", min=-180.0, max=180.0, step=5.0,
                                 initial_value=_degrees(env.target_heading[0]))
        left = gui.add_button("Turn left 90°")
        right = gui.add_button("Turn right 90°")

    def command(h_deg=None, v=None):
        with viewer._lock:
            driver.command(None if h_deg is None else math.radians(h_deg), v)

    @speed.on_update
    def _(event):
        command(v=float(speed.value))

    @heading.on_update
    def _(event):
        command(h_deg=float(heading.value))

    def turn(sign):
        h = _degrees(env.target_heading[0] + sign * 0.5 * math.pi)
        heading.value = h               # its on_update sends the command

    left.on_click(lambda event: turn(1.0))
    right.on_click(lambda event: turn(-1.0))
    return speed, heading


def _degrees(rad):
    """An angle in degrees in [-180, 180)."""
    return float((np.degrees(rad) + 180.0) % 360.0 - 180.0)
