"""Options: how a world steps, as one keyword dataclass (MuJoCo's ``mjOption``).

Every field is checked when it is set, at construction or later (``world.options.erp =
0.1``, or ``world.erp = 0.1``, which ``World`` forwards here), so a bad value is refused
with an error naming the field and nothing changes. ``step_options`` turns them into the
scalars the compiled step takes (``pipeline.arrays.StepOptions``).
"""
from dataclasses import dataclass, fields

import numpy as np

from ..errors import ModelError
from ..model.types import BROADPHASES
from ..model.validate import positive
from ..pipeline.actuators import PD_MODES
from ..pipeline.arrays import (CONTACT_LCP, CONTACT_PENALTY, CONTACT_PGS, SOLVER_DIRECT,
                               SOLVER_PGS, StepOptions)
from ..pipeline.contacts.penalty import default_penalty
from ..pipeline.integrate import (GYRO_EXPLICIT, GYRO_IMPLICIT, GYRO_NONE, GYRO_VARIATIONAL,
                                  QUAT_EXP, QUAT_LINEAR)

GYROSCOPIC = {"implicit": GYRO_IMPLICIT, "explicit": GYRO_EXPLICIT, "none": GYRO_NONE,
              "variational": GYRO_VARIATIONAL}
QUAT_INTEGRATION = {"exp": QUAT_EXP, "linear": QUAT_LINEAR}
CONTACT_MODELS = {"lcp": CONTACT_LCP, "pgs": CONTACT_PGS, "penalty": CONTACT_PENALTY}
SOLVERS = {"direct": SOLVER_DIRECT, "pgs": SOLVER_PGS}
PENALTY_INTEGRATION = {"implicit": True, "explicit": False}


def _choice(table):
    def check(value, name):
        if not isinstance(value, str) or value not in table:
            raise ModelError(f"world: {name} must be one of {list(table)}, got {value!r}")
        return value
    return check


def _nonneg(value, name):
    return positive(value, "world", name, allow_zero=True)


def _pos(value, name):
    return positive(value, "world", name)


def _fraction(value, name):
    v = _nonneg(value, name)
    if v > 1.0:
        raise ModelError(f"world: {name} must be in [0, 1], got {value!r}")
    return v


def _count(minimum):
    def check(value, name):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
            what = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
            raise ModelError(f"world: {name} must be {what}, got {value!r}")
        return int(value)
    return check


def _optional(check):
    def optional(value, name):
        return None if value is None else check(value, name)
    return optional


def _flag(value, name):
    if not isinstance(value, (bool, np.bool_, int, np.integer)):
        raise ModelError(f"world: {name} must be True or False, got {value!r}")
    return bool(value)


# How each field is checked (and normalised: ints to int, numbers to float).
_CHECKS = {
    "dt": _pos, "contact": _choice(CONTACT_MODELS), "gyroscopic": _choice(GYROSCOPIC),
    "quat_integration": _choice(QUAT_INTEGRATION), "divergence_limit": _pos,
    "solver": _choice(SOLVERS), "erp": _fraction, "cfm": _nonneg, "iterations": _count(1),
    "tolerance": _nonneg, "velocity_tolerance": _nonneg, "warm_start": _flag,
    "projection": _count(0),
    "projection_tolerance": _nonneg, "contact_erp": _fraction, "contact_cfm": _nonneg,
    "slop": _nonneg, "bounce_threshold": _nonneg, "penalty_stiffness": _optional(_pos),
    "penalty_damping": _optional(_nonneg), "slip_velocity": _optional(_pos),
    "penalty_integration": _choice(PENALTY_INTEGRATION),
    "contact_margin": _nonneg, "pd": _choice(PD_MODES), "broadphase": _choice(BROADPHASES),
    "profile": _flag, "sleep_time": _optional(_pos), "sleep_speed": _nonneg,
    "sleep_spin": _nonneg,
}


@dataclass
class Options:
    """How a world steps. All are keywords of ``World`` too, and may be changed between
    steps (``world.options.<name> = value`` or ``world.<name> = value``).

    dt : step in seconds.
    contact : 'lcp', 'pgs' or 'penalty' (the contact model; see the contact docs).
    gyroscopic : 'implicit' (default), 'variational', 'explicit' or 'none': how ``w x I w``
        enters the step; see ``tumble.pipeline.integrate``. 'variational' keeps a free
        body's angular momentum to round-off (with quat_integration 'exp' only).
    quat_integration : 'exp' (default; exact for a constant angular velocity) or
        'linear' (the lecture's ``q + h/2 (w, 0) q``, normalised).
    divergence_limit : a position or speed beyond this (m, m/s, rad/s) is a divergence.
    solver : 'direct' (default: exact, dense factorisation with an active set for limits and
        motors) or 'pgs' (projected Gauss-Seidel, warm-started).
    erp, cfm : ODE's error reduction (0..1, default 0.2) and constraint force mixing (default
        1e-10) for every joint that does not set its own.
    iterations, tolerance, velocity_tolerance : PGS sweeps at most, and what ends them
        sooner: a sweep that changes no impulse by more than ``tolerance`` (N s), or no
        row's velocity by more than ``velocity_tolerance`` (m/s, rad/s for angular rows;
        0 to sweep on). The second ends PGS on a heap of redundant contacts (a character
        lying down), whose impulses keep shifting among themselves for hundreds of sweeps
        after the bodies' velocities have settled.
    warm_start : start PGS from the previous step's impulses.
    projection : Gauss-Newton iterations that move joints back together after each position
        update without touching velocities (post-stabilisation; 0 to rely on ERP alone).
    projection_tolerance : largest row error (m, rad) past which projection runs; below it
        ERP alone pulls joints together, which dissipates less. Once running, projection
        stops when the error is below a tenth of this (or after ``projection``
        iterations).
    contact_erp, contact_cfm : ERP and CFM of contact rows (penetration pushed out per step,
        softness).
    slop : penetration (m) left alone, so resting contacts do not jitter.
    bounce_threshold : approach speed (m/s) below which restitution is ignored.
    penalty_stiffness, penalty_damping : N/m and N s/m of penalty contacts; default (None)
        from the lightest colliding body (see ``tumble.pipeline.contacts.penalty``). Geoms
        given their own ``stiffness``/``damping`` (``ModelBuilder.add_geom``) override them
        for their pairs.
    slip_velocity : None (default): penalty friction is a stick spring that holds below
        the friction angle; a speed (m/s): the regularised Coulomb law of that speed
        instead (see ``tumble.pipeline.contacts.penalty``).
    penalty_integration : 'implicit' (default): the springs and dampers of a body that no
        joint or servo holds act on its velocity at the end of the step (linearly implicit
        Euler, one 6x6 solve per body), so a heap of boxes on many contacts each is stable
        at the default stiffness; 'explicit': the lecture's forces from the state at the
        start of the step for every body (stable only while ``sqrt(K/m) h`` and ``C h/m``
        stay small; see ``tumble.pipeline.contacts.penalty``). Bodies in joints or under
        a body servo are explicit either way.
    contact_margin : contacts are found this far apart (m) so the solver stops a fast body
        at the surface instead of pushing it out afterwards (penalty ignores the gap).
    pd : how joint PD servos act: 'implicit' (default; a soft constraint row solved with
        the joints and contacts, stable for any gains and step), 'explicit' (the lecture's
        torques from the state at the start of the step) or 'stable' (stable PD, Tan et al.
        2011: explicit torques predicted against the end-of-step state by a joints-only
        implicit solve). Same gains in all three. See ``tumble.pipeline.actuators``.
    broadphase : how candidate geom pairs are found: 'sap' (sort and sweep) or 'grid'
        (hashed uniform grid, cell twice the median AABB size; planes, walls and
        heightfields kept out of it). Both give exactly the same pairs, so the contacts and
        the motion do not depend on it, only the time. A model with at most 512 geom pairs
        that may touch at all (a character, a small scene) uses neither: those pairs are
        listed once and their boxes tested every step, which is faster than sorting so few.
    profile : time every stage of the step (``World.stage_times``); off by default, when
        the step reads no clock.
    sleep_time : None (default): every body steps always. A time (s): an island of bodies
        (linked by joints or contacts) whose every body has moved at most ``sleep_speed``
        (m/s) and turned at most ``sleep_spin`` (rad/s) for that long, undriven, sleeps:
        it holds still at no cost in the solver until something touches, pushes or drives
        it (``World.sleeping``, ``World.wake``; see ``tumble.pipeline.sleep``). Box2D
        and Bullet sleep after 0.5 s and 2 s.
    sleep_speed, sleep_spin : the thresholds of rest (default 0.05 m/s, 0.1 rad/s).
    """
    dt: float
    contact: str = "lcp"
    gyroscopic: str = "implicit"
    quat_integration: str = "exp"
    divergence_limit: float = 1e8
    solver: str = "direct"
    erp: float = 0.2
    cfm: float = 1e-10
    iterations: int = 300
    tolerance: float = 1e-12
    velocity_tolerance: float = 1e-5
    warm_start: bool = True
    projection: int = 2
    projection_tolerance: float = 5e-5
    contact_erp: float = 0.2
    contact_cfm: float = 0.0
    slop: float = 1e-4
    bounce_threshold: float = 0.2
    penalty_stiffness: float = None
    penalty_damping: float = None
    slip_velocity: float = None
    penalty_integration: str = "implicit"
    contact_margin: float = 0.01
    pd: str = "implicit"
    broadphase: str = "sap"
    profile: bool = False
    sleep_time: float = None
    sleep_speed: float = 0.05
    sleep_spin: float = 0.1

    def __setattr__(self, name, value):
        if name not in _CHECKS:
            raise ModelError(f"world: no option named {name!r}; options are {list(_CHECKS)}")
        super().__setattr__(name, _CHECKS[name](value, name))


OPTION_NAMES = tuple(f.name for f in fields(Options))


def penalty_parameters(options, lightest_mass):
    """(stiffness N/m, damping N s/m) of penalty contacts at ``options.dt``: the options'
    own, or defaults for a body of ``lightest_mass`` kg."""
    k, c = default_penalty(lightest_mass, options.dt)
    return (options.penalty_stiffness or k,
            c if options.penalty_damping is None else options.penalty_damping)


def step_options(options, lightest_mass):
    """The compiled step's ``StepOptions`` for ``options``; ``lightest_mass`` (kg) of the
    colliding bodies sets the default penalty contact."""
    o = options
    if o.gyroscopic == "variational" and o.quat_integration != "exp":
        raise ModelError("world: gyroscopic='variational' needs quat_integration='exp' (its "
                         f"rotations are exponential maps), got {o.quat_integration!r}")
    k, c = penalty_parameters(o, lightest_mass)
    v_slip = o.slip_velocity or 0.0          # 0: the stick-spring friction
    return StepOptions(
        float(o.dt), GYROSCOPIC[o.gyroscopic], QUAT_INTEGRATION[o.quat_integration],
        float(o.divergence_limit), float(o.erp), float(o.cfm), SOLVERS[o.solver],
        int(o.iterations), float(o.tolerance), float(o.velocity_tolerance),
        bool(o.warm_start), int(o.projection),
        float(o.projection_tolerance), CONTACT_MODELS[o.contact], float(o.contact_erp),
        float(o.contact_cfm), float(o.slop), float(o.bounce_threshold), float(k), float(c),
        float(v_slip), PENALTY_INTEGRATION[o.penalty_integration], float(o.contact_margin),
        PD_MODES[o.pd], BROADPHASES[o.broadphase], bool(o.profile),
        float(o.sleep_time or 0.0), float(o.sleep_speed), float(o.sleep_spin))
