"""The step of a model with nothing to collide, constrain or actuate.

A model without joints, actuators or a second geom, whose bodies have no servo on, needs
only three of the step's stages (``step.py``): forces, integration and the divergence
check. ``step_free_worlds`` runs those, the same kernels in the same order, so its results
are bit for bit the full step's; ``step_free_checked`` wraps it in the same checks and
rollback as ``call.step_span``. What it saves is the first run's compile: these few
kernels take seconds to compile where the whole pipeline takes minutes (a spinning
body, a projectile, a tumbling satellite: the demo).
"""
import numpy as np
from numba import njit

from .._jit import ArgBox, assign_arrays, copy_arrays, world_of
from .arrays import (STAGE_CHECK, STAGE_COLLIDE, STAGE_COORDINATES, STAGE_FORCES,
                     STAGE_INTEGRATE_POSITIONS, STAGE_INTEGRATE_VELOCITIES, STAGE_PROJECT)
from .call import CALL_STEPPED, clear_applied, prepare_inputs
from .forces import accumulate_forces
from .integrate import first_bad_body, integrate_positions, integrate_velocities
from .step import STEP_DIVERGED, STEP_OK, _lap, _start


def is_free(model, body_servo):
    """Whether ``step_free_checked`` steps a world of ``model`` exactly as the full step
    does: no joints, no actuators, at most one geom (nothing to collide with), and no body
    servo with a gain above zero in ``body_servo`` (nworld, nbody, 4)."""
    return (model.njoint == 0 and model.nactuator == 0 and model.ngeom <= 1
            and not (body_servo > 0.0).any())


@njit(cache=True)
def step_free_worlds(m, s, c, n, o):
    """``step.step_worlds`` for a free model (``is_free``): forces, velocities, positions
    and the divergence check of every world, ``n`` times. Returns (status, world, step,
    body) as ``step_worlds`` does (without ``needed``: no buffer can run short)."""
    nb = s.body_pos.shape[1]
    force, torque = np.empty((nb, 3)), np.empty((nb, 3))
    for w in range(s.body_pos.shape[0]):
        sw, cw = world_of(s, w), world_of(c, w)
        pos, quat, vel, angvel = sw.body_pos, sw.body_quat, sw.body_vel, sw.body_angvel
        for k in range(n):
            t = _start(o)
            t = _lap(o, sw.stage_ticks, STAGE_COLLIDE, t)
            accumulate_forces(m, cw.applied_force, cw.applied_torque, force, torque)
            t = _lap(o, sw.stage_ticks, STAGE_FORCES, t)
            integrate_velocities(m, quat, vel, angvel, force, torque, o.dt, o.gyroscopic)
            t = _lap(o, sw.stage_ticks, STAGE_INTEGRATE_VELOCITIES, t)
            integrate_positions(m, pos, quat, vel, angvel, o.dt, o.quat_integration)
            t = _lap(o, sw.stage_ticks, STAGE_INTEGRATE_POSITIONS, t)
            t = _lap(o, sw.stage_ticks, STAGE_PROJECT, t)
            bad = first_bad_body(pos, quat, vel, angvel, o.divergence_limit)
            _lap(o, sw.stage_ticks, STAGE_CHECK, t)
            if bad >= 0:
                return STEP_DIVERGED, w, k, bad
        _lap(o, sw.stage_ticks, STAGE_COORDINATES, _start(o))
    return STEP_OK, -1, -1, -1


@njit(cache=True, inline="always")
def _written(s, c):
    """What a free step call may change, as a tuple of the arrays themselves: the bodies'
    state and stage times, and the body servos' target rotations (the checks normalise
    them); joints, contacts and actuators have no entries."""
    return (s.body_pos, s.body_quat, s.body_vel, s.body_angvel, s.stage_ticks,
            c.body_target_quat)


@njit(cache=True, inline="always")
def step_free_checked(m, s, c, n, o, ball):
    """``call.step_span`` around ``step_free_worlds``: the same checks, the same
    rollback on a failure (of what ``_written`` lists), the same (stage, code, world,
    index, step, needed) report (never CALL_NEW_WORK: there is no scratch to outgrow)."""
    saved = copy_arrays(_written(s, c))
    stage, code, w, i = prepare_inputs(m, s, c, ball)
    if stage != CALL_STEPPED:
        assign_arrays(_written(s, c), saved)
        return stage, code, w, i, -1, np.int64(0)
    status, fw, fk, fb = step_free_worlds(m, s, c, n, o)
    if status == STEP_OK:
        clear_applied(c)
    else:
        assign_arrays(_written(s, c), saved)
    return CALL_STEPPED, status, fw, fb, fk, np.int64(0)


@njit(cache=True)
def box_free_args(m, s, c, ball):
    """The arrays ``step_free_checked`` takes, in one ``ArgBox`` (see
    ``call.box_step_args``: one object crosses into compiled code instead of ~90 arrays,
    which halves a free body's ``step(1)`` call)."""
    return ArgBox((m, s, c, ball))


@njit(cache=True)
def step_free_boxed(box, n, o):
    """``step_free_checked`` on the arrays held by ``box`` (``box_free_args``)."""
    m, s, c, ball = box.args
    return step_free_checked(m, s, c, n, o, ball)
