"""tumble: rigid-body dynamics for physics-based character animation, compiled with Numba.

The public API (see the README and DESIGN notes):

    ModelBuilder, Model   build and validate a model
    World, State          step it and read or set its state
    load_bvh, Motion      motion capture in (and save_bvh out)
    Recorder, Recording   record a run, save/load it (.npz); tumble.viewer views and exports
    ModelError, StateError, SimulationError, TumbleError
"""
from ._cache import invalidate_stale_kernels

invalidate_stale_kernels()

from .errors import ModelError, SimulationError, StateError, TumbleError
from .io import Motion, load_bvh, load_bvh_string, save_bvh
from .model import Model, ModelBuilder
from .world import State, World
from .viewer.recorder import Recorder, Recording

__version__ = "0.1.0"

del invalidate_stale_kernels

__all__ = ["ModelBuilder", "Model", "World", "State", "Motion", "load_bvh", "load_bvh_string",
           "save_bvh", "Recorder", "Recording",
           "TumbleError", "ModelError", "StateError", "SimulationError", "__version__"]
