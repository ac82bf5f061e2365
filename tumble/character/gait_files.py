"""Gait files: the ``Gait`` a SIMBICON controller walks with and the ``Style`` of the
generalized controller, read from JSON.

A gait file (``tumble/character/gaits/<name>.json``, or any path, or a dict) holds the two
states of a half cycle and the servo settings; see ``Gait`` and ``GaitState`` for the
fields, units (rad, m, s, N m) and sign conventions. ``load_gait`` checks every field and
names the file, the field and its line in its errors.

A style file (same folder, same conventions, ``"controller": "generalized"``) holds the
parameters of the generalized controller (tumble.character.generalized): step timing,
foot placement corrections, swing height, virtual-force gains and the same servo groups;
see ``Style``. ``load_style`` reads one, ``style_names`` lists the shipped ones;
``gait_names`` lists only SIMBICON gaits.
"""
import json
import math
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path

from ..errors import ModelError

__all__ = ["GaitState", "Gait", "load_gait", "gait_names", "Style", "load_style",
           "style_names"]

# Joint groups sharing servo gains and torque bounds.
_GROUPS = ("hip", "torso", "knee", "ankle", "toe", "spine", "neck", "arm")


@dataclass(frozen=True)
class GaitState:
    """One state of the half cycle (stance leg fixed). Angles in rad.

    duration : s. The first state ends after it; the second ends at swing-foot contact
        (``on_contact``) or after it at the latest.
    swing_hip : (flexion, abduction) of the swing thigh in the heading frame: flexion > 0
        brings the thigh forward of vertical, abduction > 0 takes it outward.
    swing_knee, stance_knee : flexion, > 0 bends the knee (shank backward).
    swing_ankle, stance_ankle : dorsiflexion, > 0 lifts the toes (relative to the shank).
    torso : (pitch, roll) of the pelvis in the heading frame: pitch > 0 leans forward,
        roll > 0 leans toward the stance side.
    c_d, c_v : (sagittal, coronal) feedback gains of the swing hip on the COM offset from
        the stance ankle (rad/m) and the COM velocity (rad s/m).
    """
    duration: float
    on_contact: bool
    swing_hip: tuple
    swing_knee: float
    swing_ankle: float
    stance_knee: float
    stance_ankle: float
    torso: tuple
    c_d: tuple
    c_v: tuple


@dataclass(frozen=True)
class Gait:
    """A walking style: the two states of a step and the servo settings.

    name, description : text.
    states : (first, second) GaitState; the left and right steps mirror them.
    gains : {group: (kp N m/rad, kd N m s/rad)} for the groups hip (swing hip), torso
        (pelvis, through the stance hip), knee, ankle, toe, spine, neck, arm.
    max_torque : {group: N m} bound on each servo's torque per degree of freedom.
    speed : target forward speed (m/s; < 0 walks backwards) for the speed regulator, or
        None to walk at the gait's own speed.
    speed_gain, speed_p : the regulator's integral gain (rad of swing-hip flexion added
        after each step per m/s of error of the step's mean speed) and proportional gain
        (rad per m/s); speed_limit : bound on the offset, rad.
    turn_rate : rad/s of heading change (> 0 turns left).
    arms : (down, elbow): shoulders lowered from the T-pose by ``down``, elbows bent by
        ``elbow`` (forearm forward).
    swing_foot_world : keep the swing foot level with the heading frame (ankle target
        computed from the shank's orientation) instead of a joint-local ankle target.
    stance_ankle_world: likewise for the stance foot (a foot flat on level ground).
    flexion_range, abduction_range : (low, high) bounds (rad) of the swing hip's targets
        after feedback; a bounded adduction keeps the swing leg from crossing the stance leg.
    slope_lean, slope_hip, slope_ankle : rad of torso pitch, swing-hip flexion and ankle
        dorsiflexion added per rad of terrain slope under the stance foot along the heading
        (> 0 uphill; the controller's ``terrain`` gives it).
    min_step_width : m, or None: the swing hip abducts at least enough for the swing foot to
        land this far outward of the stance ankle (legs do not cross after a lateral push).
    """
    name: str
    description: str
    states: tuple
    gains: dict
    max_torque: dict
    speed: float = None
    speed_gain: float = 0.05
    speed_p: float = 0.0
    speed_limit: float = 0.3
    turn_rate: float = 0.0
    arms: tuple = (1.3, 0.2)
    swing_foot_world: bool = False
    stance_ankle_world: bool = False
    flexion_range: tuple = (-1.2, 1.5)
    abduction_range: tuple = (-0.15, 0.8)
    slope_lean: float = 0.0
    slope_hip: float = 0.0
    slope_ankle: float = 1.0
    min_step_width: float = None

    def with_(self, **changes):
        """A copy with fields replaced (e.g. ``speed=1.2``, ``turn_rate=0.2``)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class Style:
    """A walking style of the generalized controller (tumble.character.generalized).
    Lengths in m, times in s, angles in rad, forces in N; (sagittal, coronal) pairs are
    along the heading and to its left.

    name, description : text.
    gains, max_torque : as ``Gait``'s, the same joint groups: hip (the swing hip, tracking
        the thigh orientation the leg's inverse kinematics gives), torso (the pelvis's
        world orientation, through the stance hip), knee, ankle, toe, spine, neck, arm.
    speed, side_speed : commanded COM velocity (m/s) along the heading (< 0 backward) and
        to its left (< 0 right). turn_rate : rad/s of heading change (> 0 turns left).
    step_time : s, the planned duration of a step (the swing trajectory's phase 0 to 1).
    min_phase : a swing foot contact ends the step once the phase is past this;
        max_phase : the step ends at this phase whatever the foot does. strike_load : the
        contact counts when the ground's normal force on the swing foot is at least this
        fraction of the body's weight.
    ipm_scale : multipliers of the pendulum's steps; alpha : s, the step is shortened by
        ``alpha * v_desired`` (the pendulum then keeps moving at about the desired speed).
    step_width : m, outward offset of the coronal step from where the pendulum stops;
        min_step_width : m, the swing ankle lands at least this far outward of the stance
        ankle (no crossing); max_step : bounds of the step from the COM.
    foot_center : m, the foot's pivot ahead of the ankle (the ankle lands this much behind
        the pendulum's foot point, and the stance ankle's torque puts the centre of pressure
        there); cop_margin : m, the stance ankle's torque (pivot and velocity force) is
        bounded to centres of pressure this far inside the sole's edges.
    predict : the step is planned from the COM moved on at its velocity for ``predict``
        times the step's remaining time (0: from the present COM, the target moving with
        it; 1: from where the COM will be at the step's end).
    reach : a swing target farther from the hip than ``reach`` times the leg's length is
        moved horizontally toward the hip (the foot lands short rather than in the air); 0
        leaves it.
    freeze_phase : from this phase on the planned step is held in the world (not replanned
        from the moving COM), so the swing foot comes to rest on it and lands still.
    step_height : m, the swing ankle's lift at ``step_peak`` of the phase; landing : m,
        how far below the ground the trajectory ends (the foot looks for the ground);
        lift_phase : the part of the phase in which the foot rises before it moves
        horizontally; swing_ease : 0..1, the horizontal path's blend from ``1 - (1 - u)^2``
        (fastest at lift-off) toward a smoothstep (at rest at both ends).
    stance_knee_gains : (kp, kd) of the stance knee's servo, or null for the knee group's
        (the swing knee keeps those).
    step_time_speed : s taken off ``step_time`` per m/s of the commanded speed (faster walks
        take quicker steps, not only longer ones), down to ``min_step_time``.
    hurry : s taken off the step's duration per m/s of the COM's horizontal velocity error
        (from the command) beyond ``hurry_deadband`` m/s (the sway of a normal walk), down to
        ``min_step_time`` s: a pushed character steps sooner, as people do, instead of
        waiting out a step it cannot stop in (0: fixed timing).
    knee_time : s over which the stance knee's target goes from the knee's bend at the
        strike to ``stance_knee``; knee_rate : rad/s, the fastest it goes there (a leg that
        lands deeply bent straightens over more than ``knee_time`` instead of launching
        the body; 0: no bound).
    stance_knee, swing_ankle, stance_ankle : knee flexion (rad) of the stance leg; ankle
        dorsiflexion of the swing foot relative to level in the heading frame (tilted with
        the ground's slope) and of the stance foot relative to its shank (or, with
        ``stance_ankle_world``, relative to level like the swing foot's).
    slope_knee : rad of stance-knee bend per rad of downhill slope, added over the step (the
        knee yields under the body: walking down must absorb what the descent gives).
    torso : (pitch, roll) of the pelvis in the heading frame (pitch > 0 leans forward, roll
        > 0 toward the stance side); lean_speed : rad of extra pitch per m/s of commanded
        speed; slope_lean : rad of pitch per rad of slope under the stance foot.
    gravity_compensation : fraction of the swing leg's and the upper body's weight
        compensated by Jacobian-transpose torques (0 off, 1 all).
    knee_support : fraction of the body's weight the stance knee carries as a vertical
        virtual force at the COM (Jacobian transpose from the ground), so the stance leg
        does not fold under the body.
    height_gain : (N/m, N s/m) PD of the COM height above the stance ankle toward the
        standing height less ``height_drop`` (m), added to the knee's vertical force.
    velocity_gain : (sagittal, coronal) N per m/s of COM velocity error: the virtual force
        on the COM, carried by the stance leg's ankle and knee; max_force : its bounds (N).
    speed_gain : m of sagittal step correction per m/s of the last step's speed error,
        integrated step to step (bounded by speed_limit m): the step length adapts until the
        commanded speed is walked. side_gain : the same for the coronal step.
    accel : m/s^2, the rate at which the walk's commanded velocity follows ``speed`` and
        ``side_speed`` (from rest at the start, or after a change of command).
    arms : (down, elbow) as ``Gait``'s.
    """
    name: str
    description: str
    gains: dict
    max_torque: dict
    speed: float = 0.8
    side_speed: float = 0.0
    turn_rate: float = 0.0
    step_time: float = 0.45
    min_phase: float = 0.6
    max_phase: float = 1.4
    strike_load: float = 0.2
    ipm_scale: tuple = (1.0, 1.0)
    alpha: tuple = (0.05, 0.05)
    step_width: float = 0.08
    min_step_width: float = 0.1
    max_step: tuple = (0.45, 0.3)
    foot_center: float = 0.05
    cop_margin: float = 0.01
    predict: float = 0.0
    freeze_phase: float = 1.0
    reach: float = 0.0
    step_height: float = 0.08
    step_peak: float = 0.5
    landing: float = 0.03
    lift_phase: float = 0.1
    stance_knee: float = 0.1
    knee_time: float = 0.0
    knee_rate: float = 0.0
    swing_ease: float = 0.0
    step_time_speed: float = 0.0
    slope_knee: float = 0.0
    hurry: float = 0.0
    hurry_deadband: float = 0.3
    min_step_time: float = 0.25
    stance_knee_gains: tuple = None
    swing_ankle: float = 0.0
    stance_ankle: float = 0.0
    stance_ankle_world: bool = False
    torso: tuple = (0.0, 0.0)
    lean_speed: float = 0.0
    slope_lean: float = 0.0
    gravity_compensation: float = 1.0
    knee_support: float = 0.0
    height_gain: tuple = (0.0, 0.0)
    height_drop: float = 0.02
    velocity_gain: tuple = (200.0, 100.0)
    max_force: tuple = (150.0, 100.0)
    speed_gain: float = 0.05
    side_gain: float = 0.0
    speed_limit: float = 0.2
    accel: float = 1.0
    arms: tuple = (1.3, 0.2)

    def with_(self, **changes):
        """A copy with fields replaced (e.g. ``speed=1.2``, ``turn_rate=0.5``)."""
        return replace(self, **changes)


def _gains_and_limits(r, data):
    """The ``gains`` ({group: (kp, kd)}) and ``max_torque`` ({group: N m}, default inf) of
    a gait or style file, every joint group named and checked (``r``: the file's reader)."""
    gains_in = data.get("gains")
    if not isinstance(gains_in, dict):
        r.fail("gains", "must be an object {group: [kp, kd]}")
    gains = {}
    for g in _GROUPS:
        kp, kd = r.pair(gains_in, g, "gains.")
        if kp < 0 or kd < 0:
            r.fail(f"gains.{g}", f"gains must be >= 0, got {[kp, kd]}")
        gains[g] = (kp, kd)
    for k in gains_in:
        if k not in _GROUPS:
            r.fail(f"gains.{k}", f"is not a joint group (groups: {list(_GROUPS)})")
    lim_in = data.get("max_torque", {})
    if not isinstance(lim_in, dict):
        r.fail("max_torque", "must be an object {group: N m}")
    limits = {g: r.number(lim_in, g, "max_torque.", default=math.inf, lo=1e-9) for g in _GROUPS}
    for k in lim_in:
        if k not in _GROUPS:
            r.fail(f"max_torque.{k}", f"is not a joint group (groups: {list(_GROUPS)})")
    return gains, limits


def _shipped(controller):
    """Names of the shipped JSON files in gaits/ whose "controller" is ``controller``
    (files without the field are SIMBICON gaits)."""
    folder = resources.files("tumble.character").joinpath("gaits")
    out = []
    for p in folder.iterdir():
        if not p.name.endswith(".json"):
            continue
        try:
            kind = json.loads(p.read_text()).get("controller", "simbicon")
        except (json.JSONDecodeError, AttributeError):
            kind = "simbicon"           # load_gait reports what is wrong with it
        if kind == controller:
            out.append(p.name[:-5])
    return sorted(out)


def gait_names():
    """Names of the SIMBICON gaits shipped with tumble (``tumble/character/gaits/*.json``)."""
    return _shipped("simbicon")


def style_names():
    """Names of the generalized controller's styles shipped with tumble (the JSON files in
    ``tumble/character/gaits/`` with ``"controller": "generalized"``)."""
    return _shipped("generalized")


def _line_of(text, path):
    """1-based line of the field ``path`` ('states[1].c_d', 'gains.knee', 'speed') in the
    JSON ``text``, found by searching its keys in order (the i-th occurrence of a key after
    a list field for index i), or None."""
    pos, skip = 0, 0
    for part in path.split("."):
        name, _, index = part.partition("[")
        for _ in range(skip + 1):
            i = text.find(f'"{name}"', pos)
            if i < 0:
                return None
            pos = i + 1
        skip = int(index.rstrip("]")) if index else 0
    return text.count("\n", 0, pos - 1) + 1


class _Reader:
    """Typed access to a parsed gait file, with errors naming the file, field and line."""

    def __init__(self, source, text):
        self.source, self.text = source, text

    def fail(self, field_name, msg):
        line = _line_of(self.text, field_name)
        at = f" (line {line})" if line else ""
        raise ModelError(f"gait {self.source}: field '{field_name}'{at}: {msg}")

    def number(self, d, key, where, *, default=None, lo=None, hi=None, required=True):
        if key not in d:
            if required and default is None:
                self.fail(f"{where}{key}", "is missing")
            return default
        v = d[key]
        if v is None and not required:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self.fail(f"{where}{key}", f"must be a finite number, got {v!r}")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            self.fail(f"{where}{key}", f"must be in [{lo}, {hi}], got {v!r}")
        return float(v)

    def pair(self, d, key, where, default=None):
        if key not in d:
            if default is None:
                self.fail(f"{where}{key}", "is missing")
            return tuple(default)
        v = d[key]
        if (not isinstance(v, list) or len(v) != 2 or
                not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                        and math.isfinite(x) for x in v)):
            self.fail(f"{where}{key}", f"must be a list of two finite numbers, got {v!r}")
        return (float(v[0]), float(v[1]))

    def flag(self, d, key, where, default):
        v = d.get(key, default)
        if not isinstance(v, bool):
            self.fail(f"{where}{key}", f"must be true or false, got {v!r}")
        return v


def _parse_gait(data, source, text):
    r = _Reader(source, text)
    if not isinstance(data, dict):
        raise ModelError(f"gait {source}: the file must hold a JSON object")
    if data.get("controller", "simbicon") != "simbicon":
        raise ModelError(f"gait {source}: it is a style of the {data['controller']!r} "
                         f"controller, not a SIMBICON gait (load it with load_style)")
    known = {"controller", "name", "description", "states", "gains", "max_torque", "speed", "speed_gain",
             "speed_p", "speed_limit", "turn_rate", "arms", "swing_foot_world",
             "stance_ankle_world", "flexion_range", "abduction_range", "slope_lean",
             "slope_hip", "slope_ankle", "min_step_width"}
    for k in data:
        if k not in known:
            r.fail(k, f"is not a gait field (known: {sorted(known)})")
    states = data.get("states")
    if not isinstance(states, list) or len(states) != 2:
        r.fail("states", "must be a list of two states (the half cycle)")
    parsed = []
    state_keys = {"duration", "swing_hip", "swing_knee", "swing_ankle", "stance_knee",
                  "stance_ankle", "torso", "c_d", "c_v"}
    for i, s in enumerate(states):
        where = f"states[{i}]."
        if not isinstance(s, dict):
            r.fail(f"states[{i}]", "must be an object")
        for k in s:
            if k not in state_keys:
                r.fail(where + k, f"is not a state field (known: {sorted(state_keys)})")
        parsed.append(GaitState(
            duration=r.number(s, "duration", where, lo=1e-3, hi=10.0),
            on_contact=(i == 1),
            swing_hip=r.pair(s, "swing_hip", where),
            swing_knee=r.number(s, "swing_knee", where, lo=-0.5, hi=2.8),
            swing_ankle=r.number(s, "swing_ankle", where, lo=-1.5, hi=1.5),
            stance_knee=r.number(s, "stance_knee", where, lo=-0.5, hi=2.8),
            stance_ankle=r.number(s, "stance_ankle", where, lo=-1.5, hi=1.5),
            torso=r.pair(s, "torso", where, default=(0.0, 0.0)),
            c_d=r.pair(s, "c_d", where, default=(0.0, 0.0)),
            c_v=r.pair(s, "c_v", where, default=(0.0, 0.0))))
    gains, limits = _gains_and_limits(r, data)
    name = data.get("name", Path(str(source)).stem)
    if not isinstance(name, str):
        r.fail("name", "must be a string")
    return Gait(name=name, description=str(data.get("description", "")),
                states=tuple(parsed), gains=gains, max_torque=limits,
                speed=r.number(data, "speed", "", required=False, lo=-3.0, hi=3.0),
                speed_gain=r.number(data, "speed_gain", "", default=0.05, lo=0.0),
                speed_p=r.number(data, "speed_p", "", default=0.0, lo=0.0),
                speed_limit=r.number(data, "speed_limit", "", default=0.3, lo=0.0),
                turn_rate=r.number(data, "turn_rate", "", default=0.0, lo=-3.0, hi=3.0),
                arms=r.pair(data, "arms", "", default=(1.3, 0.2)),
                swing_foot_world=r.flag(data, "swing_foot_world", "", False),
                stance_ankle_world=r.flag(data, "stance_ankle_world", "", False),
                flexion_range=r.pair(data, "flexion_range", "", default=(-1.2, 1.5)),
                abduction_range=r.pair(data, "abduction_range", "", default=(-0.15, 0.8)),
                slope_lean=r.number(data, "slope_lean", "", default=0.0, lo=-5.0, hi=5.0),
                slope_hip=r.number(data, "slope_hip", "", default=0.0, lo=-5.0, hi=5.0),
                slope_ankle=r.number(data, "slope_ankle", "", default=1.0, lo=-5.0, hi=5.0),
                min_step_width=r.number(data, "min_step_width", "", required=False, lo=-0.5,
                                        hi=0.5))


def _read(spec, what, names):
    """(data, source, text) of a gait or style given by a shipped name, a path or a dict;
    ``what`` ('gait', 'style') and ``names`` (the shipped names) for the errors."""
    if isinstance(spec, dict):
        return spec, "<dict>", json.dumps(spec, indent=1)
    if not isinstance(spec, (str, Path)):
        raise ModelError(f"load_{what}: expected a {what} name, a path or a dict, got "
                         f"{type(spec).__name__}")
    path = Path(spec)
    if path.suffix == ".json" or path.exists():
        if not path.exists():
            raise ModelError(f"load_{what}: no {what} file {path}")
        text, source = path.read_text(), str(path)
    else:
        res = resources.files("tumble.character").joinpath("gaits", f"{spec}.json")
        if not res.is_file():
            raise ModelError(f"load_{what}: no {what} named {spec!r}; shipped {what}s: "
                             f"{names()}")
        text, source = res.read_text(), f"{spec}.json"
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ModelError(f"{what} {source}: invalid JSON at line {e.lineno}, column {e.colno}: "
                         f"{e.msg}") from None
    return data, source, text


def load_gait(gait):
    """A :class:`Gait` from a shipped name ('walk', 'fast', ...; see ``gait_names()``), a
    path to a JSON file, or a dict with the same fields. Raises ModelError naming the file,
    the field and its line for anything malformed."""
    if isinstance(gait, Gait):
        return gait
    data, source, text = _read(gait, "gait", gait_names)
    return _parse_gait(data, source, text)


_STYLE_NUMBERS = {
    # name: (low, high)
    "speed": (-3.0, 3.0), "side_speed": (-2.0, 2.0), "turn_rate": (-3.0, 3.0),
    "step_time": (0.1, 2.0), "min_phase": (0.0, 1.0), "max_phase": (0.5, 5.0), "strike_load": (0.0, 2.0),
    "step_width": (-0.5, 0.5), "min_step_width": (-0.5, 0.5), "foot_center": (-0.3, 0.3), "cop_margin": (0.0, 0.1),
    "predict": (0.0, 1.0), "freeze_phase": (0.0, 5.0), "reach": (0.0, 1.0), "step_height": (0.0, 0.5), "step_peak": (0.05, 0.95), "landing": (0.0, 0.3), "lift_phase": (0.0, 0.9),
    "stance_knee": (-0.5, 2.8), "knee_time": (0.0, 2.0), "knee_rate": (0.0, 100.0), "swing_ease": (0.0, 1.0), "step_time_speed": (-1.0, 1.0), "slope_knee": (0.0, 20.0), "hurry": (0.0, 2.0), "hurry_deadband": (0.0, 5.0), "min_step_time": (0.05, 2.0), "swing_ankle": (-1.5, 1.5), "stance_ankle": (-1.5, 1.5),
    "lean_speed": (-2.0, 2.0), "slope_lean": (-5.0, 5.0), "gravity_compensation": (0.0, 2.0), "knee_support": (0.0, 2.0), "height_drop": (-0.5, 0.5),
    "speed_gain": (0.0, 2.0), "side_gain": (0.0, 2.0), "speed_limit": (0.0, 1.0),
    "accel": (0.01, 100.0)}
_STYLE_FLAGS = ("stance_ankle_world",)
_STYLE_PAIRS = ("height_gain", "ipm_scale", "alpha", "max_step", "torso", "velocity_gain", "max_force",
                "arms")


def _parse_style(data, source, text):
    r = _Reader(source, text)
    if not isinstance(data, dict):
        raise ModelError(f"style {source}: the file must hold a JSON object")
    if data.get("controller") != "generalized":
        r.fail("controller", "must be \"generalized\" in a style file (a file without it is "
                             "a SIMBICON gait: load it with load_gait)")
    known = {"controller", "name", "description", "gains", "max_torque", "stance_knee_gains"} | set(_STYLE_NUMBERS) \
        | set(_STYLE_PAIRS) | set(_STYLE_FLAGS)
    for k in data:
        if k not in known:
            r.fail(k, f"is not a style field (known: {sorted(known)})")
    gains, limits = _gains_and_limits(r, data)
    name = data.get("name", Path(str(source)).stem)
    if not isinstance(name, str):
        r.fail("name", "must be a string")
    defaults = Style(name="", description="", gains={}, max_torque={})
    kw = {}
    for k, (lo, hi) in _STYLE_NUMBERS.items():
        kw[k] = r.number(data, k, "", default=getattr(defaults, k), lo=lo, hi=hi)
    for k in _STYLE_PAIRS:
        kw[k] = r.pair(data, k, "", default=getattr(defaults, k))
    if data.get("stance_knee_gains") is not None:
        kw["stance_knee_gains"] = r.pair(data, "stance_knee_gains", "")
        if min(kw["stance_knee_gains"]) < 0:
            r.fail("stance_knee_gains", "gains must be >= 0")
    for k in _STYLE_FLAGS:
        kw[k] = r.flag(data, k, "", getattr(defaults, k))
    if kw["min_phase"] >= kw["max_phase"]:
        r.fail("max_phase", f"must be larger than min_phase ({kw['min_phase']})")
    for k in ("ipm_scale", "max_step", "velocity_gain", "max_force"):
        if min(kw[k]) < 0:
            r.fail(k, f"must not be negative, got {list(kw[k])}")
    return Style(name=name, description=str(data.get("description", "")), gains=gains,
                 max_torque=limits, **kw)


def load_style(style):
    """A :class:`Style` of the generalized controller from a shipped name (see
    ``style_names()``), a path to a JSON file, or a dict with the same fields. Raises
    ModelError naming the file, the field and its line for anything malformed."""
    if isinstance(style, Style):
        return style
    data, source, text = _read(style, "style", style_names)
    return _parse_style(data, source, text)
