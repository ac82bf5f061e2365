"""SIMBICON walking (tumble/character/simbicon.py) on the GAMES-105 course character, and the
terrains it walks on (tumble/character/terrain.py).

What is checked, and how:
- the pose bookkeeping against the World's own joint coordinates: rest-frame joint
  rotations placed by forward kinematics read back as ``conj(Fa) R Fb`` (to 1e-9);
- the world-frame targets: the stance-hip servo target is the rotation that would put the
  pelvis at the torso's desired orientation, the swing-hip target the one that would put the
  thigh at its desired one; the balance law ``theta = theta0 + c_d d + c_v v`` against d, v
  computed here from the bodies;
- terrain heights and normals against ray casts of the built model (to 1e-9);
- walking outcomes with thresholds (the longer measurements, 50 m per style and the push
  force search, are bench/bench_walk.py's): 60 s on flat ground per shipped style with no
  fall (pelvis above 0.55 m, nothing but the feet on the ground: the controller's own
  check, restated here on the result), speed and step length in a band; pushes of 0.2 s
  to the chest in four directions; 5 degree slopes up and down; a heightfield; speed and
  turning parameters; the 'rule' form of the stance hip. Control and physics step 1/60 s.
"""
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import tumble
from tumble.math import quat_np as Q
from tumble.character.balance import center_of_mass
from tumble.character.balance import Push
from tumble.character.simbicon import (BipedMap, SimbiconController, gait_names, load_gait,
                                       run_walk)
from tumble.character.terrain import Heightfield, Slope
from tumble.errors import ModelError

DT = 1.0 / 60.0            # physics and control step of the walking tests
FALL_HEIGHT = 0.55         # m: the pelvis below this above the ground is a fall


def make(gait="walk", terrain=None, dt=DT, **kw):
    rd = tumble.games105_ragdoll(terrain=terrain)
    world = rd.make_world(dt=dt, contact="pgs")
    return SimbiconController(world, rd, gait, control_dt=DT, terrain=terrain,
                              fall_height=FALL_HEIGHT, **kw)


@pytest.fixture(scope="module")
def ctrl():
    return make()


# ------------------------------------------------------------------------------ gaits

def test_shipped_gaits_load():
    names = gait_names()
    assert {"walk", "fast"} <= set(names)
    for n in names:
        g = load_gait(n)
        assert len(g.states) == 2 and g.states[1].on_contact and not g.states[0].on_contact
        assert set(g.gains) == {"hip", "torso", "knee", "ankle", "toe", "spine", "neck", "arm"}


def _gait_dict():
    return json.loads(json.dumps({
        "name": "t", "states": [
            {"duration": 0.3, "swing_hip": [0.5, 0.0], "swing_knee": 1.0, "swing_ankle": 0.2,
             "stance_knee": 0.05, "stance_ankle": 0.0},
            {"duration": 0.7, "swing_hip": [0.0, 0.0], "swing_knee": 0.1, "swing_ankle": 0.1,
             "stance_knee": 0.05, "stance_ankle": 0.0}],
        "gains": {g: [100, 10] for g in ("hip", "torso", "knee", "ankle", "toe", "spine",
                                         "neck", "arm")}}))


def test_gait_errors_name_field_and_line(tmp_path):
    d = _gait_dict()
    d["states"][1]["swing_knee"] = "bent"
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(d, indent=1))
    line = next(i + 1 for i, t in enumerate(p.read_text().splitlines()) if '"swing_knee": "bent"' in t)
    with pytest.raises(ModelError, match=rf"states\[1\]\.swing_knee.*line {line}.*finite number"):
        load_gait(p)
    d = _gait_dict()
    d["stride"] = 1
    p.write_text(json.dumps(d, indent=1))
    with pytest.raises(ModelError, match="'stride'.*not a gait field"):
        load_gait(p)
    d = _gait_dict()
    del d["gains"]["knee"]
    with pytest.raises(ModelError, match="gains.knee.*missing"):
        load_gait(d)
    p.write_text('{"name": "x",\n "states": [\n  {"duration": 0.3,}\n ]}')
    with pytest.raises(ModelError, match="invalid JSON at line 3"):
        load_gait(p)
    with pytest.raises(ModelError, match="no gait named 'moonwalk'"):
        load_gait("moonwalk")


def test_controller_errors():
    rd = tumble.games105_ragdoll()
    w = rd.make_world(dt=1 / 120)
    with pytest.raises(ModelError, match="control_dt"):
        SimbiconController(w, rd, control_dt=1 / 50)
    with pytest.raises(ModelError, match="hip_control must be 'implicit', 'rule' or"):
        SimbiconController(w, rd, hip_control="magic")
    with pytest.raises(ModelError, match="knee joint 'lKneecap'"):
        SimbiconController(w, rd, biped=BipedMap(knee=("lKneecap", "rKnee")))


# ------------------------------------------------------------------- pose bookkeeping

_angle = st.floats(-1.0, 1.0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(_angle, _angle, _angle), min_size=20, max_size=20))
def test_rest_frame_rotations_read_back_as_joint_targets(ctrl, rotvecs):
    """FK of rest-frame joint rotations, read by the World, gives conj(Fa) R Fb."""
    m = ctrl.model
    R = np.tile(Q.IDENTITY, (m.njoint, 1))
    for j, rv in enumerate(rotvecs):
        t = m.joint_type_names[j]
        if t == "ball":
            a = float(np.linalg.norm(rv))
            R[j] = (np.r_[np.sin(a / 2) * np.asarray(rv) / a, np.cos(a / 2)] if a > 0
                    else Q.IDENTITY)
        elif t == "hinge":
            axis = Q.qrot(ctrl.Fa[j], np.array([1.0, 0.0, 0.0]))
            R[j] = np.r_[np.sin(rv[0] / 2) * axis, np.cos(rv[0] / 2)]
    pos, quat = ctrl.body_poses(R)
    w = ctrl.world
    w.body_pos[:] = pos
    w.body_quat[:] = quat
    w.update_joint_coordinates()
    want = ctrl.joint_targets(R)
    got = np.asarray(w.joint_quat)
    served = [j for j in range(m.njoint) if m.joint_type_names[j] != "free"]
    dots = np.abs(np.sum(want[served] * got[served], axis=1))
    assert np.all(dots > 1 - 1e-12)
    assert np.max(w.joint_separation()) < 1e-9          # FK keeps the joints together


def test_standing_pose_arms_down_forearms_forward(ctrl):
    pos, _ = ctrl.body_poses(ctrl.standing_pose())
    m = ctrl.model
    for side in "lr":
        shoulder = pos[m.body_index(f"{side}Shoulder")]
        hand = pos[m.body_index(f"{side}Wrist")]
        elbow = pos[m.body_index(f"{side}Elbow")]
        assert hand[1] < shoulder[1] - 0.3                 # hanging down
        assert elbow[2] > shoulder[2] + 0.01               # forearm bent forward (+z)


def test_place_leans_the_pelvis_as_the_gait_with_vertical_legs():
    """place(): the pelvis pitched forward by the first state's torso pitch plus slope_lean
    times the slope (the torso servo starts with no error), the legs as standing (thighs
    and shanks at their rest orientation), the feet on the slope."""
    angle = math.radians(5)
    c = make("walk", terrain=Slope(angle))
    c.place()
    w, m = c.world, c.model
    lean = c.gait.states[0].torso[0] + c.gait.slope_lean * angle
    assert c.gait.slope_lean != 0.0

    def rest_rel(body):
        return Q.qmul(w.body_quat[body], Q.qconj(m.body_quat0[body]))

    # rest frame: forward +z, left +x; a forward pitch is a rotation about +x
    assert np.allclose(Q.qrotvec(rest_rel(c.pelvis)), [lean, 0.0, 0.0], atol=1e-12)
    for s in range(2):
        for body in (c.thigh[s], int(m.joint_child[c.knee[s]])):
            assert Q.qangle(rest_rel(body)) < 1e-12
    # the feet (level) rest 1 mm above the highest ground under the foot bodies
    feet = [g for g in range(m.ngeom) if m.geom_body[g] in c.feet_bodies
            and (m.geom_contype[g] or m.geom_conaffinity[g])]
    low = min(_lowest_y(c, g) for g in feet)
    ground = max(c.ground_height(w.body_pos[m.geom_body[g]]) for g in feet)
    assert low == pytest.approx(ground - 0.001, abs=1e-9)


def _lowest_y(c, g):
    """Lowest world height (m) of box geom g (the feet are boxes)."""
    m, w = c.model, c.world
    b = m.geom_body[g]
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    q = Q.qmul(w.body_quat[b], m.geom_quat[g])
    pts = (w.body_pos[b] + Q.qrot(w.body_quat[b], m.geom_pos[g])
           + Q.qrot(np.broadcast_to(q, (8, 4)), corners * m.geom_size[g][:3]))
    return float(pts[:, 1].min())


def test_world_frame_targets_and_balance_law(ctrl):
    c = ctrl
    c.place(speed=0.4)
    for _ in range(70):                                    # into the second step
        c.step()
    c.control()
    w, m = c.world, c.model
    st_ = c.gait.states[c.state]
    stance, swing = c.stance, 1 - c.stance
    fwd = np.array([math.sin(c.heading), 0.0, math.cos(c.heading)])
    left = np.cross([0.0, 1.0, 0.0], fwd)
    # the balance law from the bodies
    com, v = center_of_mass(w)
    k = c.ankle[stance]
    ankle = w.body_pos[m.joint_child[k]] + Q.qrot(w.body_quat[m.joint_child[k]], m.joint_anchor_b[k])
    d = com - ankle
    flex = st_.swing_hip[0] + st_.c_d[0] * (d @ fwd) + st_.c_v[0] * (v @ fwd) - c.speed_offset
    flex = min(max(flex, c.gait.flexion_range[0]), c.gait.flexion_range[1])
    s = 1.0 if swing == 0 else -1.0
    abd = st_.swing_hip[1] + st_.c_d[1] * s * (d @ left) + st_.c_v[1] * s * (v @ left)
    abd = min(max(abd, c.gait.abduction_range[0]), c.gait.abduction_range[1])
    assert c.last_feedback[4] == pytest.approx(flex, abs=1e-12)
    assert c.last_feedback[5] == pytest.approx(abd, abs=1e-12)

    def rest_rel(body):
        return Q.qmul(w.body_quat[body], Q.qconj(m.body_quat0[body]))

    def implied(joint):
        """Rest-frame rotation parent -> child of the joint's servo target."""
        return Q.qmul(c.Fa[joint], Q.qmul(w.pd_target_quat[joint], Q.qconj(c.Fb[joint])))

    def angle(a, b):
        return Q.qangle(Q.qmul(a, Q.qconj(b)))

    # desired world orientations, built here from the gait's angles
    yaw = np.r_[0.0, math.sin(c.heading / 2), 0.0, math.cos(c.heading / 2)]
    pitch, roll = st_.torso
    roll = s * roll                     # toward the stance side: about -z for a left stance
    pelvis_d = Q.qmul(yaw, Q.qmul(np.r_[0.0, 0.0, math.sin(roll / 2), math.cos(roll / 2)],
                                  np.r_[math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]))
    th = Q.qmul(yaw, Q.qmul(np.r_[0.0, 0.0, math.sin(s * abd / 2), math.cos(s * abd / 2)],
                            np.r_[math.sin(-flex / 2), 0.0, 0.0, math.cos(-flex / 2)]))
    hs, hw = c.hip[stance], c.hip[swing]
    # stance hip: pelvis = stance thigh * inverse(joint rotation) lands on the torso target
    pelvis_implied = Q.qmul(rest_rel(c.thigh[stance]), Q.qconj(implied(hs)))
    assert angle(pelvis_implied, pelvis_d) < 1e-9
    # swing hip: thigh = current pelvis * joint rotation lands on the desired thigh
    thigh_implied = Q.qmul(rest_rel(c.pelvis), implied(hw))
    assert angle(thigh_implied, th) < 1e-9
    assert w.joint_kp[hs] == c.gait.gains["torso"][0]
    assert w.joint_kp[hw] == c.gait.gains["hip"][0]


def test_rule_feeds_the_swing_hip_torque_forward():
    """hip_control='rule': the stance hip carries -tau_swing (the swing hip's torque on its
    thigh in the last physics step) on top of its torso servo, +tau_swing on the pelvis."""
    c = make(hip_control="rule")
    c.place(speed=0.4)
    for _ in range(70):
        c.step()
    w, m = c.world, c.model
    swing = 1 - c.stance
    c._last_swing = swing                                 # no stance switch in between
    tau_swing = np.array(w.joint_torque[c.hip[swing]])
    assert np.linalg.norm(tau_swing) > 1.0
    applied = w.control_arrays.applied_torque.reshape(m.nbody, 3)
    applied[:] = 0.0
    c.control()
    assert np.allclose(applied[c.thigh[c.stance]], -tau_swing, atol=1e-12)
    assert np.allclose(applied[c.pelvis], tau_swing, atol=1e-12)
    assert np.abs(np.delete(applied, [c.thigh[c.stance], c.pelvis], axis=0)).max() == 0.0
    # and across a stance switch nothing is fed forward (the new swing hip was the stance)
    c._last_swing = c.stance
    applied[:] = 0.0
    c.control()
    assert np.abs(applied).max() == 0.0


def test_rule_walks_20_s():
    r = run_walk(make(hip_control="rule"), 20.0)
    _no_fall(r)
    assert r.forward_distance > 8.0


# ------------------------------------------------------------------------- terrains

@pytest.mark.parametrize("terrain", [
    Slope(math.radians(5)), Slope(-0.2, direction=(1.0, 1.0)),
    Heightfield.hill(math.radians(5), 4.0, 2.0, flat_before=2.0, flat_after=4.0),
    Heightfield.bumps(0.05, 6.0, spacing=0.3)])
def test_terrain_height_and_normal_match_ray_casts(terrain):
    rd = tumble.games105_ragdoll(terrain=terrain)
    w = rd.make_world(dt=DT)
    rng = np.random.default_rng(1)
    checked = 0
    for _ in range(100):
        x, z = rng.uniform(-1.5, 1.5), rng.uniform(-1.5, 9.0)
        hit = w.raycast((x, 5.0, z), (0.0, -1.0, 0.0))
        if hit is None or hit[1] != "ground":
            continue                                        # a body of the character
        assert hit[3][1] == pytest.approx(terrain.height(x, z), abs=1e-9)
        assert np.allclose(hit[4], terrain.normal(x, z), atol=1e-9)
        checked += 1
    assert checked > 50


def test_terrain_errors():
    with pytest.raises(ModelError, match="Slope: angle"):
        Slope(2.0)
    with pytest.raises(ModelError, match="Heightfield: heights"):
        Heightfield(np.zeros((1, 5)), 0.1)
    with pytest.raises(ModelError, match="terrain must be"):
        tumble.games105_ragdoll(terrain="hilly")


# -------------------------------------------------------------------------- walking

def _no_fall(r):
    assert not r.fallen, r.summary()
    assert r.pelvis_min_height > FALL_HEIGHT


# (gait, speed band m/s, step length band m, least distance in 60 s), measured at control =
# physics step 1/60 s (bench/bench_walk.py, 50 m: walk 0.690 m/s, 0.312 m; fast 1.370 m/s,
# 0.435 m)
STYLES = [("walk", (0.55, 0.85), (0.24, 0.38), 30.0),
          ("fast", (1.15, 1.6), (0.36, 0.52), 50.0)]


@pytest.mark.parametrize("gait, speed, step, distance", STYLES)
def test_walks_60_s_on_flat_ground(gait, speed, step, distance):
    c = make(gait)
    r = run_walk(c, 60.0)
    _no_fall(r)
    assert r.time == pytest.approx(60.0)
    assert r.forward_distance > distance
    assert speed[0] < r.speed < speed[1]
    assert step[0] < r.step_length < step[1]
    # a walk, not a shuffle: a strike every 0.25-0.6 s, alternating feet
    assert 0.25 < r.step_time < 0.6
    sides = [s[1] for s in r.strikes]
    assert all(a != b for a, b in zip(sides, sides[1:]))
    # it keeps its heading: sideways drift under 5% of the distance (3 degrees)
    assert abs(r.com[-1][0] - r.com[0][0]) < 0.05 * r.forward_distance


# (gait, direction, N for 0.2 s at the chest): the largest forces bench/bench_walk.py found
# survived at all 4 push times of a stride after 6 s (walk: 200 / 400 / 150 / 200 N
# forward / backward / left / right; fast: 200 / 500 / 250 / 250 N), here at one other push
# time (after 5 s), where walk-right and fast-left take 50 N less: survival is not
# monotone in the push time
PUSHES = [("walk", (0, 0, 1), 200.0), ("walk", (0, 0, -1), 400.0),
          ("walk", (1, 0, 0), 150.0), ("walk", (-1, 0, 0), 150.0),
          ("fast", (0, 0, 1), 200.0), ("fast", (1, 0, 0), 200.0),
          ("fast", (-1, 0, 0), 250.0), ("fast", (0, 0, -1), 500.0)]


@pytest.mark.parametrize("gait, direction, force", PUSHES)
def test_survives_pushes(gait, direction, force):
    c = make(gait)
    c.place()
    while c.time < 5.0:
        c.step()
    f = force * np.asarray(direction, float)
    r = run_walk(c, 6.0, place=False, pushes=[Push("lowerback_torso", f, c.world.time, 0.2)])
    _no_fall(r)
    # and walks on: forward again over the last 2 s
    assert r.com[-1][2] - r.com[-1 - round(2.0 / DT)][2] > 0.5


@pytest.mark.parametrize("gait, angle, least", [("walk", 5.0, 5.0), ("walk", -5.0, 5.0),
                                                ("fast", 5.0, 15.0)],
                         ids=["walk-up", "walk-down", "fast-up"])
def test_walks_up_and_down_a_5_degree_slope(gait, angle, least):
    """From standing: the fast gait's start on the upslope needs place()'s lean (the
    torso pitched as the gait wants from the first step) and its slope_hip."""
    terrain = Slope(math.radians(angle))
    c = make(gait, terrain=terrain)
    r = run_walk(c, 20.0)
    _no_fall(r)
    assert r.forward_distance > least
    climbed = c.ground_height(c.world.body_pos[c.pelvis])
    assert np.sign(climbed) == np.sign(angle) and abs(climbed) > 0.4


def test_walks_over_a_hill_heightfield():
    terrain = Heightfield.hill(math.radians(5), up_length=5.0, top_length=2.0,
                               flat_before=2.0, flat_after=10.0)
    c = make(terrain=terrain)
    r = run_walk(c, 40.0, position=(0.0, -1.5), stop_distance=14.0)
    _no_fall(r)
    assert c.world.body_pos[c.pelvis][2] > 12.0            # over the top and down again


@pytest.mark.parametrize("gait, target", [("walk", 0.3), ("walk", 0.45), ("fast", 1.2)])
def test_speed_parameter(gait, target):
    """The step-to-step regulator holds a target speed (measured after 10 s)."""
    c = make(gait, speed=target)
    r = run_walk(c, 25.0, settle=10.0)
    _no_fall(r)
    assert r.speed == pytest.approx(target, abs=0.05)


@pytest.mark.parametrize("rate", [0.15, -0.3])
def test_turning_parameter(rate):
    c = make(turn_rate=rate)
    r = run_walk(c, 20.0)
    _no_fall(r)
    yaw = c.pelvis_heading()
    turned = (yaw - rate * 20.0 + math.pi) % (2 * math.pi) - math.pi
    assert abs(turned) < 0.2                               # the pelvis follows the heading
    # it walks the turn: a path of at least 6 m (speed is the path speed when turning)
    assert r.speed * (r.time - 2.0) > 6.0
