"""PD servos (implicit, explicit, stable), joint torques and MJCF-style actuators.

Checked against closed forms: the static equilibrium of a PD-held pendulum under gravity,
the damped-oscillator response of a servo, Newton's third law for joint torques.
"""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble
from tumble.errors import ModelError, SimulationError, StateError

MASS, LENGTH, I_COM = 1.0, 0.5, 0.01          # rod: COM LENGTH from the hinge
I_HINGE = I_COM + MASS * LENGTH ** 2


def pendulum(gravity=-9.81, **joint):
    b = tumble.ModelBuilder(gravity=(0, 0, gravity))
    rod = b.add_body("rod", pos=(LENGTH, 0, 1), mass=MASS, inertia=(I_COM, I_COM, I_COM))
    b.add_joint("hinge", "hinge", None, rod, anchor=(0, 0, 1), axis=(0, 1, 0), **joint)
    return b


def equilibrium(target, kp):
    """Angle where kp (target - theta) balances gravity's torque m g l cos(theta)."""
    theta = target
    for _ in range(100):
        f = kp * (target - theta) + MASS * 9.81 * LENGTH * math.cos(theta)
        df = -kp - MASS * 9.81 * LENGTH * math.sin(theta)
        theta -= f / df
    return theta


@pytest.mark.parametrize("mode,dt", [("implicit", 1 / 1920), ("implicit", 1 / 60),
                                     ("explicit", 1 / 1920), ("stable", 1 / 1920),
                                     ("stable", 1 / 60)])
def test_servo_holds_the_static_equilibrium(mode, dt):
    world = tumble.World(pendulum(kp=300.0, kd=30.0).build(), dt=dt, pd=mode)
    world.pd_target_q[0, 0] = 0.3
    world.step(int(round(3.0 / dt)))
    assert world.joint_q[0, 0] == pytest.approx(equilibrium(0.3, 300.0), abs=1e-6)


def test_explicit_pd_diverges_at_a_large_step_with_the_same_gains():
    world = tumble.World(pendulum(kp=300.0, kd=30.0).build(), dt=1 / 60, pd="explicit")
    world.pd_target_q[0, 0] = 0.3
    with pytest.raises(SimulationError) as err:
        world.step(120)
    assert err.value.body == "rod"


def test_implicit_servo_is_stable_for_huge_gains():
    world = tumble.World(pendulum(kp=1e7, kd=1e5).build(), dt=1 / 30)
    world.pd_target_q[0, 0] = -0.4
    world.step(60)
    assert world.joint_q[0, 0] == pytest.approx(-0.4, abs=1e-5)


@pytest.mark.parametrize("mode", ["implicit", "explicit", "stable"])
def test_servo_response_is_the_damped_oscillator(mode):
    """No gravity: I theta'' = kp (target - theta) - kd theta', underdamped; small dt."""
    kp, kd, dt = 20.0, 1.0, 1e-4
    world = tumble.World(pendulum(gravity=0.0, kp=kp, kd=kd).build(), dt=dt, pd=mode)
    world.pd_target_q[0, 0] = 0.2
    zeta = kd / (2 * math.sqrt(kp * I_HINGE))
    wn = math.sqrt(kp / I_HINGE)
    wd = wn * math.sqrt(1 - zeta ** 2)
    for t in (0.2, 0.5, 1.0):
        world.step(int(round((t - world.time) / dt)))
        exact = 0.2 * (1 - math.exp(-zeta * wn * t) * (math.cos(wd * t)
                                                         + zeta * wn / wd * math.sin(wd * t)))
        assert world.joint_q[0, 0] == pytest.approx(exact, abs=2e-3 * 0.2)


def test_ball_servo_reaches_a_target_rotation():
    b = tumble.ModelBuilder(gravity=(0, 0, 0))
    base = b.add_body("base", pos=(0, 0, 0), mass=5.0, inertia=(0.1, 0.1, 0.1), kind="static")
    arm = b.add_body("arm", pos=(0, 0, -0.3), mass=1.0, inertia=(0.02, 0.02, 0.005))
    b.add_joint("shoulder", "ball", base, arm, anchor=(0, 0, 0), kp=50.0, kd=5.0)
    world = tumble.World(b.build(), dt=1 / 60)
    target = (Rotation.from_rotvec([0.8, 0, 0]) * Rotation.from_rotvec([0, 0.5, 0])).as_quat()
    world.pd_target_quat[0] = target
    world.step(240)
    q = world.joint_quat[0]
    assert abs(np.dot(q, target)) == pytest.approx(1.0, abs=1e-9)


def test_max_torque_bounds_the_servo():
    """A servo weaker than gravity's torque cannot hold the rod up."""
    weak = MASS * 9.81 * LENGTH * 0.5
    for mode in ("implicit", "explicit", "stable"):
        world = tumble.World(pendulum(kp=500.0, kd=20.0, max_torque=weak).build(),
                             dt=1 / 1920 if mode == "explicit" else 1 / 240, pd=mode)
        world.pd_target_q[0, 0] = 0.0
        world.step(int(0.5 / world.dt))
        assert world.joint_q[0, 0] > 0.5, mode   # sagged well past the target
        world.joint_max_torque[:] = 1e6
        world.step(int(3.0 / world.dt))
        assert world.joint_q[0, 0] == pytest.approx(equilibrium(0.0, 500.0), abs=1e-4)


def test_gains_can_change_between_steps_and_zero_gains_switch_off():
    world = tumble.World(pendulum(kp=300.0, kd=30.0).build(), dt=1 / 240)
    world.step(240)
    held = world.joint_q[0, 0]
    world.set_pd_gains("hinge", 0.0, 0.0)
    world.step(120)
    assert world.joint_q[0, 0] > held + 0.5     # released: it swings down


def test_joint_torque_acts_equal_and_opposite():
    """Torque between two free bodies: total angular momentum stays zero."""
    b = tumble.ModelBuilder(gravity=(0, 0, 0))
    a = b.add_body("a", pos=(0, 0, 0), mass=2.0, inertia=(0.1, 0.2, 0.3))
    c = b.add_body("c", pos=(0.4, 0, 0), mass=1.0, inertia=(0.05, 0.05, 0.05))
    b.add_joint("j", "hinge", a, c, anchor=(0.2, 0, 0), axis=(0, 0, 1))
    world = tumble.World(b.build(), dt=1 / 240)
    for _ in range(60):
        world.apply_joint_torque("j", [2.0])
        world.step()
    assert world.joint_qd[0, 0] > 1.0
    # each body's own angular momentum is ~0.1 kg m^2/s; the two cancel up to the joint's
    # first-order drift correction, which moves anchors without touching velocities
    spin_c = 0.05 * world.body_angvel[1, 2]
    assert abs(spin_c) > 0.05
    assert np.abs(world.angular_momentum()).max() < 2e-2 * abs(spin_c)
    assert np.abs(world.linear_momentum()).max() < 1e-9


def test_motor_actuator_accelerates_by_gear_times_ctrl_over_inertia():
    b = pendulum(gravity=0.0)
    b.add_actuator("drive", "hinge", "motor", gear=3.0, ctrlrange=(-1, 1))
    world = tumble.World(b.build(), dt=1e-3)
    world.ctrl[:] = 5.0                                   # clamped to 1
    world.step(100)
    assert world.joint_qd[0, 0] == pytest.approx(3.0 / I_HINGE * 0.1, rel=1e-4)  # torque stays normal to the rod


def test_position_actuator_runs_as_the_joint_servo():
    b = pendulum()
    b.add_actuator("servo", "hinge", "position", gear=2.0, kp=100.0, kv=10.0)
    model = b.build()
    assert model.actuator_folded[0]
    assert model.joint_kp[0] == pytest.approx(400.0) and model.joint_kd[0] == pytest.approx(40.0)
    world = tumble.World(model, dt=1 / 60)
    world.ctrl[:] = 0.6                                   # joint target 0.3 rad
    world.step(240)
    assert world.joint_q[0, 0] == pytest.approx(equilibrium(0.3, 400.0), abs=1e-6)


def test_position_actuator_on_a_ball_joint_is_explicit():
    b = tumble.ModelBuilder(gravity=(0, 0, 0))
    arm = b.add_body("arm", pos=(0, 0, -0.3), mass=1.0, inertia=(0.02, 0.02, 0.005))
    b.add_joint("shoulder", "ball", None, arm, anchor=(0, 0, 0))
    b.add_actuator("sx", "shoulder", "position", axis=(1, 0, 0), kp=5.0, kv=1.0)
    model = b.build()
    assert not model.actuator_folded[0]
    world = tumble.World(model, dt=1e-3)
    world.ctrl[:] = 0.3
    world.step(5000)
    assert world.joint_q[0] == pytest.approx([0.3, 0.0, 0.0], abs=1e-4)


def test_bad_gains_targets_and_actuators_are_refused():
    with pytest.raises(ModelError, match="hinge.*kp"):
        pendulum(kp=-1.0)
    b = tumble.ModelBuilder()
    body = b.add_body("b", pos=(0, 0, 1), mass=1.0, inertia=(1, 1, 1))
    with pytest.raises(ModelError, match="weld.*fixed"):
        b.add_joint("weld", "fixed", None, body, kp=10.0)
    b.add_joint("weld", "fixed", None, body)
    with pytest.raises(ModelError, match="actuator 'm'.*nothing to actuate"):
        b.add_actuator("m", "weld")
    with pytest.raises(ModelError, match="actuator 'm'.*unknown joint"):
        b.add_actuator("m", "nope")
    b2 = pendulum(kp=10.0)
    with pytest.raises(ModelError, match="actuator 'm'.*ctrlrange"):
        b2.add_actuator("m", "hinge", ctrlrange=(1, -1))
    world = tumble.World(pendulum(kp=10.0).build())
    world.pd_target_q[0, 0] = np.nan
    before = world.get_state()
    with pytest.raises(StateError, match="joint 'hinge'.*pd_target_q"):
        world.step()
    assert np.array_equal(world.get_state().body_pos, before.body_pos)
    world.pd_target_q[0, 0] = 0.0
    world.joint_kp[0] = -5.0
    with pytest.raises(StateError, match="joint 'hinge'.*joint_kp"):
        world.step()
    with pytest.raises(ModelError, match="pd must be one of"):
        world.pd = "magic"


def ball_and_motor_world(nworld=1):
    """A ball-jointed arm and a hinge with a motor actuator, hand of god on the arm."""
    b = tumble.ModelBuilder()
    arm = b.add_body("arm", pos=(0, 0, 0.5), mass=1.0, inertia=(0.1, 0.1, 0.02))
    b.add_joint("shoulder", "ball", None, arm, anchor=(0, 0, 1), kp=10.0, kd=1.0)
    wheel = b.add_body("wheel", pos=(1, 0, 1), mass=1.0, inertia=(0.1, 0.1, 0.1))
    b.add_joint("axle", "hinge", None, wheel, anchor=(1, 0, 1), axis=(0, 1, 0))
    b.add_actuator("drive", "axle")
    return tumble.World(b.build(), nworld=nworld)


@pytest.mark.parametrize("spoil,message", [
    (lambda w: w.ctrl.__setitem__((0,), np.inf), "actuator 'drive': ctrl must be finite"),
    (lambda w: w.joint_kd.__setitem__((0,), -1.0), "joint 'shoulder': joint_kd must be finite and >= 0"),
    (lambda w: w.pd_target_quat.__setitem__((0,), 0.0), "joint 'shoulder': pd_target_quat is zero"),
    (lambda w: w.joint_max_torque.__setitem__((0,), 0.0), "joint 'shoulder': max_torque must be > 0"),
    (lambda w: w.set_body_servo("arm", 100.0, 10.0, 100.0, 10.0) or
     w.body_target_quat.__setitem__((0,), 0.0), "body 'arm': body_target_quat is zero"),
    (lambda w: w.set_body_servo("arm", 100.0, 10.0) or
     w.body_target_pos.__setitem__((0, 1), np.nan), "body 'arm': body_target_pos must be finite"),
    (lambda w: w.joint_applied_torque.__setitem__((1, 0), np.nan),
     "joint 'axle': joint torque must be finite"),
])
def test_bad_drive_inputs_are_named_and_change_nothing(spoil, message):
    world = ball_and_motor_world()
    world.step(3)
    spoil(world)
    before = world.get_state()
    with pytest.raises(StateError, match=message):
        world.step()
    after = world.get_state()
    for field in ("body_pos", "body_quat", "body_vel", "body_angvel"):
        assert np.array_equal(getattr(after, field), getattr(before, field)), field
    assert world.time == before.time


def test_a_hinge_takes_a_plain_number_and_refuses_nan():
    world = ball_and_motor_world()
    world.apply_joint_torque("axle", 2.0)
    assert world.joint_applied_torque[1, 0] == 2.0
    with pytest.raises(ModelError, match="joint 'axle': torque is not finite"):
        world.apply_joint_torque("axle", np.nan)


def test_bad_drive_input_names_its_world_in_a_batch():
    world = ball_and_motor_world(nworld=3)
    world.joint_kp[2, 0] = np.nan
    with pytest.raises(StateError, match="joint 'shoulder' in world 2: joint_kp"):
        world.step()
