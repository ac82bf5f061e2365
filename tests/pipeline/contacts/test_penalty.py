"""Penalty contacts' integration: the implicit springs of free bodies against linearly
implicit Euler worked out in NumPy, the explicit ones against explicit Euler, and what the
implicit form is for: a pyramid of boxes on eight contacts each at rest at 1/240 s."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import tumble
from tumble.apps import benchmarks

G = 9.81
MU = 0.5
HALF = 0.5
INERTIA = 1.0 / 6.0          # a unit cube of 1 kg


def tilted_box(rotvec, depth, vel, angvel, integration):
    """A unit box of 1 kg turned by ``rotvec`` whose lowest corner is ``depth`` (m) into
    the ground plane, moving at ``vel``/``angvel``; no gyroscopic term, so the step's
    angular velocity change is the torque's alone."""
    rot = Rotation.from_rotvec(rotvec)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1)
                        for sz in (-1, 1)]) * HALF
    lowest = rot.apply(corners)[:, 2].min()
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane", friction=MU)
    b.add_body("box", pos=(0.0, 0.0, -lowest - depth), quat=rot.as_quat(), mass=1.0,
               inertia=(INERTIA,) * 3, vel=vel, angvel=angvel)
    b.add_geom("box", "box", size=(HALF,) * 3, friction=MU)
    return tumble.World(b.build(), dt=1 / 240, contact="penalty", gyroscopic="none",
                        penalty_integration=integration)


def expected_velocities(world, pos, quat, vel, angvel, implicit):
    """The box's velocities after one step from (pos, quat, vel, angvel) on the contacts
    the step found, and the contacts' normal forces (N; implicit: at the end of the step),
    by (linearly implicit or explicit) Euler: springs ``k d`` and dampers
    ``c`` along the normal, a stick spring ``-k h v_t`` minus ``c v_t`` (new contacts)
    capped at ``mu f_n`` in the tangent plane; implicit: ``-h k v_n`` more on the normal
    and ``(M + h D) dv = h F``, D the dampers plus h k on the box's 6x6."""
    k, c = world.penalty_parameters()
    h = world.dt
    d_spring = c + h * k if implicit else c
    inertia = Rotation.from_quat(quat).as_matrix() @ np.diag([INERTIA] * 3) \
        @ Rotation.from_quat(quat).as_matrix().T
    wrench, damping = np.array([0.0, 0.0, -G, 0.0, 0.0, 0.0]), np.zeros((6, 6))
    con = world.contacts
    for i in range(len(con)):
        if con.depth[i] <= 0.0:
            continue
        side = 1.0 if con.bodies[i, 1] == 0 else -1.0   # force on the box: side * f
        n, r = con.normal[i], con.point[i] - pos
        lever = np.hstack([np.eye(3), -np.cross(np.eye(3), r)]).T   # G (6, 3): f -> wrench
        rel = side * (vel + np.cross(angvel, r))
        vn = rel @ n
        fn = max(k * con.depth[i] - d_spring * vn, 0.0)
        vt = rel - vn * n
        ft = -k * h * vt - c * vt
        d_t = c + h * k
        if np.linalg.norm(ft) > MU * fn:
            ft *= MU * fn / np.linalg.norm(ft)
            d_t = 0.0
        wrench += lever @ (side * (fn * n + ft))
        if implicit and fn > 0.0:
            p = d_t * np.eye(3) + (d_spring - d_t) * np.outer(n, n)
            damping += lever @ p @ lever.T
    mass = np.zeros((6, 6))
    mass[:3, :3], mass[3:, 3:] = np.eye(3), inertia
    dv = h * np.linalg.solve(mass + h * damping, wrench)
    # the contacts' normal forces at the end of the step: less the damping of the change
    normal = []
    for i in range(len(con)):
        side = 1.0 if con.bodies[i, 1] == 0 else -1.0
        n, r = con.normal[i], con.point[i] - pos
        vn = side * (vel + np.cross(angvel, r)) @ n
        fn = max(k * con.depth[i] - d_spring * vn, 0.0) if con.depth[i] > 0.0 else 0.0
        if implicit and fn > 0.0:
            fn = max(fn - d_spring * side * (dv[:3] + np.cross(dv[3:], r)) @ n, 0.0)
        normal.append(fn)
    return vel + dv[:3], angvel + dv[3:], np.array(normal)


@settings(max_examples=25, deadline=None)
@given(tilt=st.lists(st.floats(-0.4, 0.4), min_size=3, max_size=3),
       depth=st.floats(1e-4, 3e-3),
       vel=st.lists(st.floats(-0.5, 0.5), min_size=3, max_size=3),
       angvel=st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3),
       integration=st.sampled_from(["implicit", "explicit"]))
def test_a_step_is_linearly_implicit_or_explicit_euler(tilt, depth, vel, angvel,
                                                        integration):
    w = tilted_box(tilt, depth, vel, angvel, integration)
    pos, quat = w.body_pos[0].copy(), w.body_quat[0].copy()
    v0, w0 = w.body_vel[0].copy(), w.body_angvel[0].copy()
    w.step()
    assert len(w.contacts) > 0
    vel1, angvel1, normal = expected_velocities(w, pos, quat, v0, w0,
                                                integration == "implicit")
    np.testing.assert_allclose(w.body_vel[0], vel1, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(w.body_angvel[0], angvel1, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(w.contacts.normal_force, normal, rtol=1e-9, atol=1e-9)


def small_pyramid(integration, base=6):
    """The bench's pyramid with ``base`` boxes in its bottom row, at 1/240 s: each box
    straddles two below, on eight corner contacts, and carries two above."""
    cfg = dict(benchmarks.PYRAMID, base=base, dt=1 / 240)
    h, pitch = cfg["half"], 2 * cfg["half"] + cfg["gap"]
    pos = [(-0.5 * (base - row - 1) * pitch + i * pitch, 0.0, h + 2 * h * row)
           for row in range(base) for i in range(base - row)]
    return tumble.World(benchmarks._boxes(cfg, pos), contact="penalty",
                        penalty_integration=integration)


def test_a_pyramid_of_21_boxes_rests_on_implicit_springs_and_not_on_explicit_ones():
    """Defaults at 1/240 s. Implicit: at rest within 3 s, sunk by the springs' load (under
    1 cm at the top) and nothing moved sideways by a mm. The explicit springs (past their
    stability limit on eight contacts) keep the boxes jittering apart."""
    w = small_pyramid("implicit")
    p0 = w.body_pos.copy()
    w.step(720)
    assert np.abs(w.body_vel).max() < 1e-3 and np.abs(w.body_angvel).max() < 1e-3
    assert np.abs(w.body_pos[:, :2] - p0[:, :2]).max() < 1e-3
    sink = p0[:, 2] - w.body_pos[:, 2]
    assert 0.0 < sink.min() and sink.max() < 0.01
    assert np.all(np.diff(sink[[0, 6, 11, 15, 18, 20]]) > 0)   # more springs in series
    explicit = small_pyramid("explicit")
    explicit.step(720)
    assert np.linalg.norm(explicit.body_vel, axis=1).max() > 0.05


def test_bodies_in_joints_keep_explicit_springs():
    """A hinged bar dropped onto the ground: the same motion, bit for bit, under either
    option (its joint's force comes after the forces stage, so it stays explicit)."""
    def run(integration):
        b = tumble.ModelBuilder()
        b.add_geom(None, "plane", friction=MU)
        b.add_body("bar", pos=(0.5, 0.0, 0.12), mass=1.0, inertia=(0.01, 0.1, 0.1))
        b.add_geom("bar", "box", size=(0.5, 0.05, 0.05), friction=MU)
        b.add_joint("hinge", "hinge", None, "bar", anchor=(0.0, 0.0, 0.12),
                    axis=(0.0, 1.0, 0.0), collide=True)
        w = tumble.World(b.build(), dt=1 / 240, contact="penalty",
                         penalty_integration=integration)
        w.step(240)
        return w.body_pos.copy(), w.body_quat.copy(), len(w.contacts)
    (p1, q1, n1), (p2, q2, n2) = run("implicit"), run("explicit")
    assert n1 > 0 and n2 == n1
    np.testing.assert_array_equal(p1, p2)
    np.testing.assert_array_equal(q1, q2)


def test_the_integration_can_change_between_steps():
    w = small_pyramid("explicit", base=2)
    w.step(10)
    w.penalty_integration = "implicit"
    w.step(240)
    assert np.abs(w.body_vel).max() < 1e-3
    with pytest.raises(tumble.ModelError, match="penalty_integration must be one of"):
        w.penalty_integration = "semi"


def test_batched_worlds_on_threads_match_the_serial_step():
    """Three small pyramids, each started with its own velocities, on threads and serially:
    bit for bit (each thread's scratch holds its own implicit systems)."""
    model = small_pyramid("implicit", base=3).model
    runs = []
    for parallel in (True, False):
        w = tumble.World(model, nworld=3, parallel=parallel, contact="penalty")
        rng = np.random.default_rng(1)
        w.body_vel[:] += rng.normal(scale=0.3, size=(3, model.nbody, 3))
        w.step(120)
        runs.append((w.body_pos.copy(), w.body_angvel.copy(), w.contacts_of(2).force.copy()))
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)
    assert len(runs[0][2]) > 0
