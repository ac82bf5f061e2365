"""The character layer: skeletons, ragdolls built from them, and pose transfer.

    Skeleton, load_character_model, games105_character_path    skeletons in their rest pose
    Ragdoll, build_ragdoll, ragdoll_from_motion, games105_ragdoll   ragdoll models + mapping
    set_pose, get_pose, joint_targets, rest_alignment, Pose    motion <-> world poses
    PDController, pd_torques, apply_joint_torques             joint PD (in-step or NumPy)
    HandOfGod, jacobian_transpose_torques, StaticBalance, Push, center_of_mass   balance
    MotionTracker, TrackingResult                             tracking motion capture
    SimbiconController, BipedMap                              SIMBICON walking
    Gait, GaitState, load_gait, gait_names                    its gait files
    run_walk, WalkResult                                      measured walks
    Flat, Slope, Heightfield (terrain)                        ground to walk on
"""
from .pose import Pose, get_pose, joint_targets, rest_alignment, set_pose
from .ragdoll import (GAMES105_BOX_SCALES, Ragdoll, build_ragdoll, games105_ragdoll,
                      ragdoll_from_motion)
from .balance import (HandOfGod, Push, StaticBalance, center_of_mass, chain_to_root,
                      jacobian_transpose_torques)
from .pd import PDController, apply_joint_torques, pd_torques, targets_from_quats
from .tracking import MotionTracker, TrackingResult
from .gait_files import Gait, GaitState, gait_names, load_gait
from .simbicon import BipedMap, SimbiconController
from .walk import WalkResult, run_walk
from .terrain import Flat, Heightfield, Slope, Terrain
from .skeleton import CharacterModel, Skeleton, games105_character_path, load_character_model

__all__ = ["Skeleton", "CharacterModel", "load_character_model", "games105_character_path",
           "Ragdoll", "build_ragdoll", "ragdoll_from_motion", "games105_ragdoll",
           "GAMES105_BOX_SCALES", "Pose", "set_pose", "get_pose", "joint_targets",
           "rest_alignment", "PDController", "pd_torques", "apply_joint_torques",
           "targets_from_quats", "HandOfGod", "StaticBalance", "center_of_mass",
           "chain_to_root", "jacobian_transpose_torques", "Push", "MotionTracker", "TrackingResult",
           "SimbiconController", "Gait", "GaitState", "load_gait", "gait_names", "run_walk",
           "WalkResult", "BipedMap", "Terrain", "Flat", "Slope", "Heightfield"]
