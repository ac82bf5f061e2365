"""The tutorials of the documentation (docs/tutorials/*.py) run top to bottom as notebooks,
in their short version (TUMBLE_DOCS_QUICK=1), and say what the docs say they say.

Each tutorial also asserts its own physics claims in its cells (a failing claim fails its
run); these tests read the figures the tutorials print and check them again, so a page
that printed something else than its text describes fails here too.
"""
import base64

import pytest

pytest.importorskip("nbclient")
pytest.importorskip("jupytext")
pytest.importorskip("ipykernel")
pytest.importorskip("matplotlib")

from notebooks import number, outputs_of_type, run_tutorial, stdout, tutorial_paths  # noqa: E402

NAMES = [p.stem for p in tutorial_paths()]


def test_every_tutorial_is_tested():
    tested = {name[len("test_"):] for name in globals() if name.startswith("test_t")}
    assert NAMES and set(NAMES) == tested


def shows_pictures(nb, png=1, html=0):
    """The notebook showed at least ``png`` PNG images and ``html`` inline animations."""
    images = outputs_of_type(nb, "image/png")
    assert len(images) >= png
    for img in images:
        assert base64.b64decode(img)[:8] == b"\x89PNG\r\n\x1a\n"
    anims = [h for h in outputs_of_type(nb, "text/html") if "base64," in h]
    assert len(anims) >= html


def test_t01_rigid_bodies():
    nb = run_tutorial("t01_rigid_bodies")
    out = stdout(nb)
    assert number(out, r"middle\s+axis: spin axis tilts up to\s+([\d.]+) deg") > 80
    assert number(out, r"middle\s+axis: .*?, (\d+) flips") >= 2
    for axis in ("largest", "smallest"):
        assert number(out, rf"{axis}\s+axis: spin axis tilts up to\s+([\d.]+) deg") < 2
        assert number(out, rf"{axis}\s+axis: .*?, (\d+) flips") == 0
    assert number(out, r"middle\s+axis: .*E by ([\d.e+-]+)") < 1e-9
    assert abs(number(out, r"'implicit' : energy changed by ([\d.e+-]+) %")) < 1e-6
    assert number(out, r"'explicit' : energy changed by \+([\d.e+-]+) %") > 1.0
    shows_pictures(nb, png=2, html=1)           # the world, the plot; the animation


def test_t02_joints_erp_cfm():
    nb = run_tutorial("t02_joints_erp_cfm")
    out = stdout(nb)
    measured = number(out, r"period: measured ([\d.]+) s")
    formula = number(out, r"formula ([\d.]+) s")
    assert abs(measured - formula) < 0.01 * formula
    end = {label: number(out, rf"{label}[^:]*: .*at the end\s+([\d.]+) mm")
           for label in ("ERP 0, no", "ERP 0.2, no", "ERP 0.8, no", r"ERP 0.2 \+ projection")}
    assert end["ERP 0.2, no"] < 0.2 * end["ERP 0, no"]
    assert end["ERP 0.8, no"] < end["ERP 0.2, no"]
    assert end[r"ERP 0.2 \+ projection"] < 0.01
    stretch = number(out, r"CFM  1e-03: .* stretches ([\d.]+) mm")
    assert stretch == pytest.approx(number(out, r"CFM  1e-03: .*ERP = ([\d.]+) mm"), rel=1e-3)
    assert stretch > 0.1
    shows_pictures(nb, png=2)


def test_t03_contacts():
    nb = run_tutorial("t03_contacts")
    out = stdout(nb)
    sink = {c: number(out, rf"{c}\s*: top box\s+([\d.]+) mm below") for c in
            ("penalty", "lcp", "pgs")}
    deepest = {c: number(out, rf"{c}\s*: .*deepest overlap\s+([\d.]+) mm") for c in sink}
    assert sink["penalty"] > 0.1 and deepest["penalty"] > 1.0
    assert sink["lcp"] < 1e-4 and deepest["lcp"] < 1e-4
    assert sink["pgs"] < 0.1 and deepest["pgs"] < 0.1
    coulomb = number(out, r"slides v0\^2 / \(2 mu g\) = ([\d.]+) m")
    for c in sink:
        assert number(out, rf"{c}\s*: .*slid ([\d.]+) m") == pytest.approx(coulomb, rel=0.03)
    shows_pictures(nb, png=2)


def test_t04_ragdoll_bvh():
    nb = run_tutorial("t04_ragdoll_bvh")
    out = stdout(nb)
    assert "25 joints, 100 frames at 100 fps" in out
    assert number(out, r"(\d+) bodies, \d+ joints, total mass") == 20
    assert number(out, r"total mass ([\d.]+) kg") == pytest.approx(70.0)
    assert number(out, r"1 - \|q.q'\| = ([\d.e+-]+)") < 1e-12
    assert number(out, r"root position error ([\d.e+-]+) m") < 1e-12
    start = number(out, r"pelvis height: ([\d.]+) m ->")
    end = number(out, r"pelvis height: [\d.]+ m -> ([\d.]+) m")
    assert start > 0.8 and end < 0.35
    shows_pictures(nb, png=2, html=1)


def test_t05_pd_control():
    nb = run_tutorial("t05_pd_control")
    out = stdout(nb)
    rows = {line.split()[0]: line for line in out.splitlines() if line.strip().startswith("1e+")}
    assert rows["1e+02"].count("holds") == 3 and rows["1e+03"].count("holds") == 3
    for kp in ("1e+04", "1e+05", "1e+06"):
        assert rows[kp].count("holds") == 2          # implicit and stable, not explicit
    assert "diverged" in rows["1e+06"]
    assert number(out, r"implicit PD at   60 Hz: .* ([\d.]+) rad") < 0.05
    assert number(out, r"explicit PD at 1920 Hz: .* ([\d.]+) rad") < 0.05
    assert number(out, r"explicit PD at   60 Hz: .* ([\d.]+) rad") > 0.5
    shows_pictures(nb, png=2)


def test_t06_static_balance():
    nb = run_tutorial("t06_static_balance")
    out = stdout(nb)
    assert number(out, r"PD servos only, 50 N pushes: fell at t = ([\d.]+) s") < 3.0
    assert "with static balance, 50 N pushes: stood" in out
    assert number(out, r"COM at most ([\d.]+) cm") < 10
    assert number(out, r"([\d.]+) cm at the end") < 2
    assert "with static balance, 100 N pushes: fell" in out
    shows_pictures(nb, png=2)


def test_t07_tracking():
    nb = run_tutorial("t07_tracking")
    out = stdout(nb)
    hand = number(out, r"hand of god\s*: mean joint error ([\d.]+) rad")
    assert hand < 0.1
    root_hand = number(out, r"hand of god\s*: .*by ([\d.]+) cm on average")
    root_free = number(out, r"no hand of god\s*: .*by ([\d.]+) cm on average")
    assert root_hand < 0.6 * root_free
    assert (number(out, r"k_p =    300 .*error ([\d.]+) rad")
            > number(out, r"k_p =   1000 .*error ([\d.]+) rad"))
    shows_pictures(nb, png=1, html=1)


def test_t08_simbicon():
    nb = run_tutorial("t08_simbicon")
    out = stdout(nb)
    assert "FELL" not in out
    walk = number(out, r"walk: walked [\d.]+ s: [\d.]+ m, speed ([\d.]+) m/s")
    fast = number(out, r"fast: walked [\d.]+ s: [\d.]+ m, speed ([\d.]+) m/s")
    assert 0.4 < walk < 0.9 and fast > 1.6 * walk
    assert number(out, r"pushed: walked ([\d.]+) s") == pytest.approx(10.0)
    assert number(out, r"uphill: walked [\d.]+ s: ([\d.]+) m") > 2.0
    shows_pictures(nb, png=1, html=1)


def test_t09_imitation():
    pytest.importorskip("torch")
    pytest.importorskip("rsl_rl")
    nb = run_tutorial("t09_imitation")
    out = stdout(nb)
    assert "observations (8, 303), actions (8, 45)" in out
    assert number(out, r"shipped policy\s*:\s+(\d+)% of") == 100
    assert number(out, r"shipped policy\s*: .*error (\d+) mm") < 50
    assert number(out, r"no correction\s*:\s+(\d+)% of") < 50
    assert number(out, r"(\d+) iterations, \d+ samples") == 3
    assert number(out, r"\d+ iterations, (\d+) samples") == 3 * 16 * 16
    shows_pictures(nb, png=1, html=1)
