"""The in-process PD comparison (bench/compare_pd.py) runs both engines on the same scene:
tumble's implicit PD holds the pose to round-off at 60 Hz while MuJoCo's position
actuators sag (the figures of bench/README.md), and the script reports a ratio of the
timings it measured (not asserted: timings are not tested)."""
import json

import pytest

pytest.importorskip("mujoco")

from bench import compare_pd  # noqa: E402


def test_compare_pd_reports_both_engines(capsys, monkeypatch):
    monkeypatch.setattr("sys.argv", ["compare_pd.py", "--hz", "60", "--rounds", "2"])
    compare_pd.main()
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("RESULT ")][0]
    res = json.loads(line[7:])
    assert res["steps"] == 180 and res["rounds"] == 2
    assert res["tumble_max_joint_err_rad"] < 1e-6            # the issue asks < 0.05 rad
    assert 0.1 < res["mujoco_max_joint_err_rad"] < 0.3        # MuJoCo's 60 Hz sag: 0.19 rad
    assert res["tumble_ms_min"] > 0 and res["mujoco_ms_min"] > 0
    assert res["ratio_median"] > 0 and 0 <= res["tumble_faster_rounds"] <= 2
