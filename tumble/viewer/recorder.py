"""Recording a simulation: poses (and optionally velocities, contacts, energy, joint
coordinates) frame by frame, saved to and loaded from ``.npz`` exactly.

    rec = tumble.Recorder(world, contacts=True)
    rec.run(5.0, fps=60)                           # steps the world, one frame per 1/60 s
    rec.save("fall.npz")
    recording = tumble.Recording.load("fall.npz")  # replay: tumble view fall.npz

A recording carries its :class:`~tumble.viewer.scene.Scene` (shapes, colours, joints), so
it can be replayed and exported without the model or the script that made it. Only NumPy
is needed here.
"""
import os
import zipfile

import numpy as np

from ..errors import ModelError, StateError
from .scene import Scene

FORMAT = "tumble-recording"
VERSION = 1
_OPTIONAL = ("body_vel", "body_angvel", "kinetic", "potential", "joint_q")


class Recording:
    """A recorded trajectory: F frames of nbody bodies.

    time : (F,) s, increasing.  body_pos : (F, nbody, 3) COM positions, m, world frame.
    body_quat : (F, nbody, 4) principal-frame orientations (x, y, z, w).
    body_vel, body_angvel : (F, nbody, 3) m/s and rad/s, world frame, or None.
    kinetic, potential : (F,) J (``World.energy``), or None.
    joint_q : (F, njoint, 3) joint coordinates (``World.joint_q``), or None.
    contact_start : (F + 1,) int64 offsets: frame i's contacts are rows
        ``contact_start[i]:contact_start[i + 1]`` of contact_point (C, 3) m,
        contact_force (C, 3) N on the second body (world frame), contact_bodies (C, 2)
        (-1 = world); all None when contacts were not recorded.
    dt : the world's step (s).  scene : what to draw (a :class:`Scene`).
    """

    def __init__(self, scene, time, body_pos, body_quat, *, dt, body_vel=None,
                 body_angvel=None, kinetic=None, potential=None, joint_q=None,
                 contact_start=None, contact_point=None, contact_force=None,
                 contact_bodies=None, where="recording"):
        if not isinstance(scene, Scene):
            raise ModelError(f"{where}: scene must be a tumble.viewer.Scene")
        self.scene = scene
        self.dt = float(dt)
        self.time = np.asarray(time, dtype=float)
        nf, nb = len(self.time), scene.nbody
        if self.time.ndim != 1 or nf == 0:
            raise ModelError(f"{where}: time must be a non-empty 1-D array, got shape "
                             f"{self.time.shape}")
        if nf > 1 and np.any(np.diff(self.time) < 0):
            raise ModelError(f"{where}: time must not decrease")

        def arr(value, shape, name, dtype=float):
            if value is None:
                return None
            a = np.asarray(value, dtype=dtype)
            if a.shape != shape:
                raise ModelError(f"{where}: {name} must have shape {shape}, got {a.shape}")
            return a

        self.body_pos = arr(body_pos, (nf, nb, 3), "body_pos")
        self.body_quat = arr(body_quat, (nf, nb, 4), "body_quat")
        self.body_vel = arr(body_vel, (nf, nb, 3), "body_vel")
        self.body_angvel = arr(body_angvel, (nf, nb, 3), "body_angvel")
        self.kinetic = arr(kinetic, (nf,), "kinetic")
        self.potential = arr(potential, (nf,), "potential")
        self.joint_q = arr(joint_q, (nf, scene.njoint, 3), "joint_q")
        if contact_start is None:
            self.contact_start = self.contact_point = self.contact_force = None
            self.contact_bodies = None
        else:
            self.contact_start = arr(contact_start, (nf + 1,), "contact_start", np.int64)
            nc = int(self.contact_start[-1])
            if self.contact_start[0] != 0 or np.any(np.diff(self.contact_start) < 0):
                raise ModelError(f"{where}: contact_start must rise from 0")
            self.contact_point = arr(contact_point, (nc, 3), "contact_point")
            self.contact_force = arr(contact_force, (nc, 3), "contact_force")
            self.contact_bodies = arr(contact_bodies, (nc, 2), "contact_bodies", np.int32)

    # ---------------------------------------------------------------- access
    def __len__(self):
        return len(self.time)

    @property
    def duration(self):
        """Recorded time span, s (last frame time minus first)."""
        return float(self.time[-1] - self.time[0])

    @property
    def has_contacts(self):
        return self.contact_start is not None

    def contacts(self, i):
        """Contacts of frame ``i``: points (n, 3) m, forces (n, 3) N on the second body,
        bodies (n, 2); empty arrays when contacts were not recorded."""
        if self.contact_start is None:
            return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2), np.int32)
        a, b = self.contact_start[i], self.contact_start[i + 1]
        return self.contact_point[a:b], self.contact_force[a:b], self.contact_bodies[a:b]

    def frame_index(self, t):
        """Index of the last frame at or before time ``t`` (clamped to the recording)."""
        return int(np.clip(np.searchsorted(self.time, t, side="right") - 1, 0, len(self) - 1))

    def pose_at(self, t):
        """Body positions (nbody, 3) and orientations (nbody, 4) at time ``t`` (s),
        interpolated between frames (linear for positions, normalised linear for
        quaternions, taking the short way); clamped outside the recording."""
        i = self.frame_index(t)
        if i + 1 >= len(self) or t <= self.time[i]:
            return self.body_pos[i].copy(), self.body_quat[i].copy()
        t0, t1 = self.time[i], self.time[i + 1]
        a = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
        pos = (1 - a) * self.body_pos[i] + a * self.body_pos[i + 1]
        q0, q1 = self.body_quat[i], self.body_quat[i + 1]
        q1 = np.where(np.einsum("bi,bi->b", q0, q1)[:, None] < 0, -q1, q1)
        q = (1 - a) * q0 + a * q1
        return pos, q / np.linalg.norm(q, axis=1, keepdims=True)

    # ------------------------------------------------------------- save/load
    def to_arrays(self):
        """All data as a dict of arrays (what ``save`` writes)."""
        out = dict(format=np.array(FORMAT), version=np.array(VERSION), dt=np.array(self.dt),
                   time=self.time, body_pos=self.body_pos, body_quat=self.body_quat)
        for name in _OPTIONAL:
            if getattr(self, name) is not None:
                out[name] = getattr(self, name)
        if self.contact_start is not None:
            out.update(contact_start=self.contact_start, contact_point=self.contact_point,
                       contact_force=self.contact_force, contact_bodies=self.contact_bodies)
        out.update(self.scene.to_arrays())
        return out

    def save(self, path, compress=True):
        """Write the recording to ``path`` (``.npz``; the suffix is added if missing).
        Every array is stored bit for bit, so ``Recording.load`` gives it back exactly.
        Returns the path written."""
        path = os.fspath(path)
        if not path.endswith(".npz"):
            path += ".npz"
        (np.savez_compressed if compress else np.savez)(path, **self.to_arrays())
        return path

    @classmethod
    def load(cls, path):
        """Read a recording written by :meth:`save`; ModelError names the file and the
        missing or malformed field."""
        where = f"recording '{os.fspath(path)}'"
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except FileNotFoundError:
            raise ModelError(f"{where}: no such file") from None
        except (OSError, ValueError, zipfile.BadZipFile) as exc:
            raise ModelError(f"{where}: not a readable .npz file ({exc})") from None
        if str(arrays.get("format", "")) != FORMAT:
            raise ModelError(f"{where}: not a tumble recording (no 'format' = '{FORMAT}')")
        if int(arrays.get("version", -1)) > VERSION:
            raise ModelError(f"{where}: version {int(arrays['version'])} is newer than this "
                             f"tumble reads ({VERSION})")
        for key in ("time", "body_pos", "body_quat", "dt"):
            if key not in arrays:
                raise ModelError(f"{where}: the field '{key}' is missing")
        scene = Scene.from_arrays(arrays, where=where)
        contacts = {k: arrays.get(k) for k in ("contact_start", "contact_point",
                                               "contact_force", "contact_bodies")}
        return cls(scene, arrays["time"], arrays["body_pos"], arrays["body_quat"],
                   dt=float(arrays["dt"]), where=where,
                   **{k: arrays.get(k) for k in _OPTIONAL}, **contacts)

    # -------------------------------------------------------------- notebooks
    def animation(self, **kwargs):
        """The recording as an animation for a notebook cell or an HTML page: a
        :class:`~tumble.viewer.notebook.Animation` (keywords: ``format`` 'gif' or 'mp4',
        ``fps``, ``size``, ``speed``, ``follow``, ``camera``, ...). Needs the ``viewer``
        extra."""
        from .notebook import Animation
        return Animation(self, **kwargs)

    def _repr_html_(self):
        # Jupyter shows a recording as an animated GIF (tumble.viewer.notebook); without
        # the viewer extra (matplotlib, imageio-ffmpeg) it falls back to the text repr.
        try:
            return self.animation().to_html()
        except ImportError:
            return None
        except ModelError as exc:
            if "imageio-ffmpeg" in str(exc):
                return None
            raise

    def __repr__(self):
        return (f"<tumble.Recording: {len(self)} frames, {self.scene.nbody} bodies, "
                f"t = {self.time[0]:g}..{self.time[-1]:g} s>")


class Recorder:
    """Collects frames of a :class:`tumble.World` while it is stepped.

    Parameters
    ----------
    world : the World to record (world ``world_index`` of a batch).
    contacts : also store each frame's contacts (points, forces, bodies).
    velocities : also store body velocities (the viewer uses them to resume a live world
        from a frame scrubbed back to).
    energy : also store ``world.energy()`` (kinetic, potential) per frame.
    joints : also store ``world.joint_q`` per frame.
    body_colors : {body: (r, g, b)} colours for the scene (see ``Scene.from_model``).
    max_frames : keep at most this many frames, dropping the oldest (None: all).
    capture_now : take the world's current state as the first frame.

    Frames are taken by :meth:`capture` (call it after your own ``world.step``), by
    :meth:`step` (steps, then captures) or by :meth:`run` (steps for a while at a frame
    rate, with an optional controller and a progress bar).
    """

    def __init__(self, world, *, contacts=False, velocities=False, energy=False, joints=False,
                 body_colors=None, world_index=0, max_frames=None, capture_now=True):
        from ..world import World
        if not isinstance(world, World):
            raise ModelError(f"Recorder needs a tumble World, got {type(world).__name__}")
        if not 0 <= world_index < world.nworld:
            raise ModelError(f"Recorder: world_index must be in [0, {world.nworld}), "
                             f"got {world_index!r}")
        if max_frames is not None and (not isinstance(max_frames, (int, np.integer))
                                       or max_frames < 1):
            raise ModelError(f"Recorder: max_frames must be a positive integer or None, "
                             f"got {max_frames!r}")
        self.world = world
        self.scene = Scene.from_model(world.model, body_colors)
        self.world_index = int(world_index)
        self.options = dict(contacts=bool(contacts), velocities=bool(velocities),
                            energy=bool(energy), joints=bool(joints))
        self.max_frames = max_frames
        self.clear()
        if capture_now:
            self.capture()

    def clear(self):
        """Drop every frame."""
        self._frames = []

    def __len__(self):
        return len(self._frames)

    def _state(self, name):
        a = getattr(self.world, name)
        return a[self.world_index] if self.world.nworld > 1 else a

    def capture(self):
        """Store the world's current state as a frame (copies)."""
        w = self.world
        f = dict(time=float(w.time), body_pos=self._state("body_pos").copy(),
                 body_quat=self._state("body_quat").copy())
        if self.options["velocities"]:
            f["body_vel"] = self._state("body_vel").copy()
            f["body_angvel"] = self._state("body_angvel").copy()
        if self.options["energy"]:
            k, p = w.energy()
            if w.nworld > 1:
                k, p = k[self.world_index], p[self.world_index]
            f["kinetic"], f["potential"] = float(k), float(p)
        if self.options["joints"]:
            f["joint_q"] = self._state("joint_q").copy()
        if self.options["contacts"]:
            c = w.contacts_of(self.world_index)
            f["contacts"] = (c.point, c.force, c.bodies.astype(np.int32))
        if self._frames and f["time"] < self._frames[-1]["time"]:
            raise StateError(f"Recorder: the world's time went back from "
                             f"{self._frames[-1]['time']:g} s to {f['time']:g} s; call "
                             f"clear() or truncate() after resetting the world")
        self._frames.append(f)
        if self.max_frames is not None and len(self._frames) > self.max_frames:
            del self._frames[0]
        return len(self._frames) - 1

    def step(self, n=1):
        """``world.step(n)``, then :meth:`capture`."""
        self.world.step(n)
        return self.capture()

    def run(self, seconds, fps=60.0, *, control=None, progress=None, desc="simulating"):
        """Step the world for ``seconds`` of simulated time, capturing a frame every
        ``1 / fps`` s (rounded to whole steps of ``world.dt``). ``control(world)``, if
        given, is called before every single step (a controller). ``progress``: show a
        progress bar (tqdm; default: when the run is long). Returns ``self``."""
        from .progress import simulate
        simulate(self.world, seconds, fps=fps, control=control, progress=progress,
                 on_frame=lambda world: self.capture(), desc=desc)
        return self

    def truncate(self, n):
        """Keep only the first ``n`` frames (the viewer does this when a live world is
        resumed from an earlier frame)."""
        del self._frames[n:]

    def frame(self, i):
        """Frame ``i`` as a dict of arrays (time, body_pos, body_quat, ...)."""
        return self._frames[i]

    def recording(self):
        """The frames so far as a :class:`Recording` (arrays are copies)."""
        if not self._frames:
            raise StateError("Recorder: no frames captured yet")
        fr = self._frames
        kw = {}
        for name in _OPTIONAL:
            if name in fr[0]:
                kw[name] = np.array([f[name] for f in fr])
        if self.options["contacts"]:
            counts = [len(f["contacts"][0]) for f in fr]
            kw["contact_start"] = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
            for k, name in enumerate(("contact_point", "contact_force", "contact_bodies")):
                parts = [f["contacts"][k] for f in fr]
                kw[name] = np.concatenate(parts) if sum(counts) else (
                    np.zeros((0, 2), np.int32) if k == 2 else np.zeros((0, 3)))
        return Recording(self.scene, np.array([f["time"] for f in fr]),
                         np.array([f["body_pos"] for f in fr]),
                         np.array([f["body_quat"] for f in fr]), dt=self.world.dt, **kw)

    def save(self, path, compress=True):
        """Save the frames so far (see :meth:`Recording.save`); returns the path."""
        return self.recording().save(path, compress=compress)

    def __repr__(self):
        return f"<tumble.Recorder: {len(self)} frames of {self.scene.nbody} bodies>"
