"""Fuzz of the URDF loader: mutated robots load or raise a tumble error (nothing else, no
hang).

Seeds: hand-written robots with every joint type (revolute, continuous, prismatic, fixed,
floating, planar), inertials with origins and full tensors, every collision shape and
STL/OBJ meshes (found, missing, through package:// and file://). The seeded mutator
(tests/io/conftest.py) sets attributes to odd values, drops, repeats, moves, renames and
adds elements, nests them past the depth cap and corrupts the text or its bytes; some
cases are chains of links. The model is built; no world is stepped.
``TUMBLE_FUZZ_CASES=n`` runs n cases instead of the default.
"""
CASES = 500

INERTIA = 'ixx="0.01" iyy="0.02" izz="0.015" ixy="0.001" ixz="0" iyz="0"'
TAGS = ["robot", "link", "joint", "inertial", "origin", "mass", "inertia", "collision",
        "visual", "geometry", "box", "sphere", "cylinder", "capsule", "mesh", "parent",
        "child", "axis", "limit", "dynamics", "mimic", "material", "gazebo", "cone"]
ATTRS = ["name", "type", "link", "xyz", "rpy", "value", "ixx", "iyy", "izz", "ixy", "ixz",
         "iyz", "size", "radius", "length", "filename", "scale", "lower", "upper", "effort",
         "velocity", "damping", "friction", "joint"]
WORDS = {
    "type": ["revolute", "continuous", "prismatic", "fixed", "floating", "planar", "ball", ""],
    "link": ["base", "upper", "lower", "hand", "wheel", "world", "nothing", ""],
    "filename": ["cube.stl", "cube.obj", "ascii.stl", "bad.stl", "missing.stl", "adir",
                 "package://robot/meshes/cube.stl", "package://robot/missing.dae",
                 "file:///nonexistent/x.stl", "file://", "a\x01.stl", "mesh.dae", ""],
    "name": ["base", "upper", "lower", "hand", "j1", "world", "", "x"],
}

ARM = f"""<robot name="arm">
  <material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>
  <link name="base">
    <inertial><origin xyz="0 0 0.05" rpy="0 0 0"/><mass value="5"/><inertia {INERTIA}/></inertial>
    <collision><geometry><box size="0.3 0.3 0.1"/></geometry></collision>
    <visual><geometry><box size="0.3 0.3 0.1"/></geometry></visual>
  </link>
  <link name="upper">
    <inertial><origin xyz="0 0 0.2" rpy="0.1 0.2 0.3"/><mass value="1.5"/>
      <inertia {INERTIA}/></inertial>
    <collision><origin xyz="0 0 0.2"/>
      <geometry><cylinder radius="0.04" length="0.4"/></geometry></collision>
    <collision><geometry><mesh filename="cube.stl" scale="0.05 0.05 0.05"/></geometry>
    </collision>
  </link>
  <link name="lower">
    <inertial><mass value="1"/><inertia {INERTIA}/></inertial>
    <collision><geometry><capsule radius="0.03" length="0.3"/></geometry></collision>
    <collision><geometry><mesh filename="package://robot/meshes/cube.stl"/></geometry>
    </collision>
  </link>
  <link name="hand">
    <inertial><mass value="0.3"/><inertia {INERTIA}/></inertial>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
    <collision><geometry><mesh filename="missing.dae"/></geometry></collision>
  </link>
  <link name="tool"><collision><geometry>
    <mesh filename="cube.obj" scale="0.02 0.02 0.02"/></geometry></collision></link>
  <link name="slider"><inertial><mass value="0.2"/><inertia {INERTIA}/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="50" velocity="2"/>
    <dynamics damping="0.5" friction="0.1"/></joint>
  <joint name="elbow" type="continuous"><parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 0.4"/><axis xyz="0 1 0"/></joint>
  <joint name="wrist" type="revolute"><parent link="lower"/><child link="hand"/>
    <origin xyz="0 0 0.3" rpy="0 1.57 0"/><axis xyz="1 0 0"/><limit lower="-1" upper="1"/>
    <mimic joint="elbow"/></joint>
  <joint name="weld" type="fixed"><parent link="hand"/><child link="tool"/>
    <origin xyz="0 0 0.05"/></joint>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="slider"/>
    <axis xyz="1 0 0"/><limit lower="-0.2" upper="0.2"/></joint>
  <gazebo reference="base"/><transmission name="t"/>
</robot>"""

HOPPER = f"""<robot name="hopper">
  <link name="world"/>
  <link name="torso"><inertial><mass value="3"/><inertia {INERTIA}/></inertial>
    <collision><geometry><capsule radius="0.05" length="0.4"/></geometry></collision></link>
  <link name="leg"><inertial><origin xyz="0 0 -0.2"/><mass value="1"/>
    <inertia {INERTIA}/></inertial></link>
  <link name="box"><inertial><mass value="1"/><inertia {INERTIA}/></inertial></link>
  <joint name="root" type="planar"><parent link="world"/><child link="torso"/>
    <origin xyz="0 0 1.2"/><axis xyz="0 1 0"/></joint>
  <joint name="hip" type="revolute"><parent link="torso"/><child link="leg"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1"/></joint>
  <joint name="float" type="floating"><parent link="world"/><child link="box"/>
    <origin xyz="1 0 1"/></joint>
</robot>"""


def chain(n):
    links = "".join(f'<link name="l{i}"><inertial><mass value="1"/><inertia {INERTIA}/>'
                    f"</inertial></link>" for i in range(n))
    joints = "".join(f'<joint name="j{i}" type="continuous"><parent link="l{i}"/>'
                     f'<child link="l{i + 1}"/><origin xyz="0 0 -0.1"/><axis xyz="0 1 0"/>'
                     f"</joint>" for i in range(n - 1))
    return f'<robot name="chain">{links}{joints}</robot>'


def values(key):
    return WORDS[key] if key in WORDS else VALUES


VALUES = ["0 0 0", "1 0 0", "0 0 1", "0 0 0 0", "1 2", "nan 0 0", "1e308 1e308 1e308",
          "-1 -1 -1", "0.1 0.1", "0.1 0.2 0.3", "-0.1 0.2 0.3", "inf 1 1", "1 1e-20 1e-20",
          "0", "-0", "1", "-1", "0.5", "1e308", "-1e308", "1e-308", "1e400", "nan", "inf",
          "1e9", "\u00b3", "\u0663", "1_0", "", "abc", "1e-12", "7"]


def test_mutated_urdf_loads_or_raises_a_tumble_error(fuzz, tmp_path):
    import tumble
    fuzz.write_mesh_files(tmp_path)
    texts = [ARM, HOPPER, chain(4)]
    main = tmp_path / "robot.urdf"

    def case(seed, box):
        m = fuzz.Mutator(seed)
        box["descr"] = m.descr
        r = m.rng
        if r.random() < 0.02:           # (test_hardening loads a chain of 1,100 links)
            text = m.xml(chain(r.choice([20, 150])), TAGS, ATTRS, values)
            m.descr.append("a chain")
        else:
            text = m.xml(m.pick(texts), TAGS, ATTRS, values)
        how = r.randrange(10)
        if how == 0:
            text = m.text(text, ["<", "/>", ">", "</link>", "<link>", "=", '"', "&amp;"])
        kw = dict(fixed_base=r.random() < 0.5)
        if r.random() < 0.05:
            kw.update(base_pos=m.pick(["abc", (0, 0, "x"), (1e308, 0, 0), (0, 0)]),
                      base_quat=m.pick([(0, 0, 0, 0), (0, 0, 0, 1), "q", (1, 1)]))
        m.descr.append(f"keywords {kw}")
        if how == 1:
            m.descr.append("as bytes")
            data = text.encode("utf-8", "surrogatepass")
            if r.random() < 0.5:
                data = m.raw(data, 1)
            return lambda: tumble.load_urdf(data, **kw)
        if how == 2:
            main.write_bytes(m.raw(text.encode("utf-8", "surrogatepass"), 1))
            m.descr.append("as a corrupted file")
            return lambda: tumble.load_urdf(main, **kw)
        if how < 5:
            m.descr.append("as a string")
            return lambda: tumble.load_urdf(text, **kw)
        main.write_text(text, encoding="utf-8", errors="surrogatepass")
        m.descr.append("as a file")
        return lambda: tumble.load_urdf(main, **kw)

    outcomes, escapes, seconds = fuzz.run(fuzz.cases(CASES), case, label="URDF fuzz")
    assert not escapes, (f"{len(escapes)} of {sum(outcomes.values())} mutated URDF files "
                         f"raised something else than a tumble error:\n" + fuzz.report(escapes))
    assert outcomes.get("ok", 0) > 0 and outcomes.get("ModelError", 0) > 0, outcomes
