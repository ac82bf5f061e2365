"""Ball-joint swing cone and twist limits (issue 4): unilateral rows on the swing-twist
decomposition, checked against where gravity must leave a pendulum on the cone, where a
spun body must stop, and the energy it may not gain."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble
from tumble.pipeline.joints import ball

G = 9.81
L = 0.5                                     # bob distance from the anchor, m


def cone_pendulum(solver="direct", gravity=(0, 0, -G), **joint):
    """A 1 kg bob at (L, 0, 0) on a ball joint at the origin whose twist axis is world x."""
    b = tumble.ModelBuilder(gravity=gravity)
    b.add_body("bob", pos=(L, 0, 0), mass=1.0, inertia=(0.004, 0.004, 0.004))
    b.add_joint("j", "ball", None, "bob", anchor=(0, 0, 0), axis=(1, 0, 0), **joint)
    return tumble.World(b.build(), dt=1 / 240, solver=solver)


def place(w, rot):
    """Turn the bob about the anchor by ``rot`` from its built pose."""
    w.body_pos[0] = rot.apply([L, 0, 0])
    w.body_quat[0] = (rot * Rotation.from_quat(w.model.body_quat0[0])).as_quat()
    w.body_vel[0] = 0.0
    w.body_angvel[0] = 0.0


def swing(w):
    """Swing angle of the bob's axis from the joint's x axis, and its unit direction."""
    d = w.body_pos[0] / np.linalg.norm(w.body_pos[0])
    return np.arccos(np.clip(d[0], -1, 1)), d


def twist(w):
    q = w.joint_quat[0]
    t = 2 * np.arctan2(q[0], q[3])
    return (t + np.pi) % (2 * np.pi) - np.pi


def ellipse_measure(d, a, b):
    """theta * s(psi): <= 1 inside the elliptical cone (a about y, b about z)."""
    theta = np.arccos(np.clip(d[0], -1, 1))
    u = np.cross([1.0, 0, 0], d)
    u /= np.linalg.norm(u)
    return theta * np.hypot(u[1] / a, u[2] / b)


@pytest.mark.parametrize("solver", ["direct", "pgs"])
@pytest.mark.parametrize("start", ["on the axis", "outside, below", "outside, sideways"])
def test_pendulum_settles_on_the_cone_boundary(solver, start):
    """Gravity pulls the bob below the horizontal cone axis: it comes to rest on the cone,
    straight below the axis, at angle = cone from it (within 1e-3 rad)."""
    cone = 0.5
    w = cone_pendulum(solver, cone=cone, damping=0.8)
    if start == "outside, below":
        place(w, Rotation.from_rotvec([0, 1.2, 0]))              # 1.2 rad below the axis
    elif start == "outside, sideways":
        place(w, Rotation.from_rotvec([0, 0, 0.9]))              # 0.9 rad to the side
    w.step(1440)
    angle, d = swing(w)
    assert angle == pytest.approx(cone, abs=1e-3)
    np.testing.assert_allclose(d, [np.cos(cone), 0, -np.sin(cone)], atol=2e-3)
    assert np.abs(w.body_vel).max() < 1e-3


@pytest.mark.parametrize("solver", ["direct", "pgs"])
def test_elliptical_cone_bounds_each_direction(solver):
    """Cone (0.3 about y, 0.6 about z): hanging under gravity along -z the bob rests at
    0.3 rad from the axis, along -y at 0.6 rad; thrown around without gravity it never
    leaves the ellipse by more than the limit rows' one-step overshoot."""
    a, b = 0.3, 0.6
    down = cone_pendulum(solver, cone=(a, b), damping=0.3)
    down.step(1440)
    assert swing(down)[0] == pytest.approx(a, abs=1e-3)
    side = cone_pendulum(solver, gravity=(0, -G, 0), cone=(a, b), damping=0.3)
    side.step(1440)
    angle, d = swing(side)
    assert angle == pytest.approx(b, abs=1e-3) and d[1] < 0
    for v in ([0, 0.8, 0.3], [0, -0.4, 0.9], [0.1, -0.6, -0.6], [0, 0.2, -1.5]):
        w = cone_pendulum(solver, gravity=(0, 0, 0), cone=(a, b))
        w.body_vel[0] = v
        worst = 0.0
        for _ in range(240):
            w.step()
            worst = max(worst, ellipse_measure(swing(w)[1], a, b))
        assert 0.99 < worst < 1.02, v


@pytest.mark.parametrize("solver", ["direct", "pgs"])
@pytest.mark.parametrize("tilt", [0.0, 0.6])
def test_twist_limit_stops_a_spun_body(solver, tilt):
    """A bob spun about its own axis (the twist axis, swung by ``tilt`` from the parent's)
    stops at the twist bound it turns toward and stays there. Swung, the stop's torque
    (along (x_a + x_b) / (1 + x_a . x_b), the twist's gradient) also nudges the swing by
    tan(tilt / 2) of its angular impulse, as the swing-twist coordinates require."""
    lo, hi = -0.3, 0.4
    for rate, bound in ((3.0, hi), (-3.0, lo)):
        w = cone_pendulum(solver, gravity=(0, 0, 0), twist=(lo, hi))
        rot = Rotation.from_rotvec([0, 0, tilt])
        place(w, rot)
        w.body_angvel[0] = rate * rot.apply([1.0, 0, 0])
        seen = []
        for _ in range(120):
            w.step()
            seen.append(twist(w))
        assert twist(w) == pytest.approx(bound, abs=2e-3)
        assert lo - 0.01 < min(seen) and max(seen) < hi + 0.01
        assert abs(seen[-1] - seen[-20]) < 1e-6                      # stopped there
        # swing rate from the stop's sideways angular impulse: about the anchor the bob has
        # inertia m L^2 + I; the spin it lost had I * |rate|
        swing_rate = np.tan(tilt / 2) * 0.004 * abs(rate) / (L * L + 0.004)
        assert np.linalg.norm(w.body_vel[0]) / L == pytest.approx(swing_rate, abs=1e-3 * abs(rate))
        assert swing(w)[0] == pytest.approx(tilt, abs=0.01)


def test_cone_and_twist_together_hold_a_tumbling_body():
    """Thrown and spun at once: swing and twist stay within their bounds (one-step
    overshoot, 0.02 rad), and the anchor holds."""
    w = cone_pendulum(cone=0.7, twist=(-0.5, 0.5))
    w.body_vel[0] = (0, 1.5, 2.0)
    w.body_angvel[0] = (6.0, 0, 0)
    worst_swing = worst_twist = 0.0
    for _ in range(480):
        w.step()
        worst_swing = max(worst_swing, swing(w)[0])
        worst_twist = max(worst_twist, abs(twist(w)))
    assert 0.65 < worst_swing < 0.72
    assert 0.45 < worst_twist < 0.52
    assert w.joint_separation()[0] < 1e-4


@pytest.mark.parametrize("solver", ["direct", "pgs"])
def test_cone_limit_adds_no_energy(solver):
    """An undamped pendulum thrown around inside a 0.6 rad cone for 5 s: its energy never
    rises above the start by more than 0.1% of m g L (the stops only take energy out)."""
    w = cone_pendulum(solver, cone=0.6)
    w.body_vel[0] = (0, 1.2, 0.5)
    e0 = sum(w.energy())
    worst = -np.inf
    for _ in range(240):
        w.step(5)
        worst = max(worst, sum(w.energy()) - e0)
    assert worst < 1e-3 * G * L
    assert sum(w.energy()) < e0                     # the hits on the cone dissipated


def test_rates_of_swing_and_twist_match_finite_differences():
    """The axes the rows use give d(twist)/dt and d(swing measure)/dt exactly."""
    rng = np.random.default_rng(3)
    a, b = 0.4, 0.9
    ident = np.array([0.0, 0.0, 0.0, 1.0])
    for _ in range(20):
        rel = Rotation.from_rotvec(rng.normal(size=3) * 0.8)
        w = rng.normal(size=3)
        dt = 1e-7
        rel2 = Rotation.from_rotvec(w * dt) * rel
        tau, e_t, ok = ball.twist_terms(ident, rel.as_quat())
        tau2 = ball.twist_terms(ident, rel2.as_quat())[0]
        assert ok and (tau2 - tau) / dt == pytest.approx(np.dot(e_t, w), rel=1e-5, abs=1e-6)
        margin, e_s, ok = ball.swing_terms(ident, rel.as_quat(), a, b)
        margin2 = ball.swing_terms(ident, rel2.as_quat(), a, b)[0]
        d = rel.apply([1.0, 0, 0])
        s = ellipse_measure(d, a, b) / np.arccos(d[0])      # 1 / cone radius this way
        # the row's rate is that of theta * s(psi) / s(psi) at fixed s: d(g)/dt / s
        d2 = rel2.apply([1.0, 0, 0])
        rate_g = (ellipse_measure(d2, a, b) - ellipse_measure(d, a, b)) / dt
        assert ok and rate_g / s == pytest.approx(np.dot(e_s, w), rel=1e-5, abs=1e-6)
        assert margin == pytest.approx(1 / s - np.arccos(d[0]))
        del margin2


@pytest.mark.parametrize("kwargs,message", [
    (dict(cone=0.0), r"cone swing_y must be in \(0, pi\)"),
    (dict(cone=-0.2), r"cone swing_y must be in \(0, pi\)"),
    (dict(cone=np.pi), r"cone swing_y must be in \(0, pi\)"),
    (dict(cone=(0.3, 4.0)), r"cone swing_z must be in \(0, pi\)"),
    (dict(cone=(0.3, np.nan)), r"cone swing_z must be in \(0, pi\)"),
    (dict(cone=(0.1, 0.2, 0.3)), "cone must be an angle or"),
    (dict(cone="wide"), "cone must be an angle or"),
    (dict(twist=(0.5, 0.1)), "twist lower 0.5 is above upper 0.1"),
    (dict(twist=(-4.0, 0.0)), r"twist must lie within \[-pi, pi\]"),
    (dict(twist=(0.0,)), "twist must be 2 numbers"),
    (dict(cone=0.5, limit=(-1, 1)), "not both"),
])
def test_bad_cone_and_twist_are_refused(kwargs, message):
    b = tumble.ModelBuilder()
    b.add_body("a", mass=1.0, inertia=(1, 1, 1))
    with pytest.raises(tumble.ModelError, match=message) as err:
        b.add_joint("shoulder", "ball", None, "a", **kwargs)
    assert "joint 'shoulder'" in str(err.value)
    with pytest.raises(tumble.ModelError, match="apply to ball joints, not hinge"):
        b.add_joint("elbow", "hinge", None, "a", axis=(0, 1, 0), cone=0.5)
    assert b.build().njoint == 0


def test_model_reports_cone_and_twist():
    b = tumble.ModelBuilder()
    b.add_body("a", mass=1.0, inertia=(1, 1, 1))
    b.add_body("c", pos=(1, 0, 0), mass=1.0, inertia=(1, 1, 1))
    b.add_joint("j0", "ball", None, "a", cone=0.4)
    b.add_joint("j1", "ball", "a", "c", anchor=(0.5, 0, 0), cone=(0.2, 0.5), twist=(-1, 1))
    m = b.build()
    np.testing.assert_array_equal(m.joint_cone, [[0.4, 0.4], [0.2, 0.5]])
    assert m.joint_twist[0, 0] > m.joint_twist[0, 1]                # none
    np.testing.assert_array_equal(m.joint_twist[1], [-1, 1])
