"""Fuzz of the STL and OBJ readers, through the MJCF and URDF loaders: a mutated mesh file
gives a model or a tumble error naming the mesh file (never another exception, never the
misleading "has no mass" of a mesh dropped in silence).

Seeds: a binary STL cube, an ASCII STL and an OBJ (tests/io/conftest.py writes them); the
seeded mutator flips, inserts, zeroes and cuts bytes (the binary triangle count included)
and changes tokens and lines of the text formats (vertices with two or four numbers,
overflowing or non-finite numbers, keywords moved). ``TUMBLE_FUZZ_CASES=n`` runs n cases.
"""
import tumble

CASES = 400
VOCAB = ["vertex", "facet", "normal", "outer", "loop", "endloop", "endfacet", "solid",
         "endsolid", "v", "vn", "vt", "f", "#", "1", "0.5", "-1", "nan", "1e308", "1e39"]


def test_mutated_meshes_load_or_raise_a_tumble_error_naming_the_file(fuzz, tmp_path):
    fuzz.write_mesh_files(tmp_path)
    seeds = {".stl": [(tmp_path / "cube.stl").read_bytes(),
                      (tmp_path / "ascii.stl").read_bytes()],
             ".obj": [(tmp_path / "cube.obj").read_bytes()]}

    def case(seed, box):
        m = fuzz.Mutator(seed)
        box["descr"] = m.descr
        r = m.rng
        ext = ".stl" if r.random() < 0.7 else ".obj"
        data = m.pick(seeds[ext])
        if data[:5] == b"solid" or ext == ".obj":
            if r.random() < 0.8:
                data = m.text(data.decode(), VOCAB).encode("utf-8", "surrogatepass")
            else:
                data = m.raw(data)
        else:
            data = m.raw(data)
        name = f"case{ext}"
        (tmp_path / name).write_bytes(data)
        scale = m.pick(["1 1 1", "0.1 0.1 0.1", "1e200 1e200 1e200", "0 0 0", "-1 1 1"])
        m.descr.append(f"{name}, scale {scale}")
        if r.random() < 0.5:
            xml = (f'<mujoco><asset><mesh name="m" file="{name}" scale="{scale}"/></asset>'
                   f'<worldbody><body name="b"><freejoint/><geom name="g" type="mesh" mesh="m"/>'
                   f'</body></worldbody></mujoco>')
            path = tmp_path / "mesh.xml"
            path.write_text(xml)
            loader = tumble.load_mjcf
        else:
            xml = (f'<robot name="r"><link name="b"><inertial><mass value="1"/><inertia '
                   f'ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial><collision '
                   f'name="g"><geometry><mesh filename="{name}" scale="{scale}"/></geometry>'
                   f'</collision></link></robot>')
            path = tmp_path / "mesh.urdf"
            path.write_text(xml)
            loader = tumble.load_urdf

        def load():
            try:
                loader(path)
            except tumble.ModelError as e:
                # the geom is never dropped in silence: a bad mesh is named, with its geom
                # (or, for a hull too thin for its inertia, the body is)
                assert "has no mass" not in str(e), f"misleading error: {e}"
                assert name in str(e) or "<mesh" in str(e) or "scale" in str(e) or \
                    "inertia" in str(e), f"the error does not name the mesh: {e}"
                raise
        return load

    outcomes, escapes, seconds = fuzz.run(fuzz.cases(CASES), case, label="STL/OBJ fuzz")
    assert not escapes, (f"{len(escapes)} of {sum(outcomes.values())} mutated meshes raised "
                         f"something else than a tumble error naming the mesh:\n"
                         + fuzz.report(escapes))
    assert outcomes.get("ok", 0) > 0 and outcomes.get("ModelError", 0) > 0, outcomes
