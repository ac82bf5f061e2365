"""The step as a whole: its stage timer, and a failed call undone exactly."""
import numpy as np
import pytest

import tumble
from tumble.pipeline.arrays import STAGES


def pendulum_and_box(**options):
    """A hinged pendulum with a limit and a box landing on the ground: joints, limits,
    contacts and projection all run."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "plane")
    arm = b.add_body("arm", pos=(0.25, 0, 1.0), mass=1.0, inertia=(0.01, 0.02, 0.02))
    b.add_joint("pivot", "hinge", None, arm, anchor=(0, 0, 1.0), axis=(0, 1, 0),
                limit=(-0.6, 0.6))
    box = b.add_body("box", pos=(1.0, 0, 0.12), mass=1.0, inertia=(0.01, 0.01, 0.01))
    b.add_geom(box, "box", size=(0.1, 0.1, 0.1))
    return tumble.World(b.build(), **options)


@pytest.mark.parametrize("contact", ["lcp", "pgs", "penalty"])
def test_profiling_times_the_stages_and_changes_no_bit(contact):
    plain, timed = pendulum_and_box(contact=contact), pendulum_and_box(contact=contact,
                                                                       profile=True)
    for n in (1, 40, 49):
        plain.step(n)
        timed.step(n)
    for a, b in zip(plain.state_arrays, timed.state_arrays):
        if a.dtype.kind == "f":
            np.testing.assert_array_equal(a, b)
    times = timed.stage_times()
    assert list(times) == list(STAGES)
    assert all(t >= 0.0 for t in times.values()) and times["collide"] > 0.0
    assert times["solve"] > 0.0 and times["integrate_velocities"] > 0.0
    assert sum(plain.stage_times().values()) == 0.0          # off: no clock read
    timed.stage_times(reset=True)
    assert sum(timed.stage_times().values()) == 0.0


def live_contacts(w):
    """Copies of each world's live contacts (those below its count; the slots past it
    are scratch, which a failed call need not put back), field by field."""
    count = w.state_arrays.contact_count
    return [a[k, :count[k]].copy() for a in w.contact_arrays for k in range(w.nworld)]


def test_a_diverging_call_is_undone_array_for_array():
    """Every state array and live contact is as it came in after a call that diverged
    midway, the solver's warm start, the joint reactions and the counters included."""
    w = pendulum_and_box(contact="lcp", divergence_limit=50.0)
    w.step(30)
    before = [a.copy() for a in w.state_arrays] + live_contacts(w)
    assert w.state_arrays.contact_count[0] > 0
    time = w.time
    w.apply_force("box", (0.0, 0.0, 5e4))                    # 50 m/s within a step or two
    with pytest.raises(tumble.SimulationError, match="body 'box'"):
        w.step(20)
    after = [a for a in w.state_arrays] + live_contacts(w)
    for a, b in zip(before, after):
        np.testing.assert_array_equal(a, b)
    assert w.time == time


def ragdoll_world(contact="lcp", **options):
    rd = tumble.games105_ragdoll()
    return rd.make_world(dt=1 / 60, contact=contact, **options)


def snapshot(w):
    st = w.get_state()
    arrays = [a.copy() for a in w.state_arrays] + [a.copy() for a in w.control_arrays] + \
        live_contacts(w)
    return st, arrays


@pytest.mark.parametrize("contact, n", [("lcp", 1), ("pgs", 50), ("penalty", 7)])
def test_a_failed_call_leaves_every_array_and_the_twin_agrees(contact, n):
    """A torque no joint can hold, on the course ragdoll: the call fails, every state and
    control array and the live contacts are as before (the counters and the servo targets too), and
    the world then steps on exactly as its twin that never tried."""
    w, twin = ragdoll_world(contact), ragdoll_world(contact)
    for x in (w, twin):
        x.step(20)
    before_state, before = snapshot(w)
    w.apply_joint_torque("lKnee", 1e12)
    with pytest.raises(tumble.SimulationError):
        w.step(n)
    w.clear_forces()
    w.control_arrays.joint_applied[:] = 0.0
    after_state, after = snapshot(w)
    for a, b in zip(before, after):
        np.testing.assert_array_equal(a, b)
    for field in ("time", "body_pos", "body_quat", "joint_force", "joint_torque", "pd_target_quat"):
        np.testing.assert_array_equal(getattr(before_state, field), getattr(after_state, field))
    w.step(30)
    twin.step(30)
    for a, b in zip(w.state_arrays, twin.state_arrays):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("contact", ["lcp", "pgs"])
def test_chunking_does_not_change_a_bit(contact):
    """step(60), 60 x step(1) and 4 x step(15) end in the same bits (quaternions already of
    unit length are not divided again at each call)."""
    worlds = [ragdoll_world(contact) for _ in range(3)]
    worlds[0].step(60)
    for _ in range(60):
        worlds[1].step(1)
    for _ in range(4):
        worlds[2].step(15)
    for other in worlds[1:]:
        for field in ("body_pos", "body_quat", "body_vel", "body_angvel", "row_impulse",
                      "joint_q"):
            np.testing.assert_array_equal(getattr(worlds[0].state_arrays, field),
                                          getattr(other.state_arrays, field), err_msg=field)
        assert other.time == worlds[0].time                     # the clock too, bit for bit


def test_the_stage_functions_run_in_the_timer_s_order():
    """``step_worlds`` calls the stages by their place in ``arrays.STAGES`` (the timer's
    order) and each returns int64 as declared: the functions are listed in that order."""
    from tumble.pipeline.step import BRANCH_FUNCTIONS, BRANCHES, STAGE_FUNCTIONS, StageAddresses
    pairs = [(timed, f.__name__) for timed, f in zip(STAGES, STAGE_FUNCTIONS)]
    assert pairs == [("collide", "collide_stage"), ("forces", "forces_stage"),
                     ("integrate_velocities", "integrate_velocities_stage"),
                     ("rows", "rows_stage"), ("solve", "solve_stage"),
                     ("integrate_positions", "integrate_positions_stage"),
                     ("project_joints", "project_stage"), ("divergence_check", "check_stage"),
                     ("joint_coordinates", "coordinates_stage")]
    assert StageAddresses._fields == STAGES + BRANCHES
    assert [f.__name__ for f in BRANCH_FUNCTIONS] == list(BRANCHES)


def test_a_stage_with_another_result_type_is_refused(monkeypatch):
    """The stages are called through their addresses with an int64 result declared: one
    compiled to return anything else is refused before it is ever called."""
    from numba import types
    from tumble._jit import noalloc
    from tumble.pipeline import step
    world = pendulum_and_box()
    world.step(1)
    box, o = world._box, world.step_options()

    @noalloc(cache=False)
    def returns_a_float(box, w, k, n, o):
        return 1.5

    sig = step.stage_signature(box, o)
    returns_a_float.compile(sig)
    assert returns_a_float.overloads[sig].signature.return_type == types.float64
    monkeypatch.setattr(step, "STAGE_FUNCTIONS", (returns_a_float,) + step.STAGE_FUNCTIONS[1:])
    with pytest.raises(TypeError, match="returns_a_float returns float64, not int64"):
        step.stage_addresses(box, o)


def bodies_on_a_heightfield():
    """A box and a ball on a heightfield: the general collision route."""
    b = tumble.ModelBuilder()
    b.add_geom(None, "heightfield", size=(2.0, 2.0, 0.5),
               heights=np.zeros((8, 8)))
    box = b.add_body("box", pos=(0.2, 0, 0.12), mass=1.0, inertia=(0.01, 0.01, 0.01))
    b.add_geom(box, "box", size=(0.1, 0.1, 0.1))
    return b.build()


def test_a_world_compiles_the_branches_its_model_and_options_take():
    """The stages' rarer paths compile only for worlds that take them: the general
    collision for a model that is not all listed primitive pairs; sleeping, penalty
    contacts and stable PD when the options ask; the solves the options and model use."""
    from tumble.pipeline.step import takes_general_collision, wanted_branches

    def wanted(world):
        m = world.model.arrays
        return set(wanted_branches(m, world.step_options(), takes_general_collision(m)))
    assert wanted(pendulum_and_box()) == {"direct_solve", "lcp_solve"}
    assert wanted(pendulum_and_box(contact="penalty", pd="stable", sleep_time=0.5)) == {
        "penalty_contact_forces", "stable_pd_forces", "sleep", "direct_solve"}
    assert wanted(pendulum_and_box(contact="pgs")) == {"pgs_solve"}
    assert wanted(pendulum_and_box(solver="pgs")) == {"pgs_solve", "direct_solve", "lcp_solve"}
    # the bench's chain: its links collide with nothing, so no collision or contact branch
    from tumble.apps.benchmarks import chain
    assert wanted(tumble.World(chain())) == {"direct_solve"}
    assert wanted(tumble.World(chain(), contact="penalty")) == {"direct_solve"}
    terrain = tumble.World(bodies_on_a_heightfield())
    assert wanted(terrain) == {"general_collide", "lcp_solve"}
    terrain.step(30)                      # it lands on the terrain through the branch
    assert terrain.state_arrays.contact_count[0] > 0
    assert abs(terrain.body_pos[0, 2] - 0.1) < 0.01


@pytest.mark.parametrize("branch, options", [
    ("stable_pd_forces", dict(pd="stable")), ("lcp_solve", dict(contact="lcp")),
    ("penalty_contact_forces", dict(contact="penalty")), ("direct_solve", dict(contact="penalty")),
    ("pgs_solve", dict(contact="pgs")), ("sleep", dict(sleep_time=0.5))])
def test_a_branch_missing_from_the_call_is_compiled_and_the_step_taken_again(branch, options):
    """A step that reaches a branch its call has no code for (options changed after the
    stages were compiled, say) is undone, the branch compiled, the step taken again: the
    world steps on bit for bit as its twin that had the branch from the start."""
    w, twin = ragdoll_world(**options), ragdoll_world(**options)
    for x in (w, twin):
        x.set_pd_gains("lKnee", 300.0, 30.0)
        x.step(5)
    assert w._stages is not None and getattr(w._stages, branch) != 0
    w._stages = w._stages._replace(**{branch: 0})
    w.step(20)
    twin.step(20)
    assert branch in w._branches_taken and getattr(w._stages, branch) != 0
    for a, b in zip(w.state_arrays, twin.state_arrays):
        np.testing.assert_array_equal(a, b)
    assert w.time == twin.time


def test_an_unknown_branch_is_refused_by_name():
    from tumble.pipeline import step
    world = pendulum_and_box()
    world.step(1)
    with pytest.raises(ValueError, match="no such branch of the step: \\['stable_pd'\\]"):
        step.stage_addresses(world._box, world.step_options(), ("stable_pd",))
