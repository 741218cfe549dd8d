"""``jointwear study``: the Section 5.1 findings on a reduced run, the JSON contract, figures, robustness, bad arguments."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jointwear_ros.cli import main

# a reduced Section 5.1 grid: both ends, the paper's best region, the mid range, the high speeds
SPEEDS = "0,20,35,40,45,50,80,110,140,200,280"


def run_json(capsys, *args):
    rc = main(["study", *args, "--json", "--quiet"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    return json.loads(out.out)


@pytest.fixture(scope="module")
def paper_study():
    """The paper's estimator, ref-2011r, the paper's settings, 500 runs per speed (seeded)."""
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = main(["study", "--method", "paper", "--runs", "500", "--speeds", SPEEDS, "--params", "ref-2011r",
                   "--true-wear", "35", "--seed", "3", "--json", "--quiet"])
    assert rc == 0
    return json.loads(buf.getvalue())


def test_study_json_has_the_contract_keys_one_entry_per_speed(paper_study):
    d = paper_study
    for key in ("method", "runs", "seconds", "speeds", "bias", "variance", "crb"):
        assert key in d
    assert d["method"] == "paper" and d["runs"] == 500 and d["seconds"] > 0
    n = len(SPEEDS.split(","))
    assert d["speeds"] == [float(s) for s in SPEEDS.split(",")]
    assert len(d["bias"]) == len(d["variance"]) == len(d["crb"]) == n
    assert set(d["quantiles"]) == {"0.025", "0.25", "0.5", "0.75", "0.975"}


def test_study_reproduces_the_papers_findings_with_ref_2011r(paper_study):
    v = np.array(paper_study["speeds"])
    bias, var, crb = (np.array(paper_study[k], dtype=float) for k in ("bias", "variance", "crb"))
    # smallest variance in [30, 55] rad/s, and close to the bound there
    best = int(np.argmin(var))
    assert 30.0 <= v[best] <= 55.0
    region = (v >= 30) & (v <= 55)
    assert np.all(var[region] / crb[region] < 1.25) and np.all(var[region] / crb[region] > 0.8)
    # much larger variance at both ends of the speed range
    assert var[v == 0][0] > 3 * var[best] and var[v == 140][0] > 8 * var[best]
    # small bias below 150 rad/s (|bias| under 4 wear units, under 0.5 at the best region) ...
    assert np.all(np.abs(bias[v < 150]) < 4.0)
    assert np.all(np.abs(bias[region]) < 0.8)
    # ... and a bias that grows above it (estimates pulled up toward the grid's middle)
    high = v >= 140
    assert np.all(np.diff(bias[high]) > 0)
    assert bias[v == 200][0] > 5.0 and bias[v == 280][0] > 20.0


def test_study_bayes_stays_near_the_bound_up_to_100_rad_s(capsys):
    d = run_json(capsys, "--method", "bayes", "--runs", "1500", "--speeds", "0,20,60,100", "--seed", "1")
    mse = np.array(d["mse"])
    crb = np.array(d["crb"])
    assert np.all(mse / crb < 1.35)
    assert np.all(np.abs(np.array(d["bias"])) < 0.6)


def test_study_joint_reports_one_cycle_row_with_temperature(capsys):
    d = run_json(capsys, "--method", "joint", "--runs", "200", "--speeds", "0,40,45,55,65,65",
                 "--true-temperature", "uniform:25:55", "--seed", "2")
    assert d["mode"] == "cycle" and len(d["bias"]) == 1
    assert abs(d["bias"][0]) < 0.5
    assert d["variance"][0] < 1.0 and d["variance"][0] / d["crb"][0] < 1.4
    assert abs(d["temperature_bias"]) < 1.0


def test_study_plot_writes_figures_9_10_11(tmp_path, capsys):
    rc = main(["study", "--runs", "50", "--speeds", "0:100:5", "--quiet", "--plot", str(tmp_path)])
    out = capsys.readouterr()
    assert rc == 0, out.err
    names = sorted(p.name for p in tmp_path.glob("*.png"))
    assert names == ["study_paper_bias.png", "study_paper_density.png", "study_paper_variance.png"]
    assert all(p.stat().st_size > 5000 for p in tmp_path.glob("*.png"))
    # the table: one line per speed plus header lines
    assert "variance" in out.out and "crb" in out.out


def test_study_progress_bar_goes_to_stderr(capsys):
    rc = main(["study", "--runs", "20", "--speeds", "0,40", "--json"])
    out = capsys.readouterr()
    assert rc == 0
    assert "2/2" in out.err and "[" in out.err
    json.loads(out.out)  # stdout stays pure JSON


def test_robustness_reports_which_estimators_stay_unbiased(capsys):
    d = run_json(capsys, "robustness", "--runs", "300", "--speeds", "10,40,120", "--methods", "paper,joint",
                 "--seed", "4")
    rows = d["rows"]
    scen = {r["scenario"] for r in rows}
    assert {"nominal N(40,3)", "hot N(55,2)", "cold N(25,2)", "wide N(40,8)", "uniform U(30,50)"} <= scen
    by = {(r["scenario"], r["method"], r["speed"]): r for r in rows}
    # the paper's estimator, assuming U(30, 50), is biased when the true T is outside its range ...
    assert abs(by[("hot N(55,2)", "paper", "10")]["bias"]) > 5.0
    assert abs(by[("cold N(25,2)", "paper", "120")]["bias"]) > 5.0
    # ... and stays unbiased at its best speed when T is inside it
    assert by[("nominal N(40,3)", "paper", "40")]["unbiased"]
    # the joint estimator (T estimated from the cycle) stays unbiased in every scenario
    assert d["unbiased_in_every_scenario"] == {"paper": False, "joint": True}
    for r in rows:
        assert r["std"] > 0 and r["rmse"] >= abs(r["bias"]) - 1e-9


def test_robustness_with_a_given_true_distribution_has_one_scenario(capsys):
    d = run_json(capsys, "robustness", "--runs", "100", "--speeds", "40", "--methods", "paper",
                 "--true-temperature", "uniform:45:60")
    assert {r["scenario"] for r in d["rows"]} == {"given uniform:45:60"}


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--runs", "x"], "--runs"),
        (["--runs", "1"], "--runs"),
        (["--speeds", "-5"], "--speeds"),
        (["--speeds", "0:280"], "--speeds"),
        (["--true-wear", "200"], "--true-wear"),
        (["--params", "nope"], "nope"),
        (["--true-temperature", "gauss:1"], "--true-temperature"),
        (["--noise-std", "0"], "--noise-std"),
        (["--method", "paper", "--assumed-temperature", "normal:40:3"], "uniform"),
        (["robustness", "--methods", "paper,magic"], "--methods"),
        (["robustness", "--tolerance", "-1"], "--tolerance"),
    ],
)
def test_study_bad_arguments_give_one_line_and_exit_2(capsys, args, match):
    rc = main(["study", *args, "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2
    assert len(err.strip().splitlines()) == 1 and match in err


def test_study_unknown_method_is_an_argparse_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["study", "--method", "magic"])
    assert exc.value.code == 2
    assert "magic" in capsys.readouterr().err
