"""Sleeping: islands of bodies at rest leave the step until something wakes them.

On when ``StepOptions.sleep_time`` > 0 (``World(sleep_time=...)``). An *island* is a set of
dynamic bodies linked by joints or by this step's contacts (static and kinematic bodies and
the world link nothing, so a floor does not merge everything on it into one island).

Each dynamic body's time at rest, ``StateArrays.body_rest`` (s), grows by ``dt`` at every
step that starts with its speed at most ``sleep_speed`` (m/s) and its spin at most
``sleep_spin`` (rad/s), up to ``sleep_time``; it restarts from 0 when the body moves faster,
or when something drives it: an applied force or torque, a body servo, a driven joint (a
servo with stiffness, a damper with a target rate, a motor with a target, an applied joint
torque, an MJCF actuator), or a contact or joint with a moving kinematic body.

An island sleeps while all its bodies have been at rest for ``sleep_time``. Its bodies keep
their poses with zero velocities, and its contacts (those with no awake body) get no rows and
no penalty forces: they keep last step's impulses, which warm start the island when it wakes.
Its joint rows are still solved (with zero velocities: cheap, and it keeps the rows simple).
A body that touches a sleeping island this step joins it in one island, which is then awake
because the toucher has not been at rest: the island wakes in the step of the touch, before
any row is built. Every body takes its island's time at rest (the least of its bodies'), so
a woken island, or a body that parts from a moving one (a box whose support is pulled
away), needs ``sleep_time`` of rest again before it sleeps; and ``body_rest >=
sleep_time`` says exactly which bodies slept in the last step (``World.sleeping``).

Contacts are reordered so the awake ones come first (each part in its pair order); the step
lays out rows for those only. The narrow phase does not test a pair of sleeping (or static)
bodies again: they have not moved since it last did, so it takes last step's contacts of
the pair (``collide.py``).
"""
from numba import njit

from .._jit import noalloc
from ..model.types import DYNAMIC
from .contacts.arrays import copy_contact


@njit(cache=True, inline="always")
def _root(island, b):
    """The representative of body ``b``'s island (union-find with path halving)."""
    while island[b] != b:
        island[b] = island[island[b]]
        b = island[b]
    return b


@njit(cache=True, inline="always")
def _link(island, a, b):
    """Merge the islands of bodies ``a`` and ``b``."""
    ra, rb = _root(island, a), _root(island, b)
    if ra != rb:
        island[max(ra, rb)] = min(ra, rb)


@njit(cache=True, inline="always")
def _moving(vel, angvel, b, v2, w2):
    """Whether body ``b`` moves faster than the sleep thresholds (squared: v2, w2)."""
    sv = vel[b, 0] * vel[b, 0] + vel[b, 1] * vel[b, 1] + vel[b, 2] * vel[b, 2]
    sw = angvel[b, 0] * angvel[b, 0] + angvel[b, 1] * angvel[b, 1] + angvel[b, 2] * angvel[b, 2]
    return sv > v2 or sw > w2


@njit(cache=True, inline="always")
def _joint_driven(m, c, j):
    """Whether joint ``j`` is driven by its controls ``c`` (one world's)."""
    if c.pd_kp[j] > 0.0:
        return True
    for k in range(3):
        if c.joint_applied[j, k] != 0.0:
            return True
        if c.pd_kd[j] > 0.0 and c.pd_target_qd[j, k] != 0.0:
            return True
        if m.joint_motor_max[j] > 0.0 and c.motor_target[j, k] != 0.0:
            return True
    return False


@njit(cache=True, inline="always")
def _body_driven(c, b):
    """Whether body ``b`` has an applied load or a body servo in the controls ``c``."""
    for k in range(3):
        if c.applied_force[b, k] != 0.0 or c.applied_torque[b, k] != 0.0:
            return True
    for k in range(4):
        if c.body_servo[b, k] > 0.0:
            return True
    return False


@noalloc
def update_rest(m, vel, angvel, rest, c, o):
    """Each dynamic body's time at rest ``rest`` (nbody,) s, from its velocities (nbody, 3)
    at the start of the step and what drives it (the controls ``c`` of its world)."""
    v2, w2 = o.sleep_speed * o.sleep_speed, o.sleep_spin * o.sleep_spin
    for b in range(rest.shape[0]):
        if m.body_kind[b] != DYNAMIC or _moving(vel, angvel, b, v2, w2) or _body_driven(c, b):
            rest[b] = 0.0
        else:
            rest[b] = min(rest[b] + o.dt, o.sleep_time)
    for j in range(m.joint_child.shape[0]):
        p, ch = m.joint_parent[j], m.joint_child[j]
        if _joint_driven(m, c, j):
            rest[ch] = 0.0
            if p >= 0:
                rest[p] = 0.0
    for a in range(m.act_joint.shape[0]):
        j = m.act_joint[a]
        rest[m.joint_child[j]] = 0.0
        if m.joint_parent[j] >= 0:
            rest[m.joint_parent[j]] = 0.0


@njit(cache=True, inline="always")
def _touch(m, vel, angvel, rest, island, a, b, v2, w2):
    """Bodies ``a`` and ``b`` (-1: the world) touch or are joined: link two dynamic ones;
    a moving kinematic one wakes its dynamic partner."""
    if a < 0 or b < 0:
        return
    da, db = m.body_kind[a] == DYNAMIC, m.body_kind[b] == DYNAMIC
    if da and db:
        _link(island, a, b)
    elif da and _moving(vel, angvel, b, v2, w2):
        rest[a] = 0.0
    elif db and _moving(vel, angvel, a, v2, w2):
        rest[b] = 0.0


@njit(cache=True, inline="always")
def _contact_awake(con, awake, i):
    a, b = con.body[i, 0], con.body[i, 1]
    return (a >= 0 and awake[a]) or (b >= 0 and awake[b])


@noalloc
def sleep_islands(m, vel, angvel, rest, c, con, ncon, o, island, island_rest, awake, spare):
    """The sleep stage of one world, after collision: times at rest updated
    (``update_rest``), islands found, sleeping ones frozen (zero velocities) and their
    contacts moved behind the awake ones.

    vel, angvel : (nbody, 3) at the start of the step; rest : (nbody,) the world's
    ``body_rest``; c : its controls; con, ncon : this step's contacts; island (nbody,)
    int64, island_rest (nbody,) float and awake (nbody,) bool: scratch, ``awake`` left
    marking the dynamic bodies of awake islands; spare: ContactArrays as large as ``con``
    whose contents may be overwritten (the step's ``prev``, matched by then).
    Returns (contacts with an awake body, now first; bodies asleep).
    """
    nb = rest.shape[0]
    v2, w2 = o.sleep_speed * o.sleep_speed, o.sleep_spin * o.sleep_spin
    update_rest(m, vel, angvel, rest, c, o)
    for b in range(nb):
        island[b] = b
    for j in range(m.joint_child.shape[0]):
        _touch(m, vel, angvel, rest, island, m.joint_parent[j], m.joint_child[j], v2, w2)
    for i in range(ncon):
        _touch(m, vel, angvel, rest, island, con.body[i, 0], con.body[i, 1], v2, w2)
    for b in range(nb):
        island_rest[b] = o.sleep_time
    for b in range(nb):
        if m.body_kind[b] == DYNAMIC:
            r = _root(island, b)
            island_rest[r] = min(island_rest[r], rest[b])
    asleep = 0
    for b in range(nb):
        if m.body_kind[b] != DYNAMIC:
            awake[b] = False
            continue
        # the island's clock: a body that leaves a moving island has not been at rest
        rest[b] = island_rest[_root(island, b)]
        awake[b] = rest[b] < o.sleep_time
        if not awake[b]:
            asleep += 1
    if asleep == 0:
        return ncon, asleep
    freeze(vel, angvel, awake, m)
    return awake_contacts_first(con, ncon, awake, spare), asleep


@noalloc
def awake_contacts_first(con, ncon, awake, spare):
    """Move the contacts ``con[:ncon]`` that touch an ``awake`` body (nbody,) bool before
    the others, each part keeping its order (so both stay in the narrow phase's pair order,
    which the next step's warm start relies on; ``spare`` holds the sleeping ones
    meanwhile). Returns the number of contacts with an awake body."""
    first_asleep = ncon
    for i in range(ncon):
        if not _contact_awake(con, awake, i):
            first_asleep = i
            break
    mixed = False
    for i in range(first_asleep, ncon):
        if _contact_awake(con, awake, i):
            mixed = True
            break
    if not mixed:
        return first_asleep                 # already in two parts: nothing moves
    k = first_asleep
    nsleep = 0
    for i in range(first_asleep, ncon):
        if _contact_awake(con, awake, i):
            copy_contact(con, i, con, k)
            k += 1
        else:
            copy_contact(con, i, spare, nsleep)
            nsleep += 1
    for q in range(nsleep):
        copy_contact(spare, q, con, k + q)
    return k


@noalloc
def freeze(vel, angvel, awake, m):
    """Zero the velocities of the dynamic bodies that are not ``awake`` (asleep)."""
    for b in range(awake.shape[0]):
        if m.body_kind[b] == DYNAMIC and not awake[b]:
            for k in range(3):
                vel[b, k] = 0.0
                angvel[b, k] = 0.0
