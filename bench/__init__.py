"""Benchmarks of tumble against its peers (MuJoCo, PyBullet, ODE); not part of the package.

Run from the repository root, e.g. ``python bench/run.py chain``; see bench/README.md.
"""
