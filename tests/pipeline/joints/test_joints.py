"""Joints as constraints: analytic pendulums, drift, limits, motors, soft joints, solvers."""
import warnings

import numpy as np
import pytest

import tumble
import tumble.pipeline.joints.common
from tumble.apps import benchmarks
from scipy.spatial.transform import Rotation


def crossing_times(t, x):
    """Times where x changes sign, linearly interpolated."""
    i = np.where(np.diff(np.sign(x)) != 0)[0]
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def pendulum(joint, dt, solver="direct", amplitude=0.05, length=1.0, mass=1.0, i0=0.01):
    b = tumble.ModelBuilder()
    b.add_body("bob", pos=(length * np.sin(amplitude), 0, -length * np.cos(amplitude)),
               mass=mass, inertia=(i0, i0, i0))
    kwargs = dict(axis=(0, 1, 0)) if joint == "hinge" else {}
    b.add_joint("pivot", joint, None, "bob", anchor=(0, 0, 0), **kwargs)
    return tumble.World(b.build(), dt=dt, solver=solver)


@pytest.mark.parametrize("joint,solver", [("hinge", "direct"), ("ball", "direct"), ("hinge", "pgs")])
def test_small_amplitude_pendulum_period(joint, solver):
    """T = 2 pi sqrt(I / (m g d)) about the pivot, within 0.2%."""
    dt = 1e-3
    w = pendulum(joint, dt, solver)
    t, x = [], []
    for _ in range(6000):
        w.step()
        t.append(w.time)
        x.append(w.body_pos[0, 0])
    crossings = crossing_times(np.array(t), np.array(x))
    period = 2 * np.mean(np.diff(crossings))
    expected = 2 * np.pi * np.sqrt((1.0 + 0.01) / 9.81)
    assert period == pytest.approx(expected, rel=2e-3)


@pytest.mark.parametrize("projection,max_loss", [(2, 0.20), (0, 0.02)])
def test_double_pendulum_energy_drift_is_bounded(projection, max_loss):
    """10 s of chaotic swinging at dt = 1 ms: the energy never grows by more than 1%.

    Velocity-level constraints dissipate once positions are projected (the next solve
    removes the velocity normal to the corrected configuration): up to 20% in 10 s here
    with the default projection, under 2% with ERP alone (projection=0), which instead
    lets joints drift by up to ~1e-5 m.
    """
    b = tumble.ModelBuilder()
    b.add_body("upper", pos=(0.5, 0, 0), mass=1.0, inertia=(0.002, 0.02, 0.02))
    b.add_body("lower", pos=(1.5, 0, 0), mass=1.0, inertia=(0.002, 0.02, 0.02))
    b.add_joint("shoulder", "hinge", None, "upper", anchor=(0, 0, 0), axis=(0, 1, 0))
    b.add_joint("elbow", "hinge", "upper", "lower", anchor=(1, 0, 0), axis=(0, 1, 0))
    w = tumble.World(b.build(), dt=1 / 1000, projection=projection)
    e0 = sum(w.energy())
    scale = 2 * 9.81 * 2.0                       # potential released falling from horizontal
    drift = []
    for _ in range(100):
        w.step(100)
        drift.append((sum(w.energy()) - e0) / scale)
    assert max(drift) < 0.01
    assert min(drift) > -max_loss
    assert w.joint_separation().max() < (1e-4 if projection else 1e-3)


JOINTS = {
    "ball": {}, "hinge": dict(axis=(0, 0, 1)), "fixed": {}, "slider": dict(axis=(1, 0, 0)),
    "universal": dict(axis=(0, 1, 0), axis2=(0, 0, 1)),
}


@pytest.mark.parametrize("kind", sorted(JOINTS))
@pytest.mark.parametrize("solver", ["direct", "pgs"])
def test_every_joint_type_holds_together_while_tumbling(kind, solver):
    """Two bodies thrown spinning: anchors apart by < 1e-4 m after 10 s, motion as allowed."""
    b = tumble.ModelBuilder(gravity=(0, 0, -9.81))
    b.add_body("a", pos=(0, 0, 0), mass=2.0, inertia=(0.02, 0.03, 0.04), angvel=(3, -2, 5),
               vel=(1, 0, 4))
    b.add_body("b", pos=(0.4, 0, 0), mass=1.0, inertia=(0.01, 0.015, 0.02), angvel=(-4, 6, 1),
               vel=(0, 2, 4))
    b.add_joint("j", kind, "a", "b", anchor=(0.2, 0, 0), **JOINTS[kind])
    w = tumble.World(b.build(), dt=1 / 240, solver=solver)
    w.step(2400)
    assert np.all(np.isfinite(w.body_pos))
    gap = np.subtract(*tumble.pipeline.joints.common.joint_frames(
        w.model.arrays, w.body_pos, w.body_quat, 0)[1::-1])
    if kind == "slider":                               # anchors may part along the axis only
        axis = Rotation.from_quat(w.body_quat[0]).apply(
            Rotation.from_quat(w.model.joint_frame_a[0]).apply([1.0, 0, 0]))
        gap = gap - axis * (gap @ axis)
    assert np.linalg.norm(gap) < 1e-4
    if kind == "fixed":
        np.testing.assert_allclose(w.joint_quat[0][:3], 0.0, atol=1e-4)


def test_slider_keeps_orientation_and_moves_along_its_axis():
    b = tumble.ModelBuilder(gravity=(0, 0, 0))
    b.add_body("rail", pos=(0, 0, 0), mass=5.0, inertia=(0.1, 0.1, 0.1), angvel=(0, 0, 2))
    b.add_body("cart", pos=(0.5, 0, 0), mass=1.0, inertia=(0.01, 0.01, 0.01), vel=(0, 0, 0))
    b.add_joint("track", "slider", "rail", "cart", axis=(1, 0, 0))
    w = tumble.World(b.build(), dt=1 / 240)
    w.step(480)
    rail_x = w.vector_to_world("rail", (1, 0, 0))
    offset = w.body_pos[1] - w.body_pos[0]
    perp = offset - rail_x * (offset @ rail_x)
    assert np.linalg.norm(perp) < 1e-4                 # the cart stays on the rail's axis
    np.testing.assert_allclose(w.joint_quat[0][:3], 0.0, atol=1e-4)
    assert w.joint_q[0, 0] > 0.1                        # centrifugal: slides outwards


def test_hinge_limit_stops_the_swing():
    b = tumble.ModelBuilder()
    b.add_body("door", pos=(0.5, 0, 0), mass=1.0, inertia=(0.01, 0.08, 0.08))
    b.add_joint("hinge", "hinge", None, "door", anchor=(0, 0, 0), axis=(0, -1, 0),
                limit=(-0.3, 0.5))
    w = tumble.World(b.build(), dt=1 / 240)
    lowest = 0.0
    for _ in range(480):
        w.step()
        lowest = min(lowest, -w.joint_q[0, 0])
        assert w.joint_q[0, 0] > -0.3 - 0.01 and w.joint_q[0, 0] < 0.5 + 0.01
    assert w.joint_q[0, 0] == pytest.approx(-0.3, abs=2e-3)   # resting on the lower stop
    # the stop carries the door's weight torque: m g d cos(0.3)
    assert abs(w.joint_torque[0] @ np.array([0, -1, 0])) == pytest.approx(
        9.81 * 0.5 * np.cos(0.3), rel=0.02)


@pytest.mark.parametrize("solver", ["direct", "pgs"])
def test_motor_reaches_target_speed_under_load_within_its_torque(solver):
    b = tumble.ModelBuilder()
    b.add_body("arm", pos=(0.3, 0, 0), mass=2.0, inertia=(0.01, 0.06, 0.06))
    b.add_joint("motor", "hinge", None, "arm", anchor=(0, 0, 0), axis=(0, 1, 0),
                motor_max_force=20.0)
    w = tumble.World(b.build(), dt=1 / 240, solver=solver)
    w.joint_motor_target[0, 0] = 2.0                   # rad/s about the axis
    torques = []
    for _ in range(240):
        w.step()
        torques.append(abs(w.joint_torque[0] @ [0, 1, 0]))
    assert w.joint_qd[0, 0] == pytest.approx(2.0, abs=1e-3)   # turning against gravity
    assert max(torques) <= 20.0 + 1e-6
    # too weak to lift the arm (needs m g d = 5.9 N m): it stalls at its bound
    b2 = tumble.ModelBuilder()
    b2.add_body("arm", pos=(0.3, 0, 0), mass=2.0, inertia=(0.01, 0.06, 0.06))
    b2.add_joint("motor", "hinge", None, "arm", anchor=(0, 0, 0), axis=(0, 1, 0),
                 motor_max_force=3.0)
    weak = tumble.World(b2.build(), dt=1 / 240, solver=solver)
    weak.joint_motor_target[0, 0] = -2.0               # trying to lift (axis +y: -angle is up)
    weak.step(10)
    assert abs(weak.joint_torque[0] @ [0, 1, 0]) == pytest.approx(3.0, rel=1e-6)


def test_soft_joint_is_the_spring_it_was_given():
    """A ball joint given as spring k sags by m g / k under a hanging mass."""
    k, c, m = 2000.0, 50.0, 2.0
    b = tumble.ModelBuilder()
    b.add_body("weight", pos=(0, 0, -0.1), mass=m, inertia=(0.01, 0.01, 0.01))
    b.add_joint("spring", "ball", None, "weight", anchor=(0, 0, -0.1), spring=(k, c))
    for dt in (1 / 60, 1 / 1000):
        w = tumble.World(b.build(), dt=dt)
        w.step(int(3.0 / dt))
        assert w.joint_separation()[0] == pytest.approx(m * 9.81 / k, rel=1e-3)


def test_erp_cfm_mapping():
    from tumble.pipeline.joints.rows import soft_erp_cfm
    erp, cfm = soft_erp_cfm(1000.0, 10.0, 0.01)
    assert erp == pytest.approx(10 / 20) and cfm == pytest.approx(1 / 20)


def test_chain_scene_stays_together_without_gaining_energy():
    """The 30-link chain of tumble.apps.benchmarks: dt 1/240, 2000 steps."""
    b = tumble.ModelBuilder(gravity=(0, 0, benchmarks.GRAVITY))
    parent = None
    for i, link in enumerate(benchmarks.chain_links()):
        b.add_body(f"link{i}", pos=link["com"], mass=link["mass"], inertia=link["inertia"])
        b.add_joint(f"joint{i}", "ball", parent, f"link{i}", anchor=link["joint"])
        parent = f"link{i}"
    w = tumble.World(b.build(), dt=benchmarks.CHAIN["dt"])
    e0 = sum(w.energy())
    worst_gain, worst_gap = -np.inf, 0.0
    for _ in range(benchmarks.CHAIN["steps"] // 10):
        w.step(10)
        worst_gain = max(worst_gain, (sum(w.energy()) - e0) / benchmarks.chain_energy_scale())
        worst_gap = max(worst_gap, w.joint_separation().max())
    assert np.all(np.isfinite(w.body_pos))
    assert worst_gap < 1e-3
    assert worst_gain < 0.02


def test_direct_and_pgs_agree_on_a_loaded_structure():
    """A beam on a hinge held level by a second link: same reactions from both solvers."""
    def build(solver):
        b = tumble.ModelBuilder()
        b.add_body("beam", pos=(0.5, 0, 0), mass=3.0, inertia=(0.01, 0.25, 0.25))
        b.add_body("strut", pos=(1.0, 0, 0.5), mass=0.5, inertia=(0.04, 0.04, 0.001))
        b.add_joint("wall", "hinge", None, "beam", anchor=(0, 0, 0), axis=(0, 1, 0))
        b.add_joint("pin", "ball", "beam", "strut", anchor=(1.0, 0, 0))
        b.add_joint("ceiling", "ball", None, "strut", anchor=(1.0, 0, 1.0))
        return tumble.World(b.build(), dt=1 / 240, solver=solver, iterations=500,
                            tolerance=1e-12)
    d, p = build("direct"), build("pgs")
    d.step(240)
    p.step(240)
    np.testing.assert_allclose(p.joint_force, d.joint_force, atol=2e-3 * 3.5 * 9.81)
    # the wall carries half the beam: 3 * 9.81 / 2 up
    assert d.joint_force[0, 2] == pytest.approx(3 * 9.81 / 2, rel=1e-3)
    assert np.abs(d.body_vel).max() < 1e-6


@pytest.mark.parametrize("args,kwargs,message", [
    (("hinge", None, "a"), dict(axis=(0, 0, 0)), "axis is the zero vector"),
    (("hinge", None, "a"), dict(), "needs an axis"),
    (("universal", None, "a"), dict(axis=(1, 0, 0), axis2=(1, 0, 0)), "perpendicular"),
    (("ball", "a", "a"), dict(), "to itself"),
    (("ball", None, "nobody"), dict(), "unknown body 'nobody'"),
    (("ball", "a", None), dict(), "child must be a body"),
    (("twist", None, "a"), dict(), "type must be"),
    (("fixed", None, "a"), dict(limit=(0, 1)), "limits apply"),
    (("ball", None, "a"), dict(axis=(1, 0, 0), axis2=(1, 0, 0)), "perpendicular"),
    (("hinge", None, "a"), dict(axis=(0, 1, 0), limit=(1, 0)), "above upper"),
    (("free", "a", "w"), dict(), "no parent"),
])
def test_bad_joints_are_refused(args, kwargs, message):
    b = tumble.ModelBuilder()
    b.add_body("a", mass=1.0, inertia=(1, 1, 1))
    b.add_body("w", kind="static")
    with pytest.raises(tumble.ModelError, match=message) as err:
        b.add_joint("knee", *args, **kwargs)
    assert "joint 'knee'" in str(err.value)
    assert b.build().njoint == 0


def test_far_anchor_warns_and_loops_are_legal():
    b = tumble.ModelBuilder()
    b.add_body("a", mass=1.0, inertia=(1, 1, 1))
    b.add_body("b", pos=(1, 0, 0), mass=1.0, inertia=(1, 1, 1))
    with pytest.warns(tumble.errors.TumbleWarning, match="joint 'far'"):
        b.add_joint("far", "ball", "a", "b", anchor=(10, 10, 10))
    b2 = tumble.ModelBuilder()
    for i, x in enumerate((0.0, 1.0, 1.0, 0.0)):
        b2.add_body(f"l{i}", pos=(x, 0, -float(i in (1, 2))), mass=1.0, inertia=(0.1, 0.1, 0.1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for i in range(4):
            b2.add_joint(f"j{i}", "hinge", f"l{i}", f"l{(i + 1) % 4}", axis=(0, 1, 0),
                         anchor=b2._bodies[(i + 1) % 4]["pos"])
        b2.add_joint("pin", "hinge", None, "l0", axis=(0, 1, 0))
    w = tumble.World(b2.build(), dt=1 / 240)
    w.step(240)
    assert w.joint_separation().max() < 1e-4         # the default projection tolerance


@pytest.mark.parametrize("joint,axes", [("ball", dict(axis=(0, 1, 0), axis2=(0, 0, 1))),
                                        ("universal", dict(axis=(1, 0, 0), axis2=(0, 1, 0)))])
def test_ball_and_universal_limits_bound_every_coordinate(joint, axes):
    """A bob thrown sideways on a joint limited to +-0.3 rad: every coordinate stays inside
    (to the limit rows' ERP overshoot, 0.02 rad) and the limit is reached."""
    b = tumble.ModelBuilder()
    b.add_body("bob", pos=(0, 0, -1), mass=1.0, inertia=(0.01, 0.01, 0.01), vel=(2.0, 1.5, 0))
    b.add_joint("j", joint, None, "bob", anchor=(0, 0, 0), limit=(-0.3, 0.3), **axes)
    w = tumble.World(b.build(), dt=1 / 480)
    worst = 0.0
    for _ in range(96):
        w.step(5)
        worst = max(worst, np.abs(w.joint_q[0]).max())
    assert 0.25 < worst < 0.32


def test_oriented_ball_frame_sets_the_coordinate_axes():
    """A ball joint with axis = y: a swing about world y is coordinate 0, the others stay 0."""
    b = tumble.ModelBuilder()
    b.add_body("bob", pos=(0, 0, -1), mass=1.0, inertia=(0.01, 0.01, 0.01), vel=(0.5, 0, 0))
    b.add_joint("j", "ball", None, "bob", anchor=(0, 0, 0), axis=(0, 1, 0), axis2=(0, 0, 1))
    w = tumble.World(b.build(), dt=1 / 480)
    w.step(48)
    q = w.joint_q[0]
    assert q[0] < -0.01 and abs(q[1]) < 1e-9 and abs(q[2]) < 1e-9
