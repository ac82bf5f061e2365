"""World: the state of one model (or a batch of copies), its controls and options, and
the call that steps it.

The calls of ``World`` live by concept (``tumble.world``): this module builds a world,
holds its arrays and steps it; ``state.py`` snapshots and files; ``control.py`` what users
write between steps; ``queries.py`` what they read; ``options.py`` how it steps.
"""
import warnings

import numpy as np

from .._jit import ENTRY_POINTS, compiled_any, tick_seconds
from ..errors import ModelError, SimulationError, StateError, TumbleWarning
from ..model.model import Model
from ..model.types import DYNAMIC
from ..pipeline import call
from ..pipeline.arrays import (STAGES, ControlArrays, StateArrays, make_control_arrays,
                               make_state_arrays)
from ..pipeline.checks import (DRIVE_BAD_MAX, DRIVE_FIELDS, DRIVE_ZERO_BODY_QUAT,
                               DRIVE_ZERO_JOINT_QUAT, STATE_NONFINITE_ANGVEL,
                               STATE_NONFINITE_FORCE, STATE_NONFINITE_POS,
                               STATE_NONFINITE_QUAT, STATE_NONFINITE_TORQUE,
                               STATE_NONFINITE_VEL, STATE_ZERO_QUAT)
from ..pipeline.contacts.arrays import make_contacts
from ..pipeline.joints.rows import joint_coordinates
from ..pipeline.parallel import (box_parallel_args, make_spans, span_addresses, span_count,
                                 step_boxed_parallel)
from ..pipeline.step_free import box_free_args, is_free, step_free_boxed
from ..pipeline.step import (BRANCHES, STEP_DIVERGED, STEP_MORE_CODE, STEP_MORE_CONTACTS,
                             STEP_MORE_PAIRS, stage_addresses, takes_general_collision,
                             wanted_branches)
from .control import ControlMixin
from .options import OPTION_NAMES, Options, penalty_parameters, step_options
from .queries import QueryMixin
from .state import StateMixin

_STATE_FIELDS = {
    STATE_NONFINITE_POS: "body_pos is not finite",
    STATE_NONFINITE_QUAT: "body_quat is not finite",
    STATE_ZERO_QUAT: "body_quat is zero",
    STATE_NONFINITE_VEL: "body_vel is not finite",
    STATE_NONFINITE_ANGVEL: "body_angvel is not finite",
    STATE_NONFINITE_FORCE: "the applied force is not finite",
    STATE_NONFINITE_TORQUE: "the applied torque is not finite",
}

# How check_drives' fields are named in errors (the user-facing name where it differs).
_DRIVE_NAMES = {"motor_target": "joint_motor_target", "joint_applied": "joint torque",
                "pd_kp": "joint_kp", "pd_kd": "joint_kd", "body_servo": "body servo gain"}


def _drops_box(attr):
    """A World property kept in ``attr`` whose assignment drops what holds the old object's
    arrays: the step's box (``World._box``, ``call.make_step_box``), the batch's spans
    (``World._spans``, ``parallel.make_spans``) and their box (``World._parallel_box``)."""
    def get(world):
        return getattr(world, attr)

    def put(world, value):
        setattr(world, attr, value)
        world._box = world._spans = world._parallel_box = None
    return property(get, put)


def _capacity(value, default, name):
    if value is None:
        return default
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ModelError(f"world: {name} must be a positive integer, got {value!r}")
    return int(value)


def _option(name):
    """A World property that reads and writes ``world.options.<name>`` (checked there)."""
    def get(world):
        return getattr(world.options, name)

    def put(world, value):
        setattr(world.options, name, value)
    return property(get, put, doc=f"``options.{name}`` (see ``tumble.world.Options``).")


class World(StateMixin, ControlMixin, QueryMixin):
    """A model's state and its time stepping.

    Parameters
    ----------
    model : Model
    dt : step in seconds (default ``model.timestep``).
    nworld : number of independent copies stepped together (state arrays then carry a
        leading world axis).
    parallel : step the worlds of a batch on all of Numba's threads (``numba.set_num_threads``
        sets how many), each world bit-identical to the serial path. Default: when
        ``nworld > 1``.
    contact_capacity, pair_capacity : contacts per world, and broad-phase pairs, the
        buffers first hold (default ``8 ngeom + 64`` each). A step that finds more grows
        them and runs again, so they change the time of the first such step, never its
        result.
    **options : how it steps -- contact ('lcp', 'pgs' or 'penalty'), solver, erp, cfm, pd,
        projection, ... -- each described in ``tumble.world.Options``. They are also
        attributes of the world (``world.erp``) and of ``world.options``, and may be changed
        between steps.

    The state arrays ``body_pos``, ``body_quat``, ``body_vel``, ``body_angvel`` are live
    views: write into them between steps to set the state. The control arrays
    (``joint_kp``, ``pd_target_q``, ``ctrl``, ...) are live too (``tumble.world.control``).
    """

    def __init__(self, model, dt=None, *, nworld=1, parallel=None, contact_capacity=None,
                 pair_capacity=None, **options):
        if not isinstance(model, Model):
            raise ModelError(f"World needs a tumble Model, got {type(model).__name__}")
        self.model = model
        unknown = sorted(set(options) - set(OPTION_NAMES))
        if unknown or "dt" in options:
            raise ModelError(f"World: unknown option {(unknown or ['dt'])[0]!r}; options are "
                             f"{[n for n in OPTION_NAMES if n != 'dt']}")
        self.options = Options(dt=model.timestep if dt is None else dt, **options)
        if isinstance(nworld, bool) or not isinstance(nworld, (int, np.integer)) or nworld < 1:
            raise ModelError(f"world: nworld must be a positive integer, got {nworld!r}")
        if self.contact == "penalty":
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
        self.step_options()        # the checks across options, before anything is made
        self._state = make_state_arrays(self.nworld, model.nbody, model.njoint, model.nrow)
        self._control = make_control_arrays(self.nworld, model.nbody, model.njoint,
                                            model.nactuator)
        self._box = None           # call.make_step_box of the arrays below (and the serial
        #                            step's scratch, kept between calls), once made
        default = 8 * model.ngeom + 64
        self._contacts = make_contacts(self.nworld, _capacity(contact_capacity, default,
                                                              "contact_capacity"))
        self._pairs = np.zeros((_capacity(pair_capacity, default, "pair_capacity"), 2),
                               np.int32)
        self._spans = None         # the parallel step's boxes, one per span of worlds
        self._nspan = 0            # how many spans _spans has (one per thread)
        self._parallel_box = None  # parallel.box_parallel_args of the arrays, once made
        self._span_address = None  # call.step_span's compiled code, for the spans
        self._span_stages = None   # the step's stages' compiled code, for the spans
        self._stages = None        # step.stage_addresses for self._box
        self._branches_taken = set()  # the step's branches a step asked for (STEP_MORE_CODE)
        self._general_collision = None  # step.takes_general_collision(model), once asked
        self._parallel_entry = None  # step_boxed_parallel's compiled entry point
        self._entry = None         # step_span's compiled entry point, once called
        self._free_entry = None    # step_free_boxed's, once called (a free model)
        self._free_box = None      # step_free.box_free_args of the arrays, once made
        self._tick_seconds = None  # _jit.ticks' unit, measured on the first stage_times
        self.reset()
        self._prepare_step()

    # The step's boxes hold these objects' arrays: replacing one drops them.
    _contacts = _drops_box("_contacts_arrays")
    _pairs = _drops_box("_pairs_buffer")

    def _prepare_step(self):
        """The serial step's scratch memory and compiled entry point, made now when an
        earlier world of the process has compiled the step for the same argument types:
        the first ``step`` call then costs what the others do instead of a millisecond
        more. The first world of a process compiles the step on its first ``step``."""
        if self.parallel or not compiled_any(call.step_span):
            return
        o = self.step_options()
        box = self._make_box(o, compiled_only=True)
        if box is None:
            return
        stages = stage_addresses(box, o, self._branches(o), compiled_only=True)
        if stages is None:
            return
        entry = ENTRY_POINTS.get(call.step_span, (box, stages, 1, o, True),
                                 compiled_only=True)
        if entry is not None:
            self._box, self._stages, self._entry = box, stages, entry

    def _array(self, field):
        """The state or control array called ``field`` (``pipeline.arrays``)."""
        if field in StateArrays._fields:
            return getattr(self._state, field)
        if field in ControlArrays._fields:
            return getattr(self._control, field)
        raise AttributeError(field)

    # ---------------------------------------------------------------- state
    def reset(self):
        """Back to the model's initial state at time 0; applied forces cleared, servos
        holding the built pose with the model's gains. (``lcp_fallbacks`` and
        ``stage_times`` count on since the world was made.)"""
        s, c, m = self._state, self._control, self.model
        for field, a in zip(StateArrays._fields, s):
            if field not in ("lcp_fallbacks", "stage_ticks"):
                a[...] = 0
        for a in c:
            a[...] = 0
        s.body_pos[:] = m.body_pos0
        s.body_quat[:] = m.body_quat0
        s.body_vel[:] = m.body_vel0
        s.body_angvel[:] = m.body_angvel0
        c.pd_kp[:] = m.joint_kp
        c.pd_kd[:] = m.joint_kd
        c.pd_max[:] = m.joint_max_torque
        c.body_target_pos[:] = m.body_pos0
        c.body_target_quat[:] = m.body_quat0
        self.time = 0.0
        self._update_joint_coordinates()
        # servos hold the built pose until told otherwise
        c.pd_target_quat[:] = s.joint_qrel
        c.pd_target_q[:] = s.joint_q

    def update_joint_coordinates(self):
        """Recompute ``joint_q``, ``joint_qd`` and ``joint_quat`` from the body state, after
        writing ``body_pos`` etc. directly (stepping and ``set_state`` do it themselves)."""
        self._update_joint_coordinates()

    def _update_joint_coordinates(self, worlds=None):
        if self.model.njoint == 0:        # nothing to compute (nor to compile)
            return
        s = self._state
        for w in range(self.nworld) if worlds is None else worlds:
            joint_coordinates(self.model.arrays, s.body_pos[w], s.body_quat[w], s.body_vel[w],
                              s.body_angvel[w], s.joint_q[w], s.joint_qd[w], s.joint_qrel[w])

    def _view(self, a):
        return a[0] if self.nworld == 1 else a

    def _assign(self, field, value):
        target = self._array(field)
        try:
            v = np.broadcast_to(np.asarray(value, dtype=float), self._view(target).shape)
        except ValueError:
            raise StateError(f"{field}: expected shape {self._view(target).shape}, got "
                             f"{np.shape(value)}") from None
        self._view(target)[...] = v

    def _world_slice(self, world):
        if world is None:
            return slice(None)
        if isinstance(world, bool) or not isinstance(world, (int, np.integer)) \
                or not 0 <= world < self.nworld:
            raise ModelError(f"world index must be in [0, {self.nworld}), got {world!r}")
        return int(world)

    @property
    def state_arrays(self):
        """The live state arrays with their leading world axis whatever ``nworld`` is
        (``pipeline.arrays.StateArrays``), for code that handles batches. Write into them
        between steps only as into ``body_pos`` etc.; the arrays themselves stay."""
        return self._state

    @property
    def control_arrays(self):
        """The live control arrays with their leading world axis
        (``pipeline.arrays.ControlArrays``): forces, servo gains and targets, ctrl."""
        return self._control

    @property
    def contact_arrays(self):
        """The live contact arrays of the last step (``pipeline.contacts.arrays``), each
        (nworld, contact_capacity, ...); the first ``state_arrays.contact_count[w]`` of
        world w are its contacts. ``contacts_of`` reads them as forces."""
        return self._contacts

    @property
    def contact_capacity(self):
        """Contacts per world the contact arrays hold now (they grow as needed)."""
        return self._contacts.depth.shape[1]

    @property
    def pair_capacity(self):
        """Broad-phase pairs the pair buffer holds now (it grows as needed)."""
        return self._pairs.shape[0]

    def __getattr__(self, name):
        if name in ("record", "view"):
            raise AttributeError(
                f"World.{name} was removed (the viewer sits above World, which does not "
                f"import it): use " + ("tumble.Recorder(world, ...)" if name == "record"
                                       else "tumble.viewer.view(world, ...)"))
        raise AttributeError(f"'World' object has no attribute {name!r}")

    @property
    def body_pos(self):
        """COM positions, m, world frame: (nbody, 3), or (nworld, nbody, 3) for a batch."""
        return self._view(self._state.body_pos)

    @body_pos.setter
    def body_pos(self, value):
        self._assign("body_pos", value)
        self.wake()

    @property
    def body_quat(self):
        """Orientations of the principal frames (x, y, z, w): (nbody, 4) or (nworld, nbody, 4)."""
        return self._view(self._state.body_quat)

    @body_quat.setter
    def body_quat(self, value):
        self._assign("body_quat", value)
        self.wake()

    @property
    def body_vel(self):
        """COM velocities, m/s, world frame: (nbody, 3) or (nworld, nbody, 3)."""
        return self._view(self._state.body_vel)

    @body_vel.setter
    def body_vel(self, value):
        self._assign("body_vel", value)
        self.wake()

    @property
    def body_angvel(self):
        """Angular velocities, rad/s, world frame: (nbody, 3) or (nworld, nbody, 3)."""
        return self._view(self._state.body_angvel)

    @body_angvel.setter
    def body_angvel(self, value):
        self._assign("body_angvel", value)
        self.wake()

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

    # ---------------------------------------------------------------- step
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
        o = self.step_options()
        while True:
            if is_free(self.model, self._control.body_servo):
                stage, code, w, i, k, needed = self._call_free(n, o)
            elif self.parallel:
                stage, code, w, i, k, needed = self._call_parallel(n, o)
            else:
                stage, code, w, i, k, needed = self._call_serial(n, o)
            if stage == call.CALL_BAD_STATE:
                raise self._state_error(code, w, i)
            if stage == call.CALL_BAD_DRIVE:
                raise self._drive_error(code, w, i)
            if stage == call.CALL_NEW_WORK:
                self._box = self._spans = None
            elif code == STEP_MORE_CODE:
                self._branches_taken.add(BRANCHES[needed])
                self._stages = self._span_stages = None
            elif not self._grew_buffers(code, needed):
                break
        if code == STEP_DIVERGED:
            t = self.time + k * self.dt
            where = f"body '{self.model.body_names[i]}'" + (
                f" in world {w}" if self.nworld > 1 else "")
            raise SimulationError(
                f"simulation diverged: {where} has a non-finite or runaway state after step "
                f"{k} of this call (t = {t:.6g} s, dt = {self.dt:g} s); the world is left as it "
                f"was before the call. Try a smaller dt or check the forces applied.",
                body=self.model.body_names[i], step=int(k), time=t, world=int(w))
        # added step by step, so that step(n) and n x step(1) end at the same time bits
        t, dt = self.time, self.dt
        for _ in range(n):
            t += dt
        self.time = t

    def _call_serial(self, n, o):
        """``call.step_span`` over all the worlds, on the arrays held in ``self._box`` (one
        object to hand over instead of ~210 arrays), straight through its compiled entry
        point once known: Numba's dispatcher would spend more time matching types than a
        small world's step. Returns step_span's (stage, code, world, index, step,
        needed)."""
        if self._box is None:
            self._box, self._stages = self._make_box(o), None
        if self._stages is None:
            self._stages = call.step_code(self._box, o, self._branches(o))
        return self._through_entry("_entry", call.step_span,
                                   (self._box, self._stages, n, o, True))

    def _call_parallel(self, n, o):
        """``parallel.step_boxed_parallel`` on the arrays and each span's scratch held in
        ``self._parallel_box``, through its compiled entry point once known (as
        ``_call_serial``); each thread calls ``call.step_span`` for its span through the
        address of its compiled code."""
        nspan = span_count(self.nworld)
        if self._spans is None or nspan != self._nspan:
            self._spans = make_spans(self.model.arrays, self._state, self._control,
                                     self._contacts, self._pairs, self._ball_joints, o, nspan)
            self._nspan, self._parallel_box = nspan, None      # the box held the old spans
        if self._parallel_box is None:
            self._parallel_box = box_parallel_args(self._state, self._control, self._contacts,
                                                   self._spans)
            self._span_stages = None
        if self._span_stages is None:
            self._span_address, self._span_stages = span_addresses(self._spans, o,
                                                                   self._branches(o))
        return self._through_entry("_parallel_entry", step_boxed_parallel,
                                   (self._parallel_box, n, o, self._span_address,
                                    self._span_stages))

    def _call_free(self, n, o):
        """``step_free.step_free_boxed`` (a model with nothing to collide, constrain or
        actuate: the full step's results from a few kernels, which compile in seconds),
        through its compiled entry point once known."""
        if self._free_box is None:
            self._free_box = box_free_args(self.model.arrays, self._state, self._control,
                                           self._ball_joints)
        return self._through_entry("_free_entry", step_free_boxed, (self._free_box, n, o))

    def _through_entry(self, attr, dispatcher, args):
        """``dispatcher(*args)``, straight through its compiled entry point once known (kept
        in the attribute ``attr``): the first call goes through the dispatcher, which
        compiles or loads the code, and the entry point is found after it."""
        entry = getattr(self, attr)
        if entry is None:
            out = dispatcher(*args)
            setattr(self, attr, ENTRY_POINTS.get(dispatcher, args))
            return out
        return entry(*args)

    def _make_box(self, o, compiled_only=False):
        """``call.make_step_box`` of this world's arrays (a new scratch for them and options
        ``o``), through its compiled entry point once there is one; with
        ``compiled_only``, None when nothing is compiled for these types yet."""
        args = (self.model.arrays, self._state, self._control, self._contacts, self._pairs,
                self._ball_joints, o)
        make = ENTRY_POINTS.get(call.make_step_box, args, compiled_only=compiled_only)
        return None if make is None else make(*args)

    def _branches(self, o):
        """The step's branches to compile for options ``o``: those the model and options
        call for (``step.wanted_branches``) and those a step of this world took."""
        if self._general_collision is None:
            self._general_collision = takes_general_collision(self.model.arrays)
        return wanted_branches(self.model.arrays, o, self._general_collision) + \
            tuple(self._branches_taken)

    def _grew_buffers(self, status, needed):
        """Grow the broad-phase or contact buffer when the step asked for it (the step was
        undone; it is called again). False if it did not ask."""
        if status == STEP_MORE_PAIRS:
            self._pairs = np.zeros((2 * needed, 2), np.int32)
        elif status == STEP_MORE_CONTACTS:
            self._grow_contacts(needed)
        else:
            return False
        return True

    def _grow_contacts(self, needed):
        old, n = self._contacts, self._contacts.depth.shape[1]
        new = make_contacts(self.nworld, max(needed, 2 * n))
        for a, b in zip(new, old):
            a[:, :n] = b
        self._contacts = new

    def _state_error(self, code, w, b):
        """The StateError for check_state's report ``code`` on body ``b`` of world ``w``."""
        where = f"body '{self.model.body_names[b]}'" + (
            f" in world {w}" if self.nworld > 1 else "")
        return StateError(f"{where}: {_STATE_FIELDS[code]}")

    def _drive_error(self, code, w, i):
        """The StateError for check_drives' report ``code`` on index ``i`` of world ``w``."""
        m = self.model
        field = (DRIVE_FIELDS[code] if code < len(DRIVE_FIELDS)
                 else {DRIVE_ZERO_BODY_QUAT: "body_target_quat", DRIVE_BAD_MAX: "pd_max",
                       DRIVE_ZERO_JOINT_QUAT: "pd_target_quat"}[code])
        where = (f"actuator '{m.actuator_names[i]}'" if field == "ctrl" else
                 f"body '{m.body_names[i]}'" if field.startswith("body")
                 else f"joint '{m.joint_names[i]}'")
        if self.nworld > 1:
            where += f" in world {w}"
        if code == DRIVE_ZERO_BODY_QUAT:
            return StateError(f"{where}: body_target_quat is zero")
        if code == DRIVE_BAD_MAX:
            return StateError(f"{where}: max_torque must be > 0, got "
                              f"{self._control.pd_max[w, i]!r}")
        if code == DRIVE_ZERO_JOINT_QUAT:
            return StateError(f"{where}: pd_target_quat is zero")
        gain = field in ("pd_kp", "pd_kd", "body_servo")
        return StateError(f"{where}: {_DRIVE_NAMES.get(field, field)} must be finite"
                          + (" and >= 0" if gain else "")
                          + f", got {self._array(field)[w, i]!r}")

    def step_options(self):
        """The compiled step's ``StepOptions`` (``pipeline.arrays``) for the current options:
        what a pipeline kernel called directly takes."""
        return step_options(self.options, self._lightest_colliding_mass)

    def penalty_parameters(self):
        """(stiffness N/m, damping N s/m) of penalty contacts at the current dt."""
        return penalty_parameters(self.options, self._lightest_colliding_mass)

    def _warn_stiff_geoms(self):
        """Warn about geoms whose own contact stiffness k makes their body's penalty spring
        unstable at this dt: semi-implicit Euler needs sqrt(k / m) dt < 2 on one contact,
        < 1 on four sharing the weight (see ``tumble.pipeline.contacts.penalty``). Bodies
        outside joints are safe under the default implicit springs."""
        m = self.model
        jointed = set(m.joint_parent.tolist()) | set(m.joint_child.tolist())
        implicit = self.options.penalty_integration == "implicit"
        for g in np.flatnonzero(m.geom_stiffness > 0):
            b = m.geom_body[g]
            if b < 0 or m.body_kind[b] != DYNAMIC or (implicit and b not in jointed):
                continue
            wh = np.sqrt(m.geom_stiffness[g] / m.body_mass[b]) * self.dt
            if wh > 1.0:
                warnings.warn(
                    f"geom '{m.geom_names[g]}': contact stiffness {m.geom_stiffness[g]:.4g} N/m "
                    f"on body '{m.body_names[b]}' ({m.body_mass[b]:.4g} kg) gives "
                    f"sqrt(k/m) dt = {wh:.3g} at dt = {self.dt:g} s; penalty contacts are "
                    f"stable below 1 (four contacts) to 2 (one): lower the stiffness or dt",
                    TumbleWarning, stacklevel=3)

    # ------------------------------------------------------------ sleeping
    @property
    def sleeping(self):
        """Which bodies slept in the last step (``sleep_time`` option): bool (nbody,) or
        (nworld, nbody); all False while sleeping is off. Read-only (a copy)."""
        t = self.options.sleep_time
        if t is None:
            return self._view(np.zeros(self._state.body_rest.shape, np.bool_))
        return self._view(self._state.body_rest >= t)

    def wake(self, world=None):
        """Wake every body of one world (index) or of all (None): their times at rest
        restart, so none sleeps before ``sleep_time`` of rest again. Writing the state
        through ``body_pos = ...`` (and the other setters) wakes all; write into the arrays
        in place (``world.body_pos[...] = ...``) and a sleeping body moved there stays
        asleep where it was put until ``wake``."""
        self._state.body_rest[self._world_slice(world)] = 0.0

    # ------------------------------------------------------------ profile
    def stage_times(self, reset=False):
        """Seconds spent in each stage of the step (``pipeline.arrays.STAGES``), summed over
        the worlds and the steps since the world was made (or last reset), as a dict.

        Stages are timed only while ``options.profile`` is on (``World(...,
        profile=True)``); with it off the step reads no clock and these stay as they
        were. ``reset`` zeroes them after reading."""
        if self._tick_seconds is None:
            self._tick_seconds = tick_seconds()
        totals = self._state.stage_ticks.sum(axis=0) * self._tick_seconds
        if reset:
            self._state.stage_ticks[:] = 0
        return {name: float(t) for name, t in zip(STAGES, totals)}

    def _repr_png_(self):
        """Jupyter shows a world as a picture of its bodies (``tumble.viewer.notebook``'s
        ``world_png``: the software renderer, no display needed). The viewer sits above
        World, so it is found by name when a notebook asks, never on import; without the
        viewer extra the text repr is shown."""
        import importlib
        try:
            notebook = importlib.import_module("tumble.viewer.notebook")
            return notebook.world_png(self)
        except ImportError:
            return None

    def __repr__(self):
        return (f"<tumble.World: {self.model.nbody} bodies, dt={self.dt:g} s, t={self.time:g} s"
                + (f", {self.nworld} worlds" if self.nworld > 1 else "") + ">")


for _name in OPTION_NAMES:
    setattr(World, _name, _option(_name))
del _name
