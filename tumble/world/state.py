"""A world's state as a value: ``State`` snapshots, restoring them, and the ``.npz``
state file.

``StateMixin`` gives ``World`` its ``get_state``/``set_state``, ``save_state``/
``load_state`` and ``set_body_state``; everything is validated before anything is
written, so a refused state leaves the world as it was.
"""
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ModelError, StateError
from ..pipeline.contacts.arrays import ContactArrays


def _npz_path(path):
    """``path`` with ``.npz`` appended to file names that lack it (np.savez's own rule)."""
    if isinstance(path, (str, os.PathLike)):
        path = Path(path)
        return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")
    return path


def _names_preview(names, count=6):
    names = list(names)
    return str(names) if len(names) <= count else str(names[:count])[:-1] + ", ...]"


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
    body_rest (nworld, nbody): s each body has been at rest, which decides sleeping (with
    the ``sleep_time`` option; None: all awake).
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
    body_rest: np.ndarray = None


# Fields of State past the body state, each a copy of the StateArrays field of that name.
_EXTRA_STATE = ("row_impulse", "motor_target", "applied_force", "applied_torque",
                "joint_force", "joint_torque", "pd_kp", "pd_kd", "pd_max", "pd_target_quat",
                "pd_target_q", "pd_target_qd", "joint_applied", "ctrl", "body_servo",
                "body_target_pos", "body_target_quat", "body_target_vel", "body_target_angvel",
                "body_rest")
# Fields a state file may lack (written before they existed): None when missing.
_OPTIONAL_IN_FILE = ("body_rest",)
# Actuator fields: left as they are when a State does not carry them.
_DRIVE_STATE = ("pd_kp", "pd_kd", "pd_max", "pd_target_quat", "pd_target_q", "pd_target_qd",
                "joint_applied", "ctrl", "body_servo", "body_target_pos", "body_target_quat",
                "body_target_vel", "body_target_angvel")
_STATE_FILE_VERSION = 2


class StateMixin:
    """The state calls of ``World`` (see the module docstring)."""

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
                     **{f: self._array(f).copy() for f in _EXTRA_STATE})

    def set_state(self, state):
        """Restore a ``State`` from ``get_state`` (validated; nothing changes if refused).

        Fields left None are reset: zero impulses, forces and motor targets, no contacts
        (and then every body awake).
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
                    arrays[field] = np.zeros_like(self._array(field))
                continue
            try:
                if np.iscomplexobj(value):
                    raise TypeError
                a = np.asarray(value, dtype=float)
            except (TypeError, ValueError):
                raise StateError(f"set_state: {field} must be an array of real numbers, got "
                                 f"{type(value).__name__}") from None
            if a.shape != self._array(field).shape:
                raise StateError(f"set_state: {field} has shape {a.shape}, this world needs "
                                 f"{self._array(field).shape}")
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
            self._array(field)[...] = a
        self.time = time
        if count.max(initial=0) > self._contacts.depth.shape[1]:
            self._grow_contacts(int(count.max()))
        n = int(count.max(initial=0))
        for k, mine in enumerate(self._contacts):
            mine[...] = 0
            if n:
                mine[:, :n] = contacts[k][:, :n]
        s.contact_count[:] = count
        s.lcp_backoff[:] = 0        # a restored state tries Lemke at once, as a fresh one
        if contacts is None:
            # a pair of sleeping bodies is not tested again but keeps its last contacts
            # (tumble.pipeline.collide): a state without contacts starts every body awake
            s.body_rest[...] = 0.0
        self._update_joint_coordinates()

    def set_body_state(self, body_pos, body_quat, body_vel, body_angvel, *, worlds=None):
        """Place the bodies of some worlds of a batch (all by default) and start them afresh.

        body_pos (k, nbody, 3) m, body_quat (k, nbody, 4) xyzw (normalised here), body_vel
        and body_angvel (k, nbody, 3) m/s and rad/s, world frame, for the k worlds selected by
        ``worlds`` (indices, a boolean mask of nworld, or None for all; a single world may
        drop the leading axis). Their solver memory (warm-start impulses, last contacts),
        pending forces and joint reactions are cleared, their bodies woken (``sleep_time``)
        and their joint coordinates refreshed; servo gains, targets and actuator controls are left as they are, and so
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
                      "joint_torque", "body_rest"):
            self._array(field)[idx] = 0.0
        s.contact_count[idx] = 0
        s.lcp_backoff[idx] = 0
        self._contacts.impulse[idx] = 0.0
        self._update_joint_coordinates(idx)

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
        from ..io._files import MissingFileError
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
        from ..io._files import MAX_STATE_BYTES, MissingStateFileError, mib
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
                      **{f: data.get(f) if f in _OPTIONAL_IN_FILE else field(f)
                         for f in ("body_pos", "body_quat", "body_vel", "body_angvel")
                         + _EXTRA_STATE})
        try:
            self.set_state(state)
        except StateError as exc:
            raise StateError(f"load_state: {name}: {exc}") from None

