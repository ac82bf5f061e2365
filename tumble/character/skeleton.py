"""Skeletons: a joint tree in its rest pose, from a BVH motion or the course character file.

A :class:`Skeleton` is what the ragdoll builder needs of a character: joint names, parents
and the world position of every joint in the *rest pose*, the pose in which every joint
rotation is the identity (a T-pose for the course files). Positions are in metres (or the
motion's units), world frame; ``up`` is the unit vector pointing up (Y for BVH files).

:func:`load_character_model` reads the GAMES-105 ``character_model.npy``; the copy shipped
with tumble is at :func:`games105_character_path`.
"""
import pickle
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import ModelError
from ..io.bvh import Motion
from ..model.tree import check_tree, tree_order

__all__ = ["Skeleton", "CharacterModel", "load_character_model", "games105_character_path"]

_UP = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def up_vector(up, where):
    """``'x'``, ``'y'``, ``'z'`` or a nonzero 3-vector -> unit (3,) vector."""
    if isinstance(up, str):
        if up.lower() not in _UP:
            raise ModelError(f"{where}: up must be 'x', 'y', 'z' or a 3-vector, got {up!r}")
        return np.array(_UP[up.lower()])
    v = np.array(up, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-12:
        raise ModelError(f"{where}: up must be 'x', 'y', 'z' or a nonzero 3-vector, got {up!r}")
    return v / np.linalg.norm(v)


class Skeleton:
    """A joint tree in its rest pose.

    Attributes: ``joint_names`` list of J unique names; ``parents`` (J,) int, -1 for the
    single root; ``rest_positions`` (J, 3) joint origins in the world in the rest pose (every
    joint rotation the identity), m; ``up`` (3,) unit up vector (world frame).
    Derived: ``offsets`` (J, 3) each joint's origin relative to its parent's in the rest pose
    (the root's is its position), ``root`` index, ``children(j)``, ``index(name)``.
    """

    def __init__(self, joint_names, parents, rest_positions, up="y"):
        where = "Skeleton"
        names, parents = check_tree(joint_names, parents, where)
        J = len(names)
        pos = np.array(rest_positions, dtype=np.float64)
        if pos.shape != (J, 3):
            raise ModelError(f"{where}: rest_positions has shape {pos.shape}, expected ({J}, 3)")
        if not np.all(np.isfinite(pos)):
            j = int(np.argwhere(~np.isfinite(pos))[0, 0])
            raise ModelError(f"{where}: rest_positions of joint '{names[j]}' is not finite")
        self.joint_names = names
        self.parents = parents
        self.rest_positions = pos
        self.up = up_vector(up, where)
        self._index = {n: i for i, n in enumerate(names)}
        self.order, self._children = tree_order(parents, names, where)
        self.parents.setflags(write=False)
        self.rest_positions.setflags(write=False)

    @classmethod
    def from_motion(cls, motion, root_position=None, up="y"):
        """The rest pose of a :class:`~tumble.Motion`: offsets chained with identity rotations.

        root_position : (3,) world position of the root in the rest pose; default the
            root's offset (for BVH files usually zero: pass a height, or let the ragdoll
            builder place the skeleton on the ground).
        """
        if not isinstance(motion, Motion):
            raise ModelError(f"Skeleton.from_motion needs a tumble Motion, got "
                             f"{type(motion).__name__}")
        offsets = motion.offsets.copy()
        if root_position is not None:
            rp = np.array(root_position, dtype=float).reshape(-1)
            if rp.shape != (3,) or not np.all(np.isfinite(rp)):
                raise ModelError(f"Skeleton.from_motion: root_position must be 3 finite "
                                 f"numbers, got {root_position!r}")
            offsets[motion.root] = rp
        # Chain the offsets parents-first: a skeleton with zero positions gives the order.
        order = cls(motion.joint_names, motion.parents, np.zeros_like(offsets), up=up).order
        pos = np.zeros_like(offsets)
        for j in order:
            p = motion.parents[j]
            pos[j] = offsets[j] if p < 0 else pos[p] + offsets[j]
        return cls(motion.joint_names, motion.parents, pos, up=up)

    # ------------------------------------------------------------ properties
    @property
    def num_joints(self):
        return len(self.joint_names)

    @property
    def root(self):
        """Index of the root joint."""
        return int(np.flatnonzero(self.parents == -1)[0])

    @property
    def offsets(self):
        """(J, 3) rest-pose offset of every joint from its parent (the root: its position)."""
        par = np.where(self.parents < 0, 0, self.parents)
        out = self.rest_positions - self.rest_positions[par]
        out[self.root] = self.rest_positions[self.root]
        return out

    def index(self, name):
        """Index of joint ``name``; ModelError naming it (and the known joints) if absent."""
        try:
            return self._index[name]
        except KeyError:
            raise ModelError(f"Skeleton: no joint named {name!r}; joints are "
                             f"{self.joint_names}") from None

    def children(self, j):
        """Indices of the children of joint ``j`` (index or name), in index order."""
        j = self.index(j) if isinstance(j, str) else int(j)
        return list(self._children[j])

    def __repr__(self):
        return f"Skeleton({self.num_joints} joints, root '{self.joint_names[self.root]}')"


@dataclass(frozen=True)
class CharacterModel:
    """The contents of a course ``character_model.npy``.

    skeleton : :class:`Skeleton` of all joints (end sites included), T-pose, Y up, m.
    body_pos : (nbody, 3) world centre of the body driven by joint i, for i < nbody.
    """
    skeleton: Skeleton
    body_pos: np.ndarray

    @property
    def nbody(self):
        return len(self.body_pos)


def games105_character_path():
    """Path of the GAMES-105 ``character_model.npy`` shipped with tumble (BSD 3-Clause,
    LICENSE beside it)."""
    return Path(str(resources.files("tumble.data.games105").joinpath("character_model.npy")))


def load_character_model(path=None):
    """Read a course character file (``character_model.npy``) into a :class:`CharacterModel`.

    path : file path, or a dict with the file's keys; default the GAMES-105 character
        shipped with tumble. The file is a pickled dict, so only load files you trust.
    Keys: ``joint_name`` (J,) names, ``joint_pos`` (J, 3) T-pose world positions (m),
    ``body_pos`` (nbody, 3) body centres of joints 0..nbody-1, ``parent`` (J,) parent
    indices (-1 for the root). Raises ModelError naming the file and the key for a
    malformed file, FileNotFoundError for a missing one.
    """
    if isinstance(path, dict):
        data, source = path, "character model"
    else:
        p = games105_character_path() if path is None else Path(path)
        source = p.name
        try:
            raw = np.load(p, allow_pickle=True)
        except (ValueError, OSError, EOFError, pickle.UnpicklingError) as exc:
            if isinstance(exc, FileNotFoundError):
                raise
            raise ModelError(f"{source}: not a NumPy .npy file ({exc})") from None
        if not (isinstance(raw, np.ndarray) and raw.dtype == object and raw.shape == ()):
            raise ModelError(f"{source}: expected a pickled dict, got an array of shape "
                             f"{getattr(raw, 'shape', None)}")
        data = raw.item()
        if not isinstance(data, dict):
            raise ModelError(f"{source}: expected a pickled dict, got {type(data).__name__}")
    missing = [k for k in ("joint_name", "joint_pos", "body_pos", "parent") if k not in data]
    if missing:
        raise ModelError(f"{source}: missing keys {missing}")
    names = [str(n) for n in np.asarray(data["joint_name"]).reshape(-1)]
    J = len(names)

    def arr(key, shape, dtype=float):
        try:
            a = np.array(data[key], dtype=dtype)
        except (TypeError, ValueError):
            raise ModelError(f"{source}: {key} is not numeric") from None
        if a.shape != shape:
            raise ModelError(f"{source}: {key} has shape {a.shape}, expected {shape}")
        if dtype is float and not np.all(np.isfinite(a)):
            raise ModelError(f"{source}: {key} has non-finite values")
        return a

    joint_pos = arr("joint_pos", (J, 3))
    parent = arr("parent", (J,), np.int64)
    body_pos = np.array(data["body_pos"], dtype=float) if np.ndim(data["body_pos"]) else None
    if body_pos is None or body_pos.ndim != 2 or body_pos.shape[1] != 3 or \
            not 0 < body_pos.shape[0] <= J:
        raise ModelError(f"{source}: body_pos has shape {np.shape(data['body_pos'])}, expected "
                         f"(nbody, 3) with 0 < nbody <= {J}")
    if not np.all(np.isfinite(body_pos)):
        raise ModelError(f"{source}: body_pos has non-finite values")
    try:
        skeleton = Skeleton(names, parent, joint_pos, up="y")
    except ModelError as exc:
        raise ModelError(f"{source}: {exc}") from None
    nb = body_pos.shape[0]
    # Bodies belong to joints 0..nbody-1, so a body's parent joint must have one too.
    for i in range(nb):
        if parent[i] >= nb:
            raise ModelError(f"{source}: joint '{names[i]}' owns body {i} but its parent "
                             f"'{names[parent[i]]}' has no body (parents must come first)")
    body_pos.setflags(write=False)
    return CharacterModel(skeleton, body_pos)
