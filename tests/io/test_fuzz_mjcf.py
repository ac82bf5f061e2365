"""Fuzz of the MJCF loader: mutated MuJoCo models load or raise a tumble error (nothing
else, no hang).

Seeds: the gymnasium models (when gymnasium is installed) and hand-written files that use
what the loader reads (default classes, frames, includes, STL/OBJ/inline meshes, every
geom and joint type, actuators, contact exclusion, compiler options). The seeded mutator
(tests/io/conftest.py) sets attributes to odd values, drops, repeats, moves, renames and
adds elements, nests them past the depth cap, adds includes (of the parts file, of itself,
of a directory, of a missing file), and corrupts the text or its bytes. The model is built;
no world is stepped. ``TUMBLE_FUZZ_CASES=n`` runs n cases instead of the default.
"""
import os

CASES = 500

TAGS = ["body", "geom", "joint", "freejoint", "inertial", "frame", "default", "include",
        "mesh", "asset", "worldbody", "compiler", "option", "actuator", "motor", "position",
        "general", "contact", "exclude", "site", "mujoco", "tendon", "camera"]
ATTRS = ["name", "class", "childclass", "pos", "quat", "axisangle", "euler", "xyaxes",
         "zaxis", "fromto", "size", "type", "mass", "density", "diaginertia", "fullinertia",
         "range", "limited", "axis", "damping", "frictionloss", "stiffness", "ref", "joint",
         "jointinparent", "gear", "ctrlrange", "forcerange", "ctrllimited", "forcelimited",
         "kp", "kv", "friction", "condim", "contype", "conaffinity", "margin", "file", "mesh",
         "scale", "vertex", "angle", "eulerseq", "coordinate", "inertiafromgeom",
         "settotalmass", "boundmass", "boundinertia", "autolimits", "meshdir", "timestep",
         "gravity", "mocap", "body1", "body2", "gainprm", "biasprm", "gaintype", "biastype",
         "dyntype", "armature", "springref", "gravcomp", "balanceinertia"]
WORDS = {
    "type": ["hinge", "slide", "ball", "free", "plane", "sphere", "capsule", "cylinder", "box",
             "ellipsoid", "mesh", "hfield", "sdf", "cone", ""],
    "file": ["parts.xml", "main.xml", "missing.xml", "adir", "cube.stl", "cube.obj",
             "ascii.stl", "bad.stl", "missing.stl", "adir/x.stl", "a\x01b", "../x.xml", ""],
    "mesh": ["stl", "obj", "inline", "ascii", "bad", "gone", "nothing"],
    "class": ["main", "heavy", "heavier", "slider", "nothing", ""],
    "childclass": ["main", "heavy", "heavier", "nothing"],
    "joint": ["hip", "knee", "slide", "j0", "nothing", ""],
    "body1": ["world", "torso", "thigh", "nothing"],
    "body2": ["world", "torso", "thigh", "nothing"],
    "angle": ["degree", "radian", "grad"], "coordinate": ["local", "global", "polar"],
    "eulerseq": ["xyz", "ZYX", "xyzx", "abc", "xYz"],
    "inertiafromgeom": ["true", "false", "auto", "maybe"],
    "limited": ["true", "false", "auto", "1"], "ctrllimited": ["true", "false", "auto"],
    "forcelimited": ["true", "false", "auto"], "autolimits": ["true", "false", "x"],
    "mocap": ["true", "false", "yes"], "meshdir": [".", "adir", "missing", ""],
    "gaintype": ["fixed", "affine"], "biastype": ["none", "affine"],
    "dyntype": ["none", "filter"], "condim": ["1", "3", "4", "6", "2", "1e9"],
}

PARTS = """<mujoco><worldbody>
  <body name="part" pos="2 0 1"><freejoint/><geom type="box" size="0.1 0.1 0.1"/>
    <body name="tip" pos="0 0 -0.3"><joint name="j0" type="hinge" axis="0 1 0" range="-30 30"/>
      <geom type="sphere" size="0.1"/></body></body>
</worldbody></mujoco>"""

KITCHEN = """<mujoco model="kitchen">
  <compiler angle="degree" eulerseq="xyz" inertiafromgeom="auto" meshdir="." autolimits="true"/>
  <option timestep="0.004" gravity="0 0 -9.81"/>
  <default>
    <geom type="capsule" size="0.05 0.2" density="500" friction="0.8 0.01 0.001"/>
    <joint damping="1" type="hinge" axis="0 1 0"/>
    <default class="heavy"><geom density="2000"/>
      <default class="heavier"><geom density="3000"/><joint damping="4"/></default>
    </default>
    <default class="slider"><joint type="slide" axis="1 0 0" range="-0.5 0.5"/></default>
  </default>
  <asset>
    <mesh name="stl" file="cube.stl" scale="0.2 0.2 0.2"/>
    <mesh name="obj" file="cube.obj" scale="0.1 0.1 0.1"/>
    <mesh name="ascii" file="ascii.stl"/>
    <mesh name="inline" vertex="0 0 0 1 0 0 0 1 0 0 0 1" scale="0.3 0.3 0.3"/>
    <mesh name="gone" file="missing.stl"/>
  </asset>
  <include file="parts.xml"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <frame pos="0 0 0.1" euler="0 0 10">
      <body name="torso" pos="0 0 1.2" childclass="heavy">
        <freejoint name="root"/>
        <geom name="chest" type="box" size="0.15 0.1 0.2" quat="1 0 0 0"/>
        <geom name="belly" type="ellipsoid" size="0.1 0.08 0.06" pos="0 0 -0.25"/>
        <geom name="hull" type="mesh" mesh="stl" pos="0.2 0 0"/>
        <body name="thigh" pos="0 0.1 -0.4" axisangle="1 0 0 5">
          <joint name="hip" type="hinge" axis="1 0 0" range="-90 90" stiffness="5"/>
          <joint name="hip_y" axis="0 1 0" range="-45 45" frictionloss="0.1"/>
          <joint name="hip_z" axis="0 0 1" range="-30 30"/>
          <geom name="thigh_g" fromto="0 0 0 0 0 -0.4" size="0.06" class="heavier"/>
          <body name="shin" pos="0 0 -0.45" xyaxes="1 0 0 0 1 0">
            <joint name="knee" range="-150 0" ref="10"/>
            <joint name="slide" class="slider"/>
            <geom name="shin_g" type="cylinder" fromto="0 0 0 0 0 -0.4" size="0.05"/>
            <geom name="foot" type="mesh" mesh="obj" pos="0 0 -0.45"/>
            <site name="s"/>
          </body>
        </body>
        <body name="arm" pos="0.25 0 0" zaxis="1 0 0">
          <joint name="shoulder" type="ball" range="0 60"/>
          <inertial pos="0 0 0.1" mass="2" fullinertia="0.02 0.02 0.01 0 0 0"/>
          <geom name="hand" type="mesh" mesh="inline"/>
          <geom name="glove" type="mesh" mesh="ascii" condim="6"/>
        </body>
      </body>
    </frame>
    <body name="target" mocap="true" pos="1 1 1">
      <geom size="0.05" contype="0" conaffinity="0"/></body>
    <body name="ball" pos="-1 0 1"><joint type="free"/>
      <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/><geom size="0.1"/></body>
  </worldbody>
  <contact><exclude body1="torso" body2="arm"/><pair geom1="floor" geom2="hand"/></contact>
  <actuator>
    <motor name="m_hip" joint="hip" gear="50" ctrlrange="-1 1" ctrllimited="true"/>
    <position name="p_knee" joint="knee" kp="80" kv="2" forcerange="-100 100"/>
    <general name="g_sh" joint="shoulder" gainprm="30" biasprm="0 -30 -1" biastype="affine"/>
    <motor name="m_tip" joint="j0"/>
  </actuator>
  <sensor><jointpos joint="knee"/></sensor>
</mujoco>"""

SMALL = """<mujoco><compiler angle="radian" coordinate="local"/><worldbody>
  <body name="bob" pos="0 0 1" quat="1 0 0 0"><joint name="pivot" axis="0 1 0" pos="0 0 1"/>
    <inertial pos="0 0 -1" mass="1" diaginertia="0.01 0.01 0.01"/>
    <geom type="sphere" size="0.1" pos="0 0 -1" mass="0.5"/></body>
</worldbody></mujoco>"""


def values(fuzz):
    """The values an attribute may be set to: mostly its own words, else odd numbers."""
    def of(key):
        odd = fuzz.VECTORS + fuzz.NUMBERS
        return WORDS[key] * (2 * len(odd) // len(WORDS[key]) + 1) + odd if key in WORDS \
            else odd
    return of


def gym_seeds():
    try:
        import gymnasium
    except ImportError:
        return []
    root = os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets")
    out = []
    for name in ("humanoid.xml", "ant.xml", "hopper.xml", "walker2d.xml", "half_cheetah.xml",
                 "inverted_pendulum.xml"):
        try:
            with open(os.path.join(root, name)) as f:
                out.append(f.read())
        except OSError:
            pass
    return out


def test_mutated_mjcf_loads_or_raises_a_tumble_error(fuzz, tmp_path):
    import tumble
    fuzz.write_mesh_files(tmp_path)
    (tmp_path / "parts.xml").write_text(PARTS)
    texts = [KITCHEN, SMALL, PARTS] + gym_seeds()
    of = values(fuzz)
    main = tmp_path / "main.xml"
    parts = (tmp_path / "parts.xml").read_text()

    def case(seed, box):
        m = fuzz.Mutator(seed)
        box["descr"] = m.descr
        r = m.rng
        text = m.pick(texts)
        (tmp_path / "parts.xml").write_text(parts)
        if r.random() < 0.15:                       # mutate the included file instead
            (tmp_path / "parts.xml").write_text(m.xml(parts, TAGS, ATTRS, of))
            m.descr.append("(in parts.xml)")
        text = m.xml(text, TAGS, ATTRS, of)
        how = r.randrange(10)
        if how == 0:
            text = m.text(text, ["<", "/>", ">", "</body>", "<body>", "=", '"', "&amp;"])
        if how == 1:
            m.descr.append("as bytes")
            data = text.encode("utf-8", "surrogatepass")
            if r.random() < 0.5:
                data = m.raw(data, 1)
            return lambda: tumble.load_mjcf(data)
        if how == 2:
            main.write_bytes(m.raw(text.encode("utf-8", "surrogatepass"), 1))
            m.descr.append("as a file")
            return lambda: tumble.load_mjcf(main)
        if how < 5:
            m.descr.append("as a string")
            return lambda: tumble.load_mjcf(text)
        main.write_text(text, encoding="utf-8", errors="surrogatepass")
        merge = r.random() < 0.8
        m.descr.append(f"as a file, merge_hinges={merge}")
        return lambda: tumble.load_mjcf(main, merge_hinges=merge)

    outcomes, escapes, seconds = fuzz.run(fuzz.cases(CASES), case, label="MJCF fuzz")
    assert not escapes, (f"{len(escapes)} of {sum(outcomes.values())} mutated MJCF files "
                         f"raised something else than a tumble error:\n" + fuzz.report(escapes))
    assert outcomes.get("ok", 0) > 0 and outcomes.get("ModelError", 0) > 0, outcomes
