"""Learned control: DeepMimic-style imitation on batched worlds (``pip install "tumble[rl]"``).

    ImitationEnv          N characters imitating a clip, observed and rewarded as arrays
    ReferenceMotion       a clip on a ragdoll: reference states at any time (looped cycles)
    BatchedEnv            the observe -> act -> step -> reward -> reset loop tasks share
    ActionError           a refused action (wrong shape, not finite)

Importing this package registers the Gymnasium environment ``tumble/Imitate-v0`` when
Gymnasium is installed (``tumble.rl.gym``). Training (``tumble.rl.train``) needs PyTorch
and rsl-rl; nothing here imports them.
"""
from .env import ActionError, BatchedEnv
from .reference import ReferenceMotion, cycle_end_frame
from .tasks.imitation import ImitationEnv, deepmimic_gains

try:
    import gymnasium as _gymnasium
except ImportError:                    # the core install has no Gymnasium
    _gymnasium = None
if _gymnasium is not None:
    from .gym import register_envs

    register_envs()

__all__ = ["ImitationEnv", "ReferenceMotion", "BatchedEnv", "ActionError", "cycle_end_frame",
           "deepmimic_gains"]
