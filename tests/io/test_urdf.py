"""Tests of the URDF loader (tumble/io/urdf.py).

Tolerances: periods to 2e-3 of the analytic value and 1e-6 between loaders (the same
model by two routes); hand-computed mass properties and frames to 1e-12.
"""
import math
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble
from tumble.errors import ModelError, TumbleWarning
from tumble.io.urdf import load_urdf, parse_urdf

INERTIA = 'ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"'

PENDULUM_URDF = f"""<robot name="pendulum">
  <link name="base"/>
  <link name="bob">
    <inertial><origin xyz="0 0 -1"/><mass value="1"/><inertia {INERTIA}/></inertial>
  </link>
  <joint name="pivot" type="continuous">
    <parent link="base"/><child link="bob"/>
    <origin xyz="0 0 0" rpy="0 0.05 0"/>
    <axis xyz="0 1 0"/>
  </joint>
</robot>"""

PENDULUM_MJCF = """<mujoco><compiler angle="radian"/><worldbody>
  <body name="bob" axisangle="0 1 0 0.05"><joint name="pivot" axis="0 1 0"/>
    <inertial pos="0 0 -1" mass="1" diaginertia="0.01 0.01 0.01"/></body>
  </worldbody></mujoco>"""


def quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TumbleWarning)
        return fn(*a, **kw)


def test_pendulum_period_matches_mjcf_builder_and_analytic(helpers):
    """The same pendulum from URDF, MJCF and the builder: the analytic small-angle period
    within 0.2%, and the three within 1e-6 of each other."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        urdf = load_urdf(PENDULUM_URDF, fixed_base=True)
        mjcf = tumble.load_mjcf(PENDULUM_MJCF)
    assert urdf.nbody == 1 and urdf.joint_type_names == ["hinge"]
    t_urdf = helpers.measure_period(urdf)
    t_mjcf = helpers.measure_period(mjcf)
    t_builder = helpers.measure_period(helpers.builder_pendulum())
    assert t_urdf == pytest.approx(helpers.analytic_period(), rel=2e-3)
    assert t_urdf == pytest.approx(t_builder, rel=1e-6)
    assert t_urdf == pytest.approx(t_mjcf, rel=1e-6)


def test_root_named_world_is_the_world_and_a_massless_floating_root_is_refused():
    m = load_urdf(PENDULUM_URDF.replace('"base"', '"world"'))
    assert m.body_names == ["bob"] and m.joint_parent[0] == -1
    with pytest.raises(ModelError, match=r"line 2, <link name='base'>: link 'base' moves .* "
                                         r"has no mass"):
        load_urdf(PENDULUM_URDF)                                 # floating by default


def test_inertial_origin_rpy_and_full_tensor():
    """Inertia given in a frame rotated by rpy about fixed axes, in a link whose joint
    origin is rotated too: world tensor R I R^T with R = R_joint R_inertial."""
    urdf = """<robot name="r">
      <link name="base"/>
      <link name="arm">
        <inertial>
          <origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.5"/>
          <mass value="2.5"/>
          <inertia ixx="0.4" ixy="0.05" ixz="-0.02" iyy="0.3" iyz="0.01" izz="0.2"/>
        </inertial>
      </link>
      <joint name="j" type="revolute">
        <parent link="base"/><child link="arm"/>
        <origin xyz="0 0 1" rpy="0 0 1.2"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="2" effort="10" velocity="3"/>
        <dynamics damping="0.7" friction="0.2"/>
      </joint>
    </robot>"""
    with pytest.warns(TumbleWarning, match="joint limit effort"):
        m = load_urdf(urdf, fixed_base=True)
    r_joint = Rotation.from_euler("z", 1.2)
    # rpy: roll about x, then pitch about y, then yaw about z, all fixed axes
    r_in = Rotation.from_rotvec([0, 0, 0.5]) * Rotation.from_rotvec([0, -0.2, 0]) * \
        Rotation.from_rotvec([0.3, 0, 0])
    tensor = np.array([[0.4, 0.05, -0.02], [0.05, 0.3, 0.01], [-0.02, 0.01, 0.2]])
    r = (r_joint * r_in).as_matrix()
    expected = r @ tensor @ r.T
    rb = Rotation.from_quat(m.body_quat0[0]).as_matrix()
    np.testing.assert_allclose(rb @ np.diag(m.body_inertia[0]) @ rb.T, expected, atol=1e-12)
    np.testing.assert_allclose(m.body_pos0[0], [0, 0, 1] + r_joint.apply([0.1, 0.2, 0.3]),
                               atol=1e-12)
    assert m.body_mass[0] == 2.5
    np.testing.assert_allclose(m.joint_limit[0], [-1, 2])
    assert (m.joint_damping[0], m.joint_friction[0]) == (0.7, 0.2)


def test_collision_shapes_fixed_joints_and_joint_types():
    urdf = f"""<robot name="r">
      <link name="base">
        <inertial><mass value="4"/><inertia {INERTIA}/></inertial>
        <collision name="box"><geometry><box size="0.2 0.4 0.6"/></geometry></collision>
      </link>
      <link name="plate">
        <inertial><origin xyz="0 0 0.5"/><mass value="1"/><inertia {INERTIA}/></inertial>
        <collision name="cyl"><origin xyz="0 0 0.5" rpy="1.5707963267948966 0 0"/>
          <geometry><cylinder radius="0.05" length="0.4"/></geometry></collision>
      </link>
      <link name="slide">
        <inertial><mass value="1"/><inertia {INERTIA}/></inertial>
        <collision><geometry><sphere radius="0.1"/></geometry></collision>
      </link>
      <link name="cap">
        <inertial><mass value="1"/><inertia {INERTIA}/></inertial>
        <collision><geometry><capsule radius="0.03" length="0.2"/></geometry></collision>
      </link>
      <link name="puck">
        <inertial><mass value="1"/><inertia {INERTIA}/></inertial>
      </link>
      <joint name="weld" type="fixed"><parent link="base"/><child link="plate"/>
        <origin xyz="0 0 0.3"/></joint>
      <joint name="rail" type="prismatic"><parent link="plate"/><child link="slide"/>
        <origin xyz="1 0 0"/><axis xyz="0 0 2"/><limit lower="-0.1" upper="0.2"/></joint>
      <joint name="wheel" type="continuous"><parent link="slide"/><child link="cap"/>
        <origin xyz="0 1 0"/><axis xyz="0 1 0"/></joint>
      <joint name="table" type="planar"><parent link="base"/><child link="puck"/>
        <origin xyz="0 -1 0"/><axis xyz="0 0 1"/></joint>
    </robot>"""
    b, report = quiet(parse_urdf, urdf)
    m = b.build()
    # plate is welded into base: one body of 5 kg at the mass-weighted COM
    assert report.body_map["plate"] == "base"
    assert m.body_mass[m.body_index("base")] == pytest.approx(5.0)
    np.testing.assert_allclose(m.body_pos0[m.body_index("base")], [0, 0, 0.8 / 5], atol=1e-12)
    sizes = {n: m.geom_size[m.geom_index(n)] for n in ("box", "cyl")}
    np.testing.assert_allclose(sizes["box"], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(sizes["cyl"][:2], [0.05, 0.2])
    np.testing.assert_allclose(m.geom_size[m.geom_index("cap/collision0")][:2], [0.03, 0.1])
    types = dict(zip(m.joint_names, m.joint_type_names))
    assert types == {"rail": "slider", "wheel": "hinge", "table:x": "slider",
                     "table:y": "slider", "table:rot": "hinge"}       # a free root: no joint
    np.testing.assert_allclose(m.joint_limit[m.joint_index("rail")], [-0.1, 0.2])
    # the planar joint's two auxiliary bodies take their mass out of the puck's
    puck = [m.body_index(n) for n in ("puck", "puck:table:x", "puck:table:y")]
    assert sum(m.body_mass[k] for k in puck) == pytest.approx(1.0)
    assert m.body_kind[m.body_index("base")] == 0                 # floating by default
    fixed = quiet(load_urdf, urdf, fixed_base=True, base_pos=(0, 0, 2))
    assert "base" not in fixed.body_names
    assert fixed.geom_body[fixed.geom_index("box")] == -1
    np.testing.assert_allclose(fixed.geom_pos[fixed.geom_index("box")], [0, 0, 2])


def test_fixed_base_arm_hangs_and_holds(helpers):
    """A two-link arm on a fixed base under gravity: it swings, stays finite and joined."""
    urdf = f"""<robot name="arm">
      <link name="base"><collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>
      <link name="upper"><inertial><origin xyz="0.25 0 0"/><mass value="1"/>
        <inertia {INERTIA}/></inertial>
        <collision><origin xyz="0.25 0 0" rpy="0 1.5707963267948966 0"/>
          <geometry><capsule radius="0.03" length="0.4"/></geometry></collision></link>
      <link name="lower"><inertial><origin xyz="0.25 0 0"/><mass value="1"/>
        <inertia {INERTIA}/></inertial>
        <collision><origin xyz="0.25 0 0" rpy="0 1.5707963267948966 0"/>
          <geometry><capsule radius="0.03" length="0.4"/></geometry></collision></link>
      <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
        <origin xyz="0.1 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3"/></joint>
      <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
        <origin xyz="0.5 0 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2"/>
        <dynamics damping="0.1"/></joint>
    </robot>"""
    m = load_urdf(urdf, fixed_base=True)
    w = tumble.World(m, dt=1 / 480)
    lowest = np.inf
    for _ in range(48):
        w.step(10)
        lowest = min(lowest, w.body_pos[m.body_index("lower"), 2])
    assert np.all(np.isfinite(w.body_pos))
    assert lowest < -0.3                                          # it swung down
    assert w.joint_separation().max() < 1e-3
    assert abs(w.joint_q[m.joint_index("elbow"), 0]) <= 2 + 1e-2


def test_meshes_and_ignored_elements_in_one_warning(tmp_path, helpers):
    helpers.write_cube_stl(tmp_path / "cube.stl")
    (tmp_path / "r.urdf").write_text(f"""<robot name="r">
      <material name="red"><color rgba="1 0 0 1"/></material>
      <link name="a">
        <inertial><mass value="1"/><inertia {INERTIA}/></inertial>
        <visual><geometry><box size="1 1 1"/></geometry></visual>
        <collision><geometry><mesh filename="cube.stl" scale="0.2 0.2 0.2"/></geometry></collision>
        <collision><geometry><mesh filename="package://robot/meshes/missing.dae"/></geometry>
        </collision>
      </link>
      <link name="b"><inertial><mass value="1"/><inertia {INERTIA}/></inertial></link>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
        <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="5"/>
        <mimic joint="k"/></joint>
      <gazebo reference="a"/>
      <transmission name="t"/>
    </robot>""")
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        m = load_urdf(tmp_path / "r.urdf")
    assert len(record) == 1 and record[0].category is TumbleWarning
    msg = str(record[0].message)
    for item in ("missing.dae", "<gazebo>", "<transmission>", "<joint><mimic>",
                 "joint limit effort", "<link><visual>", "<material>",
                 "collision mesh 'cube.stl' of link 'a' -> its convex hull (8 vertices)"):
        assert item in msg, item
    assert m.ngeom == 1 and m.geom_type[0] == 5
    np.testing.assert_allclose(np.ptp(m.mesh_vert if hasattr(m, "mesh_vert") else
                                      m.arrays.mesh_vert, axis=0), [0.2, 0.2, 0.2])


BAD = [
    ("<robot name='r'>\n<link name='a'>\n</robot>", r"line 3.*malformed XML"),
    ("<robot name='r'><link name='a'/><link name='b'/>\n<joint name='j' type='fixed'>"
     "<parent link='a'/><child link='b'/>\n<origin xyz='0 0 x'/></joint></robot>",
     r"line 3, <origin>: attribute 'xyz': 'x' is not a number"),
    ("<robot name='r'><link name='a'/><link name='b'/>\n<joint name='j' type='ball'>"
     "<parent link='a'/><child link='b'/></joint></robot>",
     r"line 2, <joint name='j'>: attribute 'type': unknown joint type 'ball'"),
    ("<robot name='r'><link name='a'/><link name='b'/>\n<joint name='j' type='fixed'>"
     "<parent link='a'/>\n<child/></joint></robot>",
     r"line 3, <child>: attribute 'link': is required"),
    ("<robot name='r'><link name='a'/><link name='b'/>\n<joint name='j' type='fixed'>"
     "<parent link='a'/>\n<child link='c'/></joint></robot>",
     r"line 3, <child>: attribute 'link': unknown link 'c'"),
    ("<robot name='r'><link name='a'/><link name='b'/>\n<joint name='j' type='revolute'>"
     "<parent link='a'/><child link='b'/></joint></robot>",
     r"line 2, <joint name='j'>: a revolute joint needs <limit"),
    ("<robot name='r'>\n<link name='a'/><link name='b'/></robot>",
     r"line 1, <robot name='r'>: a URDF tree has exactly one root link .* found 2"),
    ("<robot name='r'><link name='a'/><link name='b'/>\n<joint name='j' type='fixed'>"
     "<parent link='a'/><child link='b'/></joint>\n<joint name='k' type='fixed'>"
     "<parent link='a'/><child link='b'/></joint></robot>",
     r"line 3, <joint name='k'>: link 'b' already has a parent joint"),
    ("<robot name='r'><link name='a'>\n<collision><geometry><cone radius='1'/></geometry>"
     "</collision></link></robot>", r"line 2, <cone>: unknown collision shape"),
    ("<robot name='r'><link name='a'>\n<inertial><mass/><inertia/></inertial></link></robot>",
     r"line 2, <mass>: attribute 'value': is required"),
    ("<robot name='r'><link name='a'><inertial><mass value='1'/>\n<inertia ixx='1' "
     "iyy='1'/></inertial></link></robot>", r"line 2, <inertia>: attribute 'izz': is required"
     r"|line 2, <inertia>: attribute 'ixy': is required"),
    ("<robot name='r'><link name='a'><collision><geometry>\n<box size='1 -1 1'/>"
     "</geometry></collision></link></robot>", r"line 2, <box>: attribute 'size'"),
    ("<mujoco/>", r"the root element must be <robot>"),
]


@pytest.mark.parametrize("xml,message", BAD)
def test_malformed_urdf_names_element_attribute_and_line(xml, message):
    with pytest.raises(ModelError, match=message):
        quiet(load_urdf, xml, fixed_base=True)


def test_inertia_that_is_not_physical_names_the_link_and_line():
    urdf = """<robot name="r">
      <link name="a"><inertial><mass value="1"/>
        <inertia ixx="1" iyy="1" izz="5" ixy="0" ixz="0" iyz="0"/></inertial></link>
    </robot>"""
    with pytest.raises(ModelError, match=r"line 2, <link name='a'>: body 'a': inertia breaks "
                                         r"the triangle inequality"):
        load_urdf(urdf)


def test_pendulum_model_matches_mjcf_arrays():
    """Loaded from URDF and MJCF, the pendulum is the same model array for array."""
    a = load_urdf(PENDULUM_URDF, fixed_base=True)
    b = tumble.load_mjcf(PENDULUM_MJCF)
    for field in ("body_mass", "body_inertia", "body_pos0", "body_quat0", "joint_anchor_a",
                  "joint_anchor_b", "joint_frame_a", "joint_frame_b"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), atol=1e-12,
                                   err_msg=field)
    assert math.isclose(a.body_pos0[0, 0], -math.sin(0.05), rel_tol=1e-12)
