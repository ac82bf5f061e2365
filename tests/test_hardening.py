"""Every bad input is a tumble error naming the thing (the "Hardening" issue, items 2 and 3).

Each test is one finding of the probe: an exception that was not tumble's (so code catching
``tumble.TumbleError`` missed it) or input that was accepted in silence. The fuzz tests in
tests/io/test_fuzz_*.py check the same over thousands of mutated files. No world is stepped.
"""
import time
import warnings

import numpy as np
import pytest

import tumble
import tumble.io._xml as xml_module
import tumble.io.bvh as bvh_module
import tumble.io.mjcf as mjcf_module
from tumble.character.pd import PDController
from tumble.errors import ModelError, StateError, TumbleError, TumbleWarning
from tumble.io.bvh import format_bvh, load_bvh, load_bvh_string

INERTIA = 'ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"'

SMALL_BVH = """HIERARCHY
ROOT hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT knee
  {
    OFFSET 0 -0.4 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 -0.4 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.5
0 1 0 0 0 0 10 0 0
0 1 0 0 0 0 20 0 0
"""


def quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TumbleWarning)
        return fn(*a, **kw)


def bvh_chain(depth):
    """A root and ``depth - 1`` joints nested in each other, one frame."""
    n = depth - 1
    return ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Yrotation Xrotation\n"
            + "".join(f"JOINT j{i}\n{{\nOFFSET 0 0.1 0\nCHANNELS 1 Zrotation\n" for i in range(n))
            + "}\n" * n + "}\nMOTION\nFrames: 1\nFrame Time: 0.1\n"
            + " ".join(["1"] * (3 + n)) + "\n")


def mjcf_chain(depth):
    return ("<mujoco><worldbody>"
            + "".join(f"<body name='b{i}' pos='0 0 -0.1'><joint axis='0 1 0'/><geom size='0.05'/>"
                      for i in range(depth)) + "</body>" * depth + "</worldbody></mujoco>")


def urdf_chain(n):
    links = "".join(f'<link name="l{i}"><inertial><mass value="1"/><inertia {INERTIA}/>'
                    f"</inertial></link>" for i in range(n))
    joints = "".join(f'<joint name="j{i}" type="continuous"><parent link="l{i}"/>'
                     f'<child link="l{i + 1}"/><origin xyz="0 0 -0.1"/><axis xyz="0 1 0"/>'
                     f"</joint>" for i in range(n - 1))
    return f'<robot name="chain">{links}{joints}</robot>'


def small_world(nworld=1, names=("a", "b")):
    b = tumble.ModelBuilder()
    b.add_body(names[0], pos=(0, 0, 1), mass=1.0, inertia=(0.1, 0.1, 0.1))
    b.add_body(names[1], pos=(0, 0, 0.5), mass=1.0, inertia=(0.1, 0.1, 0.1))
    b.add_joint("j", "ball", names[0], names[1], anchor=(0, 0, 0.75))
    return tumble.World(b.build(), nworld=nworld)


# ------------------------------------------------------------ 2. deep trees: no recursion
def test_deep_mjcf_urdf_and_bvh_trees_load_without_recursion_errors():
    """The parsers walk trees with explicit stacks: 700 nested MJCF bodies, 1,100 URDF links
    and 999 nested BVH joints load (and the BVH writes back); the probe's RecursionErrors
    came at about 600, 1,000 and 1,000."""
    m = quiet(tumble.load_mjcf, mjcf_chain(700))
    assert m.nbody == 700 and m.njoint == 700
    m = quiet(tumble.load_urdf, urdf_chain(1100), fixed_base=True)
    assert m.nbody == 1099 and m.njoint == 1099
    motion = load_bvh_string(bvh_chain(999))
    assert motion.num_joints == 999 and motion.parents[-1] == 997
    again = load_bvh_string(format_bvh(motion))
    np.testing.assert_allclose(again.forward_kinematics()[0], motion.forward_kinematics()[0],
                               atol=1e-9)


def test_nesting_past_the_caps_is_a_model_error_naming_the_cap():
    with pytest.raises(ModelError, match=r"line 4002: joint 'j999' is nested more than 1000 "
                                         r"deep.*tumble\.io\.bvh\.MAX_DEPTH"):
        load_bvh_string(bvh_chain(1001))
    deep = "<mujoco><worldbody>" + "<frame>" * 1000 + "</frame>" * 1000 + "</worldbody></mujoco>"
    with pytest.raises(ModelError, match=r"<string> line 1, <frame>: elements nested more than "
                                         r"1000 deep.*tumble\.io\._xml\.MAX_DEPTH"):
        tumble.load_mjcf(deep)
    deep = "<robot name='r'>" + "<link name='a'>" * 1000 + "</link>" * 1000 + "</robot>"
    with pytest.raises(ModelError, match=r"nested more than 1000 deep"):
        tumble.load_urdf(deep)


# ------------------------------------------------------------ 2. BVH counts
@pytest.mark.parametrize("old,new,message", [
    ("CHANNELS 3", "CHANNELS \u00b3", r"line 9: expected a channel count, got '\u00b3'"),
    ("Frames: 2", "Frames: \u00b2", r"line 17: expected a frame count, got '\u00b2'"),
    ("CHANNELS 3", "CHANNELS \u0663", r"line 9: expected a channel count"),
    ("CHANNELS 3", "CHANNELS 99999999999", r"line 9: joint 'knee' has 99999999999 channels; "
                                           r"a joint has at most 6"),
])
def test_bvh_counts_in_other_digits_are_model_errors(old, new, message):
    with pytest.raises(ModelError, match=message):
        load_bvh_string(SMALL_BVH.replace(old, new))


# ------------------------------------------------------------ 2. STL vertices
@pytest.mark.parametrize("lines", [
    ["vertex 0 0", "vertex 1 0 0", "vertex 0 1 0"],
    # six two-number lines: 12 numbers, which used to regroup silently into 4 wrong points
    ["vertex 0 0", "vertex 1 0", "vertex 0 1", "vertex 0 0", "vertex 1 1", "vertex 3 3"],
    ["vertex 0 0 0 0", "vertex 1 0 0", "vertex 0 1 0"],
])
def test_ascii_stl_vertex_without_three_numbers_names_file_line_and_geom(tmp_path, lines):
    (tmp_path / "m.stl").write_text("solid m\nfacet normal 0 0 1\nouter loop\n"
                                    + "\n".join(lines) + "\nendloop\nendfacet\nendsolid m\n")
    (tmp_path / "a.xml").write_text(
        "<mujoco><asset><mesh name='m' file='m.stl'/></asset><worldbody>\n<body name='b'>"
        "<freejoint/><geom name='g' type='mesh' mesh='m'/></body></worldbody></mujoco>")
    with pytest.raises(ModelError, match=r"a\.xml line 2, <geom name='g'>: attribute 'mesh': "
                                         r"mesh 'm' .*m\.stl' line 4: a vertex needs x y z"):
        tumble.load_mjcf(tmp_path / "a.xml")
    (tmp_path / "r.urdf").write_text(
        f"<robot name='r'><link name='b'><inertial><mass value='1'/><inertia {INERTIA}/>"
        f"</inertial>\n<collision name='c'><geometry><mesh filename='m.stl'/></geometry>"
        f"</collision></link></robot>")
    with pytest.raises(ModelError, match=r"r\.urdf line 2, <mesh>: attribute 'filename': "
                                         r"collision 'c' of link 'b': .*m\.stl' line 4"):
        tumble.load_urdf(tmp_path / "r.urdf")


# ------------------------------------------------------------ 2. bytes, paths, files
def test_non_utf8_text_and_surrogates_are_malformed_xml_with_the_line():
    body = b"<mujoco><worldbody>\n<body name='\xff'><freejoint/><geom size='1'/></body>" \
           b"</worldbody></mujoco>"
    with pytest.raises(ModelError, match=r"<string> line 2, column \d+: malformed XML"):
        tumble.load_mjcf(body)
    with pytest.raises(ModelError, match=r"<string> line 1, column \d+: malformed XML"):
        tumble.load_urdf(b"<robot name='\xfe\xff'><link name='a'/></robot>")
    with pytest.raises(ModelError, match=r"<string> line 2: malformed XML: character "
                                         r"'\\udcff' cannot be encoded"):
        tumble.load_mjcf("<mujoco>\n<worldbody><body name='\udcff'/></worldbody></mujoco>")


def test_non_utf8_files_name_the_file(tmp_path):
    (tmp_path / "bad.xml").write_bytes(b"<mujoco>\n<worldbody><body name='\xff'/>"
                                       b"</worldbody></mujoco>")
    with pytest.raises(ModelError, match=r"bad\.xml line 2, column \d+: malformed XML"):
        tumble.load_mjcf(tmp_path / "bad.xml")
    (tmp_path / "bad.urdf").write_bytes(b"<robot name='\xff'><link name='a'/></robot>")
    with pytest.raises(ModelError, match=r"bad\.urdf line 1"):
        tumble.load_urdf(tmp_path / "bad.urdf")


@pytest.mark.parametrize("load", [tumble.load_mjcf, tumble.load_urdf, load_bvh])
def test_paths_with_nul_directories_and_missing_files(load, tmp_path):
    name = load.__name__
    with pytest.raises(ModelError, match=fr"{name}: the path '.*a\\x00b' holds a NUL byte"):
        load(str(tmp_path / "a\x00b"))
    with pytest.raises(ModelError, match=fr"{name}: '.*' is a directory, not a file"):
        load(tmp_path)
    with pytest.raises(ModelError, match=fr"{name}: cannot read '.*missing': no such file") \
            as info:
        load(tmp_path / "missing")
    # the same error as before for code that catches FileNotFoundError
    assert isinstance(info.value, FileNotFoundError) and isinstance(info.value, TumbleError)


def test_bvh_scale_and_text_of_the_wrong_type():
    with pytest.raises(ModelError, match="scale must be a positive number, got 'abc'"):
        load_bvh_string(SMALL_BVH, "abc")
    with pytest.raises(ModelError, match="expected BVH text, got int"):
        load_bvh_string(5)
    assert load_bvh_string(SMALL_BVH.encode()).num_joints == 3


# ------------------------------------------------------------ 2. state files
def test_truncated_state_and_a_time_that_is_not_a_number(tmp_path):
    w = small_world()
    w.save_state(tmp_path / "s.npz")
    data = (tmp_path / "s.npz").read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(StateError, match=r"load_state: cut\.npz is not a tumble state file "
                                         r"\(BadZipFile"):
        w.load_state(tmp_path / "cut.npz")
    fields = dict(np.load(tmp_path / "s.npz"))
    for value, message in ((np.array("noon"), r"field 'time' must be a number \(s\), got <U4"),
                           (np.array([1.0, 2.0]), r"field 'time' must be a number"),
                           (np.array(np.nan), r"time is not finite")):
        np.savez(tmp_path / "t.npz", **{**fields, "time": value})
        with pytest.raises(StateError, match=message):
            w.load_state(tmp_path / "t.npz")
    for key in ("format_version", "nrow", "nworld"):
        np.savez(tmp_path / "k.npz", **{**fields, key: np.array("x")})
        with pytest.raises(StateError, match=fr"field '{key}' must be an integer"):
            w.load_state(tmp_path / "k.npz")
    np.savez(tmp_path / "n.npz", **{k: v for k, v in fields.items() if k != "joint_names"})
    with pytest.raises(StateError, match=r"n\.npz lacks the field 'joint_names'"):
        w.load_state(tmp_path / "n.npz")
    st = w.get_state()
    st.time = "noon"
    with pytest.raises(StateError, match=r"set_state: time must be a number \(s\), got 'noon'"):
        w.set_state(st)
    with pytest.raises(StateError, match=r"NUL byte"):
        w.load_state(str(tmp_path / "a\x00.npz"))
    with pytest.raises(StateError, match=r"load_state: no file missing\.npz") as info:
        w.load_state(tmp_path / "missing.npz")
    assert isinstance(info.value, FileNotFoundError)
    (tmp_path / "adir.npz").mkdir()
    with pytest.raises(StateError, match=r"adir\.npz is not a tumble state file"):
        w.load_state(tmp_path / "adir.npz")


def test_state_file_that_unpacks_past_the_cap(tmp_path, monkeypatch):
    import tumble.io._files as files
    w = small_world()
    w.save_state(tmp_path / "s.npz")
    monkeypatch.setattr(files, "MAX_STATE_BYTES", 1000)
    with pytest.raises(StateError, match=r"s\.npz unpacks to .* more than the 1000 bytes "
                                         r"tumble reads \(tumble\.io\._files\.MAX_STATE_BYTES\)"):
        w.load_state(tmp_path / "s.npz")


def test_contacts_of_a_state_must_be_this_models_geoms():
    b = tumble.ModelBuilder()
    b.add_body("ball", pos=(0, 0, 0.1), density=1000.0)
    b.add_geom("ball", "sphere", size=(0.1,))
    b.add_geom(None, "plane")
    w = tumble.World(b.build())
    st = w.get_state()
    c = w.contact_arrays
    arrays = [np.zeros((1, 1) + a.shape[2:], a.dtype) for a in c]
    arrays[0][0, 0] = (0, 7)
    arrays[1][0, 0] = (0, -1)
    st.contacts, st.contact_count = type(c)(*arrays), np.array([1])
    with pytest.raises(StateError, match=r"contacts\.geom holds geom indices outside \[0, 2\)"):
        w.set_state(st)
    arrays[0][0, 0] = (0, 1)
    arrays[1][0, 0] = (0, 0)
    with pytest.raises(StateError, match=r"contacts\.body is not the bodies of contacts\.geom"):
        w.set_state(st)
    arrays[1][0, 0] = (0, -1)
    w.set_state(st)
    assert len(w.contacts) == 1


# ------------------------------------------------------------ 2. arguments
def test_zero_target_quaternion_names_the_joint():
    w = small_world()
    pd = PDController(w, 10.0, 1.0)
    before = w.pd_target_quat.copy()
    with pytest.raises(ModelError, match=r"set_targets: the target of joint 'j' is a zero "
                                         r"quaternion"):
        pd.set_targets(np.zeros((1, 4)))
    with pytest.raises(ModelError, match=r"set_targets: .* must be numbers"):
        pd.set_targets("identity")
    with pytest.raises(ModelError, match=r"set_targets: .* must be numbers"):
        pd.set_targets([[0, 0, 0, 1]], angvel="fast")
    np.testing.assert_array_equal(w.pd_target_quat, before)
    pd.set_targets([[0, 0, 0, 2.0]])                 # not unit: normalised, as before


def test_step_count_beyond_int64_and_strings_for_numbers():
    w = small_world()
    with pytest.raises(ModelError, match=r"step: n must be a non-negative integer below 2\*\*63"):
        w.step(10 ** 20)
    for call, message in (
            (lambda: w.apply_force("a", "up"), r"apply_force on body 'a': force must be 3 "
                                               r"numbers, got 'up'"),
            (lambda: w.apply_force("a", (0, 0, 1), point=["x", 0, 0]),
             r"apply_force on body 'a': point must be 3 numbers"),
            (lambda: w.apply_torque("b", "spin"), r"apply_torque on body 'b': torque must be"),
            (lambda: tumble.ModelBuilder().add_body("x", mass=1.0, inertia="heavy"),
             r"body 'x': inertia must be numbers"),
            (lambda: tumble.ModelBuilder().add_body("x", mass=1.0, inertia=["a", 1, 1]),
             r"body 'x': inertia must be numbers"),
            (lambda: tumble.ModelBuilder().add_geom(None, "sphere", radius="big"),
             r"geom 'geom0': radius must be a number, got 'big'"),
            (lambda: tumble.ModelBuilder().add_geom(None, "sphere", size="big"),
             r"geom 'geom0': size must be numbers"),
            (lambda: tumble.ModelBuilder().add_geom(None, "capsule", radius=0.1,
                                                    half_length="long"),
             r"geom 'geom0': half_length must be a number"),
            (lambda: tumble.ModelBuilder().add_geom(None, ["box"]), r"geom 'geom0': type must"),
            (lambda: tumble.ModelBuilder().add_body("x", mass=1.0, kind=["static"]),
             r"body 'x': kind must be one of"),
    ):
        with pytest.raises(ModelError, match=message) as info:
            call()
        assert isinstance(info.value, TumbleError)
    assert not w.control_arrays.applied_force.any() and not w.control_arrays.applied_torque.any()


# ------------------------------------------------------------ 3. quiet acceptance
def test_set_state_refuses_the_state_of_another_model_with_the_same_shapes():
    w = small_world()
    other = small_world(names=("x", "y"))
    with pytest.raises(StateError, match=r"set_state: the state belongs to a model with 2 "
                                         r"bodies \['x', 'y'\]; this world's model has 2 bodies "
                                         r"\['a', 'b'\]"):
        w.set_state(other.get_state())
    st = other.get_state()
    st.body_names = st.joint_names = None           # a state written by hand: shapes only
    w.set_state(st)
    assert small_world().get_state().body_names == ("a", "b")


@pytest.mark.parametrize("old,new,message", [
    ("OFFSET 0 -0.4 0\n    CHANNELS", "OFFSET 0 1e308 0\n    CHANNELS",
     r"line 8: OFFSET of 'knee' is 1e308, beyond the \+-1e\+09 tumble reads"),
    ("OFFSET 0 -0.4 0\n    }", "OFFSET 0 -1e10 0\n    }",
     r"line 12: OFFSET of the End Site of 'knee' is -1e10"),
    ("0 1 0 0 0 0 20 0 0", "0 1e300 0 0 0 0 20 0 0",
     r"line 20: Yposition of joint 'hips' in frame 1 is 1e300, beyond"),
    ("0 1 0 0 0 0 20 0 0", "0 1 0 0 0 0 20 0 inf",
     r"line 20: non-finite channel value: Xrotation of joint 'knee' in frame 1 is 'inf'"),
])
def test_absurd_bvh_values_are_refused_naming_joint_and_line(old, new, message):
    assert old in SMALL_BVH
    with pytest.raises(ModelError, match=message):
        load_bvh_string(SMALL_BVH.replace(old, new))


def test_bvh_scale_that_overflows_the_positions():
    with pytest.raises(ModelError, match=r"scale 1e\+308 makes the joint positions overflow"):
        load_bvh_string(SMALL_BVH, scale=1e308)


def test_mjcf_includes_are_capped_in_number_and_nesting(tmp_path):
    # seven small files each including the next ten times: 10^6 includes uncapped
    for k in range(7):
        inner = "".join(f"<include file='f{k + 1}.xml'/>" for _ in range(10)) if k < 6 else \
            "<worldbody><body><freejoint/><geom size='0.1'/></body></worldbody>"
        (tmp_path / f"f{k}.xml").write_text(f"<mujoco>\n{inner}</mujoco>")
    start = time.perf_counter()
    with pytest.raises(ModelError, match=r"f\d\.xml line 2, <include>: attribute 'file': more "
                                         r"than 1000 includes in one model.*MAX_INCLUDES"):
        tumble.load_mjcf(tmp_path / "f0.xml")
    assert time.perf_counter() - start < 10.0
    for k in range(25):
        (tmp_path / f"n{k}.xml").write_text(f"<mujoco>\n<include file='n{k + 1}.xml'/></mujoco>")
    (tmp_path / "n25.xml").write_text("<mujoco/>")
    with pytest.raises(ModelError, match=r"n20\.xml line 2, <include>: attribute 'file': "
                                         r"includes nested more than 20 deep.*MAX_INCLUDE_DEPTH"):
        tumble.load_mjcf(tmp_path / "n0.xml")
    (tmp_path / "self.xml").write_text("<mujoco>\n<include file='self.xml'/></mujoco>")
    with pytest.raises(ModelError, match=r"'self\.xml' includes itself"):
        tumble.load_mjcf(tmp_path / "self.xml")
    (tmp_path / "adir").mkdir()
    (tmp_path / "d.xml").write_text("<mujoco>\n<include file='adir'/></mujoco>")
    with pytest.raises(ModelError, match=r"d\.xml line 2, <include>: attribute 'file': include: "
                                         r"'.*adir' is a directory"):
        tumble.load_mjcf(tmp_path / "d.xml")


def test_xml_size_and_element_caps(tmp_path, monkeypatch):
    (tmp_path / "part.xml").write_text("<mujoco>" + "<size/>" * 50 + "</mujoco>")
    (tmp_path / "m.xml").write_text("<mujoco>\n" + "<include file='part.xml'/>" * 5
                                    + "</mujoco>")
    monkeypatch.setattr(xml_module, "MAX_ELEMENTS", 200)
    with pytest.raises(ModelError, match=r"part\.xml line 1, <size>: the model has more than "
                                         r"200 elements .*MAX_ELEMENTS"):
        quiet(tumble.load_mjcf, tmp_path / "m.xml")
    monkeypatch.setattr(xml_module, "MAX_ELEMENTS", 10 ** 6)
    monkeypatch.setattr(mjcf_module, "MAX_XML_BYTES", 1000)
    monkeypatch.setattr(xml_module, "MAX_XML_BYTES", 1000)
    with pytest.raises(ModelError, match=r"more than 1000 bytes of XML .*MAX_XML_BYTES"):
        quiet(tumble.load_mjcf, tmp_path / "m.xml")
    (tmp_path / "big.urdf").write_text("<robot name='r'>" + " " * 2000 + "</robot>")
    with pytest.raises(ModelError, match=r"load_urdf: '.*big\.urdf' is larger than 1000 bytes"):
        tumble.load_urdf(tmp_path / "big.urdf")


def test_bvh_file_size_cap(tmp_path, monkeypatch):
    (tmp_path / "m.bvh").write_text(SMALL_BVH)
    monkeypatch.setattr(bvh_module, "MAX_FILE_BYTES", 100)
    with pytest.raises(ModelError, match=r"load_bvh: '.*m\.bvh' is larger than 100 bytes, "
                                         r"the most tumble reads \(tumble\.io\.bvh\."
                                         r"MAX_FILE_BYTES\)"):
        load_bvh(tmp_path / "m.bvh")


def test_unreadable_mesh_names_the_file_and_the_geom(tmp_path):
    corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    (tmp_path / "cube.stl").write_text(
        "solid c\n" + "".join(f"facet normal 0 0 1\nouter loop\nvertex {a} {b} {c}\n"
                              f"vertex {a} {b} {c}\nvertex {a} {b} {c}\nendloop\nendfacet\n"
                              for a, b, c in corners) + "endsolid c\n")
    (tmp_path / "bad.stl").write_bytes(b"\x00\x01 not a mesh")
    (tmp_path / "adir.stl").mkdir()
    model = ("<mujoco><asset><mesh name='m' file='{f}'/></asset><worldbody>\n<body name='b'>"
             "<freejoint/><geom name='g' type='mesh' mesh='m'/></body></worldbody></mujoco>")
    for f, why in (("bad.stl", r"mesh file '.*bad\.stl' is neither binary nor ASCII STL"),
                   ("adir.stl", r"'.*adir\.stl' is a directory")):
        (tmp_path / "a.xml").write_text(model.format(f=f))
        with pytest.raises(ModelError, match=r"a\.xml line 2, <geom name='g'>: attribute "
                                             r"'mesh': mesh 'm' \(at line 1\): .*" + why):
            tumble.load_mjcf(tmp_path / "a.xml")
    # a missing file is still dropped (named in the load's warning); if that leaves the body
    # without mass, the error says which mesh was dropped and why
    (tmp_path / "a.xml").write_text(model.format(f="missing.stl"))
    with pytest.raises(ModelError, match=r"link 'b' moves .* has no mass \(links 'b'; "
                                         r"dropped: mesh geom 'g' \(mesh 'm': mesh file "
                                         r"'.*missing\.stl' not found\)\)"):
        tumble.load_mjcf(tmp_path / "a.xml")
    urdf = (f"<robot name='r'><link name='b'><inertial><mass value='1'/><inertia {INERTIA}/>"
            f"</inertial>\n<collision name='c'><geometry><mesh filename='{{f}}'/></geometry>"
            f"</collision></link></robot>")
    (tmp_path / "r.urdf").write_text(urdf.format(f="bad.stl"))
    with pytest.raises(ModelError, match=r"r\.urdf line 2, <mesh>: attribute 'filename': "
                                         r"collision 'c' of link 'b': mesh file '.*bad\.stl' is "
                                         r"neither"):
        tumble.load_urdf(tmp_path / "r.urdf")
    (tmp_path / "r.urdf").write_text(urdf.format(f="cube.stl").replace(
        "<mesh", "<mesh scale='1e200 1e200 1e200'"))
    with pytest.raises(ModelError, match=r"r\.urdf line 2, <mesh> \(mesh file 'cube\.stl'\): "
                                         r"a point lies 1e\+200 m from the origin, beyond the "
                                         r"1e\+12 m .*MAX_COORDINATE"):
        tumble.load_urdf(tmp_path / "r.urdf")


def test_huge_hulls_are_refused_before_qhull_sees_them():
    """Qhull crashed the interpreter (segmentation fault) on this cube 1e200 m wide, which
    the mesh fuzz made from a cube STL scaled by 1e200."""
    from tumble.model import meshes
    cube = np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    with pytest.raises(ModelError, match=r"geom 'g': a point lies 5e\+199 m from the origin"):
        meshes.convex_hull(5e199 * cube, "geom 'g'")
    with pytest.raises(ModelError, match=r"geom 'g': a point lies 1e\+13 m"):
        tumble.ModelBuilder().add_geom(None, "convex", vertices=1e13 * cube, name="g")
    assert len(meshes.convex_hull(1e11 * cube)) == 8
