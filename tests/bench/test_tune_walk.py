"""The style search (bench/tune_walk.py): a tiny search runs a generation, writes its state,
log and best candidate, resumes where it stopped, and writes the best as a style file that
loads and equals the decoded candidate. The search's figures are not tested (bench/README)."""
import json

import numpy as np
import pytest

pytest.importorskip("cma")

from bench import tune_walk  # noqa: E402
from tumble.character.generalized import load_style  # noqa: E402

TINY = ["--phases", "1", "--forces", "300", "--popsize", "2", "--workers", "1", "--settle", "2",
        "--watch", "1", "--speeds", "1.0", "--speed-time", "4", "--slopes", "-10", "--dts", ""]


def test_encode_and_decode_are_inverse_on_the_shipped_style():
    st = load_style("ipm_walk")
    x = tune_walk.encode(st)
    back = tune_walk.decode(st, x)
    for field, index, lo, hi in tune_walk.SPACE:
        v = getattr(st, field) if index is None else getattr(st, field)[index]
        if lo <= v <= hi:
            got = getattr(back, field) if index is None else getattr(back, field)[index]
            assert got == pytest.approx(v, abs=1e-12), field
    assert back.gains == st.gains


def test_a_tiny_search_runs_resumes_and_writes_its_best(tmp_path, monkeypatch, capsys):
    out = tmp_path / "search"
    monkeypatch.setattr("sys.argv", ["tune_walk.py", "--out", str(out), "--generations", "1"]
                        + TINY)
    tune_walk.main()
    log = [json.loads(x) for x in (out / "log.jsonl").read_text().splitlines()]
    assert len(log) == 2 and all(r["gen"] == 1 for r in log)
    of = 1 * 8 + 30.0 * 2                       # pushes, and one speed and one slope
    assert all(0 <= r["score"] <= of for r in log)
    best = json.loads((out / "best.json").read_text())
    assert best["of"] == of and best["score"] >= max(r["score"] for r in log)
    monkeypatch.setattr("sys.argv", ["tune_walk.py", "--out", str(out), "--generations", "2"]
                        + TINY)
    tune_walk.main()
    assert "resumed at generation 1" in capsys.readouterr().out
    log = [json.loads(x) for x in (out / "log.jsonl").read_text().splitlines()]
    assert [r["gen"] for r in log] == [1, 1, 2, 2]
    path = tmp_path / "best_style.json"
    monkeypatch.setattr("sys.argv", ["tune_walk.py", "--out", str(out), "--write-best",
                                     str(path)])
    tune_walk.main()
    best = json.loads((out / "best.json").read_text())
    want = tune_walk.decode(load_style("ipm_walk"), np.array(best["x"]))
    got = load_style(str(path))
    for field, index, lo, hi in tune_walk.SPACE:
        a, b = getattr(got, field), getattr(want, field)
        assert (a if index is None else a[index]) == pytest.approx(
            b if index is None else b[index], abs=1e-12), field
    assert got.gains == want.gains
