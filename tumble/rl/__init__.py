"""Learned control on batched worlds: DeepMimic-style imitation and AMP steering
(``pip install "tumble[rl]"``).

    ImitationEnv          N characters imitating a clip, observed and rewarded as arrays
    AMPEnv                N characters steered by heading and speed in the style of clips
    ReferenceMotion       a clip on a ragdoll: reference states at any time (looped cycles)
    BatchedEnv            the observe -> act -> step -> reward -> reset loop tasks share
    ActionError           a refused action (wrong shape, not finite)

Importing this package registers the Gymnasium environments ``tumble/Imitate-v0`` and
``tumble/Steer-v0`` when Gymnasium is installed (``tumble.rl.gym``). Training (``tumble.rl.train``) needs PyTorch
and rsl-rl; nothing here imports them.
"""
from .env import ActionError, BatchedEnv
from .reference import ReferenceMotion, cycle_end_frame
from .tasks.amp import AMPEnv
from .tasks.imitation import ImitationEnv, deepmimic_gains

try:
    import gymnasium as _gymnasium
except ImportError:                    # the core install has no Gymnasium
    _gymnasium = None
if _gymnasium is not None:
    from .gym import register_envs

    register_envs()

__all__ = ["ImitationEnv", "AMPEnv", "ReferenceMotion", "BatchedEnv", "ActionError", "cycle_end_frame",
           "deepmimic_gains"]
