"""Helpers shared by the model-file tests (MJCF, URDF) and the fuzz tests."""
import os
import random
import re
import signal
import threading
import time
import traceback
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import tumble

# The compound pendulum every loader test builds: a 1 kg bob 1 m below a hinge about y,
# with 0.01 kg m^2 about its centre, released 0.05 rad from vertical.
PENDULUM = dict(mass=1.0, length=1.0, i0=0.01, amplitude=0.05)


def analytic_period(mass=1.0, length=1.0, i0=0.01, amplitude=0.05, g=9.81):
    """Small-angle period 2 pi sqrt(I_pivot / (m g L)) with the first amplitude correction
    (1 + theta0^2 / 16), which is 1.6e-4 here."""
    t0 = 2 * np.pi * np.sqrt((i0 + mass * length ** 2) / (mass * g * length))
    return t0 * (1 + amplitude ** 2 / 16)


def builder_pendulum():
    """The same pendulum made with ModelBuilder directly."""
    p = PENDULUM
    b = tumble.ModelBuilder()
    a = p["amplitude"]
    b.add_body("bob", pos=(-p["length"] * np.sin(a), 0, -p["length"] * np.cos(a)),
               mass=p["mass"], inertia=(p["i0"],) * 3)
    b.add_joint("pivot", "hinge", None, "bob", anchor=(0, 0, 0), axis=(0, 1, 0))
    return b.build()


def measure_period(model, dt=1e-3, steps=6000):
    """Mean period (s) of the bob's x oscillation, from its zero crossings."""
    w = tumble.World(model, dt=dt)
    bob = model.body_index("bob")
    t, x = [], []
    for _ in range(steps):
        w.step()
        t.append(w.time)
        x.append(w.body_pos[bob, 0])
    t, x = np.array(t), np.array(x)
    i = np.where(np.diff(np.sign(x)) != 0)[0]
    crossings = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    assert len(crossings) >= 6
    return 2 * np.mean(np.diff(crossings))


def gymnasium_assets():
    """Directory of the MuJoCo models shipped with gymnasium (skips if not installed)."""
    gym = pytest.importorskip("gymnasium")
    return os.path.join(os.path.dirname(gym.__file__), "envs", "mujoco", "assets")


def write_cube_stl(path, half=0.5):
    """A binary STL cube with this half-size, centred at the origin (12 triangles)."""
    c = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    rec = np.zeros(len(faces), dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                               ("a", "<u2")]))
    for k, f in enumerate(faces):
        rec["v"][k] = c[list(f)]
    with open(path, "wb") as fh:
        fh.write(b"\0" * 80 + np.uint32(len(faces)).tobytes() + rec.tobytes())


class _Helpers:
    PENDULUM = PENDULUM
    analytic_period = staticmethod(analytic_period)
    builder_pendulum = staticmethod(builder_pendulum)
    measure_period = staticmethod(measure_period)
    gymnasium_assets = staticmethod(gymnasium_assets)
    write_cube_stl = staticmethod(write_cube_stl)


@pytest.fixture
def helpers():
    """The helpers above (conftest modules are not importable under --import-mode=importlib)."""
    return _Helpers


# ------------------------------------------------------------------------------ fuzzing
# The fuzz tests (tests/io/test_fuzz_*.py) mutate the shipped and hand-written files with a
# seeded mutator and check that loading them either works or raises a tumble error: never
# another exception, never a hang. Each case is reproducible from its seed.

FUZZ_CASES = int(os.environ.get("TUMBLE_FUZZ_CASES", "0")) or None   # override per format
CASE_SECONDS = 20.0        # a case that takes longer is a hang (the machine may be loaded)

# Replacement values: numbers tumble must refuse or survive, words, digits int() refuses.
NUMBERS = ["0", "-0", "1", "-1", "0.5", "1e308", "-1e308", "1e-308", "5e-324", "1e400", "nan",
           "-nan", "inf", "-inf", "NaN", "Infinity", "1e9", "1e10", "4294967296",
           "18446744073709551617", "99999999999999999999999", "-2147483649", "0x10", "1_0",
           "\u00b3", "\u00b2", "\u0663", "\uff11", "1e", "--1", ".", "", "+", "1,5", "1.5.2",
           "true", "abc", "\u00e9", "1e-12", "3.14159", "1000000", "7", "2"]
VECTORS = ["0 0 0", "1 0 0", "0 0 1", "0 0 0 0", "1 2", "1 2 3 4 5 6 7", "nan 0 0",
           "1e308 1e308 1e308", "-1 -1 -1", "1e-300 0 0 0", "0 0 0 1", "1 0 0 0",
           "0.1 0.1", "0.1 0.2 0.3", "-0.1 0.2 0.3", "1 1 1 1 1 1", "0 0 0 0 0 0",
           "1 0 0 1 0 0", "0 1 0 0 0 1", "inf 1 1", "1e200 1e200 1e200 1e200", "1 1e-20 1e-20"]


class CaseHang(BaseException):
    """Raised inside a case that ran past CASE_SECONDS (BaseException: nothing catches it)."""


class Mutator:
    """Seeded mutations of text and XML files: ``descr`` lists what was done (for the
    failure report), so a case is reproduced by its seed."""

    def __init__(self, seed):
        self.rng = random.Random(seed)
        self.seed = seed
        self.descr = []

    def pick(self, seq):
        return seq[self.rng.randrange(len(seq))]

    def number(self):
        """A number tumble must refuse or survive, or half the time a plain one."""
        if self.rng.random() < 0.5:
            return self.pick(["0", "1", "-1", "0.5", "2", "10", "-0.25", "90", "1e-3", "3"])
        return self.pick(NUMBERS)

    # -- text -------------------------------------------------------------------------
    def text(self, s, vocab=(), count=None):
        """Token- and line-level mutations of ``s``."""
        count = count or self.rng.choice([1, 1, 1, 2, 3, 4])
        for _ in range(count):
            s = self._text_once(s, vocab)
        return s

    def _text_once(self, s, vocab):
        r = self.rng
        toks = re.split(r"(\s+)", s)
        words = [i for i, t in enumerate(toks) if t and not t.isspace()]
        lines = s.splitlines(keepends=True)
        op = r.randrange(10)
        if op == 0 and words:                       # a number-like token -> a number
            nums = [i for i in words if re.fullmatch(r"[-+0-9.eE]+", toks[i])] or words
            i = self.pick(nums)
            toks[i] = self.number()
            self.descr.append(f"token {i} -> {toks[i]!r}")
            return "".join(toks)
        if op == 1 and words and vocab:             # any token -> a keyword
            i = self.pick(words)
            toks[i] = self.pick(vocab)
            self.descr.append(f"token {i} -> {toks[i]!r}")
            return "".join(toks)
        if op == 2 and words:                       # drop a token
            i = self.pick(words)
            self.descr.append(f"drop token {i} {toks[i]!r}")
            toks[i] = ""
            return "".join(toks)
        if op == 3 and words:                       # repeat a token
            i = self.pick(words)
            toks[i] = toks[i] + " " + toks[i]
            self.descr.append(f"repeat token {i}")
            return "".join(toks)
        if op == 4 and len(lines) > 1:              # drop lines
            a = r.randrange(len(lines))
            b = min(len(lines), a + r.randint(1, 5))
            self.descr.append(f"drop lines {a}:{b}")
            return "".join(lines[:a] + lines[b:])
        if op == 5 and lines:                       # repeat lines
            a = r.randrange(len(lines))
            b = min(len(lines), a + r.randint(1, 8))
            k = r.choice([2, 2, 3, 50])
            self.descr.append(f"repeat lines {a}:{b} x{k}")
            return "".join(lines[:a] + lines[a:b] * k + lines[b:])
        if op == 6 and words:                       # swap two tokens
            i, j = self.pick(words), self.pick(words)
            toks[i], toks[j] = toks[j], toks[i]
            self.descr.append(f"swap tokens {i} {j}")
            return "".join(toks)
        if op == 7:                                 # cut the file short
            n = r.randrange(len(s) + 1)
            self.descr.append(f"truncate at {n}")
            return s[:n]
        if op == 8 and lines:                       # move a line
            a, b = r.randrange(len(lines)), r.randrange(len(lines))
            line = lines.pop(a)
            lines.insert(b, line)
            self.descr.append(f"move line {a} to {b}")
            return "".join(lines)
        i = r.randrange(len(s) + 1)                 # insert a character
        c = r.choice(["\x00", "\u00b3", "{", "}", "<", ">", "\"", "'", "&", "\ufeff", "\r",
                      "\t", "\u2028", "\x0c", "#", "/"])
        self.descr.append(f"insert {c!r} at {i}")
        return s[:i] + c + s[i:]

    def raw(self, data, count=None):
        """Byte-level mutations of ``data`` (bytes)."""
        b = bytearray(data)
        r = self.rng
        for _ in range(count or r.randint(1, 4)):
            op = r.randrange(6)
            i = r.randrange(len(b) + 1)
            if op == 0 and b:
                k = min(i, len(b) - 1)
                b[k] ^= 1 << r.randrange(8)
                self.descr.append(f"flip a bit of byte {k}")
            elif op == 1:
                ins = r.choice([b"\xff", b"\xfe\xff", b"\xc3\x28", b"\x00", b"\xed\xa0\x80",
                                b"\x80", b"\xef\xbb\xbf"])
                b[i:i] = ins
                self.descr.append(f"insert {bytes(ins)!r} at {i}")
            elif op == 2:
                self.descr.append(f"truncate at {i}")
                del b[i:]
            elif op == 3 and b:
                j = min(len(b), i + r.randint(1, 64))
                b[i:j] = bytes(j - i)
                self.descr.append(f"zero bytes {i}:{j}")
            elif op == 4 and b:
                j = min(len(b), i + r.randint(1, 64))
                b[i:i] = b[i:j] * r.randint(1, 4)
                self.descr.append(f"repeat bytes {i}:{j}")
            else:
                j = min(len(b), i + r.randint(1, 16))
                b[i:j] = bytes(r.randrange(256) for _ in range(j - i))
                self.descr.append(f"random bytes {i}:{j}")
        return bytes(b)

    # -- XML --------------------------------------------------------------------------
    def xml(self, s, tags, attrs, values, count=None):
        """Tree-level mutations of the XML text ``s``: attributes set to odd values or
        removed, elements dropped, repeated, moved, renamed, added or nested deeply."""
        root = ET.fromstring(s)
        r = self.rng
        deep = []       # deep nests, spliced into the text (ElementTree recurses)
        for _ in range(count or r.choice([1, 1, 2, 2, 3, 5])):
            nodes = list(root.iter())
            n = self.pick(nodes)
            parent = {c: p for p in nodes for c in p}
            op = r.randrange(11)
            if op in (0, 1, 2):                     # set an attribute
                names = list(n.attrib) if n.attrib and op < 2 else []
                key = self.pick(names) if names else self.pick(attrs)
                value = self.pick(values(key) if callable(values) else values)
                n.set(key, value)
                self.descr.append(f"<{n.tag}> {key}={value!r}")
            elif op == 3 and n.attrib:              # drop an attribute
                key = self.pick(list(n.attrib))
                del n.attrib[key]
                self.descr.append(f"<{n.tag}> drop {key}")
            elif op == 4 and n in parent:           # drop an element
                parent[n].remove(n)
                self.descr.append(f"drop <{n.tag}>")
            elif op == 5 and n in parent:           # repeat an element
                k = r.choice([1, 1, 2, 30])
                for _ in range(k):
                    parent[n].append(ET.fromstring(ET.tostring(n)))
                self.descr.append(f"repeat <{n.tag}> x{k}")
            elif op == 6 and n in parent:           # move an element elsewhere
                target = self.pick(nodes)
                if target is not n and n not in list(target.iter()) and target in nodes:
                    parent[n].remove(n)
                    target.append(n)
                    self.descr.append(f"move <{n.tag}> into <{target.tag}>")
            elif op == 7:                           # rename
                old, n.tag = n.tag, self.pick(tags)
                self.descr.append(f"<{old}> -> <{n.tag}>")
            elif op == 8:                           # add an element
                child = ET.SubElement(n, self.pick(tags))
                for _ in range(r.randint(0, 3)):
                    key = self.pick(attrs)
                    child.set(key, self.pick(values(key) if callable(values) else values))
                self.descr.append(f"add <{child.tag} {child.attrib}> to <{n.tag}>")
            elif op == 9 and n in parent:           # nest copies of an element deeply
                depth = r.choice([5, 50, 400, 999, 1100])
                start = ET.tostring(ET.Element(n.tag, dict(n.attrib)), encoding="unicode")
                start = start[:-3].rstrip() + ">"    # '<tag a="1" />' -> '<tag a="1">'
                deep.append(start * depth + f"</{n.tag}>" * depth)
                ET.SubElement(parent[n], f"fuzzdeep{len(deep) - 1}")
                self.descr.append(f"nest <{n.tag}> {depth} deep")
            else:                                   # shuffle children
                kids = list(n)
                r.shuffle(kids)
                for k in kids:
                    n.remove(k)
                for k in kids:
                    n.append(k)
                self.descr.append(f"shuffle children of <{n.tag}>")
        out = ET.tostring(root, encoding="unicode")
        for k, text in enumerate(deep):
            out = out.replace(f"<fuzzdeep{k} />", text)
        return out


def _alarm(signum, frame):
    raise CaseHang()


def run_fuzz(cases, make_case, *, label):
    """Run the cases ``make_case(seed, box)`` makes for every seed in ``range(cases)``;
    return (outcomes, escapes, seconds).

    ``make_case`` writes the mutated input (errors there fail the test as usual), puts its
    list of mutations in ``box['descr']`` and returns a function that loads it. A case's
    outcome is 'ok', or the tumble error class the load raised; an escape is (seed,
    mutations, exception text) for anything else (a hang included)."""
    import tumble
    outcomes, escapes = {}, []
    timer = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if timer:
        old = signal.signal(signal.SIGALRM, _alarm)
    start = time.perf_counter()
    try:
        for seed in range(cases):
            box = {}
            load = make_case(seed, box)
            try:
                if timer:
                    signal.setitimer(signal.ITIMER_REAL, CASE_SECONDS)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    load()
                outcome = "ok"
            except tumble.TumbleError as e:
                outcome = type(e).__name__
            except CaseHang:
                outcome = "HANG"
                escapes.append((seed, box.get("descr"), f"no answer after {CASE_SECONDS} s"))
            except Exception as e:                  # noqa: BLE001 - the point of the test
                outcome = "ESCAPE " + type(e).__name__
                tb = traceback.extract_tb(e.__traceback__)[-1]
                escapes.append((seed, box.get("descr"),
                                f"{type(e).__name__}: {str(e)[:200]} "
                                f"({os.path.basename(tb.filename)}:{tb.lineno})"))
            finally:
                if timer:
                    signal.setitimer(signal.ITIMER_REAL, 0)
            outcomes[outcome] = outcomes.get(outcome, 0) + 1
    finally:
        if timer:
            signal.signal(signal.SIGALRM, old)
    seconds = time.perf_counter() - start
    print(f"\n{label}: {cases} cases in {seconds:.1f} s: "
          + ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items())))
    return outcomes, escapes, seconds


def escape_report(escapes, limit=15):
    return "\n".join(f"seed {s}: {e}\n    mutations: {d}" for s, d, e in escapes[:limit])


CUBE = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]


def cube_obj():
    return ("# cube\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in CUBE)
            + "vt 0 0\nvn 0 0 1\nf 1 2 3\nf 5/1/1 6/1/1 7/1/1\n")


def cube_ascii_stl():
    tri = zip(CUBE, CUBE[1:] + CUBE[:1], CUBE[2:] + CUBE[:2])
    facets = "".join("facet normal 0 0 1\n  outer loop\n"
                     + "".join(f"    vertex {p[0]} {p[1]} {p[2]}\n" for p in t)
                     + "  endloop\nendfacet\n" for t in tri)
    return f"solid cube\n{facets}endsolid cube\n"


def write_mesh_files(folder):
    """The mesh files the fuzzed models name: cube.stl (binary), cube.obj, ascii.stl,
    bad.stl (not a mesh), a directory adir, and meshes/cube.stl (for package://)."""
    write_cube_stl(folder / "cube.stl")
    (folder / "cube.obj").write_text(cube_obj())
    (folder / "ascii.stl").write_text(cube_ascii_stl())
    (folder / "bad.stl").write_bytes(b"\x00\x01 not a mesh")
    (folder / "adir").mkdir(exist_ok=True)
    (folder / "meshes").mkdir(exist_ok=True)
    write_cube_stl(folder / "meshes" / "cube.stl")


class _Fuzz:
    Mutator = Mutator
    write_mesh_files = staticmethod(write_mesh_files)
    cube_obj = staticmethod(cube_obj)
    cube_ascii_stl = staticmethod(cube_ascii_stl)
    NUMBERS = NUMBERS
    VECTORS = VECTORS
    run = staticmethod(run_fuzz)
    report = staticmethod(escape_report)
    write_cube_stl = staticmethod(write_cube_stl)

    @staticmethod
    def cases(default):
        return FUZZ_CASES or default


@pytest.fixture
def fuzz():
    """The fuzzing helpers above."""
    return _Fuzz
