"""Load, edit and save BVH (Biovision Hierarchy) motion capture files.

A BVH file holds a joint tree (``HIERARCHY``) and one line of channel values per
frame (``MOTION``). :func:`load_bvh` turns it into a :class:`Motion`, whose arrays
are indexed by frame F and joint J:

* ``joint_names`` (J,), ``parents`` (J,) (-1 for the root), ``offsets`` (J, 3);
* ``local_rotations`` (F, J, 4), quaternions (x, y, z, w) like scipy's ``Rotation``,
  the rotation of each joint relative to its parent (child frame -> parent frame);
* ``local_positions`` (F, J, 3), the joint origin in its parent's frame; it is the
  offset except where the file has position channels (the root's translation);
* ``root_positions`` (F, 3) = ``local_positions[:, root]``.

Conventions
-----------
* Units: lengths are kept in the file's units, times in seconds. ``scale``
  multiplies every length (offsets and position channels), for instance 0.01
  to turn centimetres into metres. The GAMES-105 course files are already in
  metres (thigh 0.41, shank 0.39, pelvis about 0.85 above the floor), Y up.
* End Sites become joints named ``'<parent>_end'`` (the GAMES-105 convention,
  e.g. ``'lWrist_end'``), with no channels and identity rotation. A second End
  Site under the same parent gets ``'_end1'``, ``'_end2'``, ...
* Rotation channels in the order ``Zrotation Yrotation Xrotation`` mean
  ``R = Rz Ry Rx`` applied to child-frame vectors: scipy's intrinsic
  ``from_euler('ZYX', (z, y, x), degrees=True)``. Any order of 1 to 3 axes works.
* Position channels replace the offset component they name (the common reading
  of BVH); components without a channel keep the offset. The root offset is thus
  ignored when the root has all three position channels.
* The world frame is the root's parent frame, with no further conversion.
"""
import math
import re
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ModelError
from ..math import quat_np as Q
from ..model.tree import check_tree, tree_order
from ._files import file_path, read_file, write_text

__all__ = ["Motion", "load_bvh", "load_bvh_string", "save_bvh", "format_bvh"]

_AXES = "XYZ"
_ROT_CHANNELS = {"Xrotation": 0, "Yrotation": 1, "Zrotation": 2}
_POS_CHANNELS = {"Xposition": 0, "Yposition": 1, "Zposition": 2}
# Tolerance on frame indices when resampling: snaps t/dt to whole frames so that
# resampling at a multiple of the frame rate copies the original frames exactly.
_FRAME_EPS = 1e-9
#: Largest BVH file tumble reads.
MAX_FILE_BYTES = 256 * 2 ** 20
#: Deepest nesting of joints tumble reads (JOINT inside JOINT ...).
MAX_DEPTH = 1000
#: Largest magnitude of an OFFSET or channel value (file units, degrees): beyond it a
#: file is refused as corrupt rather than overflowing forward kinematics.
MAX_VALUE = 1e9


# ----------------------------------------------------------------------------
# Motion
# ----------------------------------------------------------------------------

class Motion:
    """A joint tree and its animation, F frames of J joints.

    Build it with :func:`load_bvh` or :meth:`from_arrays`; the methods that edit a
    motion (:meth:`resample`, :meth:`mirror`, :meth:`remap`, :meth:`sub`) return a
    new one. Attributes (see the module docstring for frames and units):

    ``joint_names`` list[str] (J); ``parents`` int (J,), -1 for the root;
    ``offsets`` (J, 3); ``channels`` list of J tuples of BVH channel names (empty for
    End Sites); ``frame_time`` seconds; ``local_rotations`` (F, J, 4) xyzw;
    ``local_positions`` (F, J, 3); ``root_positions`` (F, 3).
    """

    def __init__(self, joint_names, parents, offsets, channels, frame_time,
                 local_rotations, local_positions):
        # Private: use from_arrays, which checks its input, or load_bvh.
        self.joint_names = joint_names
        self.parents = parents
        self.offsets = offsets
        self.channels = channels
        self.frame_time = frame_time
        self.local_rotations = local_rotations
        self.local_positions = local_positions
        self._order = tree_order(parents, joint_names, "Motion")[0]
        self._index = {n: i for i, n in enumerate(joint_names)}

    # -- construction -------------------------------------------------------

    @classmethod
    def from_arrays(cls, joint_names, parents, offsets, local_rotations, *, frame_time,
                    root_positions=None, local_positions=None, channels=None):
        """Build a motion from arrays, checking and copying them.

        joint_names: J unique names. parents: (J,) ints, -1 for the single root, any
        order as long as there is no cycle. offsets: (J, 3), each joint's origin in
        its parent's frame (file units). local_rotations: (F, J, 4) xyzw, normalised
        here. frame_time: seconds per frame, > 0.
        root_positions: (F, 3) root translation; local_positions: (F, J, 3) joint
        origins in the parent frame. Give either (both must then agree at the root)
        or neither (every joint stays at its offset).
        channels: J sequences of BVH channel names, used by :func:`save_bvh`. By
        default the root gets ``Xposition Yposition Zposition Zrotation Yrotation
        Xrotation``, other joints ``Zrotation Yrotation Xrotation`` (plus position
        channels where ``local_positions`` leaves the offset), and leaves that never
        rotate nor move none (they are written as End Sites).
        """
        names, parents = check_tree(joint_names, parents, "Motion")
        J = len(names)
        root = int(np.flatnonzero(parents == -1)[0])
        offsets = _as_float_array(offsets, (J, 3), "offsets")
        rot = np.array(local_rotations, dtype=np.float64)
        if rot.ndim != 3 or rot.shape[1:] != (J, 4):
            raise ModelError(f"Motion: local_rotations has shape {rot.shape}, expected (F, {J}, 4)")
        F = rot.shape[0]
        if not np.all(np.isfinite(rot)):
            raise ModelError("Motion: local_rotations has non-finite values")
        norm = np.linalg.norm(rot, axis=-1, keepdims=True)
        if np.any(norm < 1e-12):
            f, j = np.argwhere(norm[..., 0] < 1e-12)[0]
            raise ModelError(f"Motion: local_rotations[{f}, {j}] ('{names[j]}') is a zero quaternion")
        rot /= norm
        frame_time = float(frame_time)
        if not (math.isfinite(frame_time) and frame_time > 0.0):
            raise ModelError(f"Motion: frame_time must be a positive number, got {frame_time}")

        if local_positions is None:
            pos = np.broadcast_to(offsets, (F, J, 3)).copy()
            if root_positions is not None:
                pos[:, root] = _as_float_array(root_positions, (F, 3), "root_positions")
        else:
            pos = _as_float_array(local_positions, (F, J, 3), "local_positions")
            if root_positions is not None:
                rp = _as_float_array(root_positions, (F, 3), "root_positions")
                if not np.allclose(rp, pos[:, root], rtol=1e-12, atol=1e-12):
                    raise ModelError("Motion: root_positions disagrees with local_positions[:, root]")

        if channels is None:
            channels = _default_channels(names, parents, offsets, rot, pos, root)
        else:
            channels = [tuple(str(c) for c in ch) for ch in channels]
            if len(channels) != J:
                raise ModelError(f"Motion: channels has {len(channels)} entries, expected {J}")
            for name, ch in zip(names, channels):
                _check_channels(ch, f"Motion: joint '{name}'")
        return cls(names, parents, offsets, channels, frame_time, rot, pos)

    def _replace(self, **changes):
        """New motion with some fields replaced (arrays already checked by the caller)."""
        fields = dict(joint_names=list(self.joint_names), parents=self.parents.copy(),
                      offsets=self.offsets.copy(), channels=list(self.channels),
                      frame_time=self.frame_time, local_rotations=self.local_rotations,
                      local_positions=self.local_positions)
        fields.update(changes)
        return Motion(**fields)

    # -- basic properties ---------------------------------------------------

    @property
    def num_frames(self):
        """F, the number of frames."""
        return self.local_rotations.shape[0]

    @property
    def num_joints(self):
        """J, the number of joints (End Sites included)."""
        return len(self.joint_names)

    @property
    def fps(self):
        """Frames per second, ``1 / frame_time``."""
        return 1.0 / self.frame_time

    @property
    def duration(self):
        """Time from the first to the last frame, seconds: ``(F - 1) * frame_time``."""
        return max(self.num_frames - 1, 0) * self.frame_time

    @property
    def root(self):
        """Index of the root joint."""
        return int(np.flatnonzero(self.parents == -1)[0])

    @property
    def root_positions(self):
        """(F, 3) root translation per frame, in the world frame (file units x scale)."""
        return self.local_positions[:, self.root]

    @property
    def end_sites(self):
        """(J,) bool: joints written as End Sites (leaves with no channels)."""
        has_child = np.zeros(self.num_joints, dtype=bool)
        has_child[self.parents[self.parents >= 0]] = True
        return np.array([not ch for ch in self.channels]) & ~has_child

    def index(self, name):
        """Index of joint ``name``; ModelError naming it if absent."""
        try:
            return self._index[name]
        except KeyError:
            raise ModelError(f"Motion: no joint named '{name}'") from None

    def __len__(self):
        return self.num_frames

    def __repr__(self):
        return (f"Motion({self.num_joints} joints, {self.num_frames} frames, "
                f"frame_time={self.frame_time:g} s)")

    # -- kinematics ---------------------------------------------------------

    def forward_kinematics(self):
        """World positions and orientations of every joint at every frame.

        Returns ``(pos, quat)``: pos (F, J, 3) joint origins in the world frame
        (file units x scale), quat (F, J, 4) xyzw joint frame -> world rotations.
        """
        F, J = self.num_frames, self.num_joints
        pos = np.empty((F, J, 3))
        quat = np.empty((F, J, 4))
        # Loop over joints only, parents first; every step works on all frames.
        for j in self._order:
            p = self.parents[j]
            if p < 0:
                pos[:, j] = self.local_positions[:, j]
                quat[:, j] = self.local_rotations[:, j]
            else:
                pos[:, j] = pos[:, p] + Q.qrot(quat[:, p], self.local_positions[:, j])
                quat[:, j] = Q.qmul(quat[:, p], self.local_rotations[:, j])
        return pos, quat

    def velocities(self):
        """World-frame linear and angular velocities of every joint, by finite differences.

        Returns ``(lin, ang)``, both (F, J, 3): lin in length units per second (file
        units x scale), ang in rad/s. Central differences inside, one-sided at the
        first and last frames; the angular one is the rotation vector of
        ``q[f+1] q[f-1]^-1`` over ``2 dt``. A single frame gives zeros.
        """
        pos, quat = self.forward_kinematics()
        F = self.num_frames
        if F < 2:
            return np.zeros_like(pos), np.zeros_like(pos)
        dt = self.frame_time
        lin = np.gradient(pos, dt, axis=0, edge_order=1)
        nxt = np.concatenate((quat[1:], quat[-1:]), axis=0)
        prv = np.concatenate((quat[:1], quat[:-1]), axis=0)
        span = np.full((F, 1, 1), 2.0 * dt)
        span[0] = span[-1] = dt
        # Left-multiplied increment: q_next = d * q_prev, so d is in the world frame.
        ang = Q.qrotvec(Q.qmul(nxt, Q.qconj(prv))) / span
        return lin, ang

    # -- editing ------------------------------------------------------------

    def sub(self, start=None, stop=None, step=None):
        """Frames ``start:stop:step`` (Python slice rules) as a new motion.

        A step > 1 multiplies ``frame_time``; negative steps are refused.
        """
        sl = slice(start, stop, step)
        step = 1 if step is None else int(step)
        if step <= 0:
            raise ModelError(f"Motion.sub: step must be positive, got {step}")
        return self._replace(frame_time=self.frame_time * step,
                             local_rotations=self.local_rotations[sl].copy(),
                             local_positions=self.local_positions[sl].copy())

    def __getitem__(self, key):
        """``motion[a:b]`` is ``motion.sub(a, b)``; ``motion[i]`` a one-frame motion."""
        if isinstance(key, slice):
            return self.sub(key.start, key.stop, key.step)
        if isinstance(key, (int, np.integer)):
            F = self.num_frames
            i = int(key) + F if key < 0 else int(key)
            if not 0 <= i < F:
                raise IndexError(f"frame {key} out of range for {F} frames")
            return self.sub(i, i + 1)
        raise TypeError(f"Motion indices must be slices or integers, not {type(key).__name__}")

    def resample(self, fps=None, *, frame_time=None):
        """The motion at another frame rate: give ``fps`` or ``frame_time`` (seconds).

        New frames sit at ``k * frame_time`` for every k that stays within the
        original duration; rotations are slerped, positions interpolated linearly.
        New frames that fall on original frames (to 1e-9 of a frame) copy them
        exactly.
        """
        if (fps is None) == (frame_time is None):
            raise ModelError("Motion.resample: give exactly one of fps and frame_time")
        new_dt = 1.0 / float(fps) if frame_time is None else float(frame_time)
        if not (math.isfinite(new_dt) and new_dt > 0.0):
            raise ModelError(f"Motion.resample: frame time must be positive, got {new_dt}")
        F = self.num_frames
        if F == 0:
            return self._replace(frame_time=new_dt)
        ratio = new_dt / self.frame_time
        n = int(math.floor((F - 1) / ratio + _FRAME_EPS)) + 1
        u = np.arange(n) * ratio              # new frame times, in old frame indices
        i0 = np.clip(np.floor(u + _FRAME_EPS).astype(np.int64), 0, F - 1)
        alpha = u - i0
        alpha[alpha < _FRAME_EPS] = 0.0
        i1 = np.minimum(i0 + 1, F - 1)
        a = alpha[:, None, None]
        rot = Q.qslerp(self.local_rotations[i0], self.local_rotations[i1], a)
        p0, p1 = self.local_positions[i0], self.local_positions[i1]
        pos = np.where(a == 0.0, p0, (1.0 - a) * p0 + a * p1)
        return self._replace(frame_time=new_dt, local_rotations=rot, local_positions=pos)

    def mirror(self, axis="x", left_right=None):
        """The motion reflected in a plane through the origin, left and right swapped.

        axis: the plane's normal, ``'x'``, ``'y'``, ``'z'`` or a 3-vector (world
        frame). ``'x'`` reflects x -> -x, the left/right plane of the course files.
        left_right: pairs ``(left_name, right_name)`` (or a dict) of joints to swap;
        by default pairs are found by name: prefixes ``l``/``r``, ``L``/``R`` (followed
        by a capital or separator), ``Left``/``Right``, ``left``/``right``, and
        suffixes ``_l``/``_r``, ``.L``/``.R`` and the like. The swap must map parents to
        parents. Joint world positions of the result are the reflections of those of
        the swapped joints; mirroring twice gives back the motion.
        """
        n = _mirror_normal(axis)
        perm = self._mirror_permutation(left_right)
        names = self.joint_names
        for j, k in enumerate(perm):
            p = self.parents[j]
            pk = self.parents[k]
            if (p < 0) != (pk < 0) or (p >= 0 and perm[p] != pk):
                raise ModelError(f"Motion.mirror: swapping '{names[j]}' with '{names[k]}' "
                                 "does not preserve the joint tree (their parents do not pair)")

        def reflect(v):
            return v - 2.0 * (v @ n)[..., None] * n

        # Reflection M = -(rotation by pi about n): M R M = qn R qn, with qn = (n, 0).
        # The minus sign keeps w unchanged for axis-aligned planes.
        qn = np.append(n, 0.0)
        rot = -Q.qmul(Q.qmul(qn, self.local_rotations[:, perm]), qn)
        return self._replace(offsets=reflect(self.offsets[perm]),
                             local_rotations=rot,
                             local_positions=reflect(self.local_positions[:, perm]))

    def _mirror_permutation(self, left_right):
        """(J,) ints: joint j of the mirrored motion takes its data from joint perm[j]."""
        names = self.joint_names
        perm = np.arange(self.num_joints)
        if left_right is None:
            for j, name in enumerate(names):
                other = _swap_side(name)
                if other is None:
                    continue
                if other not in self._index:
                    raise ModelError(f"Motion.mirror: joint '{name}' looks sided but there is "
                                     f"no '{other}'; pass left_right explicitly")
                perm[j] = self._index[other]
            return perm
        pairs = left_right.items() if isinstance(left_right, dict) else left_right
        for pair in pairs:
            a, b = pair
            ia, ib = self.index(a), self.index(b)
            perm[ia], perm[ib] = ib, ia
        return perm

    def remap(self, target):
        """The same motion with its joints in another order, matched by name.

        target: a list of joint names or another Motion (its ``joint_names``). Every
        name must exist here (ModelError lists the missing ones); joints not named
        are dropped, which is allowed only if no kept joint hangs below them.
        """
        order = list(target.joint_names if isinstance(target, Motion) else target)
        missing = [n for n in order if n not in self._index]
        if missing:
            raise ModelError(f"Motion.remap: joints not in this motion: {missing}")
        if len(set(order)) != len(order):
            raise ModelError("Motion.remap: target names are not unique")
        idx = np.array([self._index[n] for n in order], dtype=np.int64)
        new_of_old = {int(o): i for i, o in enumerate(idx)}
        parents = np.empty(len(idx), dtype=np.int64)
        for i, o in enumerate(idx):
            p = int(self.parents[o])
            if p >= 0 and p not in new_of_old:
                raise ModelError(f"Motion.remap: joint '{order[i]}' is kept but its parent "
                                 f"'{self.joint_names[p]}' is not")
            parents[i] = new_of_old[p] if p >= 0 else -1
        return Motion(joint_names=order, parents=parents, offsets=self.offsets[idx].copy(),
                      channels=[self.channels[o] for o in idx], frame_time=self.frame_time,
                      local_rotations=self.local_rotations[:, idx].copy(),
                      local_positions=self.local_positions[:, idx].copy())


def _as_float_array(value, shape, what):
    arr = np.array(value, dtype=np.float64)
    if arr.shape != shape:
        raise ModelError(f"Motion: {what} has shape {arr.shape}, expected {shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"Motion: {what} has non-finite values")
    return arr


def _check_channels(channels, where):
    rot = [c for c in channels if c in _ROT_CHANNELS]
    unknown = [c for c in channels if c not in _ROT_CHANNELS and c not in _POS_CHANNELS]
    if unknown:
        raise ModelError(f"{where}: unknown channel '{unknown[0]}'")
    if len(rot) > 3:
        raise ModelError(f"{where}: more than 3 rotation channels")
    pos = [c for c in channels if c in _POS_CHANNELS]
    if len(set(pos)) != len(pos):
        raise ModelError(f"{where}: repeated position channel")
    for a, b in zip(rot, rot[1:]):
        if a == b:
            raise ModelError(f"{where}: consecutive rotation channels about the same axis")


def _default_channels(names, parents, offsets, rot, pos, root):
    has_child = np.zeros(len(names), dtype=bool)
    has_child[parents[parents >= 0]] = True
    identity = np.array([0.0, 0.0, 0.0, 1.0])
    out = []
    for j in range(len(names)):
        moves = not np.allclose(pos[:, j], offsets[j], rtol=0.0, atol=1e-12)
        if j == root or moves:
            ch = ("Xposition", "Yposition", "Zposition")
        else:
            ch = ()
        turns = not np.allclose(np.abs(rot[:, j] @ identity), 1.0, rtol=0.0, atol=1e-12)
        if j == root or has_child[j] or turns or ch:
            ch = ch + ("Zrotation", "Yrotation", "Xrotation")
        out.append(ch)
    return out


_SIDE_PREFIXES = (("Left", "Right"), ("left", "right"), ("L", "R"), ("l", "r"))
_SIDE_SUFFIXES = (("Left", "Right"), ("left", "right"), ("L", "R"), ("l", "r"))


def _swap_side(name):
    """Name of the opposite-side joint, or None when ``name`` has no side marker.

    A prefix counts when followed by a capital or a separator, so 'lHip' and
    'Left_Arm' are sided but 'lowerback', 'Leg' and the vertebra 'L1' are not. End Sites ('lWrist_end')
    follow their joint. A suffix counts when preceded by a separator ('Hip_L', 'hip.r').
    """
    for left, right in _SIDE_PREFIXES:
        for a, b in ((left, right), (right, left)):
            rest = name[len(a):]
            if name.startswith(a) and rest and (rest[0].isupper() or rest[0] in "_.- "):
                return b + rest
    for left, right in _SIDE_SUFFIXES:
        for a, b in ((left, right), (right, left)):
            head = name[:-len(a)]
            if name.endswith(a) and len(head) > 1 and head[-1] in "_.- ":
                return head + b
    return None


def _mirror_normal(axis):
    if isinstance(axis, str):
        key = axis.lower()
        if key not in ("x", "y", "z"):
            raise ModelError(f"Motion.mirror: axis must be 'x', 'y', 'z' or a 3-vector, got '{axis}'")
        n = np.zeros(3)
        n[_AXES.index(key.upper())] = 1.0
        return n
    n = np.array(axis, dtype=np.float64).reshape(-1)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-12:
        raise ModelError(f"Motion.mirror: axis must be 'x', 'y', 'z' or a nonzero 3-vector, got {axis!r}")
    return n / np.linalg.norm(n)


# ----------------------------------------------------------------------------
# Parsing
# ----------------------------------------------------------------------------

class _Tokens:
    """Whitespace-separated tokens of the HIERARCHY section, with their line numbers."""

    def __init__(self, lines, start, stop, source, end_what):
        self.toks = []
        for lineno in range(start, stop):
            for tok in lines[lineno].split():
                self.toks.append((tok, lineno + 1))
        self.pos = 0
        self.source = source
        self.end_line = stop + 1  # 1-based number of the line after the section
        self.end_what = end_what  # what ends the section: 'MOTION' or end of file

    def error(self, line, message):
        return ModelError(f"{self.source} line {line}: {message}")

    def peek(self):
        return self.toks[self.pos] if self.pos < len(self.toks) else (None, self.end_line)

    def next(self, what):
        if self.pos >= len(self.toks):
            raise self.error(self.end_line, f"expected {what}, got {self.end_what}")
        tok = self.toks[self.pos]
        self.pos += 1
        return tok

    def expect(self, word):
        tok, line = self.next(f"'{word}'")
        if tok != word:
            raise self.error(line, f"expected '{word}', got '{tok}'")
        return line

    def number(self, what):
        tok, line = self.next(what)
        try:
            value = float(tok)
        except ValueError:
            raise self.error(line, f"expected a number for {what}, got '{tok}'") from None
        if not math.isfinite(value):
            raise self.error(line, f"{what} is not finite ('{tok}')")
        if abs(value) > MAX_VALUE:
            raise self.error(line, f"{what} is {tok}, beyond the +-{MAX_VALUE:g} tumble reads "
                                   f"(tumble.io.bvh.MAX_VALUE)")
        return value


def _parse_hierarchy(toks, names, parents, offsets, channels):
    """Fill the joint lists from the tokens, in file (depth-first) order."""
    toks.expect("HIERARCHY")
    tok, line = toks.peek()
    if tok != "ROOT":
        raise toks.error(line, f"expected 'ROOT', got '{tok}'" if tok else
                         f"expected 'ROOT', got {toks.end_what}")
    toks.next("'ROOT'")
    name, line = toks.next("the root joint name")
    _parse_joints(toks, name, line, names, parents, offsets, channels)
    tok, line = toks.peek()
    if tok == "ROOT":
        raise toks.error(line, "a second ROOT: files with several skeletons are not supported")
    if tok is not None:
        raise toks.error(line, f"expected 'MOTION', got '{tok}'")


def _count(tok):
    """The int of a count written with the ASCII digits 0-9, else None (``str.isdigit``
    also accepts superscripts and other digits that ``int`` refuses)."""
    return int(tok) if tok and tok.isascii() and tok.isdigit() else None


def _parse_joints(toks, root_name, root_line, names, parents, offsets, channels):
    """The joint tree from the root's name on, depth first with an explicit stack of the
    open joints (no recursion: nesting up to ``MAX_DEPTH``)."""
    known = set()
    open_joints = []            # [index, name, End Sites so far, CHANNELS seen]

    def start(name, name_line, parent):
        if name in known:
            raise toks.error(name_line, f"duplicate joint name '{name}'")
        if len(open_joints) >= MAX_DEPTH:
            raise toks.error(name_line, f"joint '{name}' is nested more than {MAX_DEPTH} deep, "
                                        f"the most tumble reads (tumble.io.bvh.MAX_DEPTH)")
        toks.expect("{")
        open_joints.append([len(names), name, 0, False])
        known.add(name)
        names.append(name)
        parents.append(parent)
        offsets.append(None)
        channels.append(())

    start(root_name, root_line, -1)
    while open_joints:
        frame = open_joints[-1]
        j, name = frame[0], frame[1]
        tok, line = toks.next(f"'}}' closing joint '{name}'")
        if tok == "}":
            if offsets[j] is None:
                raise toks.error(line, f"joint '{name}' has no OFFSET")
            open_joints.pop()
        elif tok == "OFFSET":
            if offsets[j] is not None:
                raise toks.error(line, f"second OFFSET in joint '{name}'")
            offsets[j] = [toks.number(f"OFFSET of '{name}'") for _ in range(3)]
        elif tok == "CHANNELS":
            if frame[3]:
                raise toks.error(line, f"second CHANNELS in joint '{name}'")
            frame[3] = True
            count_tok, cline = toks.next("the channel count")
            count = _count(count_tok)
            if count is None:
                raise toks.error(cline, f"expected a channel count, got '{count_tok}'")
            if count > 6:
                raise toks.error(cline, f"joint '{name}' has {count} channels; a joint has at "
                                        f"most 6 (3 positions, 3 rotations)")
            ch = []
            for _ in range(count):
                c, cl = toks.next(f"a channel name of '{name}'")
                if c not in _ROT_CHANNELS and c not in _POS_CHANNELS:
                    raise toks.error(cl, f"unknown channel '{c}' in joint '{name}'")
                ch.append(c)
            try:
                _check_channels(ch, f"joint '{name}'")
            except ModelError as exc:
                raise toks.error(cline, str(exc)) from None
            channels[j] = tuple(ch)
        elif tok == "JOINT":
            if offsets[j] is None:
                raise toks.error(line, f"expected 'OFFSET' in joint '{name}', got 'JOINT'")
            child, cline = toks.next("a joint name")
            start(child, cline, j)
        elif tok == "End":
            toks.expect("Site")
            if offsets[j] is None:
                raise toks.error(line, f"expected 'OFFSET' in joint '{name}', got 'End Site'")
            site = f"{name}_end" if frame[2] == 0 else f"{name}_end{frame[2]}"
            frame[2] += 1
            toks.expect("{")
            sline = toks.expect("OFFSET")
            if site in known:
                raise toks.error(sline, f"End Site name '{site}' clashes with a joint")
            known.add(site)
            names.append(site)
            parents.append(j)
            offsets.append([toks.number(f"OFFSET of the End Site of '{name}'") for _ in range(3)])
            channels.append(())
            toks.expect("}")
        else:
            expected = "'OFFSET'" if offsets[j] is None else "'CHANNELS', 'JOINT', 'End Site' or '}'"
            raise toks.error(line, f"expected {expected} in joint '{name}', got '{tok}'")


_HEADER_RE = {
    "Frames": re.compile(r"^Frames:\s*(\S*)\s*$"),
    "Frame Time": re.compile(r"^Frame\s+Time:\s*(\S*)\s*$"),
}


def _parse(text, source, scale):
    lines = text.splitlines()
    motion_line = None
    for i, line in enumerate(lines):
        if line.strip() == "MOTION":
            motion_line = i
            break
    # Without MOTION the hierarchy runs to the end of the file: a cut-off hierarchy
    # is then reported where it breaks, a complete one as missing MOTION.
    stop = len(lines) if motion_line is None else motion_line
    toks = _Tokens(lines, 0, stop, source, "end of file" if motion_line is None else "'MOTION'")
    names, parents, offsets, channels = [], [], [], []
    _parse_hierarchy(toks, names, parents, offsets, channels)
    if motion_line is None:
        raise ModelError(f"{source} line {len(lines) + 1}: expected 'MOTION', got end of file")

    # Header lines after MOTION, skipping blank lines.
    cursor = motion_line + 1

    def header(key):
        nonlocal cursor
        while cursor < len(lines) and not lines[cursor].strip():
            cursor += 1
        if cursor >= len(lines):
            raise ModelError(f"{source} line {cursor + 1}: expected '{key}:', got end of file")
        m = _HEADER_RE[key].match(lines[cursor].strip())
        if m is None:
            raise ModelError(f"{source} line {cursor + 1}: expected '{key}: <value>', "
                             f"got '{lines[cursor].strip()}'")
        cursor += 1
        return m.group(1), cursor

    value, line = header("Frames")
    num_frames = _count(value)
    if num_frames is None:
        raise ModelError(f"{source} line {line}: expected a frame count, got '{value}'")
    value, line = header("Frame Time")
    try:
        frame_time = float(value)
    except ValueError:
        raise ModelError(f"{source} line {line}: expected a frame time, got '{value}'") from None
    if not (math.isfinite(frame_time) and frame_time > 0.0):
        raise ModelError(f"{source} line {line}: frame time must be positive, got '{value}'")

    # Frame lines: exactly one per frame, each with every channel value.
    width = sum(len(c) for c in channels)
    rows, row_lines = [], []
    for i in range(cursor, len(lines)):
        fields = lines[i].split()
        if not fields:
            continue
        if len(rows) == num_frames:
            raise ModelError(f"{source} line {i + 1}: more frame lines than 'Frames: {num_frames}'")
        if len(fields) != width:
            raise ModelError(f"{source} line {i + 1}: frame {len(rows)} has {len(fields)} values, "
                             f"expected {width} (one per channel)")
        rows.append(fields)
        row_lines.append(i + 1)
    if len(rows) < num_frames:
        raise ModelError(f"{source} line {len(lines) + 1}: file ends after {len(rows)} frames, "
                         f"'Frames: {num_frames}' announced")
    try:
        data = np.array(rows, dtype=np.float64).reshape(num_frames, width)
    except ValueError:
        # Find the culprit only on failure, to keep the common path vectorised.
        for fields, line in zip(rows, row_lines):
            for tok in fields:
                try:
                    float(tok)
                except ValueError:
                    raise ModelError(f"{source} line {line}: expected a number, got '{tok}'") from None
        raise ModelError(f"{source}: the frame lines are not numbers") from None
    bad = ~(np.abs(data) <= MAX_VALUE)          # non-finite, or beyond the bound
    if bad.any():
        f, col = (int(i) for i in np.argwhere(bad)[0])
        owner = [(names[j], c) for j, ch in enumerate(channels) for c in ch][col]
        what = f"{owner[1]} of joint '{owner[0]}' in frame {f}"
        v = data[f, col]
        raise ModelError(f"{source} line {row_lines[f]}: non-finite channel value: {what} is "
                         f"'{rows[f][col]}'"
                         if not math.isfinite(v) else
                         f"{source} line {row_lines[f]}: {what} is {rows[f][col]}, beyond the "
                         f"+-{MAX_VALUE:g} tumble reads (tumble.io.bvh.MAX_VALUE)")

    J = len(names)
    # every joint position is a sum of offsets (or position channels) along its chain
    reach = (float(np.abs(offsets).sum()) + float(np.abs(data).max(initial=0.0))) * scale
    if not math.isfinite(reach):
        raise ModelError(f"{source}: scale {scale:g} makes the joint positions overflow")
    offsets = np.array(offsets, dtype=np.float64) * scale
    positions = np.broadcast_to(offsets, (num_frames, J, 3)).copy()
    rotations = np.zeros((num_frames, J, 4))
    rotations[..., 3] = 1.0
    col = 0
    for j, ch in enumerate(channels):
        rot_cols, order = [], ""
        for c in ch:
            if c in _POS_CHANNELS:
                positions[:, j, _POS_CHANNELS[c]] = data[:, col] * scale
            else:
                rot_cols.append(col)
                order += _AXES[_ROT_CHANNELS[c]]
            col += 1
        if order and num_frames:
            # Uppercase axes: intrinsic rotations, in the order the channels are listed.
            rotations[:, j] = Rotation.from_euler(order, data[:, rot_cols], degrees=True).as_quat()
    return Motion(names, np.array(parents, dtype=np.int64), offsets, channels, frame_time,
                  rotations, positions)


def load_bvh_string(text, scale=1.0, *, source="<string>"):
    """Parse BVH text into a :class:`Motion`; ``source`` names it in error messages.

    scale multiplies offsets and position channels (e.g. 0.01 for cm -> m).
    """
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ModelError(f"load_bvh: scale must be a positive number, got {scale!r}") from None
    if not (math.isfinite(scale) and scale > 0.0):
        raise ModelError(f"load_bvh: scale must be a positive number, got {scale}")
    if isinstance(text, (bytes, bytearray)):
        text = bytes(text).decode("utf-8-sig", errors="replace")
    if not isinstance(text, str):
        raise ModelError(f"load_bvh: expected BVH text, got {type(text).__name__}")
    return _parse(text, source, scale)


def load_bvh(path, scale=1.0):
    """Read a BVH file into a :class:`Motion`.

    path: a file path (str or Path), or a str holding BVH text itself (detected
    by its starting with 'HIERARCHY'). scale: multiplies every length, offsets and
    position channels alike (0.01 turns centimetres into metres); the default
    keeps the file's units (metres for the GAMES-105 files).
    Raises ModelError with the file name and line number for malformed files, and for a
    file that cannot be read (a directory, larger than ``MAX_FILE_BYTES``, ...); a missing
    file raises ``tumble.io.MissingFileError``, both a ModelError and a FileNotFoundError.
    """
    if isinstance(path, str) and path.lstrip().startswith("HIERARCHY"):
        return load_bvh_string(path, scale)
    p = file_path(path, "load_bvh")
    data = read_file(p, "load_bvh", MAX_FILE_BYTES, cap_name="tumble.io.bvh.MAX_FILE_BYTES")
    text = data.decode("utf-8-sig", errors="replace")
    return load_bvh_string(text, scale, source=Path(p).name)


# ----------------------------------------------------------------------------
# Writing
# ----------------------------------------------------------------------------

def _euler_from_quat(order, quat, name):
    """Angles (F, len(order)) in degrees of intrinsic Euler ``order`` giving ``quat``.

    Orders with fewer than three axes are completed with the missing ones, whose
    angles must then be zero (else the rotation cannot be written with those channels).
    """
    full = (order + "".join(a for a in _AXES if a not in order))[:3]
    with warnings.catch_warnings():
        # At gimbal lock scipy picks one of the equivalent angle sets; within 1e-7 rad
        # of it, it treats the rotation as locked, which costs up to ~1e-7 rad.
        warnings.simplefilter("ignore", UserWarning)
        angles = Rotation.from_quat(quat).as_euler(full, degrees=True)
    if len(order) < 3:
        extra = angles[:, len(order):]
        if np.any(np.abs(extra) > 1e-6):
            raise ModelError(f"save_bvh: joint '{name}' rotates about axes its channels "
                             f"({order}) do not have")
    return angles[:, :len(order)]


def format_bvh(motion, scale=1.0, precision=12):
    """BVH text of ``motion``; lengths multiplied by ``scale`` on the way out.

    Joints are written depth-first from the root, children in index order, which
    is the motion's order whenever it came from a file. Channel values use
    ``precision`` significant digits. Leaves without channels become End Sites
    (reloaded as '<parent>_end').
    """
    names, parents, channels = motion.joint_names, motion.parents, motion.channels
    J = motion.num_joints
    children = [[] for _ in range(J)]
    for j, p in enumerate(parents):
        if p >= 0:
            children[p].append(j)
    fmt = f"{{:.{int(precision)}g}}"
    out = ["HIERARCHY"]
    order = []          # joints with channels, in the order their columns are written

    def offset_line(j, indent):
        x, y, z = (fmt.format(v * scale) for v in motion.offsets[j])
        return f"{indent}OFFSET {x} {y} {z}"

    # depth first with an explicit stack (no recursion, so any depth works): entries are
    # (joint, depth) to write a joint, (None, depth) to close one
    stack = [(motion.root, 0)]
    while stack:
        j, depth = stack.pop()
        indent = "  " * depth
        if j is None:
            out.append(f"{indent}}}")
            continue
        is_site = not channels[j] and not children[j]
        if is_site:
            if parents[j] < 0:
                raise ModelError(f"save_bvh: root '{names[j]}' has no channels and no children")
            out.extend([f"{indent}End Site", f"{indent}{{", offset_line(j, indent + "  "),
                        f"{indent}}}"])
            continue
        head = "ROOT" if parents[j] < 0 else "JOINT"
        if any(c.isspace() for c in names[j]) or not names[j]:
            raise ModelError(f"save_bvh: joint name '{names[j]}' cannot be written in BVH")
        out.extend([f"{indent}{head} {names[j]}", f"{indent}{{", offset_line(j, indent + "  ")])
        out.append(f"{indent}  CHANNELS {len(channels[j])}" +
                   "".join(" " + c for c in channels[j]))
        order.append(j)
        stack.append((None, depth))
        stack.extend((c, depth + 1) for c in reversed(children[j]))

    F = motion.num_frames
    columns = []
    for j in order:
        ch = channels[j]
        rot_order = "".join(_AXES[_ROT_CHANNELS[c]] for c in ch if c in _ROT_CHANNELS)
        pos = motion.local_positions[:, j]
        if rot_order:
            angles = _euler_from_quat(rot_order, motion.local_rotations[:, j], names[j])
        elif F and not np.allclose(np.abs(motion.local_rotations[:, j, 3]), 1.0, atol=1e-9):
            raise ModelError(f"save_bvh: joint '{names[j]}' rotates but has no rotation channels")
        # Position components without a channel come from the offset on reload.
        for axis in range(3):
            if _AXES[axis] + "position" not in ch and not np.allclose(
                    pos[:, axis], motion.offsets[j, axis], rtol=1e-9, atol=1e-9):
                raise ModelError(f"save_bvh: joint '{names[j]}' moves along {_AXES[axis]} "
                                 "but has no position channel for it")
        r = 0
        for c in ch:
            if c in _POS_CHANNELS:
                columns.append(pos[:, _POS_CHANNELS[c]] * scale)
            else:
                columns.append(angles[:, r])
                r += 1
    out.append("MOTION")
    out.append(f"Frames: {F}")
    out.append(f"Frame Time: {motion.frame_time!r}")
    data = np.stack(columns, axis=1) if columns else np.zeros((F, 0))
    row_fmt = " ".join([fmt] * data.shape[1])
    out.extend(row_fmt.format(*row) for row in data.tolist())
    return "\n".join(out) + "\n"


def save_bvh(motion, path, scale=1.0, precision=12):
    """Write ``motion`` to a BVH file at ``path`` (see :func:`format_bvh`).

    Rotations are written as Euler angles in each joint's channel order, so a
    reload gives the same rotations (up to quaternion sign) and positions to about
    ``10**-precision`` relative.
    """
    text = format_bvh(motion, scale=scale, precision=precision)
    write_text(path, text, "save_bvh")
