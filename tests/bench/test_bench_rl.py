"""The imitation throughput bench (bench/bench_rl.py) splits a step's time and, asked,
the physics step's stages."""
from bench.bench_rl import measure
from tumble.pipeline.arrays import STAGES


def test_measure_reports_samples_shares_and_stage_times():
    r = measure(2, 0.3, stages=True)
    assert r["nworld"] == 2 and r["samples_per_s"] > 0
    assert set(r["share"]) == {"physics", "reference", "reward", "observe", "reset", "other"}
    assert 0.0 < r["share"]["physics"] < 1.0
    assert set(r["stage_us"]) == set(STAGES)
    assert all(v >= 0.0 for v in r["stage_us"].values())
    # a character on the ground: contacts collided and solved every step
    assert r["stage_us"]["solve"] > 0.0 and r["stage_us"]["collide"] > 0.0
