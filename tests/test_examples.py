"""Every runnable example runs as a user would run it (shortened) and prints its outcome.

Each runs in a fresh interpreter with tumble importable from this checkout; the kernels
come from Numba's cache the earlier tests filled, so each takes about a second.
"""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def run_example(*args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]),
        MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


def figure(pattern, text):
    match = re.search(pattern, text)
    assert match, f"{pattern!r} not in:\n{text}"
    return float(match.group(1))


def test_walk_example_walks_forward():
    out = run_example("examples/walk.py", "--duration", "4")
    assert figure(r"forward ([-\d.]+) m", out) > 0.3
    assert figure(r"lowest pelvis ([\d.]+) m", out) > 0.7


def test_tpose_example_holds_at_1920_hz_and_collapses_at_60():
    out = run_example("examples/tpose_hold.py", "--seconds", "0.5")
    assert figure(r"explicit PD at 1920 Hz: max joint error ([\d.]+) rad", out) < 0.05
    assert figure(r"explicit PD at   60 Hz: max joint error ([\d.]+) rad", out) > 0.5


def test_static_balance_example_stands():
    out = run_example("examples/static_balance.py", "--seconds", "2")
    assert "stood" in out
    assert figure(r"pelvis height min ([\d.]+) m", out) > 0.8


def test_push_and_spin_example_keeps_angular_momentum():
    out = run_example("examples/push_and_spin.py")
    norms = [float(x) for x in re.findall(r"\|L\|=([\d.]+)", out)]
    assert len(norms) >= 2
    assert max(norms) - min(norms) < 1e-3 * max(norms)


def test_track_walk_example_tracks_within_0_1_rad():
    out = run_example("examples/track_walk.py")
    assert figure(r"mean joint error ([\d.]+) rad", out) < 0.1


def test_steer_example_turns_and_keeps_its_speed():
    out = run_example("examples/steer.py", "--seconds", "8")
    assert "0 falls" in out
    assert figure(r"mean speed error ([\d.]+) m/s over 2 commands", out) < 0.3
