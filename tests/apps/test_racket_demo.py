"""The demo a new user runs first: it must flip, conserve, and print."""
import subprocess
import sys

import numpy as np

from tumble import cli
from tumble.apps import racket


def test_demo_flips_and_conserves():
    times, omegas, summary = racket.run(seconds=10.0, out=None)
    assert summary["flips"] >= 2
    assert summary["dL"] < 0.005 and summary["dE"] < 1e-9
    assert omegas.shape == (len(times), 3) and np.all(np.isfinite(omegas))


def test_cli_demo_prints_the_flip(capsys):
    assert cli.main(["demo", "--seconds", "6"]) == 0
    out = capsys.readouterr().out
    assert "flips" in out and "angular momentum changed by" in out


def test_module_entry_point():
    out = subprocess.run([sys.executable, "-m", "tumble", "info"], capture_output=True,
                         text=True, check=True).stdout
    assert out.startswith("tumble ")
