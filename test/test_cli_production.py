"""``jointwear data from-production``: a recorded simulated production (record_production) through the production
observer offline, shift by shift: the JSON's fields and counts, the same observations as the core over the bag's
samples, the observation table it writes, and one line with exit 2 for a path that is no bag or a bag without
joint states."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from jointwear_ros.cli import main
from jointwear_ros.data import synth_observations
from jointwear_ros.io.observations import read_observations
from jointwear_ros.io.production_bag import read_production, record_production
from jointwear_ros.io.tables import write_bag
from jointwear_ros.observer import ProductionConfig, observe_production
from jointwear_ros.sim.arms import arm_spec
from jointwear_ros.sim.production import pick_and_place, run_production

UR5 = arm_spec("ur5")


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory):
    run = run_production("ur5", pick_and_place("ur5"), cycles=1, wear=[10.0, 20.0, 30.0, 15.0, 25.0, 5.0], seed=2)
    return record_production(run, tmp_path_factory.mktemp("production") / "bag")


def _run(capsys: pytest.CaptureFixture[str], args: list[str]) -> tuple[int, str, str]:
    try:
        rc = main(args)
    except SystemExit as exc:
        rc = int(exc.code or 0)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_from_production_json_gives_each_shifts_counts_and_observations_as_the_core_gives_them(bag, capsys, tmp_path):
    out = tmp_path / "obs.csv"
    rc, text, err = _run(capsys, ["data", "from-production", str(bag), "--shift-seconds", "15", "--json",
                                  "--out", str(out)])
    assert rc == 0, err
    doc = json.loads(text)
    assert doc["joints"] == [f"joint_{i + 1}" for i in range(6)] and doc["arm"] is None
    assert doc["skipped"] == {} and doc["shift_seconds"] == 15.0 and doc["temperature_readings"] > 0
    # without --arm: the bag's recorded joint_sim gear ratios and torque scales (the UR5's)
    assert doc["settings_from"] == ["the recorded joint_sim's gear ratios and torque scales"]
    shifts = doc["shifts"]
    assert [s["shift_id"] for s in shifts] == list(range(1, len(shifts) + 1)) and len(shifts) >= 2
    assert sum(s["samples"] for s in shifts) == doc["samples"]
    for s in shifts:
        by_joint = {j["joint"]: j for j in s["joints"]}
        assert set(by_joint) == set(doc["joints"])
        held = by_joint["joint_6"]
        assert (held["passes"], held["observations"], held["informative"]) == (0, 0, False)
        assert held["note"] == "joint_6: never moved at a constant speed >= 10 rad/s motor in this shift"
        for j in by_joint.values():
            assert set(j) == {"joint", "observations", "passes", "paired", "model", "rejected", "rejected_total",
                              "speed_levels", "informative", "note"}
            assert j["observations"] == sum(1 for o in doc["observations"]
                                            if o["shift_id"] == s["shift_id"] and o["joint_name"] == j["joint"])
    assert doc["observations"] and all(o["source"] == "production" and o["kind"] == "paired"
                                       and o["cycle_id"] == o["shift_id"] for o in doc["observations"])
    # the core over the same samples, shift by shift
    samples = read_production([bag])
    configs = [ProductionConfig(gear_ratio=j.gear_ratio, torque_scale=j.torque_scale) for j in UR5.joints]
    period = 1 + np.floor(samples.t / 15.0).astype(int)
    want = []
    for sid in sorted(set(period.tolist())):
        sel = period == sid
        want += observe_production(samples.t[sel], samples.q[sel], samples.v[sel], samples.u[sel], samples.temps[sel],
                                   joint_names=samples.names, config=configs, shift_id=sid).observations
    assert [(o["joint_name"], o["cycle_id"], o["speed"], o["tau_f"], o["tau_f_std"]) for o in doc["observations"]] == \
        [(o.joint_name, o.cycle_id, o.speed, o.tau_f, o.tau_f_std) for o in want]
    # the table: one per joint, a production shift's
    tables = read_observations(out)
    assert sum(len(t) for t in tables.values()) == len(doc["observations"])
    assert all(np.all(t["production"] == 1.0) for t in tables.values())


def test_from_production_with_the_arm_corrects_the_part_carried_one_way_and_prints_the_reasons(bag, capsys):
    rc, text, err = _run(capsys, ["data", "from-production", str(bag)])
    assert rc == 0, err
    assert "paired+payload" not in text and "without the arm's model a part carried one way is not seen" in text
    rc, text, err = _run(capsys, ["data", "from-production", str(bag), "--arm", "ur5"])
    assert rc == 0, err
    assert "arm model ur5, the part's mass fitted per pair; shifts of 28800 s" in text
    assert "# shift 1: " in text and "joint_6: 0 passes, 0 paired, 0 model, 0 rejected (held still" in text
    assert " paired+payload " in text and "corrected for a payload of" in text
    rc, text, err = _run(capsys, ["data", "from-production", str(bag), "--arm", "ur5", "--payload", "2"])
    assert rc == 0, err
    assert "arm model ur5, a part of 2 kg;" in text and " paired+payload " in text


def _text(path):
    path.write_text("not a bag\n")
    return path


@pytest.mark.parametrize(("make", "message"), [
    (lambda d: _text(d / "notes.txt"), "not a bag"),
    (lambda d: d, "not a rosbag2 bag (no metadata.yaml)"),
    (lambda d: write_bag(synth_observations(n_cycles=2, seed=1), d / "obs_bag"),
     "no sensor_msgs/JointState on /joint_states"),
])
def test_from_production_of_a_non_bag_or_a_bag_without_joint_states_is_one_line_and_exit_2(make, message, capsys,
                                                                                          tmp_path):
    path = make(tmp_path)
    rc, _out, err = _run(capsys, ["data", "from-production", str(path)])
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("jointwear: error: ") and message in lines[0], lines[0]


@pytest.mark.parametrize(("args", "message"), [
    (["--shift-seconds", "0"], "--shift-seconds: 0 must be a positive number of seconds"),
    (["--payload", "-1"], "--payload: -1 must be a mass >= 0 kg"),
    (["--out", "obs.txt"], "must end in .csv"),
])
def test_from_production_bad_options_are_one_line_and_exit_2(args, message, capsys, tmp_path):
    rc, _out, err = _run(capsys, ["data", "from-production", str(tmp_path), *args])  # the options come first
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and message in lines[0], err
