"""Tests of the BVH loader/saver and of Motion (tumble/io/bvh.py).

Course files: tests/data/games105 (GAMES-105, BSD 3-Clause, see the LICENSE there).
Tolerances: exact-arithmetic results (copies, reflections) to 1e-12; results
through trigonometry or Euler round trips to 1e-9; values written to text to 1e-6.
"""
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from tumble.errors import ModelError
from tumble.io import Motion, format_bvh, load_bvh, load_bvh_string, save_bvh

DATA = Path(__file__).resolve().parent.parent / "data" / "games105"

COURSE_NAMES = {
    "RootJoint", "pelvis_lowerback", "lowerback_torso", "torso_head", "torso_head_end",
    "lHip", "lKnee", "lAnkle", "lToeJoint", "lToeJoint_end",
    "rHip", "rKnee", "rAnkle", "rToeJoint", "rToeJoint_end",
    "lTorso_Clavicle", "lShoulder", "lElbow", "lWrist", "lWrist_end",
    "rTorso_Clavicle", "rShoulder", "rElbow", "rWrist", "rWrist_end",
}
COURSE_FILES = {  # name: (frames, frame time in seconds)
    "walk_forward": (100, 0.01),
    "idle": (200, 1 / 60),
    "run_forward": (45, 1 / 60),
}
TAIT_BRYAN = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"]
PROPER = ["XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ"]

_cache = {}


def course(name):
    """Course motion, loaded once per test session (loading is the slow part)."""
    if name not in _cache:
        _cache[name] = load_bvh(DATA / f"{name}.bvh")
    return _cache[name]


def quat_close(q1, q2):
    """Largest distance between quaternions (..., 4), q ~ -q; about half the angle between them."""
    q1, q2 = np.asarray(q1), np.asarray(q2)
    return float(np.max(np.minimum(np.linalg.norm(q1 - q2, axis=-1),
                                   np.linalg.norm(q1 + q2, axis=-1)), initial=0.0))


def one_joint(order, angles, position=(0.0, 0.0, 0.0)):
    """BVH text: a root with position channels and rotation channels in ``order``."""
    rot = " ".join(f"{a}rotation" for a in order)
    values = " ".join(repr(float(v)) for v in (*position, *angles))
    return (f"HIERARCHY\nROOT hips\n{{\n  OFFSET 0 0 0\n"
            f"  CHANNELS {3 + len(order)} Xposition Yposition Zposition {rot}\n"
            f"  End Site\n  {{\n    OFFSET 0 1 0\n  }}\n}}\n"
            f"MOTION\nFrames: 1\nFrame Time: 0.0333333\n{values}\n")


# A two-link chain: root at (1, 2, 3) turned 90 deg about z, a child 1 along x
# turned 90 deg about its x, then an End Site 1 along the child's y.
CHAIN = """HIERARCHY
ROOT base
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT arm
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 1 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.5
1 2 3 90 0 0 0 0 90
1 2 3 0 0 0 0 0 0
"""


# --- the course files --------------------------------------------------------

@pytest.mark.parametrize("name", sorted(COURSE_FILES))
def test_course_file_structure(name):
    m = course(name)
    frames, frame_time = COURSE_FILES[name]
    assert m.num_frames == frames == len(m)
    assert m.frame_time == pytest.approx(frame_time, abs=1e-6)  # the files write 0.016667
    assert m.num_joints == 25
    assert set(m.joint_names) == COURSE_NAMES
    assert m.joint_names[0] == "RootJoint"
    # File order is depth-first: every parent comes before its children.
    assert m.parents[0] == -1
    assert all(0 <= m.parents[j] < j for j in range(1, 25))
    for j, n in enumerate(m.joint_names):
        if n.endswith("_end"):
            assert m.joint_names[m.parents[j]] == n[:-4]
            assert m.channels[j] == ()
            assert np.all(m.local_rotations[:, j] == [0, 0, 0, 1])
    assert m.channels[0] == ("Xposition", "Yposition", "Zposition",
                             "Xrotation", "Yrotation", "Zrotation")
    assert sum(len(c) for c in m.channels) == 63
    assert m.end_sites.sum() == 5
    assert m.offsets.shape == (25, 3)
    assert m.local_rotations.shape == (frames, 25, 4)
    assert m.local_positions.shape == (frames, 25, 3)
    assert m.root_positions.shape == (frames, 3)
    np.testing.assert_allclose(np.linalg.norm(m.local_rotations, axis=-1), 1.0, atol=1e-12)


def test_course_units_are_metres_and_scale_applies_to_lengths():
    m = course("walk_forward")
    # Shank and thigh lengths of the course character, in metres.
    np.testing.assert_allclose(m.offsets[m.index("lKnee")], [0.0, -0.41, 0.0], atol=1e-12)
    np.testing.assert_allclose(m.offsets[m.index("lAnkle")], [0.0, -0.39, 0.0], atol=1e-12)
    np.testing.assert_allclose(m.root_positions[0], [-2.417790, 0.850296, 3.128956], atol=1e-12)
    cm = load_bvh(DATA / "walk_forward.bvh", scale=100.0)
    np.testing.assert_allclose(cm.offsets, 100.0 * m.offsets, rtol=1e-12)
    np.testing.assert_allclose(cm.root_positions, 100.0 * m.root_positions, rtol=1e-12)
    np.testing.assert_array_equal(cm.local_rotations, m.local_rotations)
    np.testing.assert_allclose(cm.forward_kinematics()[0], 100.0 * m.forward_kinematics()[0],
                               rtol=1e-10, atol=1e-10)


def test_idle_feet_stay_on_the_ground():
    # Checks the Euler convention on real data: intrinsic angles keep the idle
    # feet planted on the floor; extrinsic ones would lift an ankle 0.34 m.
    pos, _ = course("idle").forward_kinematics()
    m = course("idle")
    for name in ("lAnkle", "rAnkle", "lToeJoint_end", "rToeJoint_end"):
        y = pos[:, m.index(name), 1]
        assert 0.0 < y.min() and y.max() < 0.07, name


def test_run_forward_order_differs_and_remap_restores_it():
    walk, run = course("walk_forward"), course("run_forward")
    assert run.joint_names != walk.joint_names
    mapped = run.remap(walk)
    assert mapped.joint_names == walk.joint_names
    np.testing.assert_array_equal(mapped.parents, walk.parents)
    np.testing.assert_allclose(mapped.offsets, walk.offsets, atol=1e-12)  # same skeleton
    # Remapping only reorders: world poses follow the joints.
    idx = [run.index(n) for n in walk.joint_names]
    pos, quat = run.forward_kinematics()
    mpos, mquat = mapped.forward_kinematics()
    np.testing.assert_allclose(mpos, pos[:, idx], atol=1e-12)
    np.testing.assert_allclose(mquat, quat[:, idx], atol=1e-12)
    assert run.remap(walk.joint_names).joint_names == walk.joint_names


def test_remap_errors_name_the_missing_and_orphaned_joints():
    m = course("walk_forward")
    with pytest.raises(ModelError, match="Pinky"):
        m.remap(list(m.joint_names) + ["Pinky"])
    # Dropping End Sites is fine, dropping a joint that has kept children is not.
    kept = [n for n in m.joint_names if not n.endswith("_end")]
    assert m.remap(kept).num_joints == 20
    with pytest.raises(ModelError, match="lKnee"):
        m.remap([n for n in m.joint_names if n != "lKnee"])


# --- forward kinematics ------------------------------------------------------

def test_forward_kinematics_of_a_chain_matches_hand_computation():
    m = load_bvh_string(CHAIN)
    assert m.joint_names == ["base", "arm", "arm_end"]
    np.testing.assert_array_equal(m.parents, [-1, 0, 1])
    pos, quat = m.forward_kinematics()
    assert pos.shape == (2, 3, 3) and quat.shape == (2, 3, 4)
    # Frame 0: Rz(90) maps x->y; the arm sits at (1,2,3) + (0,1,0). Its frame is
    # Rz(90) Rx(90), which maps the End Site offset (0,1,0) to (0,0,1).
    np.testing.assert_allclose(pos[0], [[1, 2, 3], [1, 3, 3], [1, 3, 4]], atol=1e-12)
    s = np.sqrt(0.5)
    assert quat_close(quat[0, 0], [0, 0, s, s]) < 1e-12
    assert quat_close(quat[0, 1], [0.5, 0.5, 0.5, 0.5]) < 1e-12  # Rz(90) Rx(90)
    # Frame 1: no rotation, offsets add up.
    np.testing.assert_allclose(pos[1], [[1, 2, 3], [2, 2, 3], [2, 3, 3]], atol=1e-12)


def test_forward_kinematics_matches_a_per_frame_reference_on_course_data():
    m = course("run_forward")
    pos, quat = m.forward_kinematics()
    for f in (0, 17, 44):
        for j in range(m.num_joints):
            p = m.parents[j]
            if p < 0:
                continue
            r = Rotation.from_quat(quat[f, p])
            np.testing.assert_allclose(pos[f, j], pos[f, p] + r.apply(m.offsets[j]), atol=1e-12)
            child = r * Rotation.from_quat(m.local_rotations[f, j])
            assert quat_close(quat[f, j], child.as_quat()) < 1e-12


# --- Euler orders and channel layouts -----------------------------------------

@pytest.mark.parametrize("order", TAIT_BRYAN + PROPER)
def test_each_channel_order_is_an_intrinsic_euler_sequence(order):
    angles = (30.0, -50.0, 70.0)
    m = load_bvh_string(one_joint(order, angles, position=(0.5, 1.0, -2.0)))
    expected = Rotation.from_euler(order, angles, degrees=True).as_quat()
    assert quat_close(m.local_rotations[0, 0], expected) < 1e-12
    np.testing.assert_allclose(m.root_positions[0], [0.5, 1.0, -2.0], atol=0)
    # Pin "intrinsic" without scipy: channels A B C mean R = R_A R_B R_C.
    basis = {"X": [1, 0, 0], "Y": [0, 1, 0], "Z": [0, 0, 1]}
    mat = np.eye(3)
    for axis, angle in zip(order, angles):
        mat = mat @ Rotation.from_rotvec(np.radians(angle) * np.array(basis[axis])).as_matrix()
    np.testing.assert_allclose(Rotation.from_quat(m.local_rotations[0, 0]).as_matrix(), mat,
                               atol=1e-12)


MIXED = """HIERARCHY
ROOT pelvis
{
	OFFSET 5 6 7
	CHANNELS 6 Zrotation Xposition Xrotation Yposition Yrotation Zposition
	JOINT spine
	{
		OFFSET 0 10 0
		CHANNELS 1 Yrotation
		JOINT neck
		{
			OFFSET 0 8 0
			CHANNELS 5 Yposition Xrotation Zrotation Xposition Zposition
			End Site
			{
				OFFSET 0 3 0
			}
		}
	}
	JOINT tail
	{
		OFFSET 0 -2 -1
		CHANNELS 2 Xrotation Zrotation
		End Site
		{
			OFFSET 0 0 -4
		}
	}
}
MOTION
Frames: 2
Frame Time: 0.04
10 1 20 2 30 3   45   0.5 15 25 0.25 0.75   -60 5
-10 4 -20 5 -30 6   -45   1.5 -15 -25 1.25 1.75   60 -5
"""


def test_mixed_channels_positions_anywhere_and_fewer_rotation_axes():
    m = load_bvh_string(MIXED.replace("\n", "\r\n"))  # Windows line ends too
    assert m.joint_names == ["pelvis", "spine", "neck", "neck_end", "tail", "tail_end"]
    np.testing.assert_array_equal(m.parents, [-1, 0, 1, 2, 0, 4])
    assert m.channels[1] == ("Yrotation",)
    np.testing.assert_allclose(m.root_positions, [[1, 2, 3], [4, 5, 6]], atol=0)
    expect = Rotation.from_euler("ZXY", [[10, 20, 30], [-10, -20, -30]], degrees=True).as_quat()
    assert quat_close(m.local_rotations[:, 0], expect) < 1e-12
    expect = Rotation.from_euler("Y", [[45], [-45]], degrees=True).as_quat()
    assert quat_close(m.local_rotations[:, 1], expect) < 1e-12
    # neck: position channels replace the offset, in the order they are listed.
    np.testing.assert_allclose(m.local_positions[:, 2], [[0.25, 0.5, 0.75], [1.25, 1.5, 1.75]])
    expect = Rotation.from_euler("XZ", [[15, 25], [-15, -25]], degrees=True).as_quat()
    assert quat_close(m.local_rotations[:, 2], expect) < 1e-12
    expect = Rotation.from_euler("XZ", [[-60, 5], [60, -5]], degrees=True).as_quat()
    assert quat_close(m.local_rotations[:, 4], expect) < 1e-12
    # Joints without position channels keep their offsets at every frame.
    np.testing.assert_array_equal(m.local_positions[:, 1], [[0, 10, 0]] * 2)


@settings(max_examples=60, deadline=None, database=None)
@given(order=st.sampled_from(TAIT_BRYAN + PROPER),
       angles=st.lists(st.floats(-360.0, 360.0, allow_nan=False), min_size=3, max_size=3))
@example(order="XYZ", angles=[10.0, 90.0, 20.0])    # gimbal lock: the writer picks
@example(order="ZXZ", angles=[10.0, 0.0, 20.0])     # one of many equivalent angle sets
@example(order="ZXZ", angles=[10.0, 180.0, -20.0])
def test_random_euler_angles_load_as_scipy_quaternions(order, angles):
    m = load_bvh_string(one_joint(order, angles))
    expected = Rotation.from_euler(order, angles, degrees=True).as_quat()
    assert quat_close(m.local_rotations[0, 0], expected) < 1e-12
    # Writing and reading back gives the same rotation, whatever angles the writer picks.
    # Within 1e-7 rad of gimbal lock scipy's as_euler snaps to the locked solution,
    # an error of up to that distance; elsewhere only the 12 written digits count.
    middle = np.radians(angles[1])
    lock_distance = abs(np.sin(middle)) if order[0] == order[2] else abs(np.cos(middle))
    again = load_bvh_string(format_bvh(m))
    tol = 1e-9 if lock_distance > 1e-6 else 1e-7
    assert quat_close(again.local_rotations[0, 0], expected) < tol


# --- resampling --------------------------------------------------------------

def test_resample_double_then_half_returns_the_original():
    m = course("walk_forward")
    fine = m.resample(fps=200)
    assert fine.num_frames == 199 and fine.frame_time == pytest.approx(0.005, abs=1e-15)
    back = fine.resample(frame_time=0.01)
    assert back.num_frames == m.num_frames
    assert quat_close(back.local_rotations, m.local_rotations) < 1e-9
    np.testing.assert_allclose(back.local_positions, m.local_positions, rtol=0, atol=1e-9)
    # The even frames of the fine motion are the original frames.
    assert quat_close(fine.local_rotations[::2], m.local_rotations) < 1e-9


def test_resample_slerps_halfway_and_interpolates_positions():
    m = load_bvh_string(CHAIN)  # frame 0 and 1 one half second apart
    fine = m.resample(fps=4)
    assert fine.num_frames == 3
    # Root: Rz(90) -> identity, halfway is Rz(45). Arm: Rx(90) -> identity, Rx(45).
    expect = Rotation.from_euler("z", 45, degrees=True).as_quat()
    assert quat_close(fine.local_rotations[1, 0], expect) < 1e-12
    expect = Rotation.from_euler("x", 45, degrees=True).as_quat()
    assert quat_close(fine.local_rotations[1, 1], expect) < 1e-12
    np.testing.assert_allclose(fine.root_positions[1], [1, 2, 3], atol=0)
    # A translating root moves linearly.
    moving = Motion.from_arrays(["a"], [-1], [[0, 0, 0]], np.tile([0, 0, 0, 1.0], (2, 1, 1)),
                                frame_time=1.0, root_positions=[[0, 0, 0], [2, 4, -6]])
    np.testing.assert_allclose(moving.resample(fps=4).root_positions,
                               np.linspace([0, 0, 0], [2, 4, -6], 5), atol=1e-12)


def test_resample_to_a_rate_that_does_not_divide_stays_within_the_clip():
    m = course("walk_forward")  # 0.99 s long
    r = m.resample(fps=60)
    assert r.num_frames == 60  # 0 .. 59/60 s
    assert quat_close(r.local_rotations[0], m.local_rotations[0]) < 1e-12
    # Frame 30 at 0.5 s is original frame 50.
    assert quat_close(r.local_rotations[30], m.local_rotations[50]) < 1e-9
    with pytest.raises(ModelError):
        m.resample()
    with pytest.raises(ModelError):
        m.resample(fps=30, frame_time=0.1)


# --- mirroring ---------------------------------------------------------------

def test_mirror_twice_is_the_identity():
    m = course("run_forward")
    twice = m.mirror("x").mirror("x")
    assert twice.joint_names == m.joint_names
    np.testing.assert_allclose(twice.local_rotations, m.local_rotations, atol=1e-15)
    np.testing.assert_allclose(twice.local_positions, m.local_positions, atol=1e-15)
    np.testing.assert_allclose(twice.offsets, m.offsets, atol=1e-15)
    # Also for a tilted plane, up to rounding.
    tilted = m.mirror([1.0, 0.3, -0.2]).mirror([1.0, 0.3, -0.2])
    assert quat_close(tilted.local_rotations, m.local_rotations) < 1e-12
    np.testing.assert_allclose(tilted.local_positions, m.local_positions, atol=1e-12)


@pytest.mark.parametrize("axis", ["x", "z", (0.6, 0.0, 0.8)])
def test_mirror_swaps_left_and_right_across_the_plane(axis):
    m = course("walk_forward")
    mir = m.mirror(axis)
    n = np.array([1.0, 0, 0]) if axis == "x" else np.array([0, 0, 1.0]) if axis == "z" \
        else np.array(axis)
    reflect = np.eye(3) - 2.0 * np.outer(n, n)
    pos, quat = m.forward_kinematics()
    mpos, mquat = mir.forward_kinematics()
    for j, name in enumerate(m.joint_names):
        other = "r" + name[1:] if name[0] == "l" and name[1].isupper() else \
                "l" + name[1:] if name[0] == "r" and name[1].isupper() else name
        k = m.index(other)
        np.testing.assert_allclose(mpos[:, j], pos[:, k] @ reflect.T, atol=1e-12, err_msg=name)
        # Orientations reflect as M R M.
        rk = Rotation.from_quat(quat[:, k]).as_matrix()
        np.testing.assert_allclose(Rotation.from_quat(mquat[:, j]).as_matrix(),
                                   reflect @ rk @ reflect, atol=1e-12, err_msg=name)


def test_mirror_pairs_by_name_and_by_explicit_list():
    m = course("idle")
    pairs = [(n, "r" + n[1:]) for n in m.joint_names if n[0] == "l" and n[1].isupper()]
    assert len(pairs) == 10  # per side: 4 leg joints, 4 arm joints, 2 End Sites
    auto, explicit = m.mirror("x"), m.mirror("x", left_right=pairs)
    np.testing.assert_array_equal(auto.local_rotations, explicit.local_rotations)
    np.testing.assert_array_equal(auto.local_positions, explicit.local_positions)
    # A pairing whose parents do not pair up is refused.
    with pytest.raises(ModelError, match="tree"):
        m.mirror("x", left_right=[("lHip", "rKnee")])
    with pytest.raises(ModelError):
        m.mirror("w")


# --- velocities --------------------------------------------------------------

def test_velocity_of_a_root_translating_at_constant_speed():
    F, dt = 12, 1 / 30
    v = np.array([0.5, 0.0, -1.2])  # m/s
    t = np.arange(F) * dt
    rot = np.tile(Rotation.from_euler("y", 30, degrees=True).as_quat(), (F, 2, 1))
    m = Motion.from_arrays(["root", "child"], [-1, 0], [[0, 0, 0], [0, 1, 0]], rot,
                           frame_time=dt, root_positions=np.outer(t, v) + [0, 0.9, 0])
    lin, ang = m.velocities()
    assert lin.shape == ang.shape == (F, 2, 3)
    np.testing.assert_allclose(lin, np.broadcast_to(v, (F, 2, 3)), atol=1e-12)
    np.testing.assert_allclose(ang, 0.0, atol=1e-12)


def test_angular_velocity_of_a_spinning_root_and_its_child():
    F, dt, w = 20, 0.01, 2.0  # rad/s about y
    angles = w * np.arange(F) * dt
    rot = np.zeros((F, 2, 4))
    rot[:, 0] = Rotation.from_rotvec(np.outer(angles, [0, 1, 0])).as_quat()
    rot[:, 1] = [0, 0, 0, 1]
    m = Motion.from_arrays(["root", "arm"], [-1, 0], [[0, 0, 0], [1, 0, 0]], rot, frame_time=dt)
    lin, ang = m.velocities()
    np.testing.assert_allclose(ang, np.broadcast_to([0, w, 0], (F, 2, 3)), atol=1e-9)
    # The arm tip moves on a unit circle: v = w x r, |v| = w (central differences: sin(w dt)/dt).
    pos, _ = m.forward_kinematics()
    expect = np.cross([0, w, 0], pos[:, 1])
    np.testing.assert_allclose(lin[1:-1, 1], expect[1:-1], atol=w ** 3 * dt ** 2)
    np.testing.assert_allclose(lin[:, 0], 0.0, atol=1e-12)


# --- slicing -----------------------------------------------------------------

def test_sub_and_slicing():
    m = course("idle")
    clip = m[20:50]
    assert clip.num_frames == 30 and clip.frame_time == m.frame_time
    np.testing.assert_array_equal(clip.local_rotations, m.local_rotations[20:50])
    np.testing.assert_array_equal(clip.root_positions, m.root_positions[20:50])
    half = m.sub(0, None, 2)
    assert half.num_frames == 100 and half.frame_time == pytest.approx(2 * m.frame_time)
    one = m[-1]
    assert one.num_frames == 1
    np.testing.assert_array_equal(one.local_rotations[0], m.local_rotations[-1])
    with pytest.raises(IndexError):
        m[200]


# --- saving ------------------------------------------------------------------

def assert_same_motion(a, b, rtol=1e-6):
    assert a.joint_names == b.joint_names
    np.testing.assert_array_equal(a.parents, b.parents)
    assert a.channels == b.channels
    assert a.frame_time == pytest.approx(b.frame_time, rel=1e-12)
    np.testing.assert_allclose(a.offsets, b.offsets, rtol=rtol, atol=1e-12)
    np.testing.assert_allclose(a.local_positions, b.local_positions, rtol=rtol, atol=1e-12)
    assert quat_close(a.local_rotations, b.local_rotations) < 1e-8


@pytest.mark.parametrize("name", sorted(COURSE_FILES))
def test_save_load_round_trip_of_course_files(name, tmp_path):
    m = course(name)
    save_bvh(m, tmp_path / "out.bvh")
    again = load_bvh(tmp_path / "out.bvh")
    assert_same_motion(again, m)
    np.testing.assert_allclose(again.forward_kinematics()[0], m.forward_kinematics()[0],
                               rtol=1e-6, atol=1e-9)


def test_round_trip_of_mixed_channels_mirrored_and_remapped_motions(tmp_path):
    mixed = load_bvh_string(MIXED)
    assert_same_motion(load_bvh_string(format_bvh(mixed)), mixed)
    mirrored = course("walk_forward").mirror("x")
    save_bvh(mirrored, str(tmp_path / "m.bvh"))
    assert_same_motion(load_bvh(str(tmp_path / "m.bvh")), mirrored)
    run = course("run_forward")
    # Saved in depth-first order, which for a remapped file-order motion is that order.
    remapped = run.remap(course("walk_forward"))
    assert_same_motion(load_bvh_string(format_bvh(remapped)), remapped)
    # scale on writing: centimetres out, metres back in.
    save_bvh(run, tmp_path / "cm.bvh", scale=100.0)
    assert_same_motion(load_bvh(tmp_path / "cm.bvh", scale=0.01), run)


def test_from_arrays_defaults_and_validation():
    F = 3
    rot = np.tile([0, 0, 0, 2.0], (F, 3, 1))  # normalised by from_arrays
    rot[:, 1] = Rotation.from_euler("x", [[0], [10], [20]], degrees=True).as_quat()
    m = Motion.from_arrays(["hips", "leg", "leg_end"], [-1, 0, 1],
                           [[0, 1, 0], [0.1, 0, 0], [0, -0.4, 0]], rot, frame_time=0.02)
    np.testing.assert_allclose(m.local_rotations[:, 0], [[0, 0, 0, 1]] * F)
    assert m.channels[1] == ("Zrotation", "Yrotation", "Xrotation")
    assert m.channels[2] == ()  # an unmoving leaf is an End Site
    np.testing.assert_allclose(m.root_positions, [[0, 1, 0]] * F)
    assert_same_motion(load_bvh_string(format_bvh(m)), m, rtol=1e-9)
    with pytest.raises(ModelError, match="one root"):
        Motion.from_arrays(["a", "b"], [-1, -1], np.zeros((2, 3)), rot[:, :2], frame_time=0.1)
    with pytest.raises(ModelError, match="cycle"):
        Motion.from_arrays(["a", "b", "c"], [-1, 2, 1], np.zeros((3, 3)), rot, frame_time=0.1)
    with pytest.raises(ModelError, match="duplicate"):
        Motion.from_arrays(["a", "a", "c"], [-1, 0, 1], np.zeros((3, 3)), rot, frame_time=0.1)
    with pytest.raises(ModelError, match="frame_time"):
        Motion.from_arrays(["a", "b", "c"], [-1, 0, 1], np.zeros((3, 3)), rot, frame_time=0)
    with pytest.raises(ModelError, match="shape"):
        Motion.from_arrays(["a", "b", "c"], [-1, 0, 1], np.zeros((3, 2)), rot, frame_time=0.1)


def test_save_refuses_what_the_channels_cannot_hold():
    m = load_bvh_string(MIXED)
    bent = m.local_rotations.copy()
    bent[:, 1] = Rotation.from_euler("x", 10, degrees=True).as_quat()  # spine has only Y
    with pytest.raises(ModelError, match="spine"):
        format_bvh(m._replace(local_rotations=bent))


# --- loading: inputs and errors ----------------------------------------------

def test_load_accepts_paths_strings_and_text(tmp_path):
    m = course("run_forward")
    text = (DATA / "run_forward.bvh").read_text()
    for src in (str(DATA / "run_forward.bvh"), text):
        other = load_bvh(src)
        np.testing.assert_array_equal(other.local_rotations, m.local_rotations)
    with pytest.raises(FileNotFoundError):
        load_bvh(tmp_path / "nowhere.bvh")


GOOD = CHAIN.splitlines()


def lines_with(replacements=None, drop_from=None):
    lines = list(GOOD)
    for lineno, text in (replacements or {}).items():
        lines[lineno - 1] = text
    if drop_from is not None:
        lines = lines[:drop_from - 1]
    return "\n".join(lines) + "\n"


MALFORMED = [
    # (file text, line number in the message, words in the message)
    ("", 1, "'HIERARCHY'"),
    (lines_with({2: "ROOTS base"}), 2, "expected 'ROOT', got 'ROOTS'"),
    (lines_with({4: "  OFFSET 0 zero 0"}), 4, "number"),
    (lines_with({4: "  OFSET 0 0 0"}), 4, "expected 'OFFSET'"),
    (lines_with({8: "    OFFSET 1 0"}), 9, "number"),       # the 3rd number is missing
    (lines_with({9: "    CHANNELS 3 Zrotation Yrotation Wrotation"}), 9, "Wrotation"),
    (lines_with({9: "    CHANNELS three Zrotation Yrotation Xrotation"}), 9, "channel count"),
    (lines_with(drop_from=12), 12, "end of file"),          # hierarchy cut off
    (lines_with({15: "}", 16: "MOTIONS"}), 16, "'MOTION'"),
    (lines_with(drop_from=16), 16, "expected 'MOTION'"),    # complete hierarchy, no MOTION
    (lines_with({17: "Frames 2"}), 17, "Frames"),
    (lines_with({17: "Frames: two"}), 17, "frame count"),
    (lines_with({18: "Frame Time: -0.5"}), 18, "positive"),
    (lines_with({18: "FrameTime: 0.5"}), 18, "Frame Time"),
    (lines_with({19: "1 2 3 90 0 0 0 0"}), 19, "8 values, expected 9"),
    (lines_with({20: "1 2 3 0 0 0 0 0 0 0"}), 20, "10 values, expected 9"),
    (lines_with({20: "1 2 3 0 0 0 0 0 1e"}), 20, "number"),
    (lines_with({20: "1 2 3 0 0 0 nan 0 0"}), 20, "non-finite"),
    (lines_with(drop_from=20), 20, "announced"),             # a frame line missing
    (CHAIN + "1 2 3 0 0 0 0 0 0\n", 21, "more frame lines"),
    (CHAIN.replace("JOINT arm", "JOINT base"), 6, "duplicate"),
    (CHAIN.replace("MOTION", "ROOT other\n{\nOFFSET 0 0 0\n}\nMOTION"), 16, "second ROOT"),
]


@pytest.mark.parametrize("text, line, words", MALFORMED)
def test_malformed_text_reports_the_line(text, line, words):
    with pytest.raises(ModelError) as info:
        load_bvh_string(text)
    msg = str(info.value)
    assert f"<string> line {line}:" in msg
    assert words in msg


def test_malformed_file_names_the_file_and_line(tmp_path):
    path = tmp_path / "walk.bvh"
    path.write_text(lines_with({7: "  {{"}))
    with pytest.raises(ModelError, match=r"^walk\.bvh line 7: expected '\{', got '\{\{'"):
        load_bvh(path)
    # A real file cut in the middle of its hierarchy.
    cut = "\n".join((DATA / "walk_forward.bvh").read_text().splitlines()[:57])
    path.write_text(cut)
    with pytest.raises(ModelError, match=r"^walk\.bvh line 58: expected .*end of file"):
        load_bvh(path)
