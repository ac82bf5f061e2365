"""`tumble view`, `tumble record`, `tumble export` and what MODEL may be."""
import os
import signal
import subprocess
import sys
import urllib.request

import pytest

import tumble
from tests.viewer.helpers import synthetic_recording
from tumble.cli import main
from tumble.viewer import Recording
from tumble.viewer.sources import load_source

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

MODEL_FILE = '''
import tumble

def build():
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    box = b.add_body("box", pos=(0, 0, 1.0), density=200.0)
    b.add_geom(box, "box", size=(0.1, 0.1, 0.1))
    return b.build()

def control(world):
    world.apply_force("box", (1.0, 0.0, 0.0))
'''


def test_model_files_recordings_and_demos(tmp_path):
    path = tmp_path / "scene.py"
    path.write_text(MODEL_FILE)
    world, control = load_source(path)
    assert isinstance(world, tumble.World) and world.model.body_names == ["box"]
    assert callable(control)
    (tmp_path / "w.py").write_text(MODEL_FILE + "\nworld = tumble.World(build(), dt=0.01)\n")
    world, _ = load_source(tmp_path / "w.py")
    assert world.dt == 0.01
    rec_path = synthetic_recording().save(tmp_path / "r.npz")
    rec, control = load_source(rec_path)
    assert isinstance(rec, Recording) and control is None
    world, _ = load_source("stack")
    assert "ball" in world.model.body_names


def test_sources_that_cannot_be_shown_name_the_problem(tmp_path):
    (tmp_path / "empty.py").write_text("x = 1\n")
    with pytest.raises(tumble.ModelError, match="defines none of 'world', 'model'"):
        load_source(tmp_path / "empty.py")
    (tmp_path / "wrong.py").write_text("world = 3\n")
    with pytest.raises(tumble.ModelError, match="'world' is a int"):
        load_source(tmp_path / "wrong.py")
    with pytest.raises(tumble.ModelError, match="no such file"):
        load_source(tmp_path / "missing.py")
    with pytest.raises(tumble.ModelError, match="neither a file nor a demo"):
        load_source("no-such-demo")
    (tmp_path / "m.xml").write_text("<mujoco/>")
    if not hasattr(tumble, "load_mjcf"):
        with pytest.raises(tumble.ModelError, match="cannot read MJCF"):
            load_source(tmp_path / "m.xml")


def test_record_and_export_commands(tmp_path, capsys):
    pytest.importorskip("imageio_ffmpeg")
    model = tmp_path / "scene.py"
    model.write_text(MODEL_FILE)
    out = tmp_path / "run.npz"
    assert main(["record", str(model), str(out), "--seconds", "0.5", "--fps", "20"]) == 0
    rec = Recording.load(out)
    assert len(rec) == 11 and rec.kinetic is not None and rec.contact_start is not None
    # the controller pushed the box along +x
    assert rec.body_pos[-1, 0, 0] > rec.body_pos[0, 0, 0] + 1e-3
    gif = tmp_path / "run.gif"
    assert main(["export", str(out), str(gif), "--fps", "10", "--size", "96x64"]) == 0
    from PIL import Image
    with Image.open(gif) as im:
        assert im.n_frames == 5 and im.size == (96, 64)
    assert "5 frames written" in capsys.readouterr().out
    assert main(["export", "nothing-here", str(gif)]) == 2
    assert "neither a file nor a demo" in capsys.readouterr().err


def test_view_serves_the_page_until_interrupted(tmp_path):
    pytest.importorskip("viser")
    rec = synthetic_recording().save(tmp_path / "r.npz")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
               PYTHONFAULTHANDLER="1")
    # a test run started in the background of a script ignores SIGINT, and a child that
    # inherits SIG_IGN never gets Python's KeyboardInterrupt: give it the default back
    proc = subprocess.Popen([sys.executable, "-m", "tumble", "view", rec, "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env, cwd=ROOT,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        url = None
        for line in proc.stdout:
            if line.startswith("tumble viewer: open "):
                url = line.split()[3]
                break
        assert url and url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(url, timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
        _stop_with_ctrl_c(proc, "tumble view")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _untrained_policy_file(path):
    """A policy file for the course walk with tiny random weights (actions near 0)."""
    import numpy as np
    from tumble.rl import ImitationEnv
    from tumble.rl.policy import Policy
    spec = ImitationEnv(1, "walk", contact="lcp").spec()
    D, A = spec["observation_size"], spec["action_size"]
    rng = np.random.default_rng(0)
    Policy([1e-3 * rng.standard_normal((8, D)), 1e-3 * rng.standard_normal((A, 8))],
           [np.zeros(8), np.zeros(A)], "elu", np.zeros(D), np.ones(D), 1e-8, spec).save(path)
    return path


def test_record_a_policy_and_play_it_in_the_viewer(tmp_path, capsys):
    pytest.importorskip("viser")
    policy = _untrained_policy_file(tmp_path / "walk.npz")
    # tumble record runs the policy like any controller
    assert main(["record", str(policy), str(tmp_path / "walk_rec.npz"), "--seconds", "0.5",
                 "--fps", "30"]) == 0
    rec = Recording.load(tmp_path / "walk_rec.npz")
    assert len(rec) == 16 and rec.scene.nbody == 20
    capsys.readouterr()
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
               PYTHONFAULTHANDLER="1")
    proc = subprocess.Popen([sys.executable, "-m", "tumble", "play", str(policy), "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env, cwd=ROOT,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        url, lines = None, []
        for line in proc.stdout:
            lines.append(line)
            if line.startswith("tumble viewer: open "):
                url = line.split()[3]
                break
        assert url and url.startswith("http://127.0.0.1:"), "".join(lines)
        assert any(l.startswith("tumble play: <tumble.rl.Policy: imitate walk") for l in lines)
        with urllib.request.urlopen(url, timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read().lower()
        _stop_with_ctrl_c(proc, "tumble play")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _stop_with_ctrl_c(proc, what):
    """Send Ctrl-C to a served command and check it exits cleanly within 60 s; if it hangs,
    SIGABRT makes faulthandler print every thread's stack, which the failure shows."""
    proc.send_signal(signal.SIGINT)
    try:
        code = proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGABRT)
        proc.wait(timeout=10)
        raise AssertionError(f"{what} did not stop on Ctrl-C within 60 s; it printed:\n"
                             + proc.stdout.read())
    assert code == 0, proc.stdout.read()
