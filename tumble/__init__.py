"""tumble: rigid-body dynamics for physics-based character animation, compiled with Numba.

The public API (see the README; ARCHITECTURE.md draws how a step runs):

    ModelBuilder, Model   build and validate a model
    World, State          step it and read or set its state
    load_bvh, Motion      motion capture in (and save_bvh out)
    load_mjcf, load_urdf  MuJoCo MJCF and URDF model files in
    ragdoll_from_motion, games105_ragdoll, build_ragdoll, Ragdoll, Skeleton,
    load_character_model  ragdolls from skeletons (tumble.character)
    set_pose, get_pose, joint_targets, Pose   motion frames <-> world poses
    PDController, HandOfGod, StaticBalance, MotionTracker   character control
    SimbiconController, load_gait, run_walk   SIMBICON walking (tumble.character.simbicon)
    Recorder, Recording   record a run, save/load it (.npz); tumble.viewer views and exports
    ModelError, StateError, SimulationError, TumbleError
"""
from ._cache import invalidate_stale_kernels

invalidate_stale_kernels()

from .errors import ModelError, SimulationError, StateError, TumbleError
from .io import Motion, load_bvh, load_bvh_string, load_mjcf, load_urdf, save_bvh
from .model import Model, ModelBuilder
from .world import State, World
from .character import (HandOfGod, MotionTracker, PDController, Pose, Ragdoll,
                        SimbiconController, Skeleton, StaticBalance, build_ragdoll,
                        games105_ragdoll, get_pose, joint_targets, load_character_model,
                        load_gait, ragdoll_from_motion, run_walk, set_pose)

__version__ = "0.1.0"


def __getattr__(name):
    # The recorder sits in the viewer layer, above World: it is imported when first asked
    # for, so that ``import tumble`` loads no viewer module.
    if name in ("Recorder", "Recording"):
        from .viewer import recorder
        return getattr(recorder, name)
    raise AttributeError(f"module 'tumble' has no attribute {name!r}")

del invalidate_stale_kernels

__all__ = ["ModelBuilder", "Model", "World", "State", "Motion", "load_bvh", "load_bvh_string",
           "save_bvh", "load_mjcf", "load_urdf",
           "Skeleton", "Ragdoll", "build_ragdoll", "ragdoll_from_motion", "games105_ragdoll",
           "load_character_model", "Pose", "set_pose", "get_pose", "joint_targets",
           "PDController", "HandOfGod", "StaticBalance", "MotionTracker", "Recorder",
           "Recording", "SimbiconController", "load_gait", "run_walk",
           "TumbleError", "ModelError", "StateError", "SimulationError", "__version__"]
