"""Pose transfer (tumble/character/pose.py): motion frames into worlds and back.

Course files: tests/data/games105 (GAMES-105, BSD 3-Clause). Round trips go through products
of a few dozen unit quaternions, so they are checked to 1e-12; finite-difference velocities
against an independent computation to 1e-9 (rad/s) and, where the course file's single-
precision bones (4e-7 m off the BVH offsets) enter, to 1e-4 m/s.
"""
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import tumble
from tumble.math import quat_np as Q
from tumble.character import get_pose, joint_targets, rest_alignment, set_pose

DATA = Path(__file__).resolve().parent.parent / "data" / "games105"


@pytest.fixture(scope="module")
def walk():
    return tumble.load_bvh(DATA / "walk_forward.bvh")


@pytest.fixture(scope="module")
def run():
    return tumble.load_bvh(DATA / "run_forward.bvh")


@pytest.fixture(scope="module")
def floating():
    return tumble.games105_ragdoll("floating")


@pytest.fixture(scope="module")
def world(floating):
    return floating.make_world()


def quat_err(a, b):
    """Largest component difference of two quaternion arrays, up to the sign of each."""
    a, b = np.asarray(a), np.asarray(b)
    return float(np.minimum(np.abs(a - b).max(-1), np.abs(a + b).max(-1)).max())


def test_course_files_share_the_character_rest_pose(floating, walk, run):
    for motion in (walk, run):
        np.testing.assert_array_equal(rest_alignment(floating, motion), np.tile([0, 0, 0, 1.0], (25, 1)))
    # the BVH offsets and the file's T-pose agree to the file's single precision
    sk = floating.skeleton
    for j, name in enumerate(sk.joint_names[1:], 1):
        np.testing.assert_allclose(sk.offsets[j], walk.offsets[walk.index(name)], atol=5e-7)


@pytest.mark.parametrize("frame", [0, 1, 37, 99])
def test_round_trip_walk(world, floating, walk, frame):
    set_pose(world, floating, walk, frame)
    pose = get_pose(world, floating, walk)
    assert pose.joint_names == walk.joint_names
    assert quat_err(pose.local_rotations, walk.local_rotations[frame]) < 1e-12
    np.testing.assert_allclose(pose.root_position, walk.root_positions[frame], rtol=0, atol=1e-12)
    assert quat_err(pose.root_rotation, walk.local_rotations[frame, walk.root]) < 1e-12
    # joint positions: the motion's, up to the file's single-precision bones
    pos, quat = walk.forward_kinematics()
    np.testing.assert_allclose(pose.joint_positions, pos[frame], atol=2e-6)
    assert quat_err(pose.global_rotations, quat[frame]) < 1e-12
    # in the ragdoll skeleton's own order too
    own = get_pose(world, floating)
    ref = walk.remap(floating.skeleton.joint_names).local_rotations[frame]
    assert quat_err(own.local_rotations, ref) < 1e-12


@pytest.mark.parametrize("frame", [0, 22, 44])
def test_round_trip_run_other_joint_order(world, floating, run, walk, frame):
    assert run.joint_names != walk.joint_names != floating.skeleton.joint_names
    set_pose(world, floating, run, frame)
    pose = get_pose(world, floating, run)
    assert quat_err(pose.local_rotations, run.local_rotations[frame]) < 1e-12
    np.testing.assert_allclose(pose.root_position, run.root_positions[frame], rtol=0, atol=1e-12)
    # the same through a reordered copy of the motion
    other = run.remap(walk.joint_names)
    set_pose(world, floating, other, frame)
    assert quat_err(get_pose(world, floating, run).local_rotations,
                    run.local_rotations[frame]) < 1e-12


def test_joint_targets_match_world_joint_quat(world, floating, walk):
    for frame in (3, 60):
        set_pose(world, floating, walk, frame)
        assert quat_err(world.joint_quat, joint_targets(floating, walk, frame)) < 1e-12
    every = joint_targets(floating, walk)
    assert every.shape == (100, 20, 4)
    assert quat_err(every[60], joint_targets(floating, walk, 60)) < 1e-15
    # ball joints have identity frames: the target is the motion's local rotation
    j = floating.model.joint_index("lHip")
    assert quat_err(every[:, j], walk.local_rotations[:, walk.index("lHip")]) < 1e-12


def expected_body_states(rd, motion, frame):
    """Body COM positions and orientations from the motion's own forward kinematics."""
    pos, quat = motion.forward_kinematics()
    idx = [motion.index(rd.skeleton.joint_names[j]) for j in rd.body_joints]
    x = pos[:, idx] + Q.qrot(quat[:, idx], rd.body_offset)
    q = Q.qmul(quat[:, idx], rd.body_rest_quat)
    return x, q


@pytest.mark.parametrize("frame", [0, 50, 99])
def test_velocities_are_finite_differences_of_the_motion(world, floating, walk, frame):
    set_pose(world, floating, walk, frame)
    x, q = expected_body_states(floating, walk, frame)
    lo, hi = max(frame - 1, 0), min(frame + 1, walk.num_frames - 1)
    span = (hi - lo) * walk.frame_time
    np.testing.assert_allclose(world.body_vel, (x[hi] - x[lo]) / span, atol=1e-4)
    np.testing.assert_allclose(world.body_pos, x[frame], atol=2e-6)
    # angular velocities: those of the joints, as Motion.velocities computes them
    _, ang = walk.velocities()
    idx = [walk.index(n) for n in floating.body_names]
    np.testing.assert_allclose(world.body_angvel, ang[frame, idx], atol=1e-9)
    set_pose(world, floating, walk, frame, velocities=False)
    assert not world.body_vel.any() and not world.body_angvel.any()


def test_velocities_exact_on_a_ragdoll_of_the_motion_itself(walk):
    rd = tumble.ragdoll_from_motion(walk)
    w = rd.make_world()
    frame = 40
    set_pose(w, rd, walk, frame)
    x, q = expected_body_states(rd, walk, frame)
    np.testing.assert_allclose(w.body_pos, x[frame], atol=1e-12)
    assert quat_err(w.body_quat, q[frame]) < 1e-12
    np.testing.assert_allclose(w.body_vel, (x[41] - x[39]) / (2 * walk.frame_time), atol=1e-10)
    assert quat_err(get_pose(w, rd, walk).local_rotations, walk.local_rotations[frame]) < 1e-12


def test_pinned_root_stays_at_the_pin(walk):
    rd = tumble.games105_ragdoll("pinned")
    w = rd.make_world()
    set_pose(w, rd, walk, 20)
    pose = get_pose(w, rd, walk)
    np.testing.assert_allclose(pose.root_position, rd.skeleton.rest_positions[0], atol=1e-15)
    assert quat_err(pose.local_rotations, walk.local_rotations[20]) < 1e-12
    assert w.joint_separation()[w.model.joint_index("RootJoint")] < 1e-12


def repose_rest(motion, joint, a):
    """The motion with the rest pose of ``joint``'s bones turned by rotation ``a`` (4,), and
    rotations changed to match, so every frame puts the joints where it did before."""
    sub = [joint]
    for j, p in enumerate(motion.parents):          # descendants (parents come first in BVH)
        if p in sub:
            sub.append(j)
    offsets = motion.offsets.copy()
    offsets[sub[1:]] = Q.qrot(a, offsets[sub[1:]])
    rot = motion.local_rotations.copy()
    inv = Q.qconj(a)
    rot[:, joint] = Q.qmul(rot[:, joint], inv)
    for j in sub[1:]:
        rot[:, j] = Q.qmul(a, Q.qmul(rot[:, j], inv))
    return tumble.Motion.from_arrays(motion.joint_names, motion.parents, offsets, rot,
                                     frame_time=motion.frame_time,
                                     root_positions=motion.root_positions)


def test_motion_with_another_rest_pose_is_aligned(walk):
    # a ragdoll of the walk's own skeleton, so its bones match the motion's exactly
    floating = tumble.ragdoll_from_motion(walk)
    world = floating.make_world()
    a = Rotation.from_euler("z", -60, degrees=True).as_quat()      # left arm down: an A-pose
    aposed = repose_rest(walk, walk.index("lShoulder"), a)
    pos0, _ = walk.forward_kinematics()
    pos1, _ = aposed.forward_kinematics()
    np.testing.assert_allclose(pos1, pos0, atol=1e-12)             # same motion, other rest
    align = rest_alignment(floating, aposed)
    sk = floating.skeleton
    for name in ("lShoulder", "lElbow", "lWrist"):
        assert quat_err(align[sk.index(name)], Q.qconj(a)) < 1e-12
    assert quat_err(align[sk.index("rShoulder")], [0, 0, 0, 1]) == 0.0
    set_pose(world, floating, walk, 30)
    ref = [world.body_pos.copy(), world.body_quat.copy(), world.body_vel.copy(),
           world.body_angvel.copy()]
    set_pose(world, floating, aposed, 30)
    np.testing.assert_allclose(world.body_pos, ref[0], atol=1e-12)
    assert quat_err(world.body_quat, ref[1]) < 1e-12
    np.testing.assert_allclose(world.body_vel, ref[2], atol=1e-9)
    np.testing.assert_allclose(world.body_angvel, ref[3], atol=1e-9)
    pose = get_pose(world, floating, aposed)
    assert quat_err(pose.local_rotations, aposed.local_rotations[30]) < 1e-12


def test_batch_worlds(floating, walk):
    w = floating.make_world(nworld=2)
    set_pose(w, floating, walk, 20)
    set_pose(w, floating, walk, 70, world_index=1)
    assert quat_err(get_pose(w, floating, walk).local_rotations, walk.local_rotations[20]) < 1e-12
    assert quat_err(get_pose(w, floating, walk, world_index=1).local_rotations,
                    walk.local_rotations[70]) < 1e-12


def test_errors(world, floating, walk):
    short = walk.remap([n for n in walk.joint_names if not n.startswith("lWrist")])
    with pytest.raises(tumble.ModelError, match=r"no joints named \['lWrist'\]"):
        set_pose(world, floating, short, 0)
    with pytest.raises(tumble.ModelError, match="frame 100 out of range"):
        set_pose(world, floating, walk, 100)
    with pytest.raises(tumble.ModelError, match="world_index"):
        set_pose(world, floating, walk, 0, world_index=3)
    with pytest.raises(tumble.ModelError, match="Ragdoll"):
        set_pose(world, floating.model, walk, 0)
    with pytest.raises(tumble.ModelError, match="Motion"):
        get_pose(world, floating, motion="walk")
    b = tumble.ModelBuilder()
    b.add_body("ball", mass=1.0, inertia=(1, 1, 1))
    other = tumble.World(b.build())
    with pytest.raises(tumble.ModelError, match="lacks a ragdoll body"):
        set_pose(other, floating, walk, 0)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), frame=st.integers(0, 2))
def test_round_trip_any_rotations(world, floating, walk, seed, frame):
    """Random joint rotations and root positions survive world and back to round-off."""
    rng = np.random.default_rng(seed)
    rot = rng.normal(size=(3, walk.num_joints, 4))
    motion = tumble.Motion.from_arrays(walk.joint_names, walk.parents, walk.offsets, rot,
                                       frame_time=1 / 60,
                                       root_positions=rng.uniform(-5, 5, size=(3, 3)))
    set_pose(world, floating, motion, frame)
    pose = get_pose(world, floating, motion)
    body = [motion.index(n) for n in floating.body_names]     # end sites have no rotation
    assert quat_err(pose.local_rotations[body], motion.local_rotations[frame, body]) < 1e-12
    np.testing.assert_allclose(pose.root_position, motion.root_positions[frame], atol=1e-12)
