"""Helpers shared by the model-file tests (MJCF, URDF)."""
import os

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
