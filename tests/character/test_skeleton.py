"""Skeletons and the course character file (tumble/character/skeleton.py)."""
from pathlib import Path

import numpy as np
import pytest

import tumble
from tumble.character import Skeleton, games105_character_path, load_character_model

DATA = Path(__file__).resolve().parent.parent / "data" / "games105"


def test_shipped_character_file():
    cm = load_character_model()
    sk = cm.skeleton
    assert sk.num_joints == 25 and cm.nbody == 20
    assert sk.joint_names[0] == "RootJoint" and sk.parents[0] == -1
    assert all(n.endswith("_end") for n in sk.joint_names[20:])
    assert not any(sk.children(j) for j in range(20, 25))          # end sites are leaves
    np.testing.assert_array_equal(sk.up, [0, 1, 0])
    walk = tumble.load_bvh(DATA / "walk_forward.bvh")
    assert set(sk.joint_names) == set(walk.joint_names)
    # the same file read by path and as a dict
    raw = np.load(games105_character_path(), allow_pickle=True).item()
    again = load_character_model(raw)
    np.testing.assert_array_equal(again.skeleton.rest_positions, sk.rest_positions)
    np.testing.assert_array_equal(again.body_pos, cm.body_pos)


def test_skeleton_from_motion_is_the_character_t_pose():
    walk = tumble.load_bvh(DATA / "walk_forward.bvh")
    cm = load_character_model()
    root = cm.skeleton.rest_positions[0]
    sk = Skeleton.from_motion(walk, root_position=root)
    for j, name in enumerate(sk.joint_names):
        np.testing.assert_allclose(sk.rest_positions[j],
                                   cm.skeleton.rest_positions[cm.skeleton.index(name)], atol=1e-6)
    assert sk.children("RootJoint") == [walk.index(n) for n in ("lHip", "rHip", "pelvis_lowerback")]
    np.testing.assert_allclose(sk.offsets[1:], walk.offsets[1:], atol=1e-15)


def save_dict(tmp_path, data, name="bad.npy"):
    path = tmp_path / name
    box = np.empty((), dtype=object)        # a 0-d object array, as the course saves its dict
    box[()] = data
    np.save(path, box, allow_pickle=True)
    return path


def good_dict():
    return dict(np.load(games105_character_path(), allow_pickle=True).item())


@pytest.mark.parametrize("change, message", [
    (lambda d: d.pop("parent"), r"missing keys \['parent'\]"),
    (lambda d: d.update(joint_pos=d["joint_pos"][:24]), r"joint_pos has shape \(24, 3\)"),
    (lambda d: d.update(joint_pos=np.where(np.eye(25, 3) > 0, np.nan, d["joint_pos"])),
     "joint_pos has non-finite"),
    (lambda d: d.update(parent=np.where(np.arange(25) == 3, 40, d["parent"])),
     "'rHip' has parent index 40 out of range"),
    (lambda d: d.update(parent=np.where(np.arange(25) == 0, 1, d["parent"])),
     "exactly one root"),
    (lambda d: d.update(body_pos=np.zeros((26, 3))), r"body_pos has shape \(26, 3\)"),
    (lambda d: d.update(joint_name=["RootJoint"] * 25), "duplicate joint names"),
    (lambda d: d.update(parent=np.where(np.arange(25) == 11, 23, d["parent"])),
     "'torso_head' owns body 11 but its parent 'lToeJoint_end' has no body"),
])
def test_malformed_character_files(tmp_path, change, message):
    data = good_dict()
    change(data)
    with pytest.raises(tumble.ModelError, match=r"bad\.npy: .*" + message):
        load_character_model(save_dict(tmp_path, data))


def test_character_files_that_are_not_dicts(tmp_path):
    path = tmp_path / "array.npy"
    np.save(path, np.zeros((3, 3)))
    with pytest.raises(tumble.ModelError, match="array.npy: expected a pickled dict"):
        load_character_model(path)
    text = tmp_path / "text.npy"
    text.write_text("joint_name: RootJoint\n")
    with pytest.raises(tumble.ModelError, match="text.npy: not a NumPy .npy file"):
        load_character_model(text)
    with pytest.raises(tumble.ModelError, match="pickled dict, got list"):
        load_character_model(save_dict(tmp_path, [1, 2]))
    with pytest.raises(FileNotFoundError):
        load_character_model(tmp_path / "missing.npy")


def test_skeleton_errors():
    with pytest.raises(tumble.ModelError, match="cycle"):
        Skeleton(["a", "b", "c"], [-1, 2, 1], np.zeros((3, 3)))
    with pytest.raises(tumble.ModelError, match=r"rest_positions has shape \(2, 3\)"):
        Skeleton(["a", "b", "c"], [-1, 0, 1], np.zeros((2, 3)))
    with pytest.raises(tumble.ModelError, match="up must be"):
        Skeleton(["a"], [-1], np.zeros((1, 3)), up="w")
    with pytest.raises(tumble.ModelError, match="no joint named 'd'"):
        Skeleton(["a"], [-1], np.zeros((1, 3))).index("d")
