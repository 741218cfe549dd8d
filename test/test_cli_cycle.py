"""``jointwear cycle design``: the chosen speeds, the bound, the comparison with the paper's choice, bad arguments."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from jointwear_ros.cli import main
from jointwear_ros.estimation.crb import crb_multi_speed, crb_per_speed
from jointwear_ros.estimation.design import design_cycle
from jointwear_ros.model import load_parameter_set, paper_wear_model

CANDS = "0,20,40,60,100,160,220"


def run_json(capsys, *args):
    rc = main(["cycle", "design", *args, "--json"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    return json.loads(out.out)


def test_design_json_gives_speeds_and_bound_that_beat_the_papers_best_single_speed(capsys):
    d = run_json(capsys, "--budget", "50", "--speeds-candidates", CANDS)
    assert len(d["speeds"]) == 3  # floor(50 / 14)
    assert set(d["speeds"]) <= {0.0, 20.0, 40.0, 60.0, 100.0, 160.0, 220.0}
    # the bound printed is the shared-T bound of the speeds printed
    m, p = paper_wear_model(), load_parameter_set("ref-2011r")
    assert d["bound_std"] == pytest.approx(np.sqrt(crb_multi_speed(m, p, d["speeds"], 35.0)), rel=1e-9)
    # the paper's best single speed, from the per-speed bound, repeated as often
    cands = [float(x) for x in CANDS.split(",")]
    best = cands[int(np.argmin(crb_per_speed(m, p, cands, 35.0)))]
    assert d["best_single_speed"] == best
    repeated = np.sqrt(crb_multi_speed(m, p, [best] * 3, 35.0))
    assert d["bound_std"] <= repeated * (1 + 1e-9)
    assert d["bound_std"] < np.sqrt(crb_per_speed(m, p, [best], 35.0)[0])
    assert d["known_temperature_bound_std"] <= d["bound_std"]


def test_seconds_per_speed_sets_the_number_of_speeds(capsys):
    d = run_json(capsys, "--budget", "40", "--seconds-per-speed", "10", "--speeds-candidates", "0,40,100")
    assert len(d["speeds"]) == 4 and d["seconds"] == 40.0


def test_no_repeats_chooses_distinct_speeds(capsys):
    d = run_json(capsys, "--budget", "42", "--no-repeats", "--speeds-candidates", CANDS)
    assert len(set(d["speeds"])) == 3


def test_design_is_no_worse_than_an_obvious_spread_of_speeds():
    cands = [0.0, 20.0, 40.0, 60.0, 100.0, 160.0]
    d = design_cycle(budget=56.0, candidates=cands)
    m, p = paper_wear_model(), load_parameter_set("ref-2011r")
    spread = np.sqrt(crb_multi_speed(m, p, [0.0, 40.0, 100.0, 160.0], 35.0))
    assert d.bound_std <= spread * 1.01


def test_design_table_names_the_speeds_and_the_comparison(capsys):
    rc = main(["cycle", "design", "--budget", "30", "--speeds-candidates", "0,40,100"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "2 speeds x 14 s" in out
    assert "bound std on w of this cycle" in out and "paper's best single speed" in out
    assert "speed 0 cannot be swept" in out  # 0 was a candidate and is in the design


def test_default_candidates_give_a_cycle_the_test_cycle_node_accepts(capsys):
    from jointwear_ros.cycle import CycleConfig, plan_cycle

    rc = main(["cycle", "design", "--budget", "42", "--json"])
    speeds = json.loads(capsys.readouterr().out)["speeds"]
    assert rc == 0 and len(speeds) == 3 and min(speeds) > 0
    plan_cycle(CycleConfig(), speeds)  # raises CycleRequestError for a speed a cycle cannot run


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--budget", "5"], "shorter than one speed"),
        (["--budget", "abc"], "not a number"),
        (["--budget", "-10"], "positive"),
        (["--seconds-per-speed", "0"], "positive"),
        (["--speeds-candidates", "0,-4"], "negative"),
        (["--speeds-candidates", "0:280"], "START:STOP:COUNT"),
        (["--prior", "foo"], "temperature distribution"),
        (["--params", "nope"], "parameter set"),
        (["--budget", "9000", "--seconds-per-speed", "1"], "at most"),
        (["--wear", "500"], "valid range"),
        (["--no-repeats", "--speeds-candidates", "0,10"], "distinct"),
        (["--noise-std", "0"], "positive"),
    ],
)
def test_bad_arguments_give_one_line_and_exit_code_2(capsys, args, match):
    rc = main(["cycle", "design", *args])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and match in err


def test_output_piped_into_head_is_not_a_traceback():
    import subprocess
    import sys
    from pathlib import Path

    exe = Path(sys.executable).with_name("jointwear")
    p = subprocess.run(f"'{exe}' model curve --speeds 0:280:2000 --json | head -c 10", shell=True,
                       capture_output=True, text=True, timeout=60)
    assert p.stdout.startswith("{") and "Traceback" not in p.stderr and "BrokenPipe" not in p.stderr, p.stderr


# --------------------------------------------------------------------------- cycle schedule

ROBOT_YAML = """
test_cycle:
  ros__parameters:
    joints: [joint_1, joint_2, joint_3, joint_4, joint_5, joint_6]
    speeds: [10.0, 20.0, 30.0, 40.0, 50.0, 80.0, 120.0, 160.0]
    joint_limits: [-1.5, 1.5]
    joint_3:
      speeds: [40.0, 80.0]
    joint_6:
      gear_ratio: 150.0
"""


def schedule(capsys, tmp_path, *args):
    f = tmp_path / "test_cycle.yaml"
    f.write_text(ROBOT_YAML)
    rc = main(["cycle", "schedule", "--params-file", str(f), *args])
    return rc, capsys.readouterr()


def test_schedule_plans_every_joint_with_its_own_settings(capsys, tmp_path):
    from jointwear_ros.cycle import CycleConfig, plan_cycle

    rc, out = schedule(capsys, tmp_path, "--json")
    assert rc == 0, out.err
    d = json.loads(out.out)
    rows = {r["joint"]: r for r in d["joints"]}
    assert list(rows) == [f"joint_{k}" for k in range(1, 7)]
    assert rows["joint_3"]["speeds"] == 2 and rows["joint_1"]["speeds"] == 8
    base = plan_cycle(CycleConfig(speeds=(10.0, 20.0, 30.0, 40.0, 50.0, 80.0, 120.0, 160.0))).duration
    assert rows["joint_1"]["seconds"] == pytest.approx(base)
    assert rows["joint_3"]["seconds"] < base / 2
    # gear 150: the same motor speeds are slower joint speeds: longer sweeps
    assert rows["joint_6"]["seconds"] != pytest.approx(base)
    assert d["total_seconds"] == pytest.approx(sum(r["seconds"] for r in rows.values()))
    assert d["schedule"] is None


def test_schedule_splits_the_robot_over_nights_within_the_budget(capsys, tmp_path):
    rc, out = schedule(capsys, tmp_path, "--seconds-per-speed", "14", "--budget", "300", "--overhead", "10",
                       "--json")
    assert rc == 0, out.err
    s = json.loads(out.out)["schedule"]
    assert all(n["seconds"] <= 300 for n in s["nights"])
    assert sorted(j for n in s["nights"] for j in n["joints"]) == [f"joint_{k}" for k in range(1, 7)]
    # 5 joints x (8 x 14 + 10) + (2 x 14 + 10) = 648 s: at least 3 nights of 300 s, and 3 suffice
    assert s["total_seconds"] == pytest.approx(5 * 122 + 38)
    assert s["period_nights"] == 3
    rc, out = schedule(capsys, tmp_path, "--seconds-per-speed", "14", "--budget", "300")
    assert rc == 0 and "each joint tested every 3 nights" in out.out and "RunTestCycle joints:" in out.out


@pytest.mark.parametrize("args,match", [
    (("--budget", "60", "--seconds-per-speed", "14"), "joint_1 alone needs 112 s"),
    (("--budget", "-5"), "--budget"),
    (("--joints", "joint_1,joint_9"), "--joints"),
    (("--joints", "joint_1,joint_1"), "--joints"),
    (("--joints", "7"), "configures 6 joints"),
    (("--speeds", "10,5000"), "joint_1: speed #2"),
    (("--seconds-per-speed", "0"), "--seconds-per-speed"),
])
def test_schedule_bad_arguments_are_one_line_errors(capsys, tmp_path, args, match):
    rc, out = schedule(capsys, tmp_path, *args)
    assert rc == 2 and out.out == ""
    assert match in out.err and len(out.err.strip().splitlines()) == 1, out.err


@pytest.mark.parametrize(("extra", "match"), [
    # the yaml's stopping allowance is the node's: a reaction time joint_3's ±1.2 rad cannot take at 160 rad/s
    ("    reaction_time: 0.3\n    joint_limits: [-1.2, 1.2]\n", r"speed #8 = 160 rad/s .* stopping allowance 0\.528 rad"),
    # the control period is the node's 1 / command_rate
    ("    command_rate: 2.0\n    joint_limits: [-1.2, 1.2]\n", r"speed #7 = 120 rad/s .* stopping allowance 0\.744 rad .*= 0\.62 s\)"),
    ("    command_rate: 0.0\n", "command_rate = 0.0 must be a rate in Hz > 0"),
])
def test_schedule_plans_with_the_nodes_stopping_allowance(capsys, tmp_path, extra, match):
    f = tmp_path / "test_cycle.yaml"
    f.write_text("test_cycle:\n  ros__parameters:\n    joints: [joint_1]\n" + extra)
    rc = main(["cycle", "schedule", "--params-file", str(f)])
    out = capsys.readouterr()
    assert rc == 2 and out.out == "" and len(out.err.strip().splitlines()) == 1, out.err
    assert re.search(match, out.err), out.err
