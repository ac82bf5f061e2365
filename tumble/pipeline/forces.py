"""Stage 1 of a step: the external force and torque on each body.

Gravity plus the user's applied forces (``World.apply_force``); later stages add
actuators. The gyroscopic term is treated in ``integrate.py``, where its explicit or
implicit form is chosen.
"""
from .._jit import noalloc
from ..model.types import DYNAMIC


@noalloc
def accumulate_forces(m, applied_force, applied_torque, force_out, torque_out):
    """Total force (N) and torque (N m) on each body about its COM, world frame.

    m : ModelArrays.  applied_force, applied_torque, force_out, torque_out : (nbody, 3).
    Bodies that are not dynamic get zero: nothing can accelerate them.
    """
    g = m.gravity
    for b in range(m.body_kind.shape[0]):
        if m.body_kind[b] != DYNAMIC:
            for k in range(3):
                force_out[b, k] = 0.0
                torque_out[b, k] = 0.0
            continue
        mass = 1.0 / m.body_inv_mass[b]
        for k in range(3):
            force_out[b, k] = mass * g[k] + applied_force[b, k]
            torque_out[b, k] = applied_torque[b, k]
