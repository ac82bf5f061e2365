"""Tracking motion capture: PD servos toward a clip's joint rotations, frame by frame.

``MotionTracker`` drives a ragdoll with ``PDController`` targets taken from a ``Motion``
(``joint_targets``), optionally helped by a ``HandOfGod`` on the root toward the clip's
root pose, and reports the tracking error of every frame.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..model.validate import positive
from .balance import HandOfGod
from .pd import PDController
from .pose import joint_targets, set_pose


@dataclass
class TrackingResult:
    """Per-frame tracking figures of a run (F frames tracked).

    time : (F,) s.  joint_error : (F,) mean angle (rad) between the ragdoll's joints and
    the clip's, over the tracked joints.  max_joint_error : (F,) the worst joint's angle.
    root_error : (F,) distance (m) of the root body from where the clip puts it.
    root_force : (F,) norm of the hand-of-god force (N), 0 without it.
    """
    time: np.ndarray
    joint_error: np.ndarray
    max_joint_error: np.ndarray
    root_error: np.ndarray
    root_force: np.ndarray

    @property
    def mean_joint_error(self):
        return float(self.joint_error.mean())


def quat_angle(a, b):
    """Angle (rad) between unit quaternions ``a`` and ``b`` (..., 4), sign-blind."""
    d = np.abs(np.sum(a * b, axis=-1))
    return 2.0 * np.arccos(np.clip(d, 0.0, 1.0))


class MotionTracker:
    """Follow ``motion`` with ``ragdoll`` in ``world`` by PD servos (and a hand of god).

    kp, kd, max_torque : servo gains (scalars, (njoint,) or {joint name: value}); the
        root's own joint (its free joint or pin) gets none.
    mode : 'implicit' (default), 'explicit' or 'stable' (``World(pd=...)``).
    hand_of_god : None for no root help, or a dict of ``HandOfGod`` gains (kp, kd, kp_rot,
        kd_rot); the force acts on the ragdoll's root body toward the clip's root pose.
    substeps : physics steps per motion frame (``world.dt`` is set to
        ``motion.frame_time / substeps``).
    """

    def __init__(self, world, ragdoll, motion, *, kp=1000.0, kd=50.0, max_torque=None,
                 mode="implicit", hand_of_god=None, substeps=1):
        if isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer)) or substeps < 1:
            raise ModelError(f"MotionTracker: substeps must be a positive integer, got {substeps!r}")
        self.world, self.ragdoll, self.motion = world, ragdoll, motion
        self.substeps = int(substeps)
        world.dt = positive(motion.frame_time, "MotionTracker", "motion.frame_time") / substeps
        m = world.model
        root_joint = ragdoll.joint_index[ragdoll.slot_of_joint[ragdoll.skeleton.root]]
        self.tracked = np.array([j for j in ragdoll.joint_index if j != root_joint
                                 and m.joint_type_names[j] in ("ball", "hinge", "universal")],
                                dtype=np.int64)
        kp_arr = np.zeros(m.njoint)
        kd_arr = np.zeros(m.njoint)
        kp_arr[self.tracked] = self._per(kp, "kp")[self.tracked]
        kd_arr[self.tracked] = self._per(kd, "kd")[self.tracked]
        self.pd = PDController(world, kp_arr, kd_arr, max_torque, mode=mode)
        self.targets = joint_targets(ragdoll, motion)            # (F, njoint, 4)
        self.root_body = int(ragdoll.body_index[ragdoll.slot_of_joint[ragdoll.skeleton.root]])
        self.root_pos, self.root_quat = self._root_track()
        self.hand = None
        if hand_of_god is not None:
            gains = {} if hand_of_god is True else dict(hand_of_god)
            self.hand = HandOfGod(world, self.root_body, **gains)

    def _per(self, value, what):
        from .pd import _per_joint
        return _per_joint(self.world.model, value, what)

    def _root_track(self):
        """Where the clip puts the root body at every frame: (F, 3), (F, 4)."""
        from ..world import World
        shadow = World(self.world.model, dt=self.world.dt)
        F = self.motion.num_frames
        pos, quat = np.zeros((F, 3)), np.zeros((F, 4))
        for f in range(F):
            set_pose(shadow, self.ragdoll, self.motion, f, velocities=False)
            pos[f] = shadow.body_pos[self.root_body]
            quat[f] = shadow.body_quat[self.root_body]
        return pos, quat

    def reset(self, frame=0):
        """Put the ragdoll in the clip's pose (and velocities) at ``frame``."""
        set_pose(self.world, self.ragdoll, self.motion, frame)

    def run(self, frames=None, *, start=0, push=None, on_frame=None):
        """Track ``frames`` motion frames (default: the whole clip) from ``start``.

        push : optional callable ``push(world, frame)`` called every frame before stepping,
            e.g. to apply a perturbation. on_frame : optional callable ``on_frame(world,
            frame)`` called after every frame's steps (e.g. ``Recorder.capture``).
        Returns a :class:`TrackingResult`.
        """
        F = self.motion.num_frames
        n = F - 1 - start if frames is None else int(frames)
        if n < 1 or start < 0 or start + n > F - 1:
            raise ModelError(f"MotionTracker.run: frames {start}..{start + n} outside the clip's "
                             f"{F} frames")
        self.reset(start)
        w = self.world
        out = {k: np.zeros(n) for k in ("time", "err", "max", "root", "force")}
        for k in range(n):
            f = start + k + 1                    # aim at the frame we are stepping toward
            self.pd.set_targets(self.targets[f])
            if self.hand is not None:
                v = (self.root_pos[f] - self.root_pos[f - 1]) / self.motion.frame_time
                force, _ = self.hand.apply(self.root_pos[f], self.root_quat[f], target_vel=v,
                                           substeps=self.substeps)
                out["force"][k] = np.linalg.norm(force)
            if push is not None:
                push(w, f)
            w.step(self.substeps)
            if on_frame is not None:
                on_frame(w, f)
            ang = quat_angle(np.asarray(w.joint_quat)[self.tracked], self.targets[f][self.tracked])
            out["time"][k] = w.time
            out["err"][k] = ang.mean()
            out["max"][k] = ang.max()
            out["root"][k] = np.linalg.norm(w.body_pos[self.root_body] - self.root_pos[f])
        return TrackingResult(out["time"], out["err"], out["max"], out["root"], out["force"])
