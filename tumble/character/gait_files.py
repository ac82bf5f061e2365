"""SIMBICON gait files: the ``Gait`` a controller walks with, read from JSON.

A gait file (``tumble/character/gaits/<name>.json``, or any path, or a dict) holds the two
states of a half cycle and the servo settings; see ``Gait`` and ``GaitState`` for the
fields, units (rad, m, s, N m) and sign conventions. ``load_gait`` checks every field and
names the file, the field and its line in its errors.
"""
import json
import math
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path

from ..errors import ModelError

__all__ = ["GaitState", "Gait", "load_gait", "gait_names"]

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


def gait_names():
    """Names of the gaits shipped with tumble (``tumble/character/gaits/*.json``)."""
    folder = resources.files("tumble.character").joinpath("gaits")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".json"))


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
    known = {"name", "description", "states", "gains", "max_torque", "speed", "speed_gain",
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
    limits = {}
    for g in _GROUPS:
        limits[g] = r.number(lim_in, g, "max_torque.", default=math.inf, lo=1e-9)
    for k in lim_in:
        if k not in _GROUPS:
            r.fail(f"max_torque.{k}", f"is not a joint group (groups: {list(_GROUPS)})")
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


def load_gait(gait):
    """A :class:`Gait` from a shipped name ('walk', 'fast', ...; see ``gait_names()``), a
    path to a JSON file, or a dict with the same fields. Raises ModelError naming the file,
    the field and its line for anything malformed."""
    if isinstance(gait, Gait):
        return gait
    if isinstance(gait, dict):
        return _parse_gait(gait, "<dict>", json.dumps(gait, indent=1))
    if not isinstance(gait, (str, Path)):
        raise ModelError(f"load_gait: expected a gait name, a path or a dict, got "
                         f"{type(gait).__name__}")
    path = Path(gait)
    if path.suffix == ".json" or path.exists():
        if not path.exists():
            raise ModelError(f"load_gait: no gait file {path}")
        text, source = path.read_text(), str(path)
    else:
        res = resources.files("tumble.character").joinpath("gaits", f"{gait}.json")
        if not res.is_file():
            raise ModelError(f"load_gait: no gait named {gait!r}; shipped gaits: {gait_names()}")
        text, source = res.read_text(), f"{gait}.json"
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ModelError(f"gait {source}: invalid JSON at line {e.lineno}, column {e.colno}: "
                         f"{e.msg}") from None
    return _parse_gait(data, source, text)
