"""Plot helpers: they draw what they are given, and contact forces add up to the weight of a
resting body."""
import numpy as np
import pytest

import tumble
from tests.viewer.helpers import synthetic_recording

pytest.importorskip("matplotlib")
from tumble.viewer import plots  # noqa: E402


def _resting_box():
    b = tumble.ModelBuilder(gravity=(0.0, 0.0, -9.81))
    b.add_geom(None, "plane")
    box = b.add_body("box", pos=(0.0, 0.0, 0.1), mass=2.0, inertia=(0.02, 0.02, 0.02))
    b.add_geom(box, "box", size=(0.1, 0.1, 0.1))
    return tumble.World(b.build(), dt=1.0 / 240.0, contact="lcp")


def test_energy_plot_from_a_recording(tmp_path):
    world = _resting_box()
    world.body_pos[0, 2] = 0.6
    rec = tumble.Recorder(world, energy=True)
    rec.run(0.5, fps=30)
    fig = plots.plot_energy(rec.recording(), path=tmp_path / "e.png")
    lines = fig.axes[0].get_lines()
    assert [ln.get_label() for ln in lines] == ["kinetic", "potential (from start)", "total"]
    k = lines[0].get_ydata()
    assert k[0] == 0.0 and k.max() > 0.0
    assert (tmp_path / "e.png").stat().st_size > 1000
    with pytest.raises(tumble.ModelError, match="energy=True"):
        plots.plot_energy(synthetic_recording())
    with pytest.raises(tumble.ModelError, match="equal-length"):
        plots.plot_energy(time=[0, 1], kinetic=[0], potential=[0, 1])


def test_joint_tracking_plot(tmp_path):
    t = np.linspace(0, 1, 50)
    fig = plots.plot_joint_tracking(t, np.sin(t), 0.5, name="knee", path=tmp_path / "j.png")
    target, angle = fig.axes[0].get_lines()
    np.testing.assert_array_equal(target.get_ydata(), np.full(50, 0.5))
    np.testing.assert_array_equal(angle.get_ydata(), np.sin(t))
    with pytest.raises(tumble.ModelError, match="equal-length"):
        plots.plot_joint_tracking(t, t[:-1], 0.0)


def test_contact_forces_of_a_resting_box_carry_its_weight(tmp_path):
    world = _resting_box()
    rec = tumble.Recorder(world, contacts=True, capture_now=False)
    rec.run(0.5, fps=20)
    names, forces = plots.contact_force_series(rec.recording())
    assert names == ["box"]
    np.testing.assert_allclose(forces[-5:, 0], 2.0 * 9.81, rtol=1e-3)
    fig = plots.plot_contact_forces(rec.recording(), path=tmp_path / "c.png")
    labels = [ln.get_label() for ln in fig.axes[0].get_lines()]
    assert labels == ["box", "total weight 20 N"]
    with pytest.raises(tumble.ModelError, match="contacts=True"):
        plots.plot_contact_forces(synthetic_recording())
