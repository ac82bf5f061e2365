"""The ODE runner (bench/peers/bench_ode.py) builds the scenes of bench/scenes.py faithfully.

Checked against analytic answers: a resting box sinks by exactly the compliance its contact
parameters give it, the chain starts assembled with the energy M g z of its links, and the
explicit PD pushes a bent joint back. Skipped when panda3d is not installed."""
import math

import numpy as np
import pytest

pytest.importorskip("panda3d.ode")

from bench import scenes as S  # noqa: E402
from bench.peers import bench_ode as O  # noqa: E402


def contact_sag(load, n_contacts, dt):
    """Rest penetration (m) of ``n_contacts`` equal contacts carrying ``load`` N: ODE's
    soft contact is a spring of stiffness ERP / (dt CFM) per contact."""
    k = O.WORLD_ERP / (dt * O.CONTACT_CFM)
    return load / (n_contacts * k)


@pytest.mark.parametrize("variant, tol", [("step", 2e-6), ("default", 2e-5)])
def test_box_rests_at_analytic_height(variant, tol):
    cfg = S.STACK
    dt, h, m = cfg["dt"], cfg["half"], cfg["mass"]
    sc = O.build_boxes([(0.0, 0.0, h)], h, m)
    step = sc.stepper(dt, variant)
    for _ in range(240):                        # 1 s: the ERP transient has long decayed
        step()
    depths = sc.contact_depths()
    assert depths.size == 4                     # box on plane: the four bottom corners
    sag = contact_sag(m * abs(S.GRAVITY), 4, dt)    # 0.051 mm
    z = sc.positions()[0]
    assert abs(z[2] - (h - sag)) < tol
    np.testing.assert_allclose(depths, sag, atol=tol)
    assert np.hypot(z[0], z[1]) < 1e-6          # no sliding
    q = sc.quats()[0]
    assert abs(abs(q[0]) - 1.0) < 1e-6          # no tilting


def test_chain_starts_assembled_with_its_potential_energy():
    c = S.CHAIN
    sc = O.build_chain()
    assert O.chain_separation(sc) < 1e-6        # float32 positions around 5 m
    # at rest, horizontal at z = 5: E = n m |g| z
    expect = c["n"] * c["mass"] * abs(S.GRAVITY) * c["anchor"][2]
    assert abs(O.chain_energy(sc) - expect) < 1e-3
    step = sc.stepper(c["dt"], "default")
    for _ in range(48):
        step()
    # falling, joints held within a millimetre, energy kept within 2% of M g L/2
    assert sc.positions()[-1, 2] < c["anchor"][2] - 0.1
    assert O.chain_separation(sc) < 1e-3
    assert abs(O.chain_energy(sc) - expect) < 0.02 * S.chain_energy_scale()


def _rotate_about_point(body, point, axis, angle):
    """Turn an ODE body (at identity) by angle (rad) about a world axis through point."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    q = (math.cos(angle / 2), *(math.sin(angle / 2) * a))
    R = S.quat_to_mat_wxyz(q)
    p = np.asarray(tuple(body.getPosition()), float)
    body.setPosition(*(point + R @ (p - point)))
    body.setQuaternion(q)


@pytest.mark.parametrize("name, axis", [("lower_arm_l", (0.0, 1.0, 0.0)),     # hinge
                                        ("upper_arm_l", (1.0, 0.0, 0.0))])    # ball
def test_pd_torque_pushes_a_bent_joint_back(name, axis):
    parts = S.ragdoll_parts()
    sc = O.build_ragdoll(parts)
    gains = S.ragdoll_pd_gains(parts, "spec")
    pd = O.RagdollPD(sc, parts, gains)
    i = [p["name"] for p in parts].index(name)
    subtree, grew = {name}, True
    while grew:
        below = {p["name"] for p in parts if p["parent"] in subtree}
        grew = not below <= subtree
        subtree |= below
    for j, p in enumerate(parts):
        if p["name"] in subtree:
            _rotate_about_point(sc.bodies[j], np.array(parts[i]["joint"]), axis, 0.3)
    tau = pd.torques()
    k = list(pd.child).index(i)
    kp = gains[name][0]
    np.testing.assert_allclose(tau[k], -kp * 0.3 * np.array(axis), atol=1e-4 * kp)
    others = np.delete(np.arange(len(pd.child)), k)
    # the joints below the bent one are still straight (their bodies turned with it)
    assert np.abs(tau[others]).max() < 1e-4 * kp
