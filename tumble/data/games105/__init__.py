"""The GAMES-105 course reference character and motion clips (BSD 3-Clause, see LICENSE).

``character_model.npy`` is the character (``tumble.games105_ragdoll`` builds it); the BVH
clips are the course's: ``walk`` (walk_forward.bvh, one walking cycle, 100 frames at
100 fps), ``run`` (run_forward.bvh, 45 frames at 60 fps) and ``idle`` (idle.bvh, 200 frames
at 60 fps).
"""
from pathlib import Path

from ...errors import ModelError

CLIPS = {"walk": "walk_forward.bvh", "run": "run_forward.bvh", "idle": "idle.bvh"}


def clip_path(name):
    """Path of the course clip ``name`` ('walk', 'run' or 'idle')."""
    if name not in CLIPS:
        raise ModelError(f"games105 clip: unknown clip {name!r}; the course ships "
                         f"{sorted(CLIPS)}")
    return Path(__file__).with_name(CLIPS[name])
