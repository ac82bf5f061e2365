"""Ragdoll builders (tumble/character/ragdoll.py): the GAMES-105 reference ragdoll against the
course's facts (tests/data/games105/README.md), ragdolls from BVH skeletons, and their errors.

Tolerances: quantities computed in closed form from the file (masses, sizes, anchors) to
1e-12; simulations are checked for what must hold whatever the step: finite states, no
sinking, joints that stay together (to the drift tumble's joints allow, 1e-3 m), energy
that does not grow.
"""
from pathlib import Path

import numpy as np
import pytest

import tumble
from tumble.character import (GAMES105_BOX_SCALES, Skeleton, build_ragdoll,
                              games105_character_path, load_character_model)
from tumble.math import quat_np as Q
from tumble.model.builder import body_pair_key

DATA = Path(__file__).resolve().parent.parent / "data" / "games105"

# The course facts, restated from the README of the data (not from the code under test).
SCALES = {"RootJoint": (0.06, 0.06, 0.04), "torso_head": (0.05, 0.08, 0.04),
          "lowerback_torso": (0.03, 0.04, 0.04), "pelvis_lowerback": (0.03, 0.035, 0.04)}
for _s in "lr":
    SCALES.update({_s + "Hip": (0.03, 0.15, 0.03), _s + "Knee": (0.03, 0.16, 0.03),
                   _s + "Ankle": (0.045, 0.024, 0.07), _s + "ToeJoint": (0.045, 0.018, 0.02),
                   _s + "Torso_Clavicle": (0.05, 0.03, 0.03), _s + "Shoulder": (0.07, 0.03, 0.03),
                   _s + "Elbow": (0.07, 0.03, 0.03), _s + "Wrist": (0.05, 0.018, 0.033)})
HINGES = {"lKnee": (1, 0, 0), "rKnee": (1, 0, 0), "lToeJoint": (1, 0, 0),
          "rToeJoint": (1, 0, 0), "lElbow": (0, 1, 0), "rElbow": (0, 1, 0)}


@pytest.fixture(scope="module")
def character():
    return load_character_model()


@pytest.fixture(scope="module")
def floating():
    return tumble.games105_ragdoll("floating")


@pytest.fixture(scope="module")
def pinned():
    return tumble.games105_ragdoll("pinned")


@pytest.fixture(scope="module")
def walk():
    return tumble.load_bvh(DATA / "walk_forward.bvh")


def joint_frame_world(model, j):
    """Joint j's frame in the world at build time, from the parent's side."""
    p = model.joint_parent[j]
    fa = model.joint_frame_a[j]
    return fa if p < 0 else Q.qmul(model.body_quat0[p], fa)


# ------------------------------------------------------------------ GAMES-105 reference

def test_games105_masses_inertia_and_total(floating, character):
    m = floating.model
    names = character.skeleton.joint_names[:20]
    assert m.body_names == names
    for i, n in enumerate(names):
        full = 10.0 * np.array(SCALES.get(n, (0.03, 0.03, 0.03)))
        rho = 100.0 if "Toe" in n else 50.0
        mass = rho * full.prod()
        assert m.body_mass[i] == pytest.approx(mass, rel=1e-12)
        a, b, c = full
        np.testing.assert_allclose(m.body_inertia[i],
                                   mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]),
                                   rtol=1e-12)
        np.testing.assert_allclose(m.body_quat0[i], [0, 0, 0, 1], atol=1e-15)  # axis-aligned
    assert m.body_mass.sum() == pytest.approx(78.47, abs=1e-9)
    assert m.body_mass.sum() == pytest.approx(78.5, abs=0.05)       # "about 78.5 kg"
    assert GAMES105_BOX_SCALES["lAnkle"] == SCALES["lAnkle"]


def test_games105_bodies_and_collision_boxes(floating, character):
    m = floating.model
    for i, n in enumerate(m.body_names):
        centre = character.body_pos[i] + ((0, 0.01, 0) if "Toe" in n else 0.0)
        np.testing.assert_allclose(m.body_pos0[i], centre, atol=1e-15)
        g = m.geom_index(f"{n}_geom")
        assert m.geom_body[g] == i
        np.testing.assert_allclose(m.geom_size[g], 0.75 * np.array(SCALES.get(n, (0.03,) * 3)),
                                   rtol=1e-15)                        # full sides 1.5 s
        np.testing.assert_allclose(m.geom_pos[g], 0.0, atol=1e-15)
        toe = "Toe" in n
        assert (m.geom_contype[g], m.geom_conaffinity[g]) == ((0, 0) if toe else (1, 1))
        assert m.geom_friction[g] == 1.5 and m.geom_restitution[g] == 0.0
    ground = m.geom_index("ground")
    assert m.geom_body[ground] == -1 and m.geom_friction[ground] == 1.5
    assert m.geom_restitution[ground] == 0.0
    # plane normal: the geom's z axis, which must be +y through the origin
    np.testing.assert_allclose(Q.qrot(m.geom_quat[ground], [0, 0, 1]), [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(m.geom_pos[ground], 0.0)
    np.testing.assert_array_equal(m.gravity, [0, -9.81, 0])
    assert m.timestep == 1 / 1920


@pytest.mark.parametrize("root", ["pinned", "floating"])
def test_games105_joints_types_axes_anchors(root, character, pinned, floating):
    rd = pinned if root == "pinned" else floating
    m, sk = rd.model, character.skeleton
    assert m.joint_names == sk.joint_names[:20]
    for j, n in enumerate(m.joint_names):
        i = sk.index(n)
        parent = sk.parents[i]
        assert m.joint_child[j] == i and m.joint_parent[j] == parent
        assert rd.joint_of[n] == n and rd.body_of[n] == n
        if i == 0:
            assert m.joint_type_names[j] == ("ball" if root == "pinned" else "free")
            if root == "pinned":
                np.testing.assert_allclose(m.joint_anchor_a[j], sk.rest_positions[0], atol=1e-15)
            continue
        if n in HINGES:
            assert m.joint_type_names[j] == "hinge"
            x_axis = Q.qrot(joint_frame_world(m, j), [1.0, 0, 0])
            np.testing.assert_allclose(x_axis, HINGES[n], atol=1e-15)
        else:
            assert m.joint_type_names[j] == "ball"
        # both sides of the joint put the anchor at joint_pos[i]
        for body, anchor in ((parent, m.joint_anchor_a[j]), (i, m.joint_anchor_b[j])):
            world = m.body_pos0[body] + Q.qrot(m.body_quat0[body], anchor)
            np.testing.assert_allclose(world, sk.rest_positions[i], atol=1e-15)
        # bodies joined by a joint never collide
        assert body_pair_key(parent, i, m.nbody) in set(m.exclude_keys.tolist())


def test_games105_world_options_map_contact_softness(floating):
    assert floating.world_options == dict(dt=1 / 1920, contact_erp=0.9, contact_cfm=0.001)
    w = floating.make_world(contact="pgs")
    assert (w.dt, w.contact_erp, w.contact_cfm, w.contact) == (1 / 1920, 0.9, 0.001, "pgs")


def test_games105_rest_pose_has_no_overlapping_colliding_bodies(floating):
    from tumble.pipeline.collide import may_collide
    w = floating.make_world()
    m = w.model
    for a in range(m.ngeom):
        for b in range(a + 1, m.ngeom):
            if min(m.geom_body[a], m.geom_body[b]) >= 0 and may_collide(m.arrays, a, b, m.nbody):
                assert w.geom_distance(a, b)[0] > 0.0, (m.geom_names[a], m.geom_names[b])


def test_shipped_character_is_package_data():
    path = games105_character_path()
    assert path.is_file() and (path.parent / "LICENSE").is_file()
    tomllib = pytest.importorskip("tomllib")   # Python >= 3.11
    root = Path(__file__).resolve().parents[2]
    with open(root / "pyproject.toml", "rb") as fh:
        data = tomllib.load(fh)["tool"]["setuptools"]["package-data"]
    assert "character_model.npy" in data["tumble.data.games105"]


# ------------------------------------------------------------------ simulation

def test_floating_ragdoll_dropped_on_the_ground_lands_without_nan(floating):
    w = floating.make_world()
    w.body_pos[:, 1] += 0.2                     # drop the T-pose from 0.2 m
    _, pe0 = w.energy()
    w.step(960)                                 # 0.5 s
    assert np.all(np.isfinite(w.body_pos)) and np.all(np.isfinite(w.body_quat))
    kinetic, potential = w.energy()
    assert kinetic + potential < pe0            # fell and lost energy
    # nothing sinks: every collision box stays above y = -1 cm
    m = w.model
    for g in range(m.ngeom):
        b = m.geom_body[g]
        if b < 0 or m.geom_contype[g] == 0:
            continue
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        pts = w.body_pos[b] + Q.qrot(w.body_quat[b], corners * m.geom_size[g])
        assert pts[:, 1].min() > -0.01, m.geom_names[g]
    assert len(w.contacts) > 0
    assert np.any(w.contacts.bodies == -1)      # resting on the ground
    # joint 0 is the root's free joint (no constraint): the others hold together
    assert w.model.joint_type_names[0] == "free"
    assert w.joint_separation()[1:].max() < 1e-3


def test_pinned_ragdoll_hangs_from_its_root(pinned, character):
    w = pinned.make_world()
    e0 = sum(w.energy())
    wrist = w.model.body_index("lWrist")
    y0 = w.body_pos[wrist, 1]
    w.step(480)                                 # 0.25 s
    assert np.all(np.isfinite(w.body_pos))
    pin = w.model.joint_index("RootJoint")
    assert w.joint_separation()[pin] < 1e-4
    # the root body turns about the pin but its joint point stays at joint_pos[0]
    root_joint = w.body_pos[0] + Q.qrot(w.body_quat[0], w.model.joint_anchor_b[pin])
    np.testing.assert_allclose(root_joint, character.skeleton.rest_positions[0], atol=1e-4)
    assert w.body_pos[wrist, 1] < y0 - 0.05     # the arms fall
    assert sum(w.energy()) <= e0 + 1e-6         # passive joints do not make energy
    assert w.joint_separation().max() < 1e-3


def test_ragdoll_from_walk_skeleton_builds_and_simulates(walk):
    rd = tumble.ragdoll_from_motion(walk, total_mass=70.0,
                                    joint_types={"lKnee": "hinge", "rKnee": "hinge"},
                                    joint_axes={"lKnee": (1, 0, 0), "rKnee": (1, 0, 0)})
    m = rd.model
    with_children = [n for j, n in enumerate(walk.joint_names)
                     if np.any(walk.parents == j)]
    assert sorted(m.body_names) == sorted(with_children) and len(with_children) == 20
    assert m.body_mass.sum() == pytest.approx(70.0, rel=1e-12)
    assert m.joint_type_names[m.joint_index("lKnee")] == "hinge"
    assert m.joint_type_names[m.joint_index("RootJoint")] == "free"
    np.testing.assert_array_equal(m.gravity, [0, -9.81, 0])
    # bones sized from the skeleton: the shank capsule spans knee to ankle (0.39 m)
    g = m.geom_index("lKnee_geom")
    radius, half = m.geom_size[g][:2]
    assert half + radius == pytest.approx(0.195, rel=1e-6)
    assert radius == pytest.approx(0.5 * 0.3 * 0.39, rel=1e-6)
    # placed on the ground: the lowest geom point is at y = 0
    w = rd.make_world(dt=1 / 600)
    lowest = min(w.geom_distance(g, "ground")[0] for g in range(m.ngeom) if m.geom_body[g] >= 0)
    assert lowest == pytest.approx(0.0, abs=1e-12)
    # the rest pose is the BVH offsets
    np.testing.assert_allclose(rd.skeleton.offsets[1:], walk.offsets[1:], atol=1e-15)
    w.body_pos[:, 1] += 0.1
    w.step(150)                                 # 0.25 s
    assert np.all(np.isfinite(w.body_pos))
    assert len(w.contacts) > 0
    assert w.joint_separation()[1:].max() < 1e-3


def test_generic_builder_options_box_pinned_density_width():
    sk = Skeleton(["hip", "knee", "foot"], [-1, 0, 1], [(0, 1, 0), (0, 0.5, 0), (0, 0.1, 0)])
    rd = build_ragdoll(sk, shape="box", width={"hip": 0.1}, width_ratio=0.25, density=500.0,
                       root="pinned", ground=False,
                       joint_types={"knee": "hinge"}, joint_axes={"knee": (1, 0, 0)},
                       joint_kwargs={"knee": {"limit": (-2.0, 0.0), "damping": 0.5}})
    m = rd.model
    assert m.body_names == ["hip", "knee"] and m.ngeom == 2
    np.testing.assert_allclose(m.geom_size[0], [0.05, 0.05, 0.25])        # width 0.1 given
    np.testing.assert_allclose(m.geom_size[1], [0.05, 0.05, 0.2])         # 0.25 x 0.4
    assert m.body_mass[0] == pytest.approx(500 * 0.1 * 0.1 * 0.5)
    j = m.joint_index("knee")
    np.testing.assert_allclose(m.joint_limit[j], [-2.0, 0.0])
    assert m.joint_damping[j] == 0.5
    assert m.joint_type_names[m.joint_index("hip")] == "ball"
    assert m.joint_parent[m.joint_index("hip")] == -1
    np.testing.assert_allclose(m.body_pos0[1], [0, 0.3, 0])
    # bones along y: the body's long axis (local z) points along the bone
    np.testing.assert_allclose(np.abs(Q.qrot(m.body_quat0[0], [0, 0, 1])), [0, 1, 0], atol=1e-12)


def test_siblings_do_not_collide_unless_asked():
    sk = Skeleton(["root", "a", "b", "a_end", "b_end"], [-1, 0, 0, 1, 2],
                  [(0, 1, 0), (0.05, 1.1, 0), (-0.05, 1.1, 0), (0.05, 1.5, 0), (-0.05, 1.5, 0)])
    keys = lambda rd: set(rd.model.exclude_keys.tolist())   # noqa: E731
    rd = build_ragdoll(sk)
    a, b = rd.model.body_index("a"), rd.model.body_index("b")
    assert body_pair_key(a, b, rd.model.nbody) in keys(rd)
    rd = build_ragdoll(sk, collide_siblings=True)
    assert body_pair_key(a, b, rd.model.nbody) not in keys(rd)


# ------------------------------------------------------------------ errors

def test_unknown_joint_names_are_refused(walk):
    with pytest.raises(tumble.ModelError, match=r"joint_types names unknown joints \['lKneee'\]"):
        tumble.ragdoll_from_motion(walk, joint_types={"lKneee": "hinge"})
    with pytest.raises(tumble.ModelError, match="lWrist_end"):   # an end site drives no body
        tumble.ragdoll_from_motion(walk, joint_kwargs={"lWrist_end": {}})
    with pytest.raises(tumble.ModelError, match="joint_kwargs names unknown joints"):
        tumble.games105_ragdoll(joint_kwargs={"nose": {"damping": 1.0}})
    with pytest.raises(tumble.ModelError, match="width names unknown joints"):
        tumble.ragdoll_from_motion(walk, width={"tail": 0.1})


def test_bad_joint_options_are_refused(walk):
    with pytest.raises(tumble.ModelError, match="joint 'lKnee' is a hinge and needs an axis"):
        tumble.ragdoll_from_motion(walk, joint_types={"lKnee": "hinge"})
    with pytest.raises(tumble.ModelError, match="type must be one of"):
        tumble.ragdoll_from_motion(walk, joint_types={"lKnee": "slider"})
    with pytest.raises(tumble.ModelError, match="takes no axis"):
        tumble.ragdoll_from_motion(walk, joint_axes={"lKnee": (1, 0, 0)})
    with pytest.raises(tumble.ModelError, match="may not set"):
        tumble.ragdoll_from_motion(walk, joint_kwargs={"lKnee": {"anchor": (0, 0, 0)}})
    with pytest.raises(tumble.ModelError, match="root must be one of"):
        tumble.games105_ragdoll("hanging")
    with pytest.raises(tumble.ModelError, match="shape"):
        tumble.ragdoll_from_motion(walk, shape="cone")
    with pytest.raises(tumble.ModelError, match="total_mass"):
        tumble.ragdoll_from_motion(walk, total_mass=-1.0)
    with pytest.raises(tumble.ModelError, match="floating"):
        tumble.ragdoll_from_motion(walk, joint_types={"RootJoint": "ball"})
    with pytest.raises(tumble.ModelError, match="Motion"):
        tumble.ragdoll_from_motion("walk_forward.bvh")
