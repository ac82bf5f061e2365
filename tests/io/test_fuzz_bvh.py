"""Fuzz of the BVH reader: mutated course files and hand-written ones load or raise a
tumble error (nothing else, no hang), and what loads has finite forward kinematics.

A seeded mutator (tests/io/conftest.py) changes tokens and lines (numbers replaced by
overflowing, non-finite and non-ASCII-digit ones, keywords swapped in, lines dropped or
repeated, the file cut short), nests joints past the depth cap, and corrupts bytes (non-UTF-8
sequences, NUL). ``TUMBLE_FUZZ_CASES=n`` runs n cases instead of the default.
"""
import math
from pathlib import Path

import numpy as np
import pytest

from tumble.errors import ModelError
from tumble.io.bvh import format_bvh, load_bvh, load_bvh_string

DATA = Path(__file__).resolve().parents[1] / "data" / "games105"
CASES = 800

VOCAB = ["HIERARCHY", "ROOT", "JOINT", "End", "Site", "OFFSET", "CHANNELS", "MOTION",
         "Frames:", "Frame", "Time:", "{", "}", "Xrotation", "Yrotation", "Zrotation",
         "Xposition", "Yposition", "Zposition", "0", "3", "6", "7", "\u00b3", "\u00b2",
         "-1", "1000000", "RootJoint", "lHip", "nan", "1e308"]

MIXED = """HIERARCHY
ROOT hips
{
  OFFSET 0 0 0
  CHANNELS 6 Zposition Xposition Yposition Yrotation Xrotation Zrotation
  JOINT lThigh
  {
    OFFSET 0.1 -0.1 0
    CHANNELS 2 Xrotation Zrotation
    End Site
    {
      OFFSET 0 -0.4 0
    }
    End Site
    {
      OFFSET 0 -0.4 0.1
    }
  }
  JOINT rThigh
  {
    OFFSET -0.1 -0.1 0
    CHANNELS 4 Yposition Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 -0.4 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
0 1 0.9 10 20 30 5 6 0.1 7 8 9
0 1 0.9 11 21 31 5 6 0.2 7 8 9
0 1 0.9 12 22 32 5 6 0.3 7 8 9
"""


def trimmed(path, frames=6):
    """A course file cut to its first frames (the hierarchy whole), for speed."""
    text = path.read_text()
    head, motion = text.split("MOTION", 1)
    lines = motion.strip().splitlines()
    rows = [ln for ln in lines[2:] if ln.strip()][:frames]
    return head + f"MOTION\nFrames: {len(rows)}\n{lines[1]}\n" + "\n".join(rows) + "\n"


def seeds():
    return [trimmed(p) for p in sorted(DATA.glob("*.bvh"))] + [MIXED]


def deep_chain(depth):
    """JOINT blocks nested ``depth`` deep, to splice into a joint."""
    return ("".join(f"JOINT deep{i}\n{{\nOFFSET 0 0.1 0\nCHANNELS 1 Zrotation\n"
                    for i in range(depth)) + "}\n" * depth)


def test_mutated_bvh_loads_or_raises_a_tumble_error(fuzz, tmp_path):
    texts = seeds()

    def case(seed, box):
        m = fuzz.Mutator(seed)
        box["descr"] = m.descr
        r = m.rng
        text = m.pick(texts)
        if r.random() < 0.08:                       # nest joints past the cap (or not)
            depth = r.choice([50, 999, 1001, 3000])
            i = text.index("JOINT")
            text = text[:i] + deep_chain(depth) + text[i:]
            m.descr.append(f"nest {depth} joints")
        text = m.text(text, VOCAB)
        scale = 1.0 if r.random() < 0.9 else m.pick([0.01, 1e300, -1.0, float("nan"), "abc"])
        how = r.randrange(3)
        m.descr.append(f"scale {scale!r}, via {['file', 'string', 'bytes file'][how]}")
        path = tmp_path / "case.bvh"
        if how != 1:
            data = text.encode("utf-8", "surrogatepass")
            path.write_bytes(m.raw(data, 1) if how == 2 else data)
        write_back = r.random() < 0.3

        def load():
            motion = load_bvh_string(text, scale) if how == 1 else load_bvh(path, scale)
            pos, quat = motion.forward_kinematics()
            assert np.all(np.isfinite(pos)) and np.all(np.isfinite(quat)), \
                "loaded, but the forward kinematics is not finite"
            if motion.num_frames and write_back:
                format_bvh(motion)
        return load

    outcomes, escapes, seconds = fuzz.run(fuzz.cases(CASES), case, label="BVH fuzz")
    assert not escapes, (f"{len(escapes)} of {sum(outcomes.values())} mutated BVH files "
                         f"raised something else than a tumble error:\n" + fuzz.report(escapes))
    assert outcomes.get("ok", 0) > 0 and outcomes.get("ModelError", 0) > 0, outcomes


def test_special_paths_raise_tumble_errors(tmp_path):
    """A directory, a NUL byte, a missing file (also a FileNotFoundError), a non-path."""
    with pytest.raises(ModelError, match="is a directory"):
        load_bvh(tmp_path)
    with pytest.raises(ModelError, match="NUL byte"):
        load_bvh(str(tmp_path / "a\x00.bvh"))
    with pytest.raises(ModelError, match="cannot read") as info:
        load_bvh(tmp_path / "missing.bvh")
    assert isinstance(info.value, FileNotFoundError)
    with pytest.raises(ModelError, match="expected a file path"):
        load_bvh(3.5)
    assert math.isfinite(load_bvh(DATA / "run_forward.bvh").frame_time)
