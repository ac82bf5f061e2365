"""Measured SIMBICON walks: ``run_walk`` steps a controller and sums up the walk.

Distances in m, times in s (simulated, except ``wall_time``), speeds in m/s; horizontal
means perpendicular to the controller's ``up``.
"""
import math
import time
from dataclasses import dataclass

import numpy as np

from ..math import quat_np as Q
from .balance import center_of_mass

__all__ = ["WalkResult", "run_walk"]


@dataclass
class WalkResult:
    """Figures of a walk (``run_walk``).

    time : simulated s walked (until the end or the fall). fallen, fall_reason.
    distance : horizontal distance (m) of the COM from its start; forward_distance : along
        the initial heading. speed : mean horizontal COM speed (m/s) after ``settle`` s.
    step_length : mean distance (m) between consecutive foot strikes along the heading
        (the feet's lateral offset left out); step_time :
        mean s between strikes; steps : number of strikes.
    wall_time : s of computation; com : (F, 3) COM per control period; strikes : the
    controller's foot strikes; pelvis_min_height : lowest pelvis COM height above the
    terrain (m).
    """
    time: float
    fallen: bool
    fall_reason: str
    distance: float
    forward_distance: float
    speed: float
    step_length: float
    step_time: float
    steps: int
    wall_time: float
    com: np.ndarray
    strikes: list
    pelvis_min_height: float = math.nan

    def summary(self):
        """One line of the figures."""
        state = f"FELL at {self.time:.2f} s ({self.fall_reason})" if self.fallen else \
            f"walked {self.time:.1f} s"
        return (f"{state}: {self.distance:.1f} m, speed {self.speed:.2f} m/s, step length "
                f"{self.step_length:.3f} m, step time {self.step_time:.3f} s, {self.steps} steps")


def run_walk(controller, duration, *, pushes=(), settle=2.0, stop_distance=None,
             on_step=None, start_speed=0.0, place=True, position=(0.0, 0.0), yaw=0.0):
    """Walk ``controller`` for ``duration`` s (or until it falls or has gone
    ``stop_distance`` m) and measure it; returns a :class:`WalkResult`.

    pushes : :class:`~tumble.character.balance.Push` list (start times in world time,
    ``world.time``). settle : s excluded from the speed and step figures (the start from
    standing). on_step : called as ``on_step(controller)`` after every control period (e.g.
    to capture a frame of a ``world.record()`` Recorder). place : put the character
    standing first (with ``start_speed``, at ``position`` (x, z) facing ``yaw``).
    """
    c = controller
    w = c.world
    if place:
        c.place(speed=start_speed, position=position, yaw=yaw)
    com0, _ = center_of_mass(w)
    n = int(round(duration / c.control_dt))
    coms = []
    t0 = time.perf_counter()
    pel_min = math.inf
    up = c.up
    for _ in range(n):
        c.step(pushes)
        com, _ = center_of_mass(w)
        coms.append(com)
        p = w.body_pos[c.pelvis]
        pel_min = min(pel_min, float(p @ up) - c.ground_height(p))
        if on_step is not None:
            on_step(c)
        if c.fallen:
            break
        if stop_distance is not None:
            dh = com - com0
            dh = dh - (dh @ up) * up
            if np.linalg.norm(dh) >= stop_distance:
                break
    wall = time.perf_counter() - t0
    coms = np.array(coms)
    times = c.control_dt * (np.arange(len(coms)) + 1)

    def horiz(v):
        return v - np.outer(v @ up, up)

    disp = horiz(coms[-1:] - com0)[0]
    fwd0 = Q.qrot(Q.qaxis_angle_one(up, yaw), c.fwd0)
    after = times >= settle
    if after.sum() >= 2:
        ca = coms[after]
        path = np.linalg.norm(np.diff(horiz(ca), axis=0), axis=1).sum()
        span = times[after][-1] - times[after][0]
        straight = np.linalg.norm(horiz(ca[-1:] - ca[:1])[0])
        speed = (straight if c.gait.turn_rate == 0 else path) / span if span > 0 else math.nan
        if c.gait.speed is not None and c.gait.speed < 0:
            speed = -speed
    else:
        speed = math.nan
    strikes = [s for s in c.strikes if s[0] >= settle]
    if len(strikes) >= 2:
        pts = np.array([s[2] for s in strikes])
        yaws = np.array([s[3] for s in strikes])
        mid = 0.5 * (yaws[1:] + yaws[:-1])
        fw = Q.qrot(np.array([Q.qaxis_angle_one(up, y) for y in mid]), np.broadcast_to(c.fwd0, (len(mid), 3)))
        # along the heading: the lateral offset between the feet is not step length
        step_len = float(np.abs(np.sum(np.diff(pts, axis=0) * fw, axis=1)).mean())
        step_time = float(np.diff([s[0] for s in strikes]).mean())
    else:
        step_len = step_time = math.nan
    return WalkResult(time=float(c.time), fallen=c.fallen, fall_reason=c.fall_reason,
                      distance=float(np.linalg.norm(disp)),
                      forward_distance=float(disp @ fwd0), speed=float(speed),
                      step_length=step_len, step_time=step_time, steps=len(c.strikes),
                      wall_time=wall, com=coms, strikes=list(c.strikes),
                      pelvis_min_height=pel_min)
