"""The browser viewer: a viser server (three.js client) showing a live World or a Recording.

    viewer = tumble.viewer.Viewer(world)          # or Viewer(recording), Viewer(model)
    print(viewer.url)                             # open it in a browser
    viewer.serve_forever()                        # until Ctrl-C

A live world is stepped in a background thread at ``speed`` times real time; every shown
frame is kept (with velocities), so the time slider scrubs back through the run and Play
resumes the simulation from the frame scrubbed to. A recording is replayed and scrubbed
the same way. The page has Play/Pause, Step, a speed slider, the time slider, toggles for
contact points, contact forces, joint axes and the centre of mass, a camera that follows
the centre of mass or a body, and, on a live world, dragging a body with the left mouse
button pulls it towards the pointer with a damped spring applied through
``World.apply_force`` at the grabbed point.

Needs the ``viewer`` extra (viser).
"""
import threading
import time
import traceback

import numpy as np

from ..errors import ModelError, TumbleError
from .recorder import Recorder, Recording
from .render import auto_camera
from .scene import CONVEX, HEIGHTFIELD, PLANE, quat_to_matrix

_SPEEDS = (0.1, 4.0)
_CONTACT_RGB = (220, 30, 30)
_FORCE_RGB = (240, 120, 20)
_AXIS_RGB = ((220, 40, 40), (40, 170, 40), (40, 80, 230))


def _wxyz(q_xyzw):
    q = np.asarray(q_xyzw, float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def _rgb255(c):
    return tuple(int(round(255 * float(x))) for x in c)


class Viewer:
    """Serve a browser view of ``source``: a :class:`tumble.World` (live), a
    :class:`tumble.Model` (a World is made with the model's timestep), a
    :class:`Recording` or a :class:`Recorder` (replayed).

    Parameters
    ----------
    host, port : where to serve (``port=0`` picks a free port; see ``url``).
    fps : frames shown per second (and, for a live world, frames kept per simulated second
        at speed 1).
    speed : simulated seconds per wall-clock second (0.1 to 4).
    paused : start paused.
    control : live worlds: ``control(world)`` is called before every step (a controller).
    follow : None, 'com' or a body: the camera follows it.
    history : live worlds: seconds of frames kept for scrubbing (oldest dropped).
    loop : recordings: start again at the end (otherwise pause there).
    contacts, forces, joints, com : initial state of the overlay toggles.
    body_colors : {body: (r, g, b)} for live worlds (see ``Scene.from_model``).
    push_stiffness : initial stiffness k (1/s^2, per kg of the pushed body) of the spring
        that pulls a dragged body (the page has a slider for it).
    lighting : 'simple' (directional and ambient lights: quick to start even in a software
        WebGL browser) or 'studio' (viser's image-based lighting; nicer on a GPU).
    verbose : let viser print its banner and connection messages.
    """

    def __init__(self, source, *, host="127.0.0.1", port=8080, fps=30.0, speed=1.0,
                 paused=False, control=None, follow=None, history=120.0, loop=True,
                 contacts=False, forces=False, joints=False, com=False, body_colors=None,
                 push_stiffness=200.0, lighting="simple", label=None, verbose=False):
        try:
            import viser
        except ImportError:
            raise ModelError("the viewer needs viser: pip install 'tumble[viewer]'") from None
        from ..model.model import Model
        from ..world import World

        if not (np.isfinite(fps) and fps > 0):
            raise ModelError(f"viewer: fps must be > 0, got {fps!r}")
        if lighting not in ("simple", "studio"):
            raise ModelError(f"viewer: lighting must be 'simple' or 'studio', got {lighting!r}")
        if not (np.isfinite(push_stiffness) and 1.0 <= push_stiffness <= 1000.0):
            raise ModelError(f"viewer: push_stiffness must be in [1, 1000] 1/s^2, "
                             f"got {push_stiffness!r}")
        self._push_k0 = float(push_stiffness)
        self._lighting = lighting
        self.fps = float(fps)
        self._lock = threading.RLock()
        self.world = None
        self.control = control
        self.loop = bool(loop)
        if isinstance(source, Model):
            source = World(source)
        if isinstance(source, World):
            if source.nworld != 1:
                raise ModelError(f"viewer: shows one world; this World holds {source.nworld} "
                                 f"(make a World with nworld=1)")
            self.world = source
            keep = max(2, int(round(float(history) * self.fps)))
            self._history = Recorder(source, contacts=True, velocities=True, max_frames=keep,
                                     body_colors=body_colors)
            self.scene = self._history.scene
            self._recording = None
            dt = source.dt
            self._steps_per_frame = max(1, int(round(1.0 / (self.fps * dt))))
        elif isinstance(source, (Recording, Recorder)):
            self._recording = source if isinstance(source, Recording) else source.recording()
            self.scene = self._recording.scene
            self._history = None
        else:
            raise ModelError(f"viewer: expected a World, Model, Recording or Recorder, got "
                             f"{type(source).__name__}")
        self._frame = 0                 # index of the shown frame
        self._clock = self._frame_time(0)   # simulated time of the play head (recordings)
        self._playing = not paused
        self._carry = 0.0               # fraction of a step owed to a live world
        self._push = None               # (body, grab point in the body frame, target world)
        self._status = ""
        self._shown = None              # key of the frame last sent to the browser
        self._stop = threading.Event()

        self.speed = speed                      # validated before a server exists
        self.follow = follow
        self.server = viser.ViserServer(host=host, port=port, verbose=verbose,
                                        label=label or "tumble")
        self._build_scene()
        self._build_gui(contacts, forces, joints, com)
        self._show(force=True)
        self._thread = threading.Thread(target=self._run, name="tumble-viewer", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------- state
    @property
    def url(self):
        """The page to open, e.g. ``http://127.0.0.1:8080``."""
        return f"http://{self.server.get_host()}:{self.server.get_port()}"

    @property
    def live(self):
        """True when showing a World being simulated, False for a recording."""
        return self.world is not None

    @property
    def nframes(self):
        """Frames available to scrub through."""
        return len(self._history) if self.live else len(self._recording)

    @property
    def frame(self):
        """Index of the frame shown."""
        return self._frame

    @property
    def time(self):
        """Simulated time (s) of the frame shown."""
        return self._frame_time(self._frame)

    @property
    def playing(self):
        return self._playing

    @property
    def speed(self):
        return self._speed

    @speed.setter
    def speed(self, value):
        v = float(value)
        if not (_SPEEDS[0] <= v <= _SPEEDS[1]):
            raise ModelError(f"viewer: speed must be in [{_SPEEDS[0]}, {_SPEEDS[1]}], "
                             f"got {value!r}")
        self._speed = v
        if hasattr(self, "_gui_speed"):
            self._gui_speed.value = v

    @property
    def follow(self):
        return self._follow

    @follow.setter
    def follow(self, value):
        if value is not None and value != "com":
            self.scene.body_index(value)
            if not isinstance(value, str):
                value = str(self.scene.body_names[value])
        self._follow = value
        if hasattr(self, "_gui_follow"):
            self._gui_follow.value = self._follow_label(value)

    def _frame_time(self, i):
        if self.live:
            return self._history.frame(i)["time"]
        return float(self._recording.time[i])

    def _frame_data(self, i):
        """(time, body_pos, body_quat, contact points, contact forces) of frame i."""
        if self.live:
            f = self._history.frame(i)
            points, forces = f["contacts"][0], f["contacts"][1]
            return f["time"], f["body_pos"], f["body_quat"], points, forces
        r = self._recording
        points, forces, _ = r.contacts(i)
        return float(r.time[i]), r.body_pos[i], r.body_quat[i], points, forces

    # ---------------------------------------------------------------- controls
    def play(self):
        """Start playing (a live world resumes from the frame shown, dropping later frames)."""
        with self._lock:
            if self.live and self._frame < len(self._history) - 1:
                self._resume_from(self._frame)
            if not self.live and self._frame >= len(self._recording) - 1:
                self._frame = 0
            self._clock = self._frame_time(self._frame)
            self._playing = True
            self._sync_gui()

    def pause(self):
        """Stop playing; the frame shown stays."""
        with self._lock:
            self._playing = False
            self._sync_gui()

    def step(self):
        """Pause and move one frame on: the next recorded frame, or for a live world at the
        end of its history, ``round(1 / (fps dt))`` more simulation steps."""
        with self._lock:
            self._playing = False
            if self.live and self._frame >= len(self._history) - 1:
                self._simulate(self._steps_per_frame)
            else:
                self._frame = min(self._frame + 1, self.nframes - 1)
            self._clock = self._frame_time(self._frame)
            self._sync_gui()
            self._show()

    def seek(self, frame):
        """Pause and show frame ``frame`` (0 .. nframes - 1; negative counts from the end)."""
        with self._lock:
            n = self.nframes
            i = int(frame) + (n if frame < 0 else 0)
            if not 0 <= i < n:
                raise ModelError(f"viewer: frame must be in [0, {n}), got {frame!r}")
            self._playing = False
            self._frame = i
            self._clock = self._frame_time(i)
            self._sync_gui()
            self._show()

    def reset(self):
        """Live worlds: back to the model's initial state, history cleared."""
        if not self.live:
            return self.seek(0)
        with self._lock:
            self.world.reset()
            self._history.clear()
            self._history.capture()
            self._frame = 0
            self._status = ""
            self._sync_gui()
            self._show(force=True)

    def push(self, body, target, point=None):
        """Live worlds: pull ``body`` (name or index) at ``point`` (world frame, default its
        COM) towards the world point ``target`` until :meth:`release`, as a mouse drag
        does. The force is a damped spring acting at the grabbed point p (velocity v_p),
        ``m (k (target - p) - 2 zeta sqrt(k) v_p)`` with the body's mass m, the Stiffness
        slider's k and zeta = 0.7, applied through ``World.apply_force`` before every
        step while the world plays."""
        if not self.live:
            raise ModelError("viewer: push needs a live world, not a recording")
        b = self.scene.body_index(body)
        with self._lock:
            pos, quat = self.world.body_pos[b], self.world.body_quat[b]
            p = pos if point is None else np.asarray(point, float)
            local = quat_to_matrix(quat).T @ (p - pos)
            self._push = (b, local, np.asarray(target, float))

    def release(self):
        """End a push."""
        self._push = None

    # ------------------------------------------------------------- simulation
    def _resume_from(self, i):
        """Put the world back in the state of history frame i and forget later frames."""
        from ..world import State
        f = self._history.frame(i)
        self.world.set_state(State(f["time"], f["body_pos"][None], f["body_quat"][None],
                                   f["body_vel"][None], f["body_angvel"][None]))
        self._history.truncate(i + 1)

    def _push_force(self, push):
        b, local, target = push
        w = self.world
        m = float(self.scene.body_mass[b])
        if not np.isfinite(m):
            return None
        r = quat_to_matrix(w.body_quat[b]) @ local
        p = w.body_pos[b] + r
        v = w.body_vel[b] + np.cross(w.body_angvel[b], r)
        k = float(self._gui_stiffness.value)
        force = m * (k * (target - p) - 2.0 * 0.7 * np.sqrt(k) * v)
        return b, force, p

    def _simulate(self, n):
        """n steps of the live world (controller and push applied), then one frame kept."""
        w = self.world
        try:
            if self.control is None and self._push is None:
                w.step(n)
            else:
                for _ in range(n):
                    if self.control is not None:
                        self.control(w)
                    push = self._push
                    if push is not None:
                        pf = self._push_force(push)
                        if pf is not None:
                            w.apply_force(pf[0], pf[1], point=pf[2])
                    w.step(1)
        except Exception as exc:          # noqa: BLE001 - a controller's bug must not kill the UI
            if not isinstance(exc, TumbleError):
                traceback.print_exc()
            self._playing = False
            self._status = f"stopped: {type(exc).__name__}: {exc}"
            w.clear_forces()
        self._history.capture()
        self._frame = len(self._history) - 1

    def _tick(self, wall_dt):
        """Advance the play head by wall_dt seconds of wall-clock time."""
        if not self._playing:
            return
        if self.live:
            self._carry += wall_dt * self._speed / self.world.dt
            n = int(self._carry)
            if n >= 1:
                self._carry -= n
                self._simulate(n)
        else:
            r = self._recording
            self._clock += wall_dt * self._speed
            if self._clock > r.time[-1]:
                if self.loop and len(r) > 1:
                    self._clock = r.time[0] + (self._clock - r.time[-1])
                else:
                    self._clock = r.time[-1]
                    self._playing = False
            self._frame = r.frame_index(self._clock)
        self._sync_gui()

    def _run(self):
        period = 1.0 / self.fps
        last = time.perf_counter()
        while not self._stop.is_set():
            now = time.perf_counter()
            with self._lock:
                try:
                    # a slow simulation runs slower than real time rather than piling up work
                    self._tick(min(now - last, 4 * period))
                    self._show()
                except Exception:                 # noqa: BLE001 - keep serving the page
                    traceback.print_exc()
                    self._playing = False
            last = now
            self._stop.wait(max(0.0, period - (time.perf_counter() - now)))

    # ------------------------------------------------------------------- scene
    def _build_scene(self):
        s, sc = self.scene, self.server.scene
        sc.set_up_direction(tuple(s.up))
        if self._lighting == "simple":
            # image-based lighting takes seconds to prepare in a software-rendering browser
            sc.configure_environment_map(None)
            sc.add_light_ambient("/lights/ambient", intensity=0.8)
        cam = auto_camera(s, self._frame_data(0)[1], aspect=16 / 10, fov=50.0)
        eye = cam.eye(s.up)
        self.server.initial_camera.position = tuple(eye)
        self.server.initial_camera.look_at = tuple(cam.target)
        self.server.initial_camera.up = tuple(s.up)
        self.server.initial_camera.fov = float(np.radians(cam.fov))
        self._size = max(s.extent(), 0.1)
        self._body_nodes = []
        self._bodies_visible = True
        for b in range(s.nbody):
            self._body_nodes.append(sc.add_frame(f"/bodies/b{b}", show_axes=False))
        self._geom_nodes = []
        for g in range(s.ngeom):
            t = s.geom_type[g]
            if t == PLANE:
                normal_quat = _wxyz(s.geom_quat[g])
                self._geom_nodes.append(sc.add_grid(
                    f"/ground/g{g}", width=40.0, height=40.0, plane="xy",
                    cell_size=0.5, section_size=1.0, infinite_grid=True, fade_distance=40.0,
                    plane_color=_rgb255(s.geom_color[g]), plane_opacity=0.6,
                    shadow_opacity=0.2, wxyz=normal_quat, position=tuple(s.geom_pos[g])))
                continue
            v, f = s.geom_mesh(g, detail=24)
            parent = f"/bodies/b{s.geom_body[g]}" if s.geom_body[g] >= 0 else "/static"
            node = sc.add_mesh_simple(
                f"{parent}/g{g}", vertices=v, faces=f, color=_rgb255(s.geom_color[g]),
                flat_shading=bool(t in (HEIGHTFIELD, CONVEX)),
                side="double" if t == HEIGHTFIELD else "front",
                wxyz=_wxyz(s.geom_quat[g]), position=tuple(s.geom_pos[g]))
            if s.geom_body[g] >= 0:
                self._attach_drag(node, int(s.geom_body[g]))
            self._geom_nodes.append(node)
        empty = np.zeros((1, 2, 3))
        self._contact_points = sc.add_point_cloud(
            "/overlay/contacts", points=np.zeros((1, 3)), colors=_CONTACT_RGB,
            point_size=0.04 * self._size + 0.01, point_shape="circle", visible=False)
        self._force_arrows = sc.add_arrows(
            "/overlay/forces", points=empty, colors=_FORCE_RGB, shaft_radius=0.01,
            head_radius=0.025, head_length=0.05, visible=False)
        self._joint_lines = sc.add_line_segments(
            "/overlay/joints", points=empty, colors=np.zeros((1, 2, 3), np.uint8),
            thickness=0.012, visible=False)
        self._com_ball = sc.add_icosphere("/overlay/com", radius=0.04, color=(20, 20, 20),
                                          visible=False)
        self._com_line = sc.add_line_segments("/overlay/com_drop", points=empty,
                                              colors=(20, 20, 20), thickness=0.006,
                                              visible=False)
        self._push_line = sc.add_line_segments("/overlay/push", points=empty,
                                               colors=(250, 200, 0), thickness=0.015,
                                               visible=False)

    def _attach_drag(self, node, body):
        @node.on_drag("left")
        async def _drag(event):
            # async: the phases arrive in order on the server's event loop. No lock here
            # (the loop must never wait for the simulation thread); replacing the _push
            # tuple is atomic, and the simulation thread reads it once per step.
            if not self.live:
                return
            if event.phase == "start":
                _, pos, quat, _, _ = self._frame_data(self._frame)
                grab = np.asarray(event.start_position, float)
                local = quat_to_matrix(quat[body]).T @ (grab - pos[body])
                self._push = (body, local, np.asarray(event.end_position, float))
            elif event.phase == "update":
                push = self._push
                if push is not None:
                    self._push = (push[0], push[1], np.asarray(event.end_position, float))
            elif event.phase == "end":
                self._push = None

    def _show(self, force=False):
        """Send the shown frame (and overlays) to the browser if anything changed."""
        t, pos, quat, points, forces = self._frame_data(self._frame)
        toggles = (self._gui_contacts.value, self._gui_forces.value, self._gui_joints.value,
                   self._gui_com.value, self._gui_bodies.value)
        key = (self._frame, t, toggles, self._follow, self._push is not None)
        if key == self._shown and not force and self._push is None:
            return
        self._shown = key
        with self.server.atomic():
            for b, node in enumerate(self._body_nodes):
                node.position = tuple(pos[b])
                node.wxyz = tuple(_wxyz(quat[b]))
            self._show_overlays(pos, quat, points, forces, toggles)
            self._gui_time.value = f"{t:.3f} s"
            self._gui_status.value = self._status or ("live" if self.live else "recording")
        self._follow_camera(pos)

    def _show_overlays(self, pos, quat, points, forces, toggles):
        s = self.scene
        show_contacts, show_forces, show_joints, show_com, show_bodies = toggles
        if bool(show_bodies) != self._bodies_visible:
            self._bodies_visible = bool(show_bodies)
            for node in self._body_nodes:
                node.visible = self._bodies_visible
        n = len(points)
        self._contact_points.visible = bool(show_contacts and n)
        if show_contacts and n:
            self._contact_points.points = np.asarray(points, np.float32)
            self._contact_points.colors = np.tile(np.array(_CONTACT_RGB, np.uint8), (n, 1))
        self._force_arrows.visible = bool(show_forces and n)
        if show_forces and n:
            m = s.body_mass[np.isfinite(s.body_mass)]
            weight = (m.max() if m.size else 1.0) * max(np.linalg.norm(s.gravity), 1.0)
            seg = np.stack([points, points + forces * (0.5 / weight)], axis=1)
            self._force_arrows.points = seg.astype(np.float32)
            self._force_arrows.colors = np.tile(np.array(_FORCE_RGB, np.uint8), (n, 1))
        if show_joints and s.njoint:
            anchors, axes = s.joint_axes(pos, quat)
            length = 0.6 * self._size + 0.05
            segs, cols = [], []
            for j in range(s.njoint):
                for k, a in enumerate(axes[j]):
                    segs.append((anchors[j], anchors[j] + length * a))
                    cols.append((_AXIS_RGB[k],) * 2)
            if segs:
                self._joint_lines.points = np.asarray(segs, np.float32)
                self._joint_lines.colors = np.asarray(cols, np.uint8)
            self._joint_lines.visible = bool(segs)
        else:
            self._joint_lines.visible = False
        self._com_ball.visible = self._com_line.visible = bool(show_com)
        if show_com:
            c = s.com(pos)
            self._com_ball.position = tuple(c)
            ground = self._ground_below(c)
            self._com_line.visible = ground is not None
            if ground is not None:
                self._com_line.points = np.asarray([[c, ground]], np.float32)
        push = self._push
        if push is not None and self.live:
            b, local, target = push
            grab = pos[b] + quat_to_matrix(quat[b]) @ local
            self._push_line.points = np.asarray([[grab, target]], np.float32)
            self._push_line.visible = True
        else:
            self._push_line.visible = False

    def _ground_below(self, c):
        s = self.scene
        best = None
        for g in np.flatnonzero(s.geom_type == PLANE):
            normal = quat_to_matrix(s.geom_quat[g])[:, 2]
            h = (c - s.geom_pos[g]) @ normal
            if normal @ s.up > 0.99 and h > 0 and (best is None or h < best[0]):
                best = (h, c - h * normal)
        return None if best is None else best[1]

    def _follow_camera(self, pos):
        if self._follow is None:
            return
        target = (self.scene.com(pos) if self._follow == "com"
                  else pos[self.scene.body_index(self._follow)])
        for client in self.server.get_clients().values():
            cam = client.camera
            try:
                # moving the position moves look_at with it: the view keeps its offset
                cam.position = cam.position + (target - cam.look_at)
            except (AssertionError, ValueError):
                pass                       # this client has not reported its camera yet

    # --------------------------------------------------------------------- gui
    @staticmethod
    def _follow_label(value):
        return {None: "off", "com": "centre of mass"}.get(value, value)

    def _build_gui(self, contacts, forces, joints, com):
        gui = self.server.gui
        kind = "live simulation" if self.live else "recording"
        gui.add_markdown(f"**tumble** — {kind}, {self.scene.nbody} bodies")
        self._gui_play = gui.add_button("Pause" if self._playing else "Play")
        self._gui_step = gui.add_button("Step")
        self._gui_time = gui.add_text("Time", initial_value="0.000 s", disabled=True)
        self._gui_frame = gui.add_slider("Frame", min=0, max=max(self.nframes - 1, 0),
                                         step=1, initial_value=0)
        self._gui_speed = gui.add_slider("Speed", min=_SPEEDS[0], max=_SPEEDS[1], step=0.05,
                                         initial_value=self._speed)
        if self.live:
            self._gui_reset = gui.add_button("Reset")
        with gui.add_folder("Show"):
            self._gui_bodies = gui.add_checkbox("Bodies", True)
            self._gui_contacts = gui.add_checkbox("Contact points", contacts)
            self._gui_forces = gui.add_checkbox("Contact forces", forces)
            self._gui_joints = gui.add_checkbox("Joint axes", joints)
            self._gui_com = gui.add_checkbox("Centre of mass", com)
        with gui.add_folder("Camera"):
            options = ["off", "centre of mass"] + [str(n) for n in self.scene.body_names]
            self._gui_follow = gui.add_dropdown("Follow", options,
                                                initial_value=self._follow_label(self._follow))
        with gui.add_folder("Push", visible=self.live):
            gui.add_markdown("Drag a body with the left mouse button to pull it.")
            self._gui_stiffness = gui.add_slider("Stiffness (1/s²)", min=1.0, max=1000.0,
                                                 step=1.0, initial_value=self._push_k0)
        self._gui_status = gui.add_text("Status", initial_value="", disabled=True)

        @self._gui_play.on_click
        def _(event):
            self.pause() if self._playing else self.play()

        @self._gui_step.on_click
        def _(event):
            self.step()

        @self._gui_frame.on_update
        def _(event):
            if event.client is None:         # our own update while playing
                return
            with self._lock:
                i = int(self._gui_frame.value)
                if 0 <= i < self.nframes and i != self._frame:
                    self.seek(i)

        @self._gui_speed.on_update
        def _(event):
            if event.client is not None:
                self._speed = float(self._gui_speed.value)

        @self._gui_follow.on_update
        def _(event):
            if event.client is not None:
                value = self._gui_follow.value
                self._follow = {"off": None, "centre of mass": "com"}.get(value, value)

        def redraw(event):
            with self._lock:
                self._show()

        for box in (self._gui_contacts, self._gui_forces, self._gui_joints, self._gui_com,
                    self._gui_bodies):
            box.on_update(redraw)

        if self.live:
            @self._gui_reset.on_click
            def _(event):
                self.reset()

    def _sync_gui(self):
        """Make the play button, frame slider and time read what the viewer does."""
        label = "Pause" if self._playing else "Play"
        if self._gui_play.label != label:
            self._gui_play.label = label
        top = max(self.nframes - 1, 0)
        if self._gui_frame.max != top:
            self._gui_frame.max = top
        if self._gui_frame.value != self._frame:
            self._gui_frame.value = self._frame

    # --------------------------------------------------------------- lifetime
    @property
    def address_line(self):
        """What the command line prints for a user: where to open the viewer."""
        return f"tumble viewer: open {self.url} in a browser (Ctrl-C to stop)"

    def serve_forever(self, announce=False):
        """Block until Ctrl-C (or :meth:`close` from another thread), then close.

        With ``announce`` the ``address_line`` is printed first, inside the Ctrl-C guard: a
        user who stops the viewer the moment its address appears must not get a
        traceback."""
        try:
            if announce:
                print(self.address_line, flush=True)
            while not self._stop.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            self.close()

    def close(self):
        """Stop the simulation thread and the server."""
        if self._stop.is_set() and not self._thread.is_alive():
            return
        self._stop.set()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)
        self.server.stop()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _repr_html_(self):
        # Jupyter embeds the viewer's page in the cell (tumble.viewer.notebook.viewer_html)
        from .notebook import viewer_html
        return viewer_html(self)

    def __repr__(self):
        kind = "live" if self.live else "recording"
        return f"<tumble.viewer.Viewer {kind} at {self.url}, frame {self._frame}/{self.nframes}>"


def view(source, *, block=True, **kwargs):
    """Open a :class:`Viewer` on ``source`` and print its address; with ``block`` serve
    until Ctrl-C, otherwise return the viewer (call ``close()`` when done)."""
    viewer = Viewer(source, **kwargs)
    if block:
        viewer.serve_forever(announce=True)
    else:
        print(viewer.address_line, flush=True)
    return viewer
