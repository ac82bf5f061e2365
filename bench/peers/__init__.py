"""Peer runners: the benchmark scenes built and run in MuJoCo, PyBullet and ODE.

Each runner imports its engine at the top, so ``bench/run.py`` only starts those whose
engine is installed (``pip install ".[peers]"`` for MuJoCo and PyBullet).
"""
