"""Reference motions (tumble/rl/reference.py): the course's walking clip on the GAMES-105
ragdoll as per-frame body and joint states, closed into a cycle, and sampled at any time.

Tolerances: what the module defines exactly (frame K against frame 0, sampling at frame
times, one period later) to 1e-9 or better (float rounding of times and quaternion
normalisation); velocities against finite differences of the frames to 1e-9 when the same
central difference is meant, and with stated slack (5% of the largest value) where the
velocity is computed differently (hinge rates from the bodies' angular velocities, angular
velocity against a small-angle quaternion difference).

This file never steps a world (it may run among conftest.py's STEP_FREE files).
"""
import numpy as np
import pytest

import tumble
from tumble.data.games105 import clip_path
from tumble.math import quat_np as Q
from tumble.rl import ReferenceMotion, cycle_end_frame

UP = 1            # the course is Y up


@pytest.fixture(scope="module")
def ragdoll():
    return tumble.games105_ragdoll("floating")


@pytest.fixture(scope="module")
def walk():
    return tumble.load_bvh(clip_path("walk"))


@pytest.fixture(scope="module")
def ref(ragdoll, walk):
    return ReferenceMotion(ragdoll, walk)


def angle(a, b):
    """Angle (rad) between unit quaternions, sign-blind."""
    return 2.0 * np.arccos(np.clip(np.abs(np.sum(a * b, axis=-1)), 0.0, 1.0))


def same_rotation(a, b, tol):
    """Quaternions equal up to sign, componentwise to ``tol``."""
    s = np.sign(np.sum(a * b, axis=-1, keepdims=True))
    s[s == 0] = 1.0
    return np.max(np.abs(a - s * b)) <= tol


def test_cycle_of_the_walk(ref, walk):
    # the course's walking cycle ends at frame 96 of 100 (reference.py's own documentation)
    assert ref.looped and ref.num_frames == ref.cycle_end == cycle_end_frame(walk) == 96
    assert ref.frame_time == pytest.approx(0.01, abs=1e-12)
    assert ref.period == pytest.approx(0.96, abs=1e-12)
    assert ref.duration == np.inf
    f = ref.frames
    nb, nj = ref.ragdoll.model.nbody, ref.ragdoll.model.njoint
    assert f.body_pos.shape == (97, nb, 3) and f.body_quat.shape == (97, nb, 4)
    assert f.joint_quat.shape == (97, nj, 4) and f.joint_q.shape == (97, nj, 3)
    for name in ("body_pos", "body_quat", "body_vel", "body_angvel", "joint_quat", "joint_q",
                 "joint_qd", "com_pos", "com_vel"):
        a = getattr(f, name)
        assert np.all(np.isfinite(a)), name
        assert not a.flags.writeable, name
    assert np.allclose(np.linalg.norm(f.body_quat, axis=-1), 1.0, atol=1e-12)


def test_loop_closes_the_cycle(ref):
    f, K = ref.frames, ref.num_frames
    # frame K is frame 0 moved by the cycle offset: positions shifted, rotations the same
    assert np.max(np.abs(f.body_pos[K] - f.body_pos[0] - ref.cycle_offset)) < 1e-12
    assert np.max(np.abs(f.com_pos[K] - f.com_pos[0] - ref.cycle_offset)) < 1e-12
    assert same_rotation(f.body_quat[K], f.body_quat[0], 1e-12)
    assert same_rotation(f.joint_quat[K], f.joint_quat[0], 1e-12)
    assert np.max(np.abs(f.joint_q[K] - f.joint_q[0])) < 1e-12
    # ... and so are its velocities (the cycle repeats)
    assert np.max(np.abs(f.body_vel[K] - f.body_vel[0])) < 1e-9
    assert np.max(np.abs(f.body_angvel[K] - f.body_angvel[0])) < 1e-9
    assert np.max(np.abs(f.joint_qd[K] - f.joint_qd[0])) < 1e-9
    # the offset is the root's travel over the cycle, as the mean velocity says
    mean_vel = f.com_vel[:K].mean(axis=0)
    assert np.allclose(mean_vel * ref.period, ref.cycle_offset, atol=2e-3)


def test_cycle_offset_is_the_horizontal_travel(ref, walk):
    # the vertical is the ragdoll's (gravity along -Y), not guessed from the clip: the
    # course clips' roots are 2-5 m from the origin horizontally and 0.85 m high
    assert ref.up == UP
    K = ref.num_frames
    travel = walk.root_positions[K] - walk.root_positions[0]
    assert ref.cycle_offset[UP] == 0.0
    horizontal = np.delete(np.arange(3), UP)
    assert np.allclose(ref.cycle_offset[horizontal], travel[horizontal], atol=1e-9)
    # the reference root walks forward (the walk covers about 1.2 m per cycle) and keeps
    # its height from cycle to cycle
    assert np.linalg.norm(ref.cycle_offset) > 1.0
    s = ref.sample(np.array([0.0, 10 * ref.period]))
    assert abs(s.body_pos[1, 0, UP] - s.body_pos[0, 0, UP]) < 1e-9


def test_joint_rotations_continuous_across_the_seam(ref, walk, ragdoll):
    f, K = ref.frames, ref.num_frames
    steps = angle(f.joint_quat[1:], f.joint_quat[:-1]).max(axis=1)     # (K,) per frame step
    # the steps into and out of the seam (K-1 -> K = next cycle's 0, 0 -> 1) are ordinary
    # frame steps: within 25% of the largest step inside the cycle (spreading the mismatch
    # adds a little to every step: 0.068 rad at the seam against 0.067 inside)
    inside = steps[1:-1].max()
    assert steps[-1] <= 1.25 * inside
    assert steps[0] <= 1.25 * inside
    # while the raw clip would jump (frame K of the clip against frame 1, same cycle
    # position) by well over a frame's step
    raw = ReferenceMotion(ragdoll, walk, loop=False).frames
    assert angle(raw.joint_quat[K], raw.joint_quat[1]).max() > 2.0 * inside
    # sampled just before and just after the seam: the same state
    T = ref.period
    a, b = ref.sample(np.array([T * (1 - 1e-10)])), ref.sample(np.array([T * (1 + 1e-10)]))
    assert np.max(np.abs(a.body_pos - b.body_pos)) < 1e-6
    assert np.max(angle(a.joint_quat, b.joint_quat)) < 1e-6
    assert np.max(angle(a.body_quat, b.body_quat)) < 1e-6
    assert np.max(np.abs(a.body_vel - b.body_vel)) < 1e-6


def test_velocities_are_finite_differences(ref):
    f, K, h = ref.frames, ref.num_frames, ref.frame_time
    off = ref.cycle_offset
    # central differences over the frames, the seam's neighbours from the shifted cycle
    x = np.concatenate([f.body_pos[K - 1:K] - off, f.body_pos, f.body_pos[1:2] + off])
    v = (x[2:] - x[:-2]) / (2 * h)
    assert np.max(np.abs(f.body_vel - v)) < 1e-9
    com = np.concatenate([f.com_pos[K - 1:K] - off, f.com_pos, f.com_pos[1:2] + off])
    assert np.max(np.abs(f.com_vel - (com[2:] - com[:-2]) / (2 * h))) < 1e-9
    # angular velocity: the small-angle rotation between the neighbouring frames
    q = np.concatenate([f.body_quat[K - 1:K], f.body_quat, f.body_quat[1:2]])
    d = Q.qmul(q[2:], Q.qconj(q[:-2]))
    d = d * np.sign(d[..., 3:4])
    w = 2.0 * d[..., :3] / (2 * h)
    wmax = np.abs(f.body_angvel).max()
    assert np.max(np.abs(f.body_angvel - w)) < 0.05 * wmax
    # hinge rates (computed by the world's kernel from the bodies' velocities) against the
    # finite difference of the hinge angles
    types = ref.ragdoll.model.joint_type_names
    hinge = [j for j, t in enumerate(types) if t == "hinge"]
    assert hinge
    qd_fd = (f.joint_q[2:, hinge, 0] - f.joint_q[:-2, hinge, 0]) / (2 * h)
    qd = f.joint_qd[1:-1, hinge, 0]
    assert np.max(np.abs(qd - qd_fd)) < 0.05 * np.abs(qd).max()
    # the centre of mass is the mass-weighted mean of the bodies
    m = ref.ragdoll.model.body_mass
    assert np.allclose(f.com_pos, np.einsum("b,fbi->fi", m, f.body_pos) / m.sum(), atol=1e-12)


def test_sample_at_frame_times_reproduces_frames(ref):
    f, K = ref.frames, ref.num_frames
    t = np.arange(K + 1) * ref.frame_time
    s = ref.sample(t)
    assert np.max(np.abs(s.body_pos - f.body_pos)) < 1e-9
    assert np.max(np.abs(s.com_pos - f.com_pos)) < 1e-9
    assert np.max(np.abs(s.body_vel - f.body_vel)) < 1e-9
    assert np.max(np.abs(s.body_angvel - f.body_angvel)) < 1e-9
    assert np.max(np.abs(s.joint_q - f.joint_q)) < 1e-9
    assert np.max(np.abs(s.joint_qd - f.joint_qd)) < 1e-9
    assert same_rotation(s.body_quat, f.body_quat, 1e-9)
    assert same_rotation(s.joint_quat, f.joint_quat, 1e-9)
    # written into a given sample too, and between frames a blend of its two frames
    out = ref.sample(t)
    assert ref.sample(t[::-1], out=out) is out
    assert np.max(np.abs(out.body_pos - f.body_pos[::-1])) < 1e-9
    mid = ref.sample(np.array([10.5 * ref.frame_time]))
    assert np.allclose(mid.body_pos[0], 0.5 * (f.body_pos[10] + f.body_pos[11]), atol=1e-9)
    assert np.allclose(np.linalg.norm(mid.body_quat, axis=-1), 1.0, atol=1e-12)


def test_sample_one_period_later_is_shifted_by_the_offset(ref):
    rng = np.random.default_rng(0)
    t = rng.uniform(0.0, ref.period, 40)
    for cycles in (1, 3):
        a = ref.sample(t)
        b = ref.sample(t + cycles * ref.period)
        shift = cycles * ref.cycle_offset
        assert np.max(np.abs(b.body_pos - a.body_pos - shift)) < 1e-9
        assert np.max(np.abs(b.com_pos - a.com_pos - shift)) < 1e-9
        # rotations and velocities: not at all (to the rounding of t + period)
        assert same_rotation(b.body_quat, a.body_quat, 1e-9)
        assert same_rotation(b.joint_quat, a.joint_quat, 1e-9)
        assert np.max(np.abs(b.joint_q - a.joint_q)) < 1e-9
        for name in ("body_vel", "body_angvel", "joint_qd", "com_vel"):
            assert np.max(np.abs(getattr(b, name) - getattr(a, name))) < 1e-9, name


def test_clip_played_once_holds_its_last_frame(ragdoll, walk):
    ref = ReferenceMotion(ragdoll, walk, loop=False)
    assert not ref.looped and ref.num_frames == walk.num_frames - 1
    assert np.all(ref.cycle_offset == 0.0) and ref.duration == pytest.approx(ref.period)
    s = ref.sample(np.array([ref.period, ref.period + 1.0, 50.0]))
    last = ref.frames.body_pos[-1]
    assert np.max(np.abs(s.body_pos - last)) < 1e-9
    # closing the cycle leaves frame 0 as it is
    looped = ReferenceMotion(ragdoll, walk)
    assert np.max(np.abs(ref.frames.body_pos[0] - looped.frames.body_pos[0])) < 1e-12


def test_loop_at_a_given_frame(ragdoll, walk):
    ref = ReferenceMotion(ragdoll, walk, loop=80)
    assert ref.looped and ref.num_frames == 80
    assert np.max(np.abs(ref.frames.body_pos[80] - ref.frames.body_pos[0]
                         - ref.cycle_offset)) < 1e-12
    for bad in (0, walk.num_frames, -3, 2.5, "yes"):
        with pytest.raises(tumble.ModelError, match="loop"):
            ReferenceMotion(ragdoll, walk, loop=bad)


def test_clip_missing_a_joint_is_refused(ragdoll, walk):
    names = ["lHand" if n == "lWrist" else n for n in walk.joint_names]
    renamed = tumble.Motion.from_arrays(names, walk.parents, walk.offsets, walk.local_rotations,
                                        frame_time=walk.frame_time,
                                        root_positions=walk.root_positions)
    with pytest.raises(tumble.ModelError, match="lWrist"):
        ReferenceMotion(ragdoll, renamed)


def test_pinned_ragdoll_is_refused(walk):
    pinned = tumble.games105_ragdoll("pinned")
    with pytest.raises(tumble.ModelError, match="floating"):
        ReferenceMotion(pinned, walk)


def test_wrong_arguments_are_refused(ragdoll, walk):
    with pytest.raises(tumble.ModelError, match="Ragdoll"):
        ReferenceMotion(ragdoll.model, walk)
    with pytest.raises(tumble.ModelError, match="Motion"):
        ReferenceMotion(ragdoll, "walk")


def test_ground_lift_puts_the_stance_foot_on_the_ground():
    """The course walk's foot boxes sit up to 4 cm inside the ground as captured; placed on
    the ground, no frame's lowest colliding point is below it and stance frames touch it."""
    from tumble.rl.reference import lowest_points
    rd = tumble.games105_ragdoll()
    motion = tumble.load_bvh(clip_path("walk"))
    raw = ReferenceMotion(rd, motion, ground=False)
    placed = ReferenceMotion(rd, motion)
    low_raw = lowest_points(rd.model, raw.frames.body_pos, raw.frames.body_quat, 1)
    low = lowest_points(rd.model, placed.frames.body_pos, placed.frames.body_quat, 1)
    assert low_raw.min() < -0.03                     # as captured: 3-4 cm deep
    assert low.min() > -1e-9
    assert np.mean(np.abs(low) < 1e-9) > 0.8         # most frames touch the ground
    np.testing.assert_allclose(placed.ground_lift, np.maximum(-low_raw, 0.0), atol=1e-12)
    # only heights move
    d = placed.frames.body_pos - raw.frames.body_pos
    np.testing.assert_allclose(d[..., [0, 2]], 0.0, atol=1e-12)
