"""Tests of the MJCF loader (tumble/io/mjcf.py, with tumble/io/_assembly.py).

Tolerances: model arrays that are the same numbers by two routes (degree vs radian,
local vs global, tumble vs MuJoCo's compiler) to 1e-9 relative; periods to 2e-3 of the
analytic value (as the builder's pendulum test) and 1e-6 between loaders; hand-computed
mass properties to 1e-12 relative.
"""
import math
import os
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import tumble
import tumble.io.mjcf as mjcf_module
from tumble.errors import ModelError, TumbleWarning
from tumble.io.mjcf import _add_actuators, load_mjcf, parse_mjcf

GYM_FILES = {  # file: (tumble bodies, tumble joints, MJCF bodies without the world)
    "humanoid.xml": (11, 10, 13),
    "humanoidstandup.xml": (11, 10, 13),
    "ant.xml": (9, 8, 13),
    "hopper.xml": (6, 6, 4),
    "walker2d.xml": (9, 9, 7),
    "half_cheetah.xml": (9, 9, 7),
    "inverted_pendulum.xml": (2, 2, 2),
}


def quiet_load(source, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TumbleWarning)
        return load_mjcf(source, **kw)


def quiet_parse(source, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TumbleWarning)
        return parse_mjcf(source, **kw)


def world_inertia(model, k):
    r = Rotation.from_quat(model.body_quat0[k]).as_matrix()
    return r @ np.diag(model.body_inertia[k]) @ r.T


PENDULUM_XML = """<mujoco model="pendulum">
  <compiler angle="radian"/>
  <option timestep="0.001"/>
  <worldbody>
    <body name="bob" axisangle="0 1 0 0.05">
      <joint name="pivot" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0 -1" mass="1" diaginertia="0.01 0.01 0.01"/>
    </body>
  </worldbody>
</mujoco>"""


# ------------------------------------------------------------------- physics
def test_pendulum_period_matches_builder_and_analytic(helpers):
    """T = 2 pi sqrt(I_pivot / (m g L)) (1 + theta^2/16) within 0.2%, and the loaded
    pendulum swings like the one built by hand to 1e-6."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")               # a clean model loads without warning
        model = load_mjcf(PENDULUM_XML)
    assert model.timestep == 0.001
    assert tumble.World(model).dt == 0.001
    t_mjcf = helpers.measure_period(model)
    t_builder = helpers.measure_period(helpers.builder_pendulum())
    assert t_mjcf == pytest.approx(helpers.analytic_period(), rel=2e-3)
    assert t_mjcf == pytest.approx(t_builder, rel=1e-6)


def test_fromto_capsule_geometry_and_mass():
    """A capsule from (0,0,0) to (0.3,0,-0.4) in a body at (0,0,1): length 0.5, centred at
    (0.15, 0, 0.8), axis along (0.6, 0, -0.8); mass and inertia by hand (cylinder plus two
    hemispheres with the parallel-axis theorem)."""
    model = load_mjcf("""<mujoco><worldbody><body name="arm" pos="0 0 1"><freejoint/>
        <geom name="c" type="capsule" fromto="0 0 0 0.3 0 -0.4" size="0.05" density="500"/>
        </body></worldbody></mujoco>""")
    r, length, rho = 0.05, 0.5, 500.0
    h = length / 2
    m_cyl = rho * math.pi * r * r * length
    m_sph = rho * 4 / 3 * math.pi * r ** 3
    axial = m_cyl * r * r / 2 + 0.4 * m_sph * r * r
    # each hemisphere: 83/320 m r^2 about its own COM, which sits h + 3r/8 from the centre
    transverse = m_cyl * (3 * r * r + length ** 2) / 12 + m_sph * (83 / 320 * r * r
                                                                  + (h + 3 * r / 8) ** 2)
    assert model.body_mass[0] == pytest.approx(m_cyl + m_sph, rel=1e-12)
    np.testing.assert_allclose(model.body_pos0[0], [0.15, 0, 0.8], atol=1e-12)
    d = np.array([0.6, 0.0, -0.8])
    expected = transverse * np.eye(3) + (axial - transverse) * np.outer(d, d)
    np.testing.assert_allclose(world_inertia(model, 0), expected, rtol=0, atol=1e-12 * axial * 100)
    g = model.geom_index("c")
    np.testing.assert_allclose(model.geom_size[g][:2], [r, h], rtol=1e-12)
    rb = Rotation.from_quat(model.body_quat0[0])
    centre = model.body_pos0[0] + rb.apply(np.array(model.geom_pos[g]))
    axis = (rb * Rotation.from_quat(model.geom_quat[g])).apply([0, 0, 1])
    np.testing.assert_allclose(centre, [0.15, 0, 0.8], atol=1e-12)
    assert abs(axis @ d) == pytest.approx(1.0, abs=1e-12)


DEFAULTS_XML = """<mujoco>
  <default>
    <geom type="capsule" size="0.05 0.2" density="100" friction="0.7"/>
    <joint damping="2" type="hinge" axis="0 1 0"/>
    <default class="heavy">
      <geom density="1000"/>
      <default class="heavier">
        <geom density="3000" friction="0.3"/>
        <joint damping="7"/>
      </default>
    </default>
    <default class="slider">
      <joint type="slide" axis="1 0 0" range="-0.5 0.5"/>
    </default>
  </default>
  <worldbody>
    <body name="a" pos="0 0 2"><freejoint/><geom name="ga"/></body>
    <body name="b" pos="1 0 2" childclass="heavier">
      <freejoint/>
      <geom name="gb"/>
      <geom name="gb2" class="heavy" type="sphere" size="0.1" pos="0 0 0.5"/>
      <body name="c" pos="0 0 -0.5"><joint name="jc"/><geom name="gc" density="50"/></body>
      <body name="d" pos="0.5 0 0"><joint name="jd" class="slider"/><geom name="gd"/></body>
    </body>
  </worldbody>
</mujoco>"""


def test_default_classes_and_childclass():
    """main < heavy < heavier nesting, childclass on a body (inherited by its children), an
    explicit class over the childclass, and an element's own attribute over both."""
    m = load_mjcf(DEFAULTS_XML)
    capsule = math.pi * 0.05 ** 2 * 0.4 + 4 / 3 * math.pi * 0.05 ** 3
    sphere = 4 / 3 * math.pi * 0.1 ** 3
    assert m.body_mass[m.body_index("a")] == pytest.approx(100 * capsule, rel=1e-12)
    assert m.body_mass[m.body_index("b")] == pytest.approx(3000 * capsule + 1000 * sphere,
                                                           rel=1e-12)
    assert m.body_mass[m.body_index("c")] == pytest.approx(50 * capsule, rel=1e-12)
    assert m.body_mass[m.body_index("d")] == pytest.approx(3000 * capsule, rel=1e-12)
    friction = {n: m.geom_friction[m.geom_index(n)] for n in ("ga", "gb", "gb2", "gc", "gd")}
    assert friction == {"ga": 0.7, "gb": 0.3, "gb2": 0.7, "gc": 0.3, "gd": 0.3}
    jc, jd = m.joint_index("jc"), m.joint_index("jd")
    assert m.joint_type_names[jc] == "hinge" and m.joint_damping[jc] == 7.0
    # an explicit class replaces the childclass: 'slider' inherits main's damping, not
    # heavier's (MuJoCo's compiler gives the same dampings, frictions and masses)
    assert m.joint_type_names[jd] == "slider" and m.joint_damping[jd] == 2.0
    np.testing.assert_allclose(m.joint_limit[jd], [-0.5, 0.5])
    assert m.joint_limit[jc, 0] > m.joint_limit[jc, 1]             # no range: no limit


ANGLES_XML = """<mujoco>
  <compiler angle="{unit}" eulerseq="zyx"/>
  <worldbody>
    <body name="base" pos="0 0 1" euler="{e1} {e2} {e3}">
      <geom type="box" size="0.1 0.2 0.3" axisangle="1 1 0 {a}"/>
      <body name="arm" pos="0.3 0 0" axisangle="0 0 1 {a}">
        <joint name="hinge" axis="0 1 0" range="{lo} {hi}" ref="{ref}"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.04"/>
        <body name="ball" pos="0.4 0 0">
          <joint name="ball" type="ball" range="0 {hi}"/>
          <geom type="sphere" size="0.05"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def test_angle_units_degree_and_radian_give_the_same_model():
    deg = dict(e1=30, e2=-20, e3=45, a=60, lo=-45, hi=90, ref=10)
    rad = {k: math.radians(v) for k, v in deg.items()}
    a = quiet_load(ANGLES_XML.format(unit="degree", **deg))
    b = quiet_load(ANGLES_XML.format(unit="radian", **rad))
    for field in ("body_mass", "body_inertia", "body_pos0", "body_quat0", "geom_pos",
                  "geom_quat", "geom_size", "joint_limit", "joint_anchor_a", "joint_anchor_b",
                  "joint_frame_a", "joint_frame_b"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), rtol=1e-9,
                                   atol=1e-12, err_msg=field)
    h = a.joint_index("hinge")
    # the limit is relative to the model pose, which is at ref: (lo - ref, hi - ref)
    np.testing.assert_allclose(a.joint_limit[h], np.radians([-55, 80]), rtol=1e-12)
    np.testing.assert_allclose(a.joint_limit[a.joint_index("ball")], np.radians([-90, 90]))


def test_global_coordinates_give_the_same_model():
    """coordinate="global" (MuJoCo 2.x) places everything in the world frame."""
    local = """<mujoco><compiler angle="radian"/><worldbody>
        <body name="a" pos="0 0 1" quat="0.9238795 0 0.3826834 0"><freejoint/>
          <geom type="box" size="0.1 0.1 0.1"/>
          <body name="b" pos="0.5 0 0"><joint name="j" axis="0 1 0" pos="-0.1 0 0"/>
            <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/></body></body>
        </worldbody></mujoco>"""
    r = Rotation.from_quat([0, 0.3826834, 0, 0.9238795])
    pb = np.array([0, 0, 1]) + r.apply([0.5, 0, 0])
    pj = np.array([0, 0, 1]) + r.apply([0.4, 0, 0])
    p1 = pb + r.apply([0.3, 0, 0])
    glob = f"""<mujoco><compiler angle="radian" coordinate="global"/><worldbody>
        <body name="a" pos="0 0 1" quat="0.9238795 0 0.3826834 0"><freejoint/>
          <geom type="box" size="0.1 0.1 0.1" pos="0 0 1" quat="0.9238795 0 0.3826834 0"/>
          <body name="b" pos="{pb[0]} {pb[1]} {pb[2]}" quat="0.9238795 0 0.3826834 0">
            <joint name="j" axis="0 1 0" pos="{pj[0]} {pj[1]} {pj[2]}"/>
            <geom type="capsule" fromto="{pb[0]} {pb[1]} {pb[2]} {p1[0]} {p1[1]} {p1[2]}"
                  size="0.03"/></body></body>
        </worldbody></mujoco>"""
    a, b = quiet_load(local), quiet_load(glob)
    for field in ("body_mass", "body_pos0", "body_quat0", "geom_pos", "geom_quat",
                  "joint_anchor_a", "joint_anchor_b", "joint_frame_a", "joint_frame_b"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), atol=1e-9,
                                   err_msg=field)


def test_orientations_and_euler_sequences_match_mujoco():
    """quat (w first), axisangle, euler under several eulerseq, xyaxes and zaxis give the
    same geom orientation as MuJoCo's compiler."""
    mujoco = pytest.importorskip("mujoco")
    for seq in ("xyz", "zyx", "XYZ", "xYz", "ZXZ"):
        for orient in ('euler="10 -35 70"', 'axisangle="1 2 3 40"',
                       'xyaxes="1 1 0 -1 1 0.3"', 'zaxis="0.3 -1 0.5"',
                       'quat="0.9 0.1 -0.3 0.2"'):
            xml = f"""<mujoco><compiler eulerseq="{seq}"/><worldbody>
                <body name="b" {orient}><freejoint/>
                <geom type="box" size=".1 .2 .3" pos="0.1 0.2 0.3" {orient}/></body>
                </worldbody></mujoco>"""
            mm = mujoco.MjModel.from_xml_string(xml)
            dd = mujoco.MjData(mm)
            mujoco.mj_forward(mm, dd)
            m = load_mjcf(xml)
            rb = Rotation.from_quat(m.body_quat0[0])
            rot = (rb * Rotation.from_quat(m.geom_quat[0])).as_matrix()
            pos = m.body_pos0[0] + rb.apply(np.array(m.geom_pos[0]))
            np.testing.assert_allclose(rot, dd.geom_xmat[0].reshape(3, 3), atol=1e-9,
                                       err_msg=f"{seq} {orient}")
            np.testing.assert_allclose(pos, dd.geom_xpos[0], atol=1e-9)


def test_frames_and_their_childclass_match_mujoco():
    mujoco = pytest.importorskip("mujoco")
    xml = """<mujoco><default><default class="big"><geom size="0.2"/></default></default>
      <worldbody><body name="a" pos="0 0 1"><freejoint/><geom size="0.1"/>
        <frame pos="0.5 0 0" euler="0 0 90" childclass="big">
          <geom name="g" pos="0.1 0 0"/>
          <body name="b" pos="0.3 0 0"><joint axis="1 0 0"/><geom name="gb" pos="0 0 0.1"/></body>
        </frame></body></worldbody></mujoco>"""
    m = load_mjcf(xml)
    mm = mujoco.MjModel.from_xml_string(xml)
    dd = mujoco.MjData(mm)
    mujoco.mj_forward(mm, dd)
    for name in ("g", "gb"):
        k, g = m.geom_index(name), mm.geom(name).id
        b = m.geom_body[k]
        pos = m.body_pos0[b] + Rotation.from_quat(m.body_quat0[b]).apply(np.array(m.geom_pos[k]))
        np.testing.assert_allclose(pos, dd.geom_xpos[g], atol=1e-12)
        assert m.geom_size[k, 0] == mm.geom_size[g, 0] == 0.2
    np.testing.assert_allclose(m.body_mass, mm.body_mass[1:], rtol=1e-12)


# ------------------------------------------------------------- gymnasium models
@pytest.mark.parametrize("name", sorted(GYM_FILES))
def test_gymnasium_models_load_and_match_mujoco(name, helpers):
    """Body and joint counts, and every body's mass, COM and inertia equal to MuJoCo's
    (bodies welded into one tumble body compared as their composite; auxiliary bodies
    of joint chains counted with the body they come from); geoms and joint axes too."""
    mujoco = pytest.importorskip("mujoco")
    path = os.path.join(helpers.gymnasium_assets(), name)
    with pytest.warns(TumbleWarning) as record:
        builder, report = parse_mjcf(path)
    assert len([w for w in record if issubclass(w.category, TumbleWarning)]) == 1
    model = builder.build()
    nbody, njoint, nsource = GYM_FILES[name]
    assert (model.nbody, model.njoint) == (nbody, njoint)
    assert len(report.body_map) == nsource

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")                 # settotalmass is deprecated there
        mm = mujoco.MjModel.from_xml_path(path)
    dd = mujoco.MjData(mm)
    mujoco.mj_forward(mm, dd)
    assert model.timestep == mm.opt.timestep
    np.testing.assert_allclose(model.gravity, mm.opt.gravity)
    groups = {}
    for i in range(1, mm.nbody):
        body = report.body_map[mm.body(i).name or f"body{i}"]
        r = dd.ximat[i].reshape(3, 3)
        groups.setdefault(body, []).append((mm.body_mass[i], dd.xipos[i].copy(),
                                            r @ np.diag(mm.body_inertia[i]) @ r.T))
    from tumble.model.mass import combine
    for body, parts in groups.items():
        mass, com, inertia = combine(*zip(*parts))
        ks = [model.body_index(body)] + [k for k, n in enumerate(model.body_names)
                                         if n.startswith(body + ":")]
        assert sum(model.body_mass[k] for k in ks) == pytest.approx(mass, rel=1e-9)
        np.testing.assert_allclose(model.body_pos0[ks[0]], com, atol=1e-9)
        got = sum(world_inertia(model, k) for k in ks)
        np.testing.assert_allclose(got, inertia, rtol=0, atol=1e-9 * np.abs(inertia).max())

    for g in range(mm.ngeom):
        k = model.geom_index(mm.geom(g).name)
        b = model.geom_body[k]
        if b < 0:
            pos = model.geom_pos[k]
        else:
            pos = model.body_pos0[b] + Rotation.from_quat(model.body_quat0[b]).apply(
                np.array(model.geom_pos[k]))
        np.testing.assert_allclose(pos, dd.geom_xpos[g], atol=1e-9)

    for j in range(mm.njnt):
        tj, dof, sign = report.joint_map[mm.joint(j).name]
        if tj is None:
            continue
        k = model.joint_index(tj)
        axis = _dof_axis(model, k, dof)
        np.testing.assert_allclose(sign * axis, dd.xaxis[j], atol=1e-9)


def _dof_axis(model, k, dof):
    """World axis of DoF ``dof`` of tumble joint k in the initial pose."""
    t = model.joint_type_names[k]
    if t == "universal" and dof == 0:
        p = model.joint_parent[k]
        rp = Rotation.from_quat(model.body_quat0[p]) if p >= 0 else Rotation.identity()
        return (rp * Rotation.from_quat(model.joint_frame_a[k])).apply([1, 0, 0])
    c = model.joint_child[k]
    frame = Rotation.from_quat(model.body_quat0[c]) * Rotation.from_quat(model.joint_frame_b[k])
    return frame.apply(np.eye(3)[1 if t == "universal" else dof])


def test_humanoid_joint_merges(helpers):
    m = quiet_load(os.path.join(helpers.gymnasium_assets(), "humanoid.xml"))
    types = dict(zip(m.joint_names, m.joint_type_names))
    assert types["right_hip_x+right_hip_z+right_hip_y"] == "ball"
    assert types["abdomen_z+abdomen_y"] == "universal"
    assert types["right_shoulder1+right_shoulder2"] == "universal"
    assert types["right_knee"] == "hinge" and types["abdomen_x"] == "hinge"
    assert "right_foot" not in m.body_names                     # welded into the shin
    # the hip's box is the loosest holding x [-25, 5], z [-60, 35], y [-110, 20] degrees
    lo, hi = np.degrees(m.joint_limit[m.joint_index("right_hip_x+right_hip_z+right_hip_y")])
    assert lo <= -110 + 1e-9 and hi >= 35 - 1e-9 and hi - lo == pytest.approx(145)
    # the knee's range [-160, -2] degrees, about -y
    np.testing.assert_allclose(np.degrees(m.joint_limit[m.joint_index("right_knee")]),
                               [-160, -2])


def test_humanoid_falls_and_settles_on_the_floor(helpers):
    """3 s at the file's 3 ms step: no NaN, joints hold, the torso ends lying on the floor
    (MuJoCo's own humanoid ends with its torso at 0.08 m), at rest."""
    m = quiet_load(os.path.join(helpers.gymnasium_assets(), "humanoid.xml"))
    w = tumble.World(m)
    assert w.dt == 0.003
    w.step(1000)
    assert np.all(np.isfinite(w.body_pos)) and np.all(np.isfinite(w.body_vel))
    torso = w.body_pos[m.body_index("torso")]
    pelvis = w.body_pos[m.body_index("pelvis")]
    assert 0.05 < torso[2] < 0.3 and 0.05 < pelvis[2] < 0.3
    assert w.body_pos[:, 2].min() > 0.03
    assert np.abs(w.body_vel).max() < 0.5
    assert w.joint_separation().max() < 1e-3


@pytest.mark.parametrize("name,seconds", [("ant.xml", 1.0), ("hopper.xml", 1.0),
                                          ("walker2d.xml", 1.0), ("half_cheetah.xml", 1.0),
                                          ("inverted_pendulum.xml", 1.0)])
def test_gymnasium_models_simulate(name, seconds, helpers):
    """No NaN, nothing through the floor, hinges and balls held together."""
    m = quiet_load(os.path.join(helpers.gymnasium_assets(), name))
    w = tumble.World(m)
    w.step(int(round(seconds / w.dt)))
    assert np.all(np.isfinite(w.body_pos)) and np.all(np.isfinite(w.body_vel))
    if name != "inverted_pendulum.xml":                    # no floor there
        assert w.body_pos[:, 2].min() > 0.0
    held = [k for k, t in enumerate(m.joint_type_names) if t != "slider"]
    assert w.joint_separation()[held].max() < 1e-3


def test_planar_root_chain_keeps_mass_and_com(helpers):
    """hopper's slide x, slide z, hinge y root becomes two sliders and a hinge through two
    light auxiliary bodies whose mass comes out of the torso's."""
    mujoco = pytest.importorskip("mujoco")
    path = os.path.join(helpers.gymnasium_assets(), "hopper.xml")
    m = quiet_load(path)
    assert m.body_names[-2:] == ["torso:rootx", "torso:rootz"]
    assert [m.joint_type_names[m.joint_index(n)] for n in ("rootx", "rootz", "rooty")] == \
        ["slider", "slider", "hinge"]
    mm = mujoco.MjModel.from_xml_path(path)
    assert m.body_mass.sum() == pytest.approx(mm.body_mass.sum(), rel=1e-12)
    w = tumble.World(m)
    w.body_angvel[:] = (0, 1.0, 0)            # tip it over: it must stay in the x-z plane
    w.body_vel[:] = 0.0
    w.step(500)
    assert np.abs(w.body_pos[:, 1]).max() < 1e-6
    assert np.all(np.isfinite(w.body_pos)) and w.body_pos[:, 2].min() > 0.0


def test_merge_hinges_false_chains_every_hinge(helpers):
    mujoco = pytest.importorskip("mujoco")
    path = os.path.join(helpers.gymnasium_assets(), "humanoid.xml")
    m = quiet_load(path, merge_hinges=False)
    # 2 + 3 + 3 + 2 + 2 hinges on five bodies: 7 auxiliary bodies, one tumble joint per hinge
    assert (m.nbody, m.njoint) == (18, 17)
    assert set(m.joint_type_names) == {"hinge"}
    mm = mujoco.MjModel.from_xml_path(path)
    assert m.body_mass.sum() == pytest.approx(mm.body_mass.sum(), rel=1e-12)
    np.testing.assert_allclose(m.joint_limit[m.joint_index("right_hip_y")],
                               np.radians([-110, 20]))


# ------------------------------------------------------------------- actuators
class RecordingBuilder(tumble.ModelBuilder):
    """A builder with the add_actuator the loader calls when it exists."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.actuators = []

    def add_actuator(self, **kw):
        self.actuators.append(kw)


def test_actuators_reach_the_builder_with_merged_dofs(helpers, monkeypatch):
    monkeypatch.setattr(mjcf_module, "ModelBuilder", RecordingBuilder)
    path = os.path.join(helpers.gymnasium_assets(), "humanoid.xml")
    with pytest.warns(TumbleWarning) as record:
        builder, report = parse_mjcf(path)
    assert "<actuator>" not in str(record[0].message)
    calls = {c["name"]: c for c in builder.actuators}
    assert len(calls) == 17
    hip = calls["right_hip_y"]
    assert (hip["joint"], hip["dof"], hip["kind"]) == ("right_hip_x+right_hip_z+right_hip_y",
                                                       2, "motor")
    assert abs(hip["gear"]) == 300 and hip["ctrlrange"] == (-0.4, 0.4)
    model = builder.build()
    # the torque is the same vector: tumble gear * DoF axis = MJCF gear * MJCF joint axis
    mujoco = pytest.importorskip("mujoco")
    mm = mujoco.MjModel.from_xml_path(path)
    dd = mujoco.MjData(mm)
    mujoco.mj_forward(mm, dd)
    for a in range(mm.nu):
        call = calls[mm.actuator(a).name]
        axis = _dof_axis(model, model.joint_index(call["joint"]), call["dof"])
        np.testing.assert_allclose(call["gear"] * axis,
                                   mm.actuator_gear[a, 0] * dd.xaxis[mm.actuator_trnid[a, 0]],
                                   atol=1e-9)
    assert {s.name for s in report.actuators} == set(calls)


def test_actuator_kinds_and_ranges():
    xml = """<mujoco><worldbody><body name="b"><joint name="j" axis="1 0 0"/>
        <geom size="0.1"/></body></worldbody>
        <actuator>
          <motor name="m" joint="j" gear="5" ctrlrange="-1 1"/>
          <position name="p" joint="j" kp="30" kv="2" forcerange="-10 10"/>
          <general name="g" joint="j" gainprm="40" biastype="affine" biasprm="0 -40 -3"/>
          <general name="gm" joint="j" gear="2" gainprm="7"/>
          <velocity name="v" joint="j" kv="1"/>
        </actuator></mujoco>"""
    with pytest.warns(TumbleWarning, match=r"<actuator><velocity>"):
        b, report = parse_mjcf(xml)
    specs = {s.name: s for s in report.actuators}
    assert set(specs) == {"m", "p", "g", "gm"}
    assert (specs["m"].kind, specs["m"].gear, specs["m"].ctrlrange) == ("motor", 5.0, (-1, 1))
    assert (specs["p"].kind, specs["p"].kp, specs["p"].kv, specs["p"].forcerange) == \
        ("position", 30.0, 2.0, (-10, 10))
    assert specs["p"].ctrlrange is None and not specs["p"].ctrllimited
    assert (specs["g"].kind, specs["g"].kp, specs["g"].kv) == ("position", 40.0, 3.0)
    assert (specs["gm"].kind, specs["gm"].gear) == ("motor", 14.0)
    rec = RecordingBuilder()
    rec.add_body("b", mass=1.0, inertia=(1, 1, 1))
    rec.add_joint("j", "hinge", None, "b", axis=(1, 0, 0))
    assert _add_actuators(rec, report.actuators)
    assert [c["name"] for c in rec.actuators] == ["m", "p", "g", "gm"]
    assert rec.actuators[1]["dof"] == 0
    model = b.build()                      # the loader already gave them to its builder
    assert model.actuator_names == ["m", "p", "g", "gm"]
    assert model.actuator_kind_names == ["motor", "position", "position", "motor"]
    assert np.allclose(model.actuator_gear, [5.0, 1.0, 1.0, 14.0])
    assert np.allclose(model.actuator_forcerange[1], [-10, 10])


# ----------------------------------------------------------- other features
def test_mesh_geoms_from_stl_obj_and_inline_vertices(tmp_path, helpers):
    """A unit cube mesh scaled by 0.2: a convex hull of 8 vertices and mass rho (0.2)^3."""
    helpers.write_cube_stl(tmp_path / "cube.stl")
    corners = [(x, y, z) for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)]
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "cube.obj").write_text(
        "# cube\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in corners) + "f 1 2 3\n")
    inline = " ".join(f"{x} {y} {z}" for x, y, z in corners)
    (tmp_path / "model.xml").write_text(f"""<mujoco>
      <compiler meshdir="."/>
      <asset>
        <mesh name="stl" file="cube.stl" scale="0.2 0.2 0.2"/>
        <mesh file="meshes/cube.obj" scale="0.2 0.2 0.2"/>
        <mesh name="inline" vertex="{inline}" scale="0.2 0.2 0.2"/>
        <mesh name="gone" file="missing.stl"/>
      </asset>
      <worldbody>
        <body name="a" pos="0 0 1"><freejoint/><geom type="mesh" mesh="stl"/></body>
        <body name="b" pos="1 0 1"><freejoint/><geom type="mesh" mesh="cube" density="500"/></body>
        <body name="c" pos="2 0 1"><freejoint/><geom mesh="inline"/>
          <geom type="mesh" mesh="gone"/></body>
      </worldbody></mujoco>""")
    with pytest.warns(TumbleWarning, match="mesh 'gone'") as record:
        m = load_mjcf(tmp_path / "model.xml")
    assert len(record) == 1 and "convex hull of mesh 'stl'" in str(record[0].message)
    np.testing.assert_allclose(m.body_mass, [8.0, 4.0, 8.0], rtol=1e-9)
    np.testing.assert_allclose(m.body_inertia[0], [8.0 * 0.2 ** 2 / 6] * 3, rtol=1e-9)
    assert m.ngeom == 3 and all(m.geom_type == 5)               # convex
    assert np.all(m.body_inertia[2] > 0)


def test_ellipsoid_becomes_a_hull_with_exact_mass():
    with pytest.warns(TumbleWarning, match="ellipsoid geom 'e'"):
        m = load_mjcf("""<mujoco><worldbody><body name="b"><freejoint/>
            <geom name="e" type="ellipsoid" size="0.1 0.2 0.3"/></body></worldbody></mujoco>""")
    mass = 1000 * 4 / 3 * math.pi * 0.1 * 0.2 * 0.3
    assert m.body_mass[0] == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(m.body_inertia[0],
                               mass / 5 * np.array([0.13, 0.10, 0.05]), rtol=1e-12)
    assert m.geom_type[0] == 5


def test_include_settotalmass_inertiafromgeom_and_option(tmp_path):
    (tmp_path / "parts.xml").write_text("""<mujoco><worldbody>
        <body name="b" pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.1 0.1"/>
          <inertial pos="0 0 0" mass="3" diaginertia="0.1 0.1 0.1"/>
          <body name="c" pos="0 0 -0.3"><joint type="hinge" axis="0 1 0"/>
            <geom type="sphere" size="0.1"/></body></body>
        </worldbody></mujoco>""")
    base = """<mujoco><compiler {c}/><option gravity="0 0 -3" timestep="0.004"/>
        <include file="parts.xml"/></mujoco>"""

    def load(c):
        (tmp_path / "m.xml").write_text(base.format(c=c))
        return load_mjcf(tmp_path / "m.xml")

    auto = load('inertiafromgeom="auto"')
    sphere = 1000 * 4 / 3 * math.pi * 0.001
    np.testing.assert_allclose(auto.body_mass, [3.0, sphere])
    assert auto.timestep == 0.004 and tuple(auto.gravity) == (0, 0, -3)
    geoms = load('inertiafromgeom="true"')
    np.testing.assert_allclose(geoms.body_mass, [8.0, sphere])
    total = load('settotalmass="10"')
    np.testing.assert_allclose(total.body_mass.sum(), 10.0)
    np.testing.assert_allclose(total.body_inertia[0] / auto.body_inertia[0],
                               10 / (3 + sphere))
    with pytest.raises(ModelError, match="has no mass"):
        load('inertiafromgeom="false"')


def test_contact_filters_and_mocap():
    with pytest.warns(TumbleWarning, match=r"<contact><pair>"):
        m = load_mjcf("""<mujoco><worldbody>
        <geom name="floor" type="plane" size="1 1 0.1"/>
        <body name="target" mocap="true" pos="0 0 2">
          <geom size="0.1" contype="0" conaffinity="0"/></body>
        <body name="a" pos="0 0 1"><freejoint/>
          <geom name="ga" size="0.1" contype="2" conaffinity="4"/>
          <body name="b" pos="0 0 -0.2"><joint axis="1 0 0"/><geom size="0.1"/></body>
        </body>
        <body name="c" pos="1 0 1"><freejoint/><geom size="0.1"/></body>
        </worldbody>
        <contact><exclude body1="a" body2="c"/><pair geom1="ga" geom2="floor"/></contact>
        </mujoco>""")
    from tumble.model.builder import body_pair_key
    keys = set(m.exclude_keys.tolist())
    n = m.nbody
    idx = m.body_index
    assert body_pair_key(idx("a"), idx("c"), n) in keys            # contact/exclude
    assert body_pair_key(idx("a"), idx("b"), n) in keys            # parent and child
    assert body_pair_key(idx("b"), -1, n) not in keys              # MuJoCo: world collides
    assert m.body_kind[idx("target")] == 1                         # kinematic
    g = m.geom_index("ga")
    assert (m.geom_contype[g], m.geom_conaffinity[g]) == (2, 4)
    assert m.geom_body[m.geom_index("floor")] == -1


# ------------------------------------------------------------------ warnings
def test_unsupported_elements_are_named_in_one_warning():
    xml = """<mujoco>
  <option integrator="RK4"/>
  <worldbody>
    <light pos="0 0 3"/>
    <geom type="plane" size="1 1 0.1"/>
    <body name="b" pos="0 0 1">
      <joint name="j" type="hinge" armature="0.1" stiffness="5"/>
      <geom type="sphere" size="0.1" condim="1"/>
      <site name="s"/>
    </body>
  </worldbody>
  <tendon><fixed name="t"><joint joint="j" coef="1"/></fixed></tendon>
  <sensor><jointpos joint="j"/></sensor>
  <equality/>
</mujoco>"""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        load_mjcf(xml)
    assert len(record) == 1 and record[0].category is TumbleWarning
    msg = str(record[0].message)
    for item in ("<tendon> (at line 12)", "<sensor>", "<equality>", "joint armature",
                 "geom condim", "option integrator", "<light>", "<site>"):
        assert item in msg, item


# ---------------------------------------------------------------- malformed
BAD = [
    ("<mujoco>\n<worldbody>\n<body>\n</worldbody>\n</mujoco>", r"line 4.*malformed XML"),
    ("<mujoco>\n<worldbody>\n<body name='b'>\n<geom size='0.1 abc'/>\n</body></worldbody>"
     "</mujoco>", r"line 4, <geom>: attribute 'size': 'abc' is not a number"),
    ("<mujoco><worldbody>\n<body name='b'>\n<joint name='j' type='twist'/>\n"
     "<geom size='0.1'/></body></worldbody></mujoco>",
     r"line 3, <joint name='j'>: attribute 'type': must be one of .* got 'twist'"),
    ("<mujoco><worldbody>\n<body name='b'><freejoint/>\n<inertial pos='0 0 0' "
     "diaginertia='1 1 1'/>\n</body></worldbody></mujoco>",
     r"line 3, <inertial>: attribute 'mass': is required"),
    ("<mujoco><worldbody>\n<joint name='j'/>\n</worldbody></mujoco>",
     r"line 2, <joint name='j'>: a joint cannot be in the world body"),
    ("<mujoco><worldbody>\n<body name='b' childclass='nope'><freejoint/>"
     "<geom size='0.1'/></body></worldbody></mujoco>",
     r"line 2, <body name='b'>: attribute 'childclass': unknown default class 'nope'"),
    ("<mujoco><worldbody><body name='b'><freejoint/>\n<geom type='mesh' mesh='m'/>"
     "</body></worldbody></mujoco>", r"line 2, <geom>: attribute 'mesh': unknown mesh 'm'"),
    ("<mujoco><worldbody><body name='b'>\n<joint name='j'/></body></worldbody></mujoco>",
     r"line 1, <body name='b'>: link 'b' moves .* has no mass"),
    ("<mujoco><worldbody><body name='a'><freejoint/><geom size='0.1'/>\n<body name='b'>"
     "<freejoint name='f'/><geom size='0.1'/></body></body></worldbody></mujoco>",
     r"line 2, <freejoint name='f'>: a free joint must be in a child of the world body"),
    ("<mujoco><worldbody><body name='b'><freejoint/>\n<geom type='capsule' size='0.1'/>"
     "</body></worldbody></mujoco>",
     r"line 2, <geom>: attribute 'size': a capsule needs radius and half-length"),
    ("<mujoco><worldbody><body name='b'><joint name='j' range='0 1' limited='true'/>"
     "\n<geom size='0.1' pos='1 2'/></body></worldbody></mujoco>",
     r"line 2, <geom>: attribute 'pos': expected 3 numbers, got 2"),
    ("<mujoco><worldbody><body name='b'>\n<joint name='j' range='1 0'/>"
     "<geom size='0.1'/></body></worldbody></mujoco>",
     r"line 2, <joint name='j'>: attribute 'range': lower 1.0 must be below upper 0.0"),
    ("<mujoco><worldbody><body name='b'><joint name='j'/><geom size='0.1'/></body>"
     "</worldbody>\n<actuator><motor joint='k'/></actuator></mujoco>",
     r"line 2, <motor>: attribute 'joint': unknown joint 'k'"),
    ("<mujoco><default><geom type='box'/></default><worldbody>\n<body name='b'>"
     "<freejoint/><geom size='0.1 0.1 nan'/></body></worldbody></mujoco>",
     r"line 2, <geom>: attribute 'size': 'nan' is not finite"),
    ("<robot/>", r"line 1, <robot>: the root element must be <mujoco>"),
    ("<mujoco><default>\n<geom type='hexagon'/></default><worldbody><body name='b'>"
     "<freejoint/><geom size='0.1'/></body></worldbody></mujoco>",
     r"line 2, <geom>: attribute 'type': must be one of"),
    ("<mujoco><worldbody><body name='b'><freejoint/>\n<geom size='0.1' condim='2'/>"
     "</body></worldbody></mujoco>", r"line 2, <geom>: attribute 'condim': must be 1, 3, 4 or 6"),
    ("<mujoco><worldbody><body name='b'><freejoint/>\n<geom size='0.1' friction='1 -0.1'/>"
     "</body></worldbody></mujoco>", r"line 2, <geom>: attribute 'friction': must be >= 0"),
]


@pytest.mark.parametrize("xml,message", BAD)
def test_malformed_mjcf_names_element_attribute_and_line(xml, message):
    with pytest.raises(ModelError, match=message):
        quiet_load(xml)


def test_malformed_file_names_the_file(tmp_path):
    path = tmp_path / "broken.xml"
    path.write_text("<mujoco>\n<worldbody>\n<body name='b'><freejoint/>\n"
                    "<geom size='-1'/></body></worldbody></mujoco>")
    with pytest.raises(ModelError, match=r"broken\.xml line 4, <geom>: attribute 'size'"):
        load_mjcf(path)
    with pytest.raises(ModelError, match="cannot read"):
        load_mjcf(tmp_path / "missing.xml")


# --------------------------------------------------------------- springs, actuation
SPRING_XML = """<mujoco><option gravity="0 0 0" timestep="0.0005"/>
  <worldbody><body name="rod" pos="0 0 1">
    <joint name="h" type="hinge" axis="0 1 0" stiffness="{k}"/>
    <inertial pos="0.5 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
  </body></worldbody>
  <actuator><motor name="m" joint="h" gear="2" ctrlrange="-1 1" ctrllimited="true"/>
            <position name="p" joint="h" kp="50" kv="5"/></actuator></mujoco>"""


def test_joint_stiffness_is_a_spring_with_the_analytic_period():
    k = 4.0
    inertia = 0.01 + 1.0 * 0.5 ** 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TumbleWarning)
        model = load_mjcf(SPRING_XML.format(k=k).replace(
            '<actuator><motor name="m" joint="h" gear="2" ctrlrange="-1 1" ctrllimited="true"/>'
            '\n            <position name="p" joint="h" kp="50" kv="5"/></actuator>', ""))
    assert model.joint_kp[0] == k
    world = tumble.World(model)
    world.body_angvel[0] = (0, 0.05, 0)                 # a small kick about the axis
    world.body_vel[0] = np.cross(world.body_angvel[0], world.body_pos[0] - (0, 0, 1))
    period = 2 * math.pi * math.sqrt(inertia / k)
    crossings, last = [], world.joint_q[0, 0]
    while world.time < 2.2 * period:
        world.step()
        q = world.joint_q[0, 0]
        if last < 0 <= q:
            crossings.append(world.time)
        last = q
    assert len(crossings) >= 2
    assert crossings[1] - crossings[0] == pytest.approx(period, rel=2e-3)


def test_mjcf_actuators_drive_the_joint_through_ctrl():
    model = load_mjcf(SPRING_XML.format(k=0))
    assert model.actuator_names == ["m", "p"]
    assert model.actuator_kind_names == ["motor", "position"]
    assert not model.actuator_folded[1]          # two actuators on one joint: explicit
    world = tumble.World(model)
    world.ctrl[:] = (0.5, 0.0)                   # motor torque 1 N m; position off at ctrl 0
    world.ctrl[1] = 0.0
    world.step(200)
    # the position actuator pulls back toward 0 with kp 50: the motor's 1 N m holds 0.02 rad
    world.step(20000)
    assert world.joint_q[0, 0] == pytest.approx(1.0 / 50.0, abs=1e-4)


def test_condim_4_and_6_bring_torsional_and_rolling_friction():
    """MuJoCo's friction="slide torsion roll": torsion is simulated from condim 4, rolling at
    condim 6 (MuJoCo's defaults 0.005 and 0.0001 where not given); at condim 3 they are not
    used, and a non-default value there is reported."""
    xml = """<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="b" pos="0 0 1">
      <freejoint/>
      <geom name="g3" type="sphere" size="0.1" friction="0.7 0.02 0.001"/>
      <geom name="g4" type="sphere" size="0.1" pos="0.3 0 0" condim="4" friction="0.7 0.02 0.001"/>
      <geom name="g6" type="sphere" size="0.1" pos="0.6 0 0" condim="6" friction="0.7 0.02"/>
      <geom name="g6d" type="sphere" size="0.1" pos="0.9 0 0" condim="6"/>
    </body>
  </worldbody>
</mujoco>"""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        m = load_mjcf(xml)
    spin = {n: (m.geom_torsional[m.geom_index(n)], m.geom_rolling[m.geom_index(n)])
            for n in ("floor", "g3", "g4", "g6", "g6d")}
    assert spin == {"floor": (0.0, 0.0), "g3": (0.0, 0.0), "g4": (0.02, 0.0),
                    "g6": (0.02, 0.0001), "g6d": (0.005, 0.0001)}
    assert m.geom_friction[m.geom_index("g6")] == 0.7
    assert len(record) == 1
    assert "geom friction (torsional, rolling) with condim 3" in str(record[0].message)
