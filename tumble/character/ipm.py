"""The geometry of the generalized walking controller (tumble.character.generalized):
inverted-pendulum foot placement, the swing foot's trajectory, two-link inverse kinematics.

Plain functions of vectors, no World: the controller calls them every control period and
the tests call them on synthetic states.

- ``ipm_step(v, h)``: where an inverted pendulum of height ``h`` moving at ``v`` must put
  its foot to come to rest over it, ``d = v sqrt(h/g + v^2 / (4 g^2))`` (Coros, Beaudoin
  and van de Panne 2010, after Pratt's capture point): the pendulum's energy
  ``v^2 / 2 + g h`` at the step equals ``g sqrt(h^2 + d^2)``, standing on the foot,
  with the COM height kept.
- ``plan_step``: that step in the heading frame (sagittal, coronal), with the corrections
  for a desired velocity (a step shorter by ``alpha v_d`` keeps the pendulum moving), a
  step width (the foot lands outward of the pendulum's rest point, so the COM swings back
  toward the next stance), bounds, and the no-crossing rule (the foot lands at least
  ``min_width`` outward of the stance foot).
- ``swing_target``: the swing ankle's position at a phase of the step: a horizontal blend
  from where the foot lifted off to the planned step, ``s = 1 - (1 - phase)^2``, and a
  height above the ground that rises to ``height`` and comes down ``landing`` below it at
  the end (the foot looks for the ground).
- ``two_link_ik``: hip, knee and ankle of a leg; the knee angle and the thigh direction
  that put the ankle on a target, the knee in the plane of the target and the heading.

Units: m, s, rad; vectors are world (3,) arrays.
"""
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["GRAVITY", "ipm_step", "plan_step", "StepPlan", "lipm_predict", "swing_target", "swing_height",
           "two_link_ik", "IKResult", "reachable_target"]

GRAVITY = 9.81


def ipm_step(v, h, g=GRAVITY):
    """The inverted pendulum's step (m, same sign as v): ``v sqrt(h/g + v^2 / (4 g^2))``
    for a COM at height ``h`` (m) above the pivot moving horizontally at ``v`` (m/s)."""
    return v * math.sqrt(max(h, 0.0) / g + v * v / (4.0 * g * g))


@dataclass
class StepPlan:
    """A planned step, heading frame (m): ``ipm`` (sagittal, coronal) the pendulum's steps
    from the COM; ``offset`` (sagittal, coronal) the corrected step from the COM; ``target``
    (3,) the world point under the swing ankle (height 0 along up: the caller adds the
    ground); ``limited`` what bounded it: '' or any of 'sagittal', 'coronal', 'crossing'."""
    ipm: tuple
    offset: tuple
    target: np.ndarray
    limited: str


def plan_step(com, vcom, stance_ankle, fwd, left, up, swing_sign, *, h, v_des=(0.0, 0.0),
              alpha=(0.05, 0.0), scale=(1.0, 1.0), step_width=0.1, max_step=(0.4, 0.3),
              min_width=0.1, foot_center=0.0, adjust=(0.0, 0.0), g=GRAVITY):
    """The swing ankle's landing point from the inverted pendulum (a :class:`StepPlan`).

    com, vcom : the COM position and velocity (3,). stance_ankle : the stance ankle (3,).
    fwd, left, up : the heading frame (unit (3,)). swing_sign : +1 when the swing leg is the
    left one, -1 the right (outward for the swing foot is ``swing_sign * left``).
    h : COM height above the stance pivot (m). v_des : desired (sagittal, coronal) COM
    velocity. alpha : (sagittal, coronal) s: the step is shortened by ``alpha * v_des``.
    scale : multipliers of the pendulum's steps (> 1 steps further: more cautious).
    step_width : m: the foot lands this much outward of where the coronal pendulum stops.
    max_step : (sagittal, coronal) bounds of the step from the COM (m).
    min_width : m: the ankle lands at least this far outward of the stance ankle (no
    crossing). foot_center : m, how far ahead of the ankle the foot's pivot is: the ankle
    is placed that much behind the pendulum's foot point. adjust : (sagittal, coronal) m
    added to the step before the bounds (a speed regulator's correction).

    The sagittal step is ``scale_s ipm(v_s) - alpha_s v_des_s + adjust_s``; the coronal
    one is ``scale_c ipm(v_c) - alpha_c v_des_c + swing_sign step_width + adjust_c`` (left
    positive), with v_s, v_c the COM velocity along fwd and left.
    """
    com = np.asarray(com, float)
    vcom = np.asarray(vcom, float)
    v_s, v_c = float(vcom @ fwd), float(vcom @ left)
    d_s = scale[0] * ipm_step(v_s, h, g)
    d_c = scale[1] * ipm_step(v_c, h, g)
    o_s = d_s - alpha[0] * v_des[0] + adjust[0]
    o_c = d_c - alpha[1] * v_des[1] + swing_sign * step_width + adjust[1]
    limited = []
    if abs(o_s) > max_step[0]:
        o_s = math.copysign(max_step[0], o_s)
        limited.append("sagittal")
    if abs(o_c) > max_step[1]:
        o_c = math.copysign(max_step[1], o_c)
        limited.append("coronal")
    flat = com - (com @ up) * up
    target = flat + (o_s - foot_center) * fwd + o_c * left
    # no crossing: outward of the stance ankle by min_width at least
    out = swing_sign * left
    side = float((target - stance_ankle) @ out)
    if side < min_width:
        target = target + (min_width - side) * out
        o_c += swing_sign * (min_width - side)
        limited.append("crossing")
    target = target - (target @ up) * up
    return StepPlan(ipm=(d_s, d_c), offset=(o_s, o_c), target=target,
                    limited=",".join(limited))


def lipm_predict(com, vcom, pivot, up, h, tau, g=GRAVITY):
    """The COM position and velocity (3,) after ``tau`` s of a linear inverted pendulum of
    height ``h`` over ``pivot`` (3,) (horizontal motion only; the height part of ``com``
    and of ``vcom`` is kept): ``x(t) = x0 cosh(w t) + v0 / w sinh(w t)``, ``w = sqrt(g/h)``."""
    com = np.asarray(com, float)
    vcom = np.asarray(vcom, float)
    if tau <= 0.0:
        return com.copy(), vcom.copy()
    w = math.sqrt(g / max(h, 1e-3))
    ch, sh = math.cosh(w * tau), math.sinh(w * tau)
    x = com - pivot
    x = x - (x @ up) * up
    v = vcom - (vcom @ up) * up
    x1 = x * ch + v * (sh / w)
    v1 = x * (w * sh) + v * ch
    return com + (x1 - x), vcom + (v1 - v)


def swing_height(phase, height, landing=0.0, peak=0.5):
    """Height (m) of the swing ankle above its ground line at ``phase`` of the step: 0 at
    lift-off, rising at once (``1 - (1 - u)^2``, the foot leaves the ground before it moves
    much) to ``height`` at ``peak``, then down (a smoothstep) to ``-landing`` at 1, and on
    down at ``height + landing`` per unit of phase after it (a late ground is still
    found). Continuous, with zero slope at the top."""
    p = max(phase, 0.0)
    if p <= peak:
        u = p / peak
        return height * (1.0 - (1.0 - u) ** 2)
    if p <= 1.0:
        u = (p - peak) / (1.0 - peak)
        return height + (-landing - height) * u * u * (3.0 - 2.0 * u)
    return -landing - (height + landing) * (p - 1.0)


def swing_target(phase, start, step, *, height, landing, ground_start, ground_step,
                 up, ankle_height, peak=0.5, lift=0.0, ease=0.0):
    """World position (3,) of the swing ankle at ``phase`` of the step.

    start : the swing ankle where it lifted off (3,); step : the planned landing point,
    horizontal (3,) (``plan_step``'s target); ground_start, ground_step : ground heights
    (m along up) under them; ankle_height : the ankle's height above the sole. The
    horizontal position blends with ``s = 1 - (1 - u)^2``, ``u`` the phase after ``lift``
    rescaled to 0..1 (the foot first rises, then moves fast and homes in on a step that is
    still being replanned), blended by ``ease`` (0..1) toward the smoothstep
    ``3 u^2 - 2 u^3``, which starts and ends at rest (a swing leg thrown forward at lift-off
    takes its reaction from the stance hip, which pushes the stance foot back and the body
    forward); the ground
    line moves from the start's ground to the step's (a rise by ``peak``, a drop after it),
    and ``swing_height`` is added above it.
    """
    p = min(max(phase, 0.0), 1.0)
    u = min(max((p - lift) / (1.0 - lift), 0.0), 1.0) if lift < 1.0 else 1.0
    s = (1.0 - ease) * (1.0 - (1.0 - u) ** 2) + ease * u * u * (3.0 - 2.0 * u)
    start_h = start - (start @ up) * up
    horiz = start_h + s * (step - start_h)
    # the ground line: a rise is reached by mid-swing (the foot clears the edge on its way
    # up), a drop only in the second half (the foot leaves the edge before it comes down)
    if ground_step > ground_start:
        u = min(p / peak, 1.0)
    else:
        u = max((p - peak) / (1.0 - peak), 0.0)
    ground = ground_start + u * u * (3.0 - 2.0 * u) * (ground_step - ground_start)
    y = ground + ankle_height + swing_height(phase, height, landing, peak)
    return horiz + y * up


@dataclass
class IKResult:
    """Two-link inverse kinematics of a leg.

    thigh_dir, shank_dir : unit (3,) hip to knee and knee to ankle. knee : the knee (3,).
    ankle : where the ankle ends up (3,) (the target when reachable). flex : knee flexion
    (rad, 0 straight). bend_axis : unit (3,) the knee's hinge axis (flexion is a positive
    rotation of the shank about it). reachable : the target is within the leg's reach
    (|l1 - l2| <= distance <= l1 + l2, with ``margin``); error : distance from the ankle
    to the target (m), 0 when reachable.
    """
    thigh_dir: np.ndarray
    shank_dir: np.ndarray
    knee: np.ndarray
    ankle: np.ndarray
    flex: float
    bend_axis: np.ndarray
    reachable: bool
    error: float


def cross(a, b):
    """a x b of (..., 3) arrays, written out (np.cross is slow on small arrays)."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    if a.ndim == 1 and b.ndim == 1:
        return np.array((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]))
    return np.stack((a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]), axis=-1)


def _rotate(v, axis, angle):
    """v rotated about the unit ``axis`` by ``angle`` (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + cross(axis, v) * s + axis * float(axis @ v) * (1.0 - c)


def reachable_target(hip, target, reach, up):
    """``target`` (3,) moved horizontally toward the hip (its height along ``up`` kept) until
    it is within ``reach`` (m) of ``hip``: a step too long for the leg is shortened rather
    than left in the air. Returns (target, shortened)."""
    hip = np.asarray(hip, float)
    target = np.asarray(target, float)
    r = target - hip
    if float(r @ r) <= reach * reach:
        return target, False
    dv = float(r @ up)
    horiz = r - dv * up
    n = float(np.linalg.norm(horiz))
    if abs(dv) >= reach or n < 1e-12:
        return hip + dv * up * (reach / max(abs(dv), 1e-12)), True
    return hip + dv * up + horiz * (math.sqrt(reach * reach - dv * dv) / n), True


def two_link_ik(hip, target, l1, l2, forward, *, margin=1e-6, min_flex=0.0):
    """The thigh direction and knee flexion that put the ankle of a leg (thigh ``l1``,
    shank ``l2`` m, straight at flexion 0) on ``target`` (3,), the hip at ``hip`` (3,).

    forward : the direction the knee points (the heading forward); the knee lies in the
    plane of the hip-target line and ``forward``, in front of that line. Out of reach (too
    far, or closer than |l1 - l2|) the leg points at the target, as near as it gets, and
    ``reachable`` is False. min_flex : least knee flexion (rad): a target that needs less
    is approached with this bend (the leg is shorter than l1 + l2 then).
    Returns an :class:`IKResult`.
    """
    hip = np.asarray(hip, float)
    target = np.asarray(target, float)
    fwd = np.asarray(forward, float)
    r = target - hip
    dist = float(np.linalg.norm(r))
    rhat = r / dist if dist > 1e-12 else -cross(fwd, [1.0, 0.0, 0.0])
    axis = cross(rhat, fwd)          # the knee turns the thigh about -axis, forward
    n = float(np.linalg.norm(axis))
    if n < 1e-9:
        # the target straight ahead or behind: any plane; take the one through 'up'
        trial = cross(rhat, [0.0, 1.0, 0.0])
        axis = trial / max(np.linalg.norm(trial), 1e-12)
    else:
        axis = axis / n
    bend = -axis                          # flexion: positive rotation about 'bend'
    longest = math.sqrt(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * math.cos(min_flex))
    shortest = abs(l1 - l2)
    reachable = shortest + margin <= dist <= longest - margin
    d = min(max(dist, shortest + margin), longest - margin)
    # law of cosines: the thigh's angle from the hip-target line and the knee's flexion
    ca = (l1 * l1 + d * d - l2 * l2) / (2.0 * l1 * d)
    a = math.acos(min(max(ca, -1.0), 1.0))
    ck = (l1 * l1 + l2 * l2 - d * d) / (2.0 * l1 * l2)
    inner = math.acos(min(max(ck, -1.0), 1.0))
    flex = math.pi - inner
    thigh = _rotate(rhat, axis, a)        # about +axis = -bend: toward forward
    knee = hip + l1 * thigh
    shank = _rotate(thigh, bend, flex)
    ankle = knee + l2 * shank
    err = 0.0 if reachable else float(np.linalg.norm(ankle - target))
    return IKResult(thigh_dir=thigh, shank_dir=shank, knee=knee, ankle=ankle, flex=flex,
                    bend_axis=bend, reachable=bool(reachable), error=err)
