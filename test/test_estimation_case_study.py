"""The synthetic Section 6 case study: profile, Eq. (16) reference, detection, per-speed statistics, the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jointwear_ros.cli import main
from jointwear_ros.errors import InputDataError
from jointwear_ros.estimation import make_estimator
from jointwear_ros.estimation.case_study import (
    CaseSetup,
    _wear_term,
    detect,
    reference_wear,
    run_case_study,
    wear_profile,
)
from jointwear_ros.model import load_parameter_set, paper_wear_model

SPEEDS = (0.0, 20.0, 40.0, 45.0, 150.0, 250.0)


@pytest.fixture(scope="module")
def case():
    ests = {"paper": make_estimator("paper"), "bayes": make_estimator("bayes", prior="normal:40:3")}
    return run_case_study(ests, CaseSetup(speeds=SPEEDS, seed=0))


def test_wear_profile_rises_past_35_at_k_80():
    w = wear_profile(CaseSetup())
    assert w.size == 120 and w[0] == 0.0
    assert np.all(np.diff(w) > 0)
    assert w[79] < 35.0 <= w[80]


def test_reference_wear_recovers_the_true_wear_from_a_clean_profile():
    m, p = paper_wear_model(), load_parameter_set("ref-2011r")
    v = np.linspace(0.0, 280.0, 15)
    w = np.array([0.0, 3.3, 17.0, 35.0, 61.7, 99.0])
    prof = _wear_term(m, p, v, 0.1, w)
    assert reference_wear(m, p, v, 0.1, prof) == pytest.approx(w, abs=1e-3)


def test_detect_counts_alarms_false_alarms_and_misses():
    w = np.array([10, 36, 20, 30, 36, 37, 34, 38, 39, 40], dtype=float)
    d = detect(w, 35.0, crossing=4, confirm=2)
    assert d == {"first_alarm": 1, "first_confirmed": 4, "delay": 0, "false_alarms": 1, "misses": 1}
    assert detect(np.zeros(5), 35.0, crossing=2)["first_alarm"] is None


def test_case_study_data_come_from_mismatched_joints(case):
    for rel in (case.joint_a_relative, case.joint_b_relative):
        vals = np.array(list(rel.values()))
        assert np.all(np.abs(vals) <= 0.03) and np.any(np.abs(vals) > 0.005)
    assert set(case.joint_a_relative) == {"Fsw", "vsw", "Fvw"}
    assert "Fc0" in case.joint_b_relative and "Fsw" not in case.joint_b_relative
    # w* (Eq. 16 on the profile of the mismatched joint A) stays near the true wear, but not equal to it
    assert np.max(np.abs(case.w_ref - case.w_true)) < 4.0
    assert np.max(np.abs(case.w_ref - case.w_true)) > 0.05
    assert 37.0 < case.temperatures.mean() < 43.0


def test_case_study_is_best_at_low_speed_and_detects_the_alarm_level(case):
    for name in ("paper", "bayes"):
        d = case.methods[name]
        assert d["estimates"].shape == (120, len(SPEEDS))
        assert d["best_speed"] <= 45.0
        b = d["best"]
        assert abs(b["mean"]) < 1.5 and b["std"] < 4.0 and b["worst"] < 12.0
        # larger spread and a growing bias at high speed, as in the paper's Fig. 14
        assert d["std"][-1] > 3 * b["std"]
        assert d["mean"][-1] > 10.0
        det = d["detection"]
        assert det["first_confirmed"] is not None and 76 <= det["first_confirmed"] <= 90
        assert det["false_alarms"] <= 3 and det["misses"] <= 8


def test_case_study_refuses_the_joint_estimator():
    with pytest.raises(InputDataError, match="joint"):
        run_case_study({"joint": make_estimator("joint")}, CaseSetup(speeds=(40.0,)))
    with pytest.raises(InputDataError, match="mismatch"):
        run_case_study({"paper": make_estimator("paper")}, CaseSetup(speeds=(40.0,), mismatch=0.9))


def test_study_case_cli_json_and_plot(tmp_path, capsys):
    rc = main(["study", "case", "--speeds", "20,40,200", "--methods", "paper", "--quiet", "--json",
               "--plot", str(tmp_path)])
    out = capsys.readouterr()
    assert rc == 0, out.err
    d = json.loads(out.out)
    assert d["crossing_index"] == 80 and d["threshold"] == 35.0
    p = d["methods"]["paper"]
    assert len(p["mean"]) == len(p["worst"]) == len(p["std"]) == 3
    assert len(p["estimates_at_best_speed"]) == 120
    assert set(p["detection"]) == {"first_alarm", "first_confirmed", "delay", "false_alarms", "misses"}
    assert (tmp_path / "case_study.png").stat().st_size > 5000


def test_study_case_cli_table_and_bad_arguments(capsys):
    rc = main(["study", "case", "--speeds", "40", "--methods", "paper", "--quiet"])
    out = capsys.readouterr().out
    assert rc == 0 and "best at 40.0 rad/s" in out and "first alarm" in out
    for args in (["--mismatch", "0.7"], ["--methods", "joint"], ["--speeds", "a,b"]):
        rc = main(["study", "case", *args, "--quiet"])
        err = capsys.readouterr().err
        assert rc == 2 and len(err.strip().splitlines()) == 1
