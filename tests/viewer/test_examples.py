"""The viewer examples run end to end (short runs) and write what they say."""
import importlib.util
import os

import pytest

from tumble.viewer import Recording

EXAMPLES = os.path.join(os.path.dirname(__file__), "..", "..", "examples")


def _load(name):
    spec = importlib.util.spec_from_file_location(name, os.path.join(EXAMPLES, f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_record_and_export_example(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    _load("record_and_export").main(["--seconds", "0.4", "--out", str(tmp_path)])
    rec = Recording.load(tmp_path / "ragdoll.npz")
    assert len(rec) == 25 and rec.scene.nbody == 20 and rec.has_contacts
    for name in ("ragdoll.gif", "ragdoll.mp4", "energy.png", "contacts.png"):
        assert (tmp_path / name).stat().st_size > 1000, name


def test_joint_tracking_example(tmp_path):
    pytest.importorskip("matplotlib")
    worst = _load("joint_tracking").main(["--seconds", "4", "--out", str(tmp_path)])
    # a proportional velocity command (gain K = 8/s) is a first-order lag: on a sine of
    # amplitude 0.6 rad at w = pi rad/s the error is 0.6 (w/K) / sqrt(1 + (w/K)^2) = 0.22 rad
    assert worst == pytest.approx(0.22, abs=0.03)
    assert (tmp_path / "tracking.png").stat().st_size > 1000
