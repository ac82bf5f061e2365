"""World: the state of one model (or a batch of copies) and the calls that step and query it."""
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba.typed import List as TypedList

from .errors import ModelError, SimulationError, StateError, TumbleWarning
from .math.quat import quat_rotate, quat_rotate_inv
from .model.model import DYNAMIC, Model
from .model.validate import positive
from .pipeline import step as pipeline_step
from .pipeline.contacts.arrays import ContactArrays, make_contacts
from .pipeline.contacts.penalty import default_penalty
from .pipeline.parallel import step_worlds_parallel
from .pipeline.queries import distance_between, raycast_scene
from .pipeline.actuators import PD_MODES
from .pipeline.collision.broadphase import BROADPHASES
from .pipeline.integrate import GYRO_EXPLICIT, GYRO_IMPLICIT, GYRO_NONE, QUAT_EXP, QUAT_LINEAR

GYROSCOPIC = {"implicit": GYRO_IMPLICIT, "explicit": GYRO_EXPLICIT, "none": GYRO_NONE}
QUAT_INTEGRATION = {"exp": QUAT_EXP, "linear": QUAT_LINEAR}
CONTACT_MODELS = {"lcp": pipeline_step.CONTACT_LCP, "pgs": pipeline_step.CONTACT_PGS,
                  "penalty": pipeline_step.CONTACT_PENALTY}
SOLVERS = {"direct": pipeline_step.SOLVER_DIRECT, "pgs": pipeline_step.SOLVER_PGS}

_STATE_FIELDS = {
    pipeline_step.STATE_NONFINITE_POS: "body_pos is not finite",
    pipeline_step.STATE_NONFINITE_QUAT: "body_quat is not finite",
    pipeline_step.STATE_ZERO_QUAT: "body_quat is zero",
    pipeline_step.STATE_NONFINITE_VEL: "body_vel is not finite",
    pipeline_step.STATE_NONFINITE_ANGVEL: "body_angvel is not finite",
    pipeline_step.STATE_NONFINITE_FORCE: "the applied force is not finite",
    pipeline_step.STATE_NONFINITE_TORQUE: "the applied torque is not finite",
}


def _type_key(x):
    """What Numba's type of ``x`` depends on, cheaply: for arrays dtype, rank, layout and
    writability; namedtuples field by field; other values their Python type."""
    if isinstance(x, np.ndarray):
        return (x.dtype.str, x.ndim, x.flags.c_contiguous, x.flags.writeable)
    if isinstance(x, tuple):
        return (type(x),) + tuple(_type_key(v) for v in x)
    if isinstance(x, TypedList):
        return x._numba_type_
    return type(x)


# compiled entry points found so far, by (dispatcher, _type_key of the arguments)
_ENTRY_POINTS = {}


def _entry_point(dispatcher, args, compiled_only=False):
    """The compiled entry point of Numba ``dispatcher`` for arguments typed as ``args``
    (the dispatcher itself if this Numba does not expose it): calling it skips the
    dispatcher's type matching, which costs more than a small world's step. Matching
    the types once costs 2 ms, so the entry point is remembered for every world whose
    arguments have the same types. With ``compiled_only``, None when nothing is compiled
    for these types yet (the caller then goes through the dispatcher, which compiles)."""
    key = (dispatcher, _type_key(args))
    entry = _ENTRY_POINTS.get(key)
    if entry is None:
        try:
            sig = tuple(dispatcher.typeof_pyval(a) for a in args)
            entry = dispatcher.overloads[sig].entry_point
        except KeyError:
            if compiled_only:
                return None
            entry = dispatcher
        except (AttributeError, TypeError):
            entry = dispatcher
        _ENTRY_POINTS[key] = entry
    return entry


def _drops_box(attr):
    """A World property kept in ``attr`` whose assignment drops the step's box
    (``World._box``, ``step.box_step_args``): the box holds the old object's arrays."""
    def get(world):
        return getattr(world, attr)

    def put(world, value):
        setattr(world, attr, value)
        world._box = None
    return property(get, put)


# How check_drives' fields are named in errors (the user-facing name where it differs).
_DRIVE_NAMES = {"motor_target": "joint_motor_target", "joint_applied": "joint torque",
                "pd_kp": "joint_kp", "pd_kd": "joint_kd", "body_servo": "body servo gain"}


@dataclass
class Contacts:
    """Contacts of one step, as arrays over n contacts (see ``World.contacts_of``)."""
    geoms: np.ndarray
    bodies: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    force: np.ndarray
    normal_force: np.ndarray
    torque: np.ndarray

    def __len__(self):
        return len(self.depth)


def _npz_path(path):
    """``path`` with ``.npz`` appended to file names that lack it (np.savez's own rule)."""
    if isinstance(path, (str, os.PathLike)):
        path = Path(path)
        return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")
    return path


def _names_preview(names, count=6):
    names = list(names)
    return str(names) if len(names) <= count else str(names[:count])[:-1] + ", ...]"


def _tangents(normal):
    """The tangents ``contacts.rows.tangents`` picks, vectorised over (n, 3) normals."""
    n = normal
    use_x = np.abs(n[:, 0]) < 0.57735
    a = np.where(use_x[:, None], np.stack([np.zeros(len(n)), n[:, 2], -n[:, 1]], -1),
                 np.stack([-n[:, 2], np.zeros(len(n)), n[:, 0]], -1))
    t1 = a / np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-300)
    return t1, np.cross(n, t1)


@dataclass
class State:
    """A snapshot of a world's state (copies, safe to keep): see ``World.get_state``.

    Arrays have a leading world axis: body_pos (nworld, nbody, 3), body_quat
    (nworld, nbody, 4), body_vel and body_angvel (nworld, nbody, 3); time in s.
    The rest is what makes a restored world step on bit for bit as the saved one would
    (None when not known, e.g. a State written by hand: ``set_state`` then starts from
    zero impulses, no contacts, no motor targets and no pending forces):
    row_impulse (nworld, nrow) last step's joint row impulses, N s (solver warm start);
    motor_target (nworld, njoint, 3); applied_force, applied_torque (nworld, nbody, 3)
    pending for the next step; joint_force, joint_torque (nworld, njoint, 3) of the last
    step; contact_count (nworld,) and contacts (a ``ContactArrays`` of (nworld, n, ...)
    arrays, n = the largest count) of the last step, whose impulses warm start the next;
    the joint servos and actuators: pd_kp, pd_kd, pd_max (nworld, njoint), pd_target_quat
    (nworld, njoint, 4), pd_target_q, pd_target_qd, joint_applied (nworld, njoint, 3), ctrl
    (nworld, nactuator); the body servos: body_servo (nworld, nbody, 4), body_target_pos,
    body_target_vel, body_target_angvel (nworld, nbody, 3), body_target_quat (nworld, nbody,
    4) (all left as the world has them when None).
    body_names, joint_names: the names of the model's bodies and joints (tuples), which
    ``get_state`` records so that ``set_state`` refuses the state of another model even
    when its arrays have the same shapes (None: not checked, e.g. a State written by hand).
    """
    time: float
    body_pos: np.ndarray
    body_quat: np.ndarray
    body_vel: np.ndarray
    body_angvel: np.ndarray
    row_impulse: np.ndarray = None
    motor_target: np.ndarray = None
    applied_force: np.ndarray = None
    applied_torque: np.ndarray = None
    joint_force: np.ndarray = None
    joint_torque: np.ndarray = None
    pd_kp: np.ndarray = None
    pd_kd: np.ndarray = None
    pd_max: np.ndarray = None
    pd_target_quat: np.ndarray = None
    pd_target_q: np.ndarray = None
    pd_target_qd: np.ndarray = None
    joint_applied: np.ndarray = None
    ctrl: np.ndarray = None
    body_servo: np.ndarray = None
    body_target_pos: np.ndarray = None
    body_target_quat: np.ndarray = None
    body_target_vel: np.ndarray = None
    body_target_angvel: np.ndarray = None
    contact_count: np.ndarray = None
    contacts: ContactArrays = None
    body_names: tuple = None
    joint_names: tuple = None


# Fields of State past the body state, each a copy of the StateArrays field of that name.
_EXTRA_STATE = ("row_impulse", "motor_target", "applied_force", "applied_torque",
                "joint_force", "joint_torque", "pd_kp", "pd_kd", "pd_max", "pd_target_quat",
                "pd_target_q", "pd_target_qd", "joint_applied", "ctrl", "body_servo",
                "body_target_pos", "body_target_quat", "body_target_vel", "body_target_angvel")
# Actuator fields: left as they are when a State does not carry them.
_DRIVE_STATE = ("pd_kp", "pd_kd", "pd_max", "pd_target_quat", "pd_target_q", "pd_target_qd",
                "joint_applied", "ctrl", "body_servo", "body_target_pos", "body_target_quat",
                "body_target_vel", "body_target_angvel")
_STATE_FILE_VERSION = 2


class World:
    """A model's state and its time stepping.

    Parameters
    ----------
    model : Model
    dt : step in seconds (default ``model.timestep``).
    contact : 'lcp', 'pgs' or 'penalty' (the contact model; see the contact docs).
    nworld : number of independent copies stepped together (state arrays then carry a
        leading world axis).
    gyroscopic : 'implicit' (default), 'explicit' or 'none': how ``w x I w`` enters the
        step; see ``tumble.pipeline.integrate``.
    quat_integration : 'exp' (default; exact for a constant angular velocity) or
        'linear' (the lecture's ``q + h/2 (w, 0) q``, normalised).
    divergence_limit : a position or speed beyond this (m, m/s, rad/s) is a divergence.
    solver : 'direct' (default: exact, dense factorisation with an active set for limits and
        motors) or 'pgs' (projected Gauss-Seidel, warm-started).
    erp, cfm : ODE's error reduction (0..1, default 0.2) and constraint force mixing (default
        1e-10) for every joint that does not set its own.
    iterations, tolerance : PGS sweeps at most, and the impulse change (N s) that ends them.
    warm_start : start PGS from the previous step's impulses.
    projection : Gauss-Newton iterations that move joints back together after each position
        update without touching velocities (post-stabilisation; 0 to rely on ERP alone).
    contact_erp, contact_cfm : ERP and CFM of contact rows (penetration pushed out per step,
        softness).
    contact_margin : contacts are found this far apart (m) so the solver stops a fast body
        at the surface instead of pushing it out afterwards (penalty ignores the gap).
    slop : penetration (m) left alone, so resting contacts do not jitter.
    bounce_threshold : approach speed (m/s) below which restitution is ignored.
    penalty_stiffness, penalty_damping : N/m and N s/m of penalty contacts; default from the
        lightest colliding body (see ``tumble.pipeline.contacts.penalty``). Geoms given their
        own ``stiffness``/``damping`` (``ModelBuilder.add_geom``) override them for their
        pairs; a geom stiffness too stiff for its body at this dt is warned about.
    slip_velocity : penalty friction's regularisation speed (m/s); default ``|g| dt``.
    projection_tolerance : largest row error (m, rad) past which projection runs; below it ERP
        alone pulls joints together, which dissipates less. Once running, projection stops
        when the error is below a thousandth of this (or after ``projection`` iterations).
    pd : how joint PD servos act: 'implicit' (default; a soft constraint row solved with
        the joints and contacts, stable for any gains and step), 'explicit' (the lecture's
        torques from the state at the start of the step) or 'stable' (stable PD, Tan et al.
        2011: explicit torques predicted against the end-of-step state by a joints-only
        implicit solve). Same gains in all three; may be changed between steps. See
        ``tumble.pipeline.actuators``.
    broadphase : how candidate geom pairs are found: 'sap' (sort and sweep) or 'grid'
        (hashed uniform grid, cell twice the median AABB size; planes, walls and
        heightfields kept out of it). Both give exactly the same pairs, so the contacts and
        the motion do not depend on it, only the time; may be changed between steps. A
        model with at most 512 geom pairs that may touch at all (a character, a small
        scene) uses neither: those pairs are listed once and their boxes tested every step,
        which is faster than sorting so few.
    parallel : step the worlds of a batch on all of Numba's threads (``numba.set_num_threads``
        sets how many), each world bit-identical to the serial path. Default: when
        ``nworld > 1``.

    The state arrays ``body_pos``, ``body_quat``, ``body_vel``, ``body_angvel`` are live
    views: write into them between steps to set the state.
    """

    def __init__(self, model, dt=None, *, contact="lcp", nworld=1, gyroscopic="implicit",
                 quat_integration="exp", divergence_limit=1e8, solver="direct", erp=0.2,
                 cfm=1e-10, iterations=300, tolerance=1e-12, warm_start=True, projection=2,
                 projection_tolerance=5e-5, contact_erp=0.2, contact_cfm=0.0, slop=1e-4,
                 bounce_threshold=0.2, penalty_stiffness=None, penalty_damping=None,
                 slip_velocity=None, contact_margin=0.01, pd="implicit",
                 broadphase="sap", parallel=None):
        if not isinstance(model, Model):
            raise ModelError(f"World needs a tumble Model, got {type(model).__name__}")
        self.model = model
        self.dt = model.timestep if dt is None else dt
        if contact not in CONTACT_MODELS:
            raise ModelError(f"world: contact must be one of {list(CONTACT_MODELS)}, "
                             f"got {contact!r}")
        if gyroscopic not in GYROSCOPIC:
            raise ModelError(f"world: gyroscopic must be one of {list(GYROSCOPIC)}, "
                             f"got {gyroscopic!r}")
        if quat_integration not in QUAT_INTEGRATION:
            raise ModelError(f"world: quat_integration must be one of "
                             f"{list(QUAT_INTEGRATION)}, got {quat_integration!r}")
        if isinstance(nworld, bool) or not isinstance(nworld, (int, np.integer)) or nworld < 1:
            raise ModelError(f"world: nworld must be a positive integer, got {nworld!r}")
        self.contact = contact
        self.gyroscopic = gyroscopic
        self.quat_integration = quat_integration
        self.divergence_limit = positive(divergence_limit, "world", "divergence_limit")
        if solver not in SOLVERS:
            raise ModelError(f"world: solver must be one of {list(SOLVERS)}, got {solver!r}")
        self.solver = solver
        self.erp = positive(erp, "world", "erp", allow_zero=True)
        if self.erp > 1.0:
            raise ModelError(f"world: erp must be in [0, 1], got {erp!r}")
        self.cfm = positive(cfm, "world", "cfm", allow_zero=True)
        if isinstance(iterations, bool) or not isinstance(iterations, (int, np.integer)) \
                or iterations < 1:
            raise ModelError(f"world: iterations must be a positive integer, got {iterations!r}")
        self.iterations = int(iterations)
        self.tolerance = positive(tolerance, "world", "tolerance", allow_zero=True)
        self.warm_start = bool(warm_start)
        if isinstance(projection, bool) or not isinstance(projection, (int, np.integer)) \
                or projection < 0:
            raise ModelError(f"world: projection must be an integer >= 0, got {projection!r}")
        self.projection = int(projection)
        self.projection_tolerance = positive(projection_tolerance, "world",
                                             "projection_tolerance", allow_zero=True)
        self.contact_erp = positive(contact_erp, "world", "contact_erp", allow_zero=True)
        if self.contact_erp > 1.0:
            raise ModelError(f"world: contact_erp must be in [0, 1], got {contact_erp!r}")
        self.contact_cfm = positive(contact_cfm, "world", "contact_cfm", allow_zero=True)
        self.slop = positive(slop, "world", "slop", allow_zero=True)
        self.contact_margin = positive(contact_margin, "world", "contact_margin",
                                       allow_zero=True)
        self.bounce_threshold = positive(bounce_threshold, "world", "bounce_threshold",
                                         allow_zero=True)
        self.penalty_stiffness = None if penalty_stiffness is None else positive(
            penalty_stiffness, "world", "penalty_stiffness")
        self.penalty_damping = None if penalty_damping is None else positive(
            penalty_damping, "world", "penalty_damping", allow_zero=True)
        self.slip_velocity = None if slip_velocity is None else positive(
            slip_velocity, "world", "slip_velocity")
        self.pd = pd
        self.broadphase = broadphase
        if contact == "penalty":
            self._warn_stiff_geoms()
        self.nworld = int(nworld)
        if parallel is not None and not isinstance(parallel, (bool, np.bool_)):
            raise ModelError(f"world: parallel must be True, False or None, got {parallel!r}")
        self.parallel = self.nworld > 1 if parallel is None else bool(parallel)
        self._ball_joints = np.array([t == "ball" for t in model.joint_type_names], np.bool_)
        # what the step options derive from the (immutable) model, found once
        colliding = model.body_mass[np.isin(np.arange(model.nbody), model.geom_body)
                                    & (model.body_kind == DYNAMIC)]
        self._lightest_colliding_mass = float(colliding.min()) if colliding.size else 1.0
        self._gravity_norm = float(np.linalg.norm(model.gravity))
        nb, nw, nj = model.nbody, self.nworld, model.njoint
        self._state = pipeline_step.StateArrays(
            body_pos=np.zeros((nw, nb, 3)), body_quat=np.zeros((nw, nb, 4)),
            body_vel=np.zeros((nw, nb, 3)), body_angvel=np.zeros((nw, nb, 3)),
            applied_force=np.zeros((nw, nb, 3)), applied_torque=np.zeros((nw, nb, 3)),
            row_impulse=np.zeros((nw, model.nrow)), motor_target=np.zeros((nw, nj, 3)),
            pd_kp=np.zeros((nw, nj)), pd_kd=np.zeros((nw, nj)), pd_max=np.zeros((nw, nj)),
            pd_target_quat=np.zeros((nw, nj, 4)), pd_target_q=np.zeros((nw, nj, 3)),
            pd_target_qd=np.zeros((nw, nj, 3)), joint_applied=np.zeros((nw, nj, 3)),
            ctrl=np.zeros((nw, model.nactuator)), body_servo=np.zeros((nw, nb, 4)),
            body_target_pos=np.zeros((nw, nb, 3)), body_target_quat=np.zeros((nw, nb, 4)),
            body_target_vel=np.zeros((nw, nb, 3)), body_target_angvel=np.zeros((nw, nb, 3)),
            joint_q=np.zeros((nw, nj, 3)), joint_qd=np.zeros((nw, nj, 3)),
            joint_qrel=np.zeros((nw, nj, 4)), joint_force=np.zeros((nw, nj, 3)),
            joint_torque=np.zeros((nw, nj, 3)), contact_count=np.zeros(nw, np.int64),
            lcp_fallbacks=np.zeros(nw, np.int64))
        self._box = None           # step.box_step_args of the arrays below, once made
        self._contacts = make_contacts(nw, 8 * model.ngeom + 64)
        self._pairs = np.zeros((8 * model.ngeom + 64, 2), np.int32)
        self._work = None          # scratch of the serial step, kept between calls
        self._entry = None         # step_boxed's compiled entry point, once called
        self.reset()
        self._prepare_step()

    def _prepare_step(self):
        """The serial step's scratch memory and compiled entry point, made now when an
        earlier world of the process has compiled the step for the same argument types:
        the first ``step`` call then costs what the others do instead of a millisecond
        more. The first world of a process compiles the step on its first ``step``."""
        if self.parallel or not pipeline_step.step_boxed.overloads:
            return
        options = self._options()
        work = self._make_work(options)
        box = self._make_box(work, compiled_only=True)
        if box is None:
            return
        entry = _entry_point(pipeline_step.step_boxed, (box, 1, options), compiled_only=True)
        if entry is not None:
            self._work, self._box, self._entry = work, box, entry

    # The step's box (``_box``) holds these objects' arrays: replacing one drops it.
    _contacts = _drops_box("_contacts_arrays")
    _pairs = _drops_box("_pairs_buffer")
    _work = _drops_box("_work_memory")

    @property
    def dt(self):
        """Step size in seconds; may be changed between steps."""
        return self._dt

    @dt.setter
    def dt(self, value):
        self._dt = positive(value, "world", "dt")

    @property
    def pd(self):
        """PD servo mode: 'implicit', 'explicit' or 'stable' (see the class docs)."""
        return self._pd

    @pd.setter
    def pd(self, value):
        if value not in PD_MODES:
            raise ModelError(f"world: pd must be one of {list(PD_MODES)}, got {value!r}")
        self._pd = value

    @property
    def broadphase(self):
        """Broad phase: 'sap' or 'grid' (see the class docs)."""
        return self._broadphase

    @broadphase.setter
    def broadphase(self, value):
        if not isinstance(value, str) or value not in BROADPHASES:
            raise ModelError(f"world: broadphase must be one of {list(BROADPHASES)}, "
                             f"got {value!r}")
        self._broadphase = value

    # ------------------------------------------------------------------ state
    def reset(self):
        """Back to the model's initial state at time 0; applied forces cleared."""
        s = self._state
        s.body_pos[:] = self.model.body_pos0
        s.body_quat[:] = self.model.body_quat0
        s.body_vel[:] = self.model.body_vel0
        s.body_angvel[:] = self.model.body_angvel0
        s.applied_force[:] = 0.0
        s.applied_torque[:] = 0.0
        s.row_impulse[:] = 0.0
        s.motor_target[:] = 0.0
        s.joint_force[:] = 0.0
        s.joint_torque[:] = 0.0
        s.contact_count[:] = 0
        s.pd_kp[:] = self.model.joint_kp
        s.pd_kd[:] = self.model.joint_kd
        s.pd_max[:] = self.model.joint_max_torque
        s.pd_target_qd[:] = 0.0
        s.joint_applied[:] = 0.0
        s.ctrl[:] = 0.0
        s.body_servo[:] = 0.0
        s.body_target_pos[:] = self.model.body_pos0
        s.body_target_quat[:] = self.model.body_quat0
        s.body_target_vel[:] = 0.0
        s.body_target_angvel[:] = 0.0
        self.time = 0.0
        self._update_joint_coordinates()
        # servos hold the built pose until told otherwise
        s.pd_target_quat[:] = s.joint_qrel
        s.pd_target_q[:] = s.joint_q

    def update_joint_coordinates(self):
        """Recompute ``joint_q``, ``joint_qd`` and ``joint_quat`` from the body state, after
        writing ``body_pos`` etc. directly (stepping and ``set_state`` do it themselves)."""
        self._update_joint_coordinates()

    def _update_joint_coordinates(self):
        from .pipeline.joints.rows import joint_coordinates
        s = self._state
        for w in range(self.nworld):
            joint_coordinates(self.model.arrays, s.body_pos[w], s.body_quat[w], s.body_vel[w],
                              s.body_angvel[w], s.joint_q[w], s.joint_qd[w], s.joint_qrel[w])

    def _view(self, a):
        return a[0] if self.nworld == 1 else a

    @property
    def body_pos(self):
        """COM positions, m, world frame: (nbody, 3), or (nworld, nbody, 3) for a batch."""
        return self._view(self._state.body_pos)

    @body_pos.setter
    def body_pos(self, value):
        self._assign("body_pos", value)

    @property
    def body_quat(self):
        """Orientations of the principal frames (x, y, z, w): (nbody, 4) or (nworld, nbody, 4)."""
        return self._view(self._state.body_quat)

    @body_quat.setter
    def body_quat(self, value):
        self._assign("body_quat", value)

    @property
    def body_vel(self):
        """COM velocities, m/s, world frame: (nbody, 3) or (nworld, nbody, 3)."""
        return self._view(self._state.body_vel)

    @body_vel.setter
    def body_vel(self, value):
        self._assign("body_vel", value)

    @property
    def body_angvel(self):
        """Angular velocities, rad/s, world frame: (nbody, 3) or (nworld, nbody, 3)."""
        return self._view(self._state.body_angvel)

    @body_angvel.setter
    def body_angvel(self, value):
        self._assign("body_angvel", value)

    def _assign(self, field, value):
        target = getattr(self._state, field)
        try:
            v = np.broadcast_to(np.asarray(value, dtype=float), self._view(target).shape)
        except ValueError:
            raise StateError(f"{field}: expected shape {self._view(target).shape}, got "
                             f"{np.shape(value)}") from None
        self._view(target)[...] = v

    def get_state(self):
        """A copy of the whole state, to restore later with ``set_state``: time, poses,
        velocities, and the solver's memory (impulses, contacts), motor targets and pending
        forces, so the restored world steps on bit for bit as this one would."""
        s = self._state
        n = int(s.contact_count.max(initial=0))
        contacts = ContactArrays(*(a[:, :n].copy() for a in self._contacts))
        return State(self.time, s.body_pos.copy(), s.body_quat.copy(), s.body_vel.copy(),
                     s.body_angvel.copy(), contact_count=s.contact_count.copy(),
                     contacts=contacts, body_names=tuple(self.model.body_names),
                     joint_names=tuple(self.model.joint_names),
                     **{f: getattr(s, f).copy() for f in _EXTRA_STATE})

    def set_state(self, state):
        """Restore a ``State`` from ``get_state`` (validated; nothing changes if refused).

        Fields left None are reset: zero impulses, forces and motor targets, no contacts.
        A state that names its model's bodies and joints (``get_state`` records them) must
        name this world's, else StateError names the difference."""
        s = self._state
        for what, saved, mine in (("bodies", getattr(state, "body_names", None),
                                   self.model.body_names),
                                  ("joints", getattr(state, "joint_names", None),
                                   self.model.joint_names)):
            if saved is None:
                continue
            try:
                saved = [str(n) for n in saved]
            except TypeError:
                raise StateError(f"set_state: the state's {what[:-1]} names must be a sequence "
                                 f"of names, got {type(saved).__name__}") from None
            if saved != list(mine):
                raise StateError(f"set_state: the state belongs to a model with {len(saved)} "
                                 f"{what} {_names_preview(saved)}; this world's model has "
                                 f"{len(mine)} {what} {_names_preview(mine)}")
        arrays = {}
        for field in ("body_pos", "body_quat", "body_vel", "body_angvel") + _EXTRA_STATE:
            value = getattr(state, field, None)
            if value is None:
                if field in ("body_pos", "body_quat", "body_vel", "body_angvel"):
                    raise StateError(f"set_state: {field} is missing")
                if field not in _DRIVE_STATE:
                    arrays[field] = np.zeros_like(getattr(s, field))
                continue
            try:
                if np.iscomplexobj(value):
                    raise TypeError
                a = np.asarray(value, dtype=float)
            except (TypeError, ValueError):
                raise StateError(f"set_state: {field} must be an array of real numbers, got "
                                 f"{type(value).__name__}") from None
            if a.shape != getattr(s, field).shape:
                raise StateError(f"set_state: {field} has shape {a.shape}, this world needs "
                                 f"{getattr(s, field).shape}")
            # an unbounded servo torque is +inf; nothing else may be infinite
            if not np.all(np.isfinite(a) if field != "pd_max" else ~np.isnan(a)):
                raise StateError(f"set_state: {field} is not finite")
            arrays[field] = a
        if np.any(np.linalg.norm(arrays["body_quat"], axis=-1) < 1e-12):
            raise StateError("set_state: body_quat has a zero quaternion")
        t = getattr(state, "time", None)
        try:
            if isinstance(t, (str, bytes)):
                raise TypeError
            time = float(np.asarray(t, dtype=float).reshape(()))
        except (TypeError, ValueError):
            raise StateError(f"set_state: time must be a number (s), got {t!r}") from None
        if not np.isfinite(time):
            raise StateError("set_state: time is not finite")
        count, contacts = self._checked_contacts(state)
        for field, a in arrays.items():
            getattr(s, field)[...] = a
        self.time = time
        if count.max(initial=0) > self._contacts.depth.shape[1]:
            self._grow_contacts(int(count.max()))
        n = int(count.max(initial=0))
        for k, mine in enumerate(self._contacts):
            mine[...] = 0
            if n:
                mine[:, :n] = contacts[k][:, :n]
        s.contact_count[:] = count
        self._update_joint_coordinates()

    def set_body_state(self, body_pos, body_quat, body_vel, body_angvel, *, worlds=None):
        """Place the bodies of some worlds of a batch (all by default) and start them afresh.

        body_pos (k, nbody, 3) m, body_quat (k, nbody, 4) xyzw (normalised here), body_vel
        and body_angvel (k, nbody, 3) m/s and rad/s, world frame, for the k worlds selected by
        ``worlds`` (indices, a boolean mask of nworld, or None for all; a single world may
        drop the leading axis). Their solver memory (warm-start impulses, last contacts),
        pending forces and joint reactions are cleared and their joint coordinates
        refreshed; servo gains, targets and actuator controls are left as they are, and so
        are the other worlds and the time. Validated first: nothing changes if refused.
        This is how an environment resets the worlds whose episodes ended.
        """
        s = self._state
        if worlds is None:
            idx = np.arange(self.nworld)
        else:
            sel = np.asarray(worlds)
            if sel.dtype == np.bool_:
                if sel.shape != (self.nworld,):
                    raise ModelError(f"set_body_state: a mask of worlds needs shape "
                                     f"({self.nworld},), got {sel.shape}")
                idx = np.flatnonzero(sel)
            elif np.issubdtype(sel.dtype, np.integer) and sel.ndim <= 1:
                idx = sel.reshape(-1).astype(np.int64)
                if np.any((idx < 0) | (idx >= self.nworld)):
                    raise ModelError(f"set_body_state: world indices must be in "
                                     f"[0, {self.nworld}), got {idx.tolist()}")
            else:
                raise ModelError(f"set_body_state: worlds must be indices or a boolean mask, "
                                 f"got {worlds!r}")
        k, nb = len(idx), self.model.nbody
        arrays = {}
        for field, value, width in (("body_pos", body_pos, 3), ("body_quat", body_quat, 4),
                                    ("body_vel", body_vel, 3), ("body_angvel", body_angvel, 3)):
            a = np.asarray(value, dtype=float)
            if a.shape == (nb, width) and k == 1:
                a = a[None]
            if a.shape != (k, nb, width):
                raise StateError(f"set_body_state: {field} must have shape ({k}, {nb}, "
                                 f"{width}), got {a.shape}")
            bad = ~np.isfinite(a).all(axis=-1)
            if bad.any():
                w, b = np.argwhere(bad)[0]
                raise StateError(f"set_body_state: {field} of body '{self.model.body_names[b]}' "
                                 f"in world {int(idx[w])} is not finite")
            arrays[field] = a
        norm = np.linalg.norm(arrays["body_quat"], axis=-1, keepdims=True)
        if np.any(norm < 1e-12):
            w, b = np.argwhere(norm[..., 0] < 1e-12)[0]
            raise StateError(f"set_body_state: body_quat of body '{self.model.body_names[b]}' "
                             f"in world {int(idx[w])} is zero")
        arrays["body_quat"] = arrays["body_quat"] / norm
        for field, a in arrays.items():
            getattr(s, field)[idx] = a
        for field in ("applied_force", "applied_torque", "row_impulse", "joint_force",
                      "joint_torque"):
            getattr(s, field)[idx] = 0.0
        s.contact_count[idx] = 0
        self._contacts.impulse[idx] = 0.0
        from .pipeline.joints.rows import joint_coordinates
        for w in idx:
            joint_coordinates(self.model.arrays, s.body_pos[w], s.body_quat[w], s.body_vel[w],
                              s.body_angvel[w], s.joint_q[w], s.joint_qd[w], s.joint_qrel[w])

    def ground_contacts(self, *, touching=1e-3):
        """Which bodies touched the static world (the ground, terrain, static bodies) in the
        last step: (nworld, nbody) bool, or (nbody,) for one world. A contact counts when
        its surfaces overlap or are closer than ``touching`` (m), or it carried a force."""
        s, c = self._state, self._contacts
        n = c.depth.shape[1]
        live = np.arange(n)[None, :] < s.contact_count[:, None]
        live &= (c.depth > -touching) | (c.impulse[..., 0] > 0.0)
        static = np.append(self.model.body_kind != DYNAMIC, True)    # index -1: the world
        a, b = c.body[..., 0], c.body[..., 1]
        out = np.zeros((self.nworld, self.model.nbody + 1), np.bool_)
        w = np.broadcast_to(np.arange(self.nworld)[:, None], a.shape)
        hit_a = live & static[b] & (a >= 0)
        hit_b = live & static[a] & (b >= 0)
        out[w[hit_a], a[hit_a]] = True
        out[w[hit_b], b[hit_b]] = True
        return self._view(out[:, :-1])

    def _checked_contacts(self, state):
        """(contact_count (nworld,), contacts or None) of ``state``, validated."""
        nw = self.nworld
        if state.contact_count is None and state.contacts is None:
            return np.zeros(nw, np.int64), None
        if state.contact_count is None or state.contacts is None:
            raise StateError("set_state: contact_count and contacts go together")
        count = np.asarray(state.contact_count)
        if count.shape != (nw,) or not np.issubdtype(count.dtype, np.integer) or \
                np.any(count < 0) or np.any(count > np.iinfo(np.int64).max):
            raise StateError(f"set_state: contact_count must be {nw} integers >= 0")
        if not isinstance(state.contacts, ContactArrays):
            raise StateError("set_state: contacts must be a ContactArrays")
        n = int(count.max(initial=0))
        out = []
        for field, mine, saved in zip(ContactArrays._fields, self._contacts, state.contacts):
            a = np.asarray(saved)
            if a.dtype.kind not in "biuf":
                raise StateError(f"set_state: contacts.{field} must be numbers, got dtype "
                                 f"{a.dtype}")
            shape = (nw, a.shape[1] if a.ndim > 1 else -1) + mine.shape[2:]
            if a.ndim != mine.ndim or a.shape != shape or a.shape[1] < n:
                raise StateError(f"set_state: contacts.{field} has shape {a.shape}, expected "
                                 f"({nw}, >= {n}){''.join(f', {d}' for d in mine.shape[2:])}")
            if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
                raise StateError(f"set_state: contacts.{field} is not finite")
            out.append(a)
        if len({a.shape[1] for a in out}) > 1:
            raise StateError(f"set_state: the contacts arrays hold different numbers of "
                             f"contacts: {[a.shape[1] for a in out]}")
        # the live contacts (the first count of each world) must be this model's geoms and
        # their bodies: the step and the queries index arrays with them
        geom, body = out[0], out[1]
        live = np.arange(geom.shape[1])[None, :] < count[:, None]
        g, b = geom[live], body[live]
        if np.any((g < 0) | (g >= self.model.ngeom)) or np.any(g != np.floor(g)):
            raise StateError(f"set_state: contacts.geom holds geom indices outside "
                             f"[0, {self.model.ngeom})")
        if np.any(b != np.asarray(self.model.geom_body)[g.astype(np.int64)]):
            raise StateError("set_state: contacts.body is not the bodies of contacts.geom")
        out = [a.astype(mine.dtype, copy=False) for a, mine in zip(out, self._contacts)]
        return count.astype(np.int64), ContactArrays(*out)

    def save_state(self, path):
        """Write ``get_state()`` to an ``.npz`` file (bit-exact; see ``load_state``).

        path : file name (``.npz`` is appended when missing) or a binary file object. The
        file also records the model's body and joint names, row count and the batch size,
        which ``load_state`` checks. World options (dt, solver, contact model) are not part
        of the state: load into a world made with the same ones to continue bit for bit.
        """
        st = self.get_state()
        data = dict(format_version=np.int64(_STATE_FILE_VERSION), time=np.float64(st.time),
                    body_names=np.array(self.model.body_names, dtype=str),
                    joint_names=np.array(self.model.joint_names, dtype=str),
                    nrow=np.int64(self.model.nrow), nworld=np.int64(self.nworld),
                    contact_count=st.contact_count,
                    **{f: getattr(st, f) for f in ("body_pos", "body_quat", "body_vel",
                                                   "body_angvel") + _EXTRA_STATE},
                    **{"contact_" + f: a for f, a in zip(ContactArrays._fields, st.contacts)})
        from .io._files import MissingFileError
        target = _npz_path(path)
        if "\x00" in str(target):
            raise ModelError(f"save_state: the path {str(target)!r} holds a NUL byte, which no "
                             f"file name can")
        try:
            np.savez(target, **data)
        except FileNotFoundError:
            raise MissingFileError(f"save_state: cannot write '{target}': no such "
                                   f"folder") from None
        except OSError as e:
            raise ModelError(f"save_state: cannot write '{target}': {e.strerror or e}") from None

    def load_state(self, path):
        """Restore a state written by ``save_state`` (bit-exact; nothing changes if refused).

        Raises StateError naming the file when it was saved from a model with other bodies
        or joints (names, count or order), another number of worlds, or is not a state file
        (not an ``.npz``, truncated, a field of the wrong type or shape, larger than
        ``tumble.io._files.MAX_STATE_BYTES`` unpacked); a missing file raises a StateError
        that is also a FileNotFoundError.
        """
        from .io._files import MAX_STATE_BYTES, MissingStateFileError, mib
        path = _npz_path(path)
        name = getattr(path, "name", path)
        if "\x00" in str(path):
            raise StateError(f"load_state: the path {str(path)!r} holds a NUL byte, which no "
                             f"file name can")
        try:
            with np.load(path, allow_pickle=False) as f:
                unpacked = sum(i.file_size for i in f.zip.infolist())
                if unpacked > MAX_STATE_BYTES:
                    raise StateError(f"load_state: {name} unpacks to {mib(unpacked)}, more than "
                                     f"the {mib(MAX_STATE_BYTES)} tumble reads "
                                     f"(tumble.io._files.MAX_STATE_BYTES)")
                data = {k: f[k] for k in f.files}
        except FileNotFoundError:
            raise MissingStateFileError(f"load_state: no file {name}") from None
        except StateError:
            raise
        except Exception as exc:        # whatever NumPy and zipfile make of a foreign file
            raise StateError(f"load_state: {name} is not a tumble state file "
                             f"({type(exc).__name__}: {exc})") from None
        if "format_version" not in data or "body_names" not in data:
            raise StateError(f"load_state: {name} is not a tumble state file")

        def field(key):
            if key not in data:
                raise StateError(f"load_state: {name} lacks the field '{key}'")
            return data[key]

        def scalar(key, kinds, what):
            a = field(key)
            if a.shape != () or a.dtype.kind not in kinds:
                raise StateError(f"load_state: {name}: field '{key}' must be {what}, got "
                                 f"{a.dtype} of shape {a.shape}")
            return a[()]

        def names(key):
            a = field(key)
            if a.ndim != 1 or a.dtype.kind != "U":
                raise StateError(f"load_state: {name}: field '{key}' must be a list of names, "
                                 f"got {a.dtype} of shape {a.shape}")
            return [str(n) for n in a]

        version = int(scalar("format_version", "iu", "an integer"))
        if version != _STATE_FILE_VERSION:
            raise StateError(f"load_state: {name} has format version {version}, this tumble "
                             f"reads {_STATE_FILE_VERSION}")
        for what, saved, mine in (("bodies", names("body_names"), self.model.body_names),
                                  ("joints", names("joint_names"), self.model.joint_names)):
            if saved != list(mine):
                raise StateError(f"load_state: {name} belongs to a model with {len(saved)} "
                                 f"{what} {_names_preview(saved)}; this world's model has "
                                 f"{len(mine)} {what} {_names_preview(mine)}")
        nrow = int(scalar("nrow", "iu", "an integer"))
        if nrow != self.model.nrow:
            raise StateError(f"load_state: {name} has {nrow} joint rows, this "
                             f"model {self.model.nrow} (different joint types)")
        nworld = int(scalar("nworld", "iu", "an integer"))
        if nworld != self.nworld:
            raise StateError(f"load_state: {name} holds {nworld} worlds, this "
                             f"world has nworld={self.nworld}")
        time = float(scalar("time", "iuf", "a number (s)"))
        contacts = ContactArrays(*(field("contact_" + f) for f in ContactArrays._fields))
        state = State(time, contact_count=field("contact_count"), contacts=contacts,
                      body_names=tuple(self.model.body_names),
                      joint_names=tuple(self.model.joint_names),
                      **{f: field(f) for f in ("body_pos", "body_quat", "body_vel",
                                               "body_angvel") + _EXTRA_STATE})
        try:
            self.set_state(state)
        except StateError as exc:
            raise StateError(f"load_state: {name}: {exc}") from None

    # ------------------------------------------------------------------- step
    def step(self, n=1):
        """Advance ``n`` steps of ``dt`` in one compiled call.

        Forces given by ``apply_force``/``apply_torque`` act through all ``n`` steps and
        are cleared afterwards. Raises StateError if the state written by the user is
        invalid, and SimulationError (naming the body and step) if the simulation
        diverges; in both cases the world is left as it was before the call.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0 \
                or n > np.iinfo(np.int64).max:
            raise ModelError(f"step: n must be a non-negative integer below 2**63, got {n!r}")
        if n == 0:
            return
        n = int(n)
        options = self._options()
        if self.parallel:
            status, w, k, b = self._step_parallel(n, options)
        else:
            status, w, k, b = self._step_serial(n, options)
        if status == pipeline_step.STEP_DIVERGED:
            t = self.time + k * self.dt
            where = f"body '{self.model.body_names[b]}'" + (f" in world {w}" if self.nworld > 1 else "")
            raise SimulationError(
                f"simulation diverged: {where} has a non-finite or runaway state after step "
                f"{k} of this call (t = {t:.6g} s, dt = {self.dt:g} s); the world is left as it "
                f"was before the call. Try a smaller dt or check the forces applied.",
                body=self.model.body_names[b], step=int(k), time=t, world=int(w))
        self.time += n * self.dt

    def _make_work(self, options):
        """The serial step's scratch memory (``step.make_step_work``), through its compiled
        entry point once there is one."""
        args = (self.model.arrays, self._state, self._contacts, options)
        make = _entry_point(pipeline_step.make_step_work, args, compiled_only=True)
        return (make or pipeline_step.make_step_work)(*args)

    def _make_box(self, work, compiled_only=False):
        """``step.box_step_args`` of this world's arrays and ``work``, through its compiled
        entry point once there is one; with ``compiled_only``, None when nothing is
        compiled for these types yet."""
        args = (self.model.arrays, self._state, self._contacts, self._pairs,
                self._ball_joints, work)
        make = _entry_point(pipeline_step.box_step_args, args, compiled_only=compiled_only)
        return None if make is None else make(*args)

    def _step_serial(self, n, options):
        """Checks, the step and its retries in compiled code (``step.step_checked``) on the
        arrays held in ``self._box`` (``step.box_step_args``: one object to hand over
        instead of ~210 arrays), called straight through its compiled entry point once
        known: Numba's dispatcher would spend more time matching types than a small
        world's step.
        Returns step_worlds' (status, world, step, body)."""
        while True:
            if self._work is None:
                self._work = self._make_work(options)
            if self._box is None:
                self._box = self._make_box(self._work)
            args = (self._box, n, options)
            if self._entry is None:
                stage, code, w, i, k, needed = pipeline_step.step_boxed(*args)
                self._entry = _entry_point(pipeline_step.step_boxed, args)
            else:
                stage, code, w, i, k, needed = self._entry(*args)
            if stage == pipeline_step.CALL_BAD_STATE:
                raise self._state_error(code, w, i)
            if stage == pipeline_step.CALL_BAD_DRIVE:
                raise self._drive_error(code, w, i)
            if stage == pipeline_step.CALL_NEW_WORK:
                self._work = None
            elif not self._grew_buffers(code, needed):
                return code, w, k, i

    def _step_parallel(self, n, options):
        """The batched path: checks in NumPy-facing kernels, then every world on a thread."""
        s = self._state
        code, w, b = pipeline_step.check_state(s)
        if code != pipeline_step.STATE_OK:
            raise self._state_error(code, w, b)
        code, w, i = pipeline_step.check_drives(s, self._ball_joints)
        if code != pipeline_step.DRIVE_OK:
            raise self._drive_error(code, w, i)
        pipeline_step.hold_static(self.model.arrays, s)
        pipeline_step.fold_position_actuators(self.model.arrays, s)
        while True:
            status, w, k, b, needed = step_worlds_parallel(
                self.model.arrays, s, self._contacts, self._pairs, n, options)
            if not self._grew_buffers(status, needed):
                if status == pipeline_step.STEP_OK:
                    pipeline_step.clear_applied(s)
                return status, w, k, b

    def _grew_buffers(self, status, needed):
        """Grow the broad-phase or contact buffer when the step asked for it (the step was
        undone; it is called again). False if it did not ask."""
        if status == pipeline_step.STEP_MORE_PAIRS:
            self._pairs = np.zeros((2 * needed, 2), np.int32)
        elif status == pipeline_step.STEP_MORE_CONTACTS:
            self._grow_contacts(needed)
        else:
            return False
        return True

    def _state_error(self, code, w, b):
        """The StateError for check_state's report ``code`` on body ``b`` of world ``w``."""
        where = f"body '{self.model.body_names[b]}'" + (f" in world {w}" if self.nworld > 1 else "")
        return StateError(f"{where}: {_STATE_FIELDS[code]}")

    def _drive_error(self, code, w, i):
        """The StateError for check_drives' report ``code`` on index ``i`` of world ``w``."""
        s, m = self._state, self.model
        field = (pipeline_step.DRIVE_FIELDS[code] if code < len(pipeline_step.DRIVE_FIELDS)
                 else {pipeline_step.DRIVE_ZERO_BODY_QUAT: "body_target_quat",
                       pipeline_step.DRIVE_BAD_MAX: "pd_max",
                       pipeline_step.DRIVE_ZERO_JOINT_QUAT: "pd_target_quat"}[code])
        where = (f"actuator '{m.actuator_names[i]}'" if field == "ctrl" else
                 f"body '{m.body_names[i]}'" if field.startswith("body")
                 else f"joint '{m.joint_names[i]}'")
        if self.nworld > 1:
            where += f" in world {w}"
        if code == pipeline_step.DRIVE_ZERO_BODY_QUAT:
            return StateError(f"{where}: body_target_quat is zero")
        if code == pipeline_step.DRIVE_BAD_MAX:
            return StateError(f"{where}: max_torque must be > 0, got {s.pd_max[w, i]!r}")
        if code == pipeline_step.DRIVE_ZERO_JOINT_QUAT:
            return StateError(f"{where}: pd_target_quat is zero")
        gain = field in ("pd_kp", "pd_kd", "body_servo")
        return StateError(f"{where}: {_DRIVE_NAMES.get(field, field)} must be finite"
                          + (" and >= 0" if gain else "")
                          + f", got {getattr(s, field)[w, i]!r}")

    def _options(self):
        k, c = self.penalty_parameters()
        v_slip = self.slip_velocity or max(self._gravity_norm * self.dt, 1e-3)
        return pipeline_step.StepOptions(
            float(self.dt), GYROSCOPIC[self.gyroscopic], QUAT_INTEGRATION[self.quat_integration],
            float(self.divergence_limit), float(self.erp), float(self.cfm), SOLVERS[self.solver],
            int(self.iterations), float(self.tolerance), bool(self.warm_start),
            int(self.projection),
            float(self.projection_tolerance), CONTACT_MODELS[self.contact],
            float(self.contact_erp), float(self.contact_cfm), float(self.slop),
            float(self.bounce_threshold), float(k), float(c), float(v_slip),
            float(self.contact_margin), PD_MODES[self.pd], BROADPHASES[self.broadphase])

    def penalty_parameters(self):
        """(stiffness N/m, damping N s/m) of penalty contacts at the current dt."""
        k, c = default_penalty(self._lightest_colliding_mass, self.dt)
        return (self.penalty_stiffness or k,
                c if self.penalty_damping is None else self.penalty_damping)

    def _warn_stiff_geoms(self):
        """Warn about geoms whose own contact stiffness k makes their body's penalty spring
        unstable at this dt: semi-implicit Euler needs sqrt(k / m) dt < 2 on one contact,
        < 1 on four sharing the weight (see ``tumble.pipeline.contacts.penalty``)."""
        m = self.model
        for g in np.flatnonzero(m.geom_stiffness > 0):
            b = m.geom_body[g]
            if b < 0 or m.body_kind[b] != DYNAMIC:
                continue
            wh = np.sqrt(m.geom_stiffness[g] / m.body_mass[b]) * self.dt
            if wh > 1.0:
                warnings.warn(
                    f"geom '{m.geom_names[g]}': contact stiffness {m.geom_stiffness[g]:.4g} N/m "
                    f"on body '{m.body_names[b]}' ({m.body_mass[b]:.4g} kg) gives "
                    f"sqrt(k/m) dt = {wh:.3g} at dt = {self.dt:g} s; penalty contacts are "
                    f"stable below 1 (four contacts) to 2 (one): lower the stiffness or dt",
                    TumbleWarning, stacklevel=3)

    def _grow_contacts(self, needed):
        old, n = self._contacts, self._contacts.depth.shape[1]
        new = make_contacts(self.nworld, max(needed, 2 * n))
        for a, b in zip(new, old):
            a[:, :n] = b
        self._contacts = new

    # ----------------------------------------------------------------- joints
    @property
    def joint_q(self):
        """Joint coordinates (njoint, 3): hinge angle (rad) or slider position (m) in column 0,
        universal angles in 0-1, ball rotation vector (rad, parent joint frame) in 0-2."""
        return self._view(self._state.joint_q)

    @property
    def joint_qd(self):
        """Rates of the joint coordinates (njoint, 3), rad/s or m/s, along the same axes."""
        return self._view(self._state.joint_qd)

    @property
    def joint_quat(self):
        """Rotation of each child joint frame relative to its parent's (njoint, 4), x, y, z, w."""
        return self._view(self._state.joint_qrel)

    @property
    def joint_force(self):
        """Force each joint exerted on its child over the last step (njoint, 3), N, world."""
        return self._view(self._state.joint_force)

    @property
    def joint_torque(self):
        """Torque each joint exerted on its child about the anchor (njoint, 3), N m, world."""
        return self._view(self._state.joint_torque)

    @property
    def joint_motor_target(self):
        """Live (njoint, 3) motor target velocities (rad/s or m/s) of each degree of freedom;
        the motor pushes with at most the joint's ``motor_max_force``."""
        return self._view(self._state.motor_target)

    # ------------------------------------------------------------- actuators
    @property
    def joint_kp(self):
        """Live PD servo stiffness per joint (njoint,), N m/rad or N/m (0 with kd 0: off)."""
        return self._view(self._state.pd_kp)

    @joint_kp.setter
    def joint_kp(self, value):
        self._assign("pd_kp", value)

    @property
    def joint_kd(self):
        """Live PD servo damping per joint (njoint,), N m s/rad or N s/m."""
        return self._view(self._state.pd_kd)

    @joint_kd.setter
    def joint_kd(self, value):
        self._assign("pd_kd", value)

    @property
    def joint_max_torque(self):
        """Live bound on each DoF's servo torque (njoint,), N m or N (inf: none)."""
        return self._view(self._state.pd_max)

    @joint_max_torque.setter
    def joint_max_torque(self, value):
        self._assign("pd_max", value)

    @property
    def pd_target_quat(self):
        """Live servo targets of ball joints (njoint, 4): the child joint frame relative to
        the parent's (x, y, z, w), as ``joint_quat`` reports it. Starts at the built pose."""
        return self._view(self._state.pd_target_quat)

    @pd_target_quat.setter
    def pd_target_quat(self, value):
        self._assign("pd_target_quat", value)

    @property
    def pd_target_q(self):
        """Live servo targets of hinge, universal and slider joints (njoint, 3), in the
        coordinates of ``joint_q`` (rad or m). Starts at the built pose."""
        return self._view(self._state.pd_target_q)

    @pd_target_q.setter
    def pd_target_q(self, value):
        self._assign("pd_target_q", value)

    @property
    def pd_target_qd(self):
        """Live servo target rates (njoint, 3) along the axes of ``joint_qd``; default 0."""
        return self._view(self._state.pd_target_qd)

    @pd_target_qd.setter
    def pd_target_qd(self, value):
        self._assign("pd_target_qd", value)

    def set_pd_gains(self, joint, kp, kd, max_torque=None, *, world=None):
        """Set one joint's servo gains (kp N m/rad, kd N m s/rad; joint by index or name)."""
        j = self.model.joint_index(joint)
        wsl = self._world_slice(world)
        where = f"joint '{self.model.joint_names[j]}'"
        self._state.pd_kp[wsl, j] = positive(kp, where, "kp", allow_zero=True)
        self._state.pd_kd[wsl, j] = positive(kd, where, "kd", allow_zero=True)
        if max_torque is not None:
            self._state.pd_max[wsl, j] = positive(max_torque, where, "max_torque")

    def apply_joint_torque(self, joint, torque, *, world=None):
        """Add a torque (N m; force in N for sliders) per degree of freedom of ``joint``
        along the axes of ``joint_qd``: +tau on the child, -tau on the parent. Acts through
        the next ``step(n)`` call, then is cleared, like ``apply_force``."""
        j = self.model.joint_index(joint)
        wsl = self._world_slice(world)
        n = int(self.model.joint_ndof[j])
        t = np.asarray(torque, float)
        if t.ndim == 0 and n == 1:                 # a hinge or slider takes a plain number
            t = t.reshape(1)
        if t.shape not in ((n,), (self.nworld, n)) or (t.shape != (n,) and world is not None):
            raise ModelError(f"apply_joint_torque on joint '{self.model.joint_names[j]}': "
                             f"torque must have shape ({n},), got {t.shape}")
        if not np.all(np.isfinite(t)):
            raise ModelError(f"apply_joint_torque on joint '{self.model.joint_names[j]}': "
                             f"torque is not finite: {t.tolist()}")
        self._state.joint_applied[wsl, j, :n] += t

    @property
    def joint_applied_torque(self):
        """Live (njoint, 3) torques per DoF applied through the next ``step(n)`` call."""
        return self._view(self._state.joint_applied)

    def set_body_servo(self, body, kp, kd, kp_rot=0.0, kd_rot=0.0, *, world=None):
        """Switch on (or, with all gains 0, off) the implicit PD servo pulling ``body``'s COM
        toward ``body_target_pos`` (kp N/m, kd N s/m) and its orientation toward
        ``body_target_quat`` (kp_rot N m/rad, kd_rot N m s/rad): the hand of god.

        It is an external force (from the world), solved implicitly with the joints and
        contacts, so it is stable for any gains and step. Targets default to the built pose.
        """
        b = self.model.body_index(body)
        wsl = self._world_slice(world)
        where = f"body servo of '{self.model.body_names[b]}'"
        self._state.body_servo[wsl, b] = [positive(v, where, n, allow_zero=True) for v, n in (
            (kp, "kp"), (kd, "kd"), (kp_rot, "kp_rot"), (kd_rot, "kd_rot"))]

    @property
    def body_target_pos(self):
        """Live body servo targets (nbody, 3): COM positions, m, world frame."""
        return self._view(self._state.body_target_pos)

    @body_target_pos.setter
    def body_target_pos(self, value):
        self._assign("body_target_pos", value)

    @property
    def body_target_quat(self):
        """Live body servo targets (nbody, 4): orientations as ``body_quat`` (x, y, z, w)."""
        return self._view(self._state.body_target_quat)

    @body_target_quat.setter
    def body_target_quat(self, value):
        self._assign("body_target_quat", value)

    @property
    def body_target_vel(self):
        """Live body servo target velocities (nbody, 3), m/s, world frame."""
        return self._view(self._state.body_target_vel)

    @body_target_vel.setter
    def body_target_vel(self, value):
        self._assign("body_target_vel", value)

    @property
    def body_target_angvel(self):
        """Live body servo target angular velocities (nbody, 3), rad/s, world frame."""
        return self._view(self._state.body_target_angvel)

    @body_target_angvel.setter
    def body_target_angvel(self, value):
        self._assign("body_target_angvel", value)

    @property
    def ctrl(self):
        """Live MJCF actuator controls (nactuator,) or (nworld, nactuator)."""
        return self._view(self._state.ctrl)

    @ctrl.setter
    def ctrl(self, value):
        self._assign("ctrl", value)

    def joint_separation(self):
        """Distance (m) between each joint's two anchor points: the drift; (njoint,)."""
        from .pipeline.joints.common import joint_frames
        s = self._state
        out = np.zeros((self.nworld, self.model.njoint))
        for w in range(self.nworld):
            for j in range(self.model.njoint):
                anchor_a, anchor_b = joint_frames(self.model.arrays, s.body_pos[w],
                                                  s.body_quat[w], j)[:2]
                out[w, j] = np.linalg.norm(np.subtract(anchor_b, anchor_a))
        return self._view(out)

    # --------------------------------------------------------------- contacts
    @property
    def contacts(self):
        """The contacts of the last step (world 0 of a batch; see ``contacts_of``)."""
        return self.contacts_of(0)

    def contacts_of(self, world):
        """Contacts of the last step in one world, as a ``Contacts`` of arrays (n contacts):
        ``geoms`` (n, 2), ``bodies`` (n, 2) (-1 = world), ``point`` (n, 3), ``normal`` (n, 3)
        from the first geom to the second, ``depth`` (n,) m, ``force`` (n, 3) on the second
        body in the world frame, N (the first gets the opposite), ``normal_force`` (n,) N,
        ``torque`` (n, 3) the torsional and rolling friction torque on the second body,
        N m, world frame (zero without spin friction; a pure couple, acting besides
        ``force`` at ``point``)."""
        w = self._world_slice(world) if world is not None else 0
        n = int(self._state.contact_count[w])
        c = self._contacts
        point, normal = c.point[w, :n].copy(), c.normal[w, :n].copy()
        t1, t2 = _tangents(normal)
        imp = c.impulse[w, :n] / self.dt
        force = imp[:, :1] * normal + imp[:, 1:2] * t1 + imp[:, 2:3] * t2
        torque = imp[:, 3:4] * normal + imp[:, 4:5] * t1 + imp[:, 5:6] * t2
        return Contacts(c.geom[w, :n].copy(), c.body[w, :n].copy(), point, normal,
                        c.depth[w, :n].copy(), force, imp[:, 0].copy(), torque)

    @property
    def lcp_fallbacks(self):
        """Steps (since the world was made) in which Lemke failed and PGS solved instead."""
        return int(self._state.lcp_fallbacks.sum())

    def raycast(self, origin, direction, max_dist=1e6, *, exclude_body=None, world=None):
        """First geom hit by the ray from ``origin`` along ``direction`` (world frame).

        Returns ``(distance m, geom name, body name or None, point, normal)`` or ``None``
        when nothing is hit within ``max_dist``. ``exclude_body`` skips one body's geoms
        (a character looking for the ground under its own feet).
        """
        o = self._vec3(origin, "raycast: origin", 0)
        d = self._vec3(direction, "raycast: direction", 0)
        length = np.linalg.norm(d)
        if length == 0.0:
            raise ModelError("raycast: direction is the zero vector")
        d = d / length
        skip = -2 if exclude_body is None else self.model.body_index(exclude_body)
        w = 0 if world is None else self._world_slice(world)
        ng = self.model.ngeom
        t, g, n = raycast_scene(self.model.arrays, self._state.body_pos[w], self._state.body_quat[w],
                                np.zeros((ng, 3)), np.zeros((ng, 4)), o, d,
                                float(positive(max_dist, "raycast", "max_dist")), skip)
        if g < 0:
            return None
        b = self.model.geom_body[g]
        return (float(t), self.model.geom_names[g], None if b < 0 else self.model.body_names[b],
                o + t * d, np.asarray(n))

    def geom_distance(self, geom_a, geom_b, *, world=None):
        """Signed distance (m; negative: penetration depth) between two geoms, and their
        closest (or deepest) points, world frame: ``(distance, point_a, point_b)``."""
        ga, gb = self.model.geom_index(geom_a), self.model.geom_index(geom_b)
        w = 0 if world is None else self._world_slice(world)
        ng = self.model.ngeom
        dist, pa, pb = distance_between(self.model.arrays, self._state.body_pos[w],
                                        self._state.body_quat[w], np.zeros((ng, 3)),
                                        np.zeros((ng, 4)), ga, gb)
        return float(dist), np.asarray(pa), np.asarray(pb)

    def contact_force(self, body, *, world=None):
        """Total contact force (N) and torque about the COM (N m) on ``body`` over the last step."""
        b = self.model.body_index(body)
        con = self.contacts_of(world)
        f, t = np.zeros(3), np.zeros(3)
        com = self._state.body_pos[0 if world is None else world, b]
        for sign, side in ((-1.0, 0), (1.0, 1)):
            mine = con.bodies[:, side] == b
            f += sign * con.force[mine].sum(0)
            t += sign * (np.cross(con.point[mine] - com, con.force[mine]).sum(0)
                         + con.torque[mine].sum(0))
        return f, t

    # ----------------------------------------------------------------- forces
    def _world_slice(self, world):
        if world is None:
            return slice(None)
        if isinstance(world, bool) or not isinstance(world, (int, np.integer)) \
                or not 0 <= world < self.nworld:
            raise ModelError(f"world index must be in [0, {self.nworld}), got {world!r}")
        return int(world)

    def _vec3(self, value, what, world):
        """Broadcast a force-like (3,) or per-world (nworld, 3) array, refusing non-finite."""
        try:
            if isinstance(value, (str, bytes)):
                raise TypeError
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{what} must be 3 numbers"
                             + (f" or ({self.nworld}, 3)" if self.nworld > 1 else "")
                             + f", got {value!r}") from None
        ok = a.shape == (3,) or (world is None and a.shape == (self.nworld, 3))
        if not ok:
            raise ModelError(f"{what} must have shape (3,)"
                             + (f" or ({self.nworld}, 3)" if self.nworld > 1 else "")
                             + f", got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ModelError(f"{what} is not finite: {a.tolist()}")
        return a

    def apply_force(self, body, force, point=None, *, world=None):
        """Apply ``force`` (N, world frame) at world ``point`` (default: the COM).

        Adds the torque ``(point - com) x force``. Forces accumulate and act through the
        whole next ``step(n)`` call, then are cleared. On kinematic and static bodies
        they have no effect. ``world`` picks one copy of a batch (default: all).
        """
        b = self.model.body_index(body)
        wsl = self._world_slice(world)
        f = self._vec3(force, f"apply_force on body '{self.model.body_names[b]}': force", world)
        if point is not None:
            p = self._vec3(point, f"apply_force on body '{self.model.body_names[b]}': point", world)
            r = p - self._state.body_pos[wsl, b]
            self._state.applied_torque[wsl, b] += np.cross(r, f)
        self._state.applied_force[wsl, b] += f

    def apply_torque(self, body, torque, *, world=None):
        """Apply ``torque`` (N m, world frame) to ``body`` through the next ``step(n)`` call."""
        b = self.model.body_index(body)
        wsl = self._world_slice(world)
        t = self._vec3(torque, f"apply_torque on body '{self.model.body_names[b]}': torque", world)
        self._state.applied_torque[wsl, b] += t

    def clear_forces(self):
        """Drop the forces and torques applied since the last step."""
        self._state.applied_force[:] = 0.0
        self._state.applied_torque[:] = 0.0

    # ---------------------------------------------------------------- queries
    def _body_state(self, body, world):
        b = self.model.body_index(body)
        w = 0 if world is None else self._world_slice(world)
        s = self._state
        return b, s.body_pos[w, b], s.body_quat[w, b], s.body_vel[w, b], s.body_angvel[w, b]

    def point_velocity(self, body, point, *, world=None):
        """Velocity (m/s, world) of the world ``point`` moving with ``body``: ``v + w x r``."""
        b, pos, _, vel, angvel = self._body_state(body, world)
        r = np.asarray(point, float) - pos
        return vel + np.cross(angvel, r)

    def body_to_world(self, body, point_b, *, world=None):
        """World position of a point given in the body's COM principal frame (m)."""
        b, pos, quat, _, _ = self._body_state(body, world)
        return pos + np.asarray(quat_rotate(quat, np.asarray(point_b, float)))

    def world_to_body(self, body, point_w, *, world=None):
        """Position in the body's COM principal frame of a world point (m)."""
        b, pos, quat, _, _ = self._body_state(body, world)
        return np.asarray(quat_rotate_inv(quat, np.asarray(point_w, float) - pos))

    def vector_to_world(self, body, vec_b, *, world=None):
        """Rotate a body-frame direction into the world frame."""
        b, _, quat, _, _ = self._body_state(body, world)
        return np.asarray(quat_rotate(quat, np.asarray(vec_b, float)))

    def vector_to_body(self, body, vec_w, *, world=None):
        """Rotate a world-frame direction into the body frame."""
        b, _, quat, _, _ = self._body_state(body, world)
        return np.asarray(quat_rotate_inv(quat, np.asarray(vec_w, float)))

    def _dynamic(self):
        return self.model.body_kind == DYNAMIC

    def _world_inertia(self, quat):
        """(..., nbody, 3, 3) world inertia R diag(I) R^T of the dynamic bodies (0 otherwise)."""
        x, y, z, w = np.moveaxis(quat, -1, 0)
        rot = np.stack([
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ], -2)
        moments = self.model.arrays.body_inertia
        return np.einsum("...ij,...j,...kj->...ik", rot, moments, rot)

    def energy(self):
        """(kinetic, potential) energy in J of the dynamic bodies; per world for a batch.

        Potential is gravitational, ``-m g . x``, zero at the world origin.
        """
        s, dyn = self._state, self._dynamic()
        mass = np.where(dyn, self.model.body_mass, 0.0)
        iw = self._world_inertia(s.body_quat)
        lin = 0.5 * np.einsum("b,wbi,wbi->w", mass, s.body_vel, s.body_vel)
        ang = 0.5 * np.einsum("wbi,wbij,wbj->w", s.body_angvel, iw, s.body_angvel)
        pot = -np.einsum("b,wbi,i->w", mass, s.body_pos, self.model.gravity)
        kinetic, potential = lin + ang, pot
        if self.nworld == 1:
            return float(kinetic[0]), float(potential[0])
        return kinetic, potential

    def linear_momentum(self):
        """Total linear momentum (kg m/s, world) of the dynamic bodies: (3,) or (nworld, 3)."""
        s = self._state
        mass = np.where(self._dynamic(), self.model.body_mass, 0.0)
        return self._view(np.einsum("b,wbi->wi", mass, s.body_vel))

    def angular_momentum(self, about=(0.0, 0.0, 0.0)):
        """Total angular momentum (kg m^2/s, world) about the world point ``about``.

        Sum over dynamic bodies of ``(x - about) x m v + I_w w``: (3,) or (nworld, 3).
        """
        s = self._state
        mass = np.where(self._dynamic(), self.model.body_mass, 0.0)
        r = s.body_pos - np.asarray(about, float)
        orbital = np.einsum("b,wbi->wbi", mass, np.cross(r, s.body_vel))
        spin = np.einsum("wbij,wbj->wbi", self._world_inertia(s.body_quat), s.body_angvel)
        return self._view((orbital + spin).sum(axis=1))

    # ---------------------------------------------------------------- viewing
    def record(self, **options):
        """A ``tumble.Recorder`` collecting frames of this world; options as for Recorder."""
        from .viewer.recorder import Recorder
        return Recorder(self, **options)

    def view(self, **options):
        """Open the browser viewer on this world and serve until Ctrl-C (``block=False``
        returns the Viewer at once); options as for ``tumble.viewer.Viewer``. Needs
        ``tumble[viewer]``."""
        from .viewer.app import view
        return view(self, **options)

    def __repr__(self):
        return (f"<tumble.World: {self.model.nbody} bodies, dt={self.dt:g} s, t={self.time:g} s"
                + (f", {self.nworld} worlds" if self.nworld > 1 else "") + ">")
