"""The character layer: skeletons, ragdolls built from them, and pose transfer.

    Skeleton, load_character_model, games105_character_path    skeletons in their rest pose
    Ragdoll, build_ragdoll, ragdoll_from_motion, games105_ragdoll   ragdoll models + mapping
    set_pose, get_pose, joint_targets, rest_alignment, Pose    motion <-> world poses
"""
from .pose import Pose, get_pose, joint_targets, rest_alignment, set_pose
from .ragdoll import (GAMES105_BOX_SCALES, Ragdoll, build_ragdoll, games105_ragdoll,
                      ragdoll_from_motion)
from .skeleton import CharacterModel, Skeleton, games105_character_path, load_character_model

__all__ = ["Skeleton", "CharacterModel", "load_character_model", "games105_character_path",
           "Ragdoll", "build_ragdoll", "ragdoll_from_motion", "games105_ragdoll",
           "GAMES105_BOX_SCALES", "Pose", "set_pose", "get_pose", "joint_targets",
           "rest_alignment"]
