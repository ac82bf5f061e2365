"""Projected Gauss-Seidel (``solvers/pgs.py``) and what ends its sweeps.

PGS stops after ``iterations`` sweeps, or sooner when a sweep changes no impulse by more
than ``tolerance`` (N s) or no row's velocity by more than ``velocity_tolerance`` (m/s,
rad/s). The second criterion is the one that ends PGS on redundant contacts, whose
impulses shift among themselves long after the velocities have settled."""
import numpy as np
from hypothesis import given, settings, strategies as st

from tests.pipeline.test_solve import knocked_over
from tumble.pipeline.solvers.common import make_rows_nb
from tumble.pipeline.solvers.pgs import solve_pgs

HALF = np.array([0.2, 0.1, 0.3])                 # m: the box's half extents
MASS = 6.0                                       # kg
INERTIA = MASS / 3 * np.array([HALF[1] ** 2 + HALF[2] ** 2, HALF[0] ** 2 + HALF[2] ** 2,
                               HALF[0] ** 2 + HALF[1] ** 2])


def box_on_ground(mu):
    """The rows of a box lying on the ground (y up) on its four bottom corners: per corner
    a normal row (0 .. inf) and two friction rows bounded by ``mu`` times it; 12 rows."""
    rows = make_rows_nb(12)
    axes = np.eye(3)[[1, 0, 2]]                  # normal, then two tangents
    corners = [np.array([sx * HALF[0], -HALF[1], sz * HALF[2]]) for sx in (-1, 1)
               for sz in (-1, 1)]
    for c, arm in enumerate(corners):
        for k, d in enumerate(axes):
            r = 3 * c + k
            rows.body_a[r], rows.body_b[r] = 0, -1
            rows.J[r, :3], rows.J[r, 3:6] = d, np.cross(arm, d)
            if k == 0:
                rows.lo[r], rows.hi[r] = 0.0, np.inf
            else:
                rows.parent[r], rows.mu[r] = 3 * c, mu
    return rows


def solve_box(mu, vel, angvel, velocity_tolerance, iterations=300):
    """PGS on ``box_on_ground(mu)`` from rest impulses: (sweeps, vel, angvel)."""
    vel, angvel = np.array([vel], float), np.array([angvel], float)
    sweeps = solve_pgs(box_on_ground(mu), 12, np.array([1 / MASS]),
                       np.diag(1 / INERTIA)[None], vel, angvel, np.zeros(12), iterations,
                       1e-12, velocity_tolerance, True)
    return sweeps, vel[0], angvel[0]


vectors = st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3)


@settings(max_examples=40, deadline=None)
@given(mu=st.sampled_from([0.0, 0.3, 1.0]), vel=vectors, angvel=vectors,
       tol=st.sampled_from([1e-4, 1e-5, 1e-6]))
def test_the_velocity_tolerance_ends_sweeps_near_the_converged_answer(mu, vel, angvel, tol):
    vel[1] = -abs(vel[1]) - 0.1                  # falling into the ground
    exact_sweeps, v0, w0 = solve_box(mu, vel, angvel, 0.0, iterations=3000)
    sweeps, v, w = solve_box(mu, vel, angvel, tol)
    assert sweeps <= exact_sweeps
    # the remaining error of a sweep that moved no row by more than ``tol``: a few ``tol``
    assert np.abs(v - v0).max() <= 20 * tol and np.abs(w - w0).max() <= 20 * tol


def test_a_zero_velocity_tolerance_sweeps_until_the_impulses_settle():
    sweeps, v, _ = solve_box(0.8, (0.3, -0.16, 0.1), (0.2, 0.5, -0.1), 0.0)
    fewer, _, _ = solve_box(0.8, (0.3, -0.16, 0.1), (0.2, 0.5, -0.1), 1e-5)
    assert abs(v[1]) < 1e-12 and fewer < sweeps < 300


def test_a_heap_on_pgs_moves_as_with_every_sweep():
    """The course ragdoll lying in a heap (64 contacts) on contact='pgs': PGS ended by the
    default velocity tolerance moves it as all 300 sweeps do, to 0.1 mm over 2 s."""
    worlds = [knocked_over(contact="pgs") for _ in range(2)]
    worlds[1].velocity_tolerance = 0.0
    for w in worlds:
        w.step(120)
    a, b = (w.body_pos for w in worlds)
    assert worlds[0].state_arrays.contact_count[0] >= 20
    assert np.abs(a - b).max() < 1e-4
    assert np.linalg.norm(worlds[0].body_vel, axis=-1).max() < 0.01     # m/s: at rest
