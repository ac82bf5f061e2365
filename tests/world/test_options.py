"""World options: one keyword dataclass, checked whenever a field is set."""
import pytest

import tumble
from tumble.world import Options


def small_model():
    b = tumble.ModelBuilder()
    b.add_body("ball", pos=(0, 0, 1), mass=1.0, inertia=(0.01, 0.01, 0.01))
    b.add_geom("ball", "sphere", radius=0.1)
    b.add_geom(None, "plane")
    return b.build()


def test_keywords_become_options_and_attributes():
    w = tumble.World(small_model(), dt=1 / 120, contact="pgs", erp=0.3, iterations=50)
    assert isinstance(w.options, Options)
    assert (w.options.dt, w.options.contact, w.options.erp, w.options.iterations) == \
        (1 / 120, "pgs", 0.3, 50)
    assert (w.dt, w.contact, w.erp) == (1 / 120, "pgs", 0.3)
    w.erp = 0.1                                   # forwarded to the options, checked there
    assert w.options.erp == 0.1
    w.options.solver = "pgs"
    assert w.solver == "pgs"


@pytest.mark.parametrize("name, value, message", [
    ("erp", 1.5, r"erp must be in \[0, 1\]"),
    ("contact", "soft", r"contact must be one of \['lcp', 'pgs', 'penalty'\]"),
    ("iterations", 0, "iterations must be a positive integer"),
    ("projection", -1, "projection must be an integer >= 0"),
    ("dt", 0.0, "dt must be finite and > 0"),
    ("pd", "fast", "pd must be one of"),
    ("broadphase", "bvh", "broadphase must be one of"),
    ("penalty_stiffness", -3.0, "penalty_stiffness must be finite and > 0"),
    ("penalty_integration", "semi", "penalty_integration must be one of"),
    ("profile", "yes", "profile must be True or False"),
    ("velocity_tolerance", -1e-5, "velocity_tolerance must be"),
])
def test_a_bad_value_is_refused_and_changes_nothing(name, value, message):
    w = tumble.World(small_model())
    before = getattr(w.options, name)
    with pytest.raises(tumble.ModelError, match=message):
        setattr(w, name, value)
    with pytest.raises(tumble.ModelError, match=message):
        setattr(w.options, name, value)
    with pytest.raises(tumble.ModelError, match=message):
        tumble.World(small_model(), **{name: value})
    assert getattr(w.options, name) == before


def test_unknown_options_are_named():
    with pytest.raises(tumble.ModelError, match="unknown option 'gravity'"):
        tumble.World(small_model(), gravity=(0, 0, -1))
    w = tumble.World(small_model())
    with pytest.raises(tumble.ModelError, match="no option named 'eprr'"):
        w.options.eprr = 0.2


def test_the_viewer_is_not_part_of_world():
    w = tumble.World(small_model())
    with pytest.raises(AttributeError, match=r"tumble\.Recorder\(world"):
        w.record()
    with pytest.raises(AttributeError, match=r"tumble\.viewer\.view\(world"):
        w.view()


def test_buffer_capacities_are_checked():
    with pytest.raises(tumble.ModelError, match="contact_capacity must be a positive integer"):
        tumble.World(small_model(), contact_capacity=0)
    w = tumble.World(small_model(), contact_capacity=3, pair_capacity=5)
    assert (w.contact_capacity, w.pair_capacity) == (3, 5)
