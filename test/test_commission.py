"""Commissioning (issue 18): parameter sets that carry a model, the fit on baseline cycles, the CLI, and
the estimators on a set's own model and units."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from jointwear_ros.cli import main
from jointwear_ros.commission import (
    DEFAULT_WEAR_CALIBRATION,
    CommissionError,
    commission,
    nominal_spec,
    paper_wear_values,
)
from jointwear_ros.data import synth_observations
from jointwear_ros.errors import InputDataError, ParameterSetError
from jointwear_ros.estimation import make_estimator, set_frame_table
from jointwear_ros.io.tables import write_csv
from jointwear_ros.model import (
    Parameter,
    Parameters,
    SetUnits,
    load_parameter_set_info,
    parameter_set_document,
)
from jointwear_ros.model.scaling import DataScales, data_parameters, on_bound
from jointwear_ros.types import ObservationTable


def _cycles(table: ObservationTable, drop=("temperature", "wear")) -> list[ObservationTable]:
    cols = {n: v for n, v in table.columns.items() if n not in drop}
    return [g for _, g in ObservationTable(cols, source="t").groups("cycle")]


def test_todays_sets_read_as_before_with_the_papers_model_and_units():
    info = load_parameter_set_info("ref-2011r")
    assert info.spec == "paper+wear" and info.units.frame == "motor_normalized"
    assert info.wear_calibration == "paper" and info.noise_std is None and info.covariance is None
    assert info.model().spec.endswith("wear_stribeck + wear_viscous")


def test_a_commissioned_set_round_trips_through_its_yaml(tmp_path):
    t = synth_observations(n_cycles=12, seed=2, temperature=(20.0, 50.0))
    res = commission(t, joint="joint_2", robot="cell_7", diagnose_baseline=False, cv_folds=3)
    pset = res.parameter_set("j2")
    path = tmp_path / "j2.yaml"
    path.write_text(yaml.safe_dump(parameter_set_document(pset), sort_keys=False, allow_unicode=True))
    back = load_parameter_set_info(str(path))
    assert back.values == pytest.approx(pset.values)
    assert back.spec == pset.spec and back.wear_calibration == DEFAULT_WEAR_CALIBRATION
    assert back.covariance is not None and back.covariance[0] == tuple(res.params.free())
    assert back.stderr["Fc0"] == pytest.approx(res.params["Fc0"].stderr)
    assert back.provenance["joint"] == "joint_2" and back.provenance["robot"] == "cell_7"
    assert back.valid["temperature"][0] == pytest.approx(float(np.min(t["temperature"])))
    assert back.temperature_prior and back.temperature_prior.startswith("uniform:")


@pytest.mark.parametrize("bad, match", [
    ({"units": {"frame": "wrist"}}, "frame 'wrist' unknown"),
    ({"units": {"frame": "joint", "gear_ratio": 100}}, "needs units gear_ratio and torque_scale"),
    ({"units": {"frame": "joint", "gear_ratio": -1, "torque_scale": 2}}, "gear_ratio = -1"),
    ({"covariance": {"names": ["Fc0"], "matrix": [[1, 2]]}}, "not 1x1"),
    ({"covariance": {"names": ["nope"], "matrix": [[1]]}}, "not parameters of the set"),
    ({"noise_std": -3}, "noise_std = -3"),
])
def test_a_set_file_with_a_bad_model_block_is_refused_with_the_reason(tmp_path, bad, match):
    doc = {"name": "x", "parameters": {"Fc0": 0.04}, **bad}
    p = tmp_path / "x.yaml"
    p.write_text(yaml.safe_dump(doc))
    with pytest.raises(ParameterSetError, match=match):
        load_parameter_set_info(str(p))


def test_commissioning_recovers_the_reference_joint_and_validates_on_held_out_cycles():
    t = synth_observations(n_cycles=16, seed=4)
    r = commission(t, joint="joint_1", diagnose_baseline=False)
    assert r.converged and not r.on_bound
    truth = load_parameter_set_info("ref-2011r").values
    for n in ("Fc0", "Fctm", "Fstm", "FsT", "FvT"):
        assert abs(r.params[n].value - truth[n]) < 4 * r.params[n].stderr, n
    assert r.cv_rmse < 1.2 * 0.0015 and r.bands and all(b["n"] > 0 for b in r.bands)
    # relative wear calibration on a joint like ref-2011r is the paper's, within the fit's precision
    assert r.wear["Fsw"] == pytest.approx(truth["Fsw"], rel=0.02)


def test_a_temperature_span_too_narrow_fixes_the_temperature_terms_saying_what_to_record():
    t = synth_observations(n_cycles=10, seed=1, temperature=(38.0, 42.0))
    r = commission(t, joint="j", diagnose_baseline=False)
    assert r.fixed == {"FsT": 0.0, "vsT": 0.0, "FvT": 0.0, "Tv0": r.params["Tv0"].value}
    assert not any(r.params[n].vary for n in r.fixed)
    assert any("fixed at 0" in w and "warm-up from cold" in w for w in r.warnings)
    lo, hi = r.valid["temperature"]
    assert 38.0 <= lo < hi <= 42.0  # valid narrowed to what was measured


def test_too_few_speeds_are_refused_saying_what_to_record():
    t = synth_observations(n_cycles=6, seed=1, speeds=(2.0, 10.0, 50.0, 100.0))
    with pytest.raises(CommissionError, match=r"4 distinct speed\(s\).*record test cycles over the joint's speed"):
        commission(t, joint="j", diagnose_baseline=False)


def test_a_parameter_on_its_bound_is_reported():
    p = Parameters([Parameter("a", 0.0, 0.0, 1.0), Parameter("b", 0.5, 0.0, 1.0), Parameter("c", 1.0, 0, 1, vary=False)])
    assert on_bound(p) == [("a", 0.0, 0.0)]


def test_start_values_and_bounds_scale_with_the_datas_units():
    s1 = DataScales.of(speed=[2.0, 250.0], tau_f=[0.05, 0.1], load_torque=[0.0, 0.5], temperature=[20, 50])
    s2 = DataScales.of(speed=[2.0 / 120, 250.0 / 120], tau_f=[15.0, 30.0], load_torque=[0.0, 150.0],
                       temperature=[20, 50])
    p1, p2 = data_parameters(["Fc0", "vs0", "Fv0"], s1), data_parameters(["Fc0", "vs0", "Fv0"], s2)
    assert p2["Fc0"].value / p1["Fc0"].value == pytest.approx(300.0)
    assert p2["vs0"].max / p1["vs0"].max == pytest.approx(1 / 120)
    assert p2["Fv0"].value / p1["Fv0"].value == pytest.approx(300.0 * 120)


def test_nominal_spec_drops_the_wear_terms_and_keeps_candidates():
    assert nominal_spec("paper+wear") == "paper"
    assert nominal_spec("paper + wear_stribeck + ripple(position)") == "paper + ripple(position)"


def test_a_joint_side_robot_is_commissioned_in_n_m_and_estimates_its_wear():
    info = load_parameter_set_info("arm6-wrist")
    base = set_frame_table(synth_observations(n_cycles=16, seed=5, params="arm6-wrist", temperature=(18, 52)), info)
    r = commission(base, joint="joint_5", units=info.units, wear_calibration="paper", diagnose_baseline=False)
    assert r.converged and r.params["Fc0"].value > 0.05  # N·m, not normalized
    pset = r.parameter_set("c")
    test = synth_observations(n_cycles=3, seed=9, params="arm6-wrist", model="paper+wear", wear=30.0,
                              temperature=(25, 50), position=(0.3, 0.3))
    est, truth = make_estimator("joint", params=pset), make_estimator("joint", params="arm6-wrist")
    for cyc in _cycles(test):
        a, b = est.estimate(cyc), truth.estimate(cyc)
        assert abs(a.wear - 30.0) < 3 * a.wear_std
        assert a.info["wear_std_noise"] <= 1.3 * b.wear_std  # the noise part; the total adds the wear scale
        assert a.info["wear_calibration"] == "paper" and a.info["units"] == "joint"


def test_paper_wear_values_convert_to_the_sets_units():
    w = paper_wear_values(SetUnits("joint", 100.0, 200.0))
    ref = load_parameter_set_info("ref-2011r").values
    assert w["Fsw"] == pytest.approx(ref["Fsw"] * 200) and w["vsw"] == pytest.approx(ref["vsw"] / 100)
    assert w["Fvw"] == pytest.approx(ref["Fvw"] * 200 * 100)


def _ripple_set(tmp_path: Path) -> str:
    info = load_parameter_set_info("ref-2011r")
    doc = {"name": "rip", "model": "paper+wear + ripple(position)",
           "parameters": {**info.values, "ripple_position_a": 0.003, "ripple_position_b": 0.002,
                          "ripple_position_w": 3.0}}
    p = tmp_path / "rip.yaml"
    p.write_text(yaml.safe_dump(doc))
    return str(p)


@pytest.mark.parametrize("method", ["joint", "bayes", "paper", "paper-grid"])
def test_every_estimator_takes_a_set_with_an_extra_term_exactly(tmp_path, method):
    path = _ripple_set(tmp_path)
    est = make_estimator(method, params=path, seed=0, **({"n_samples": 20} if method.startswith("paper") else {}))
    plain = make_estimator(method, params="ref-2011r", seed=0, **({"n_samples": 20} if method.startswith("paper") else {}))
    v = np.array([10.0, 30.0, 47.0, 80.0])
    pos = np.array([0.2, -1.0, 0.7, 2.0])
    info = load_parameter_set_info(path)
    m, p = info.model(), info.parameters()
    tau = m.evaluate(p, speed=v, load_torque=0.1, temperature=40.0, wear=30.0, position=pos)
    ripple = 0.003 * np.sin(3.0 * pos) + 0.002 * np.cos(3.0 * pos)
    with_pos = ObservationTable.from_arrays(speed=v, tau_f=tau, load_torque=0.1, position=pos, temperature=40.0)
    without = ObservationTable.from_arrays(speed=v, tau_f=tau - ripple, load_torque=0.1, temperature=40.0)
    a, b = est.estimate(with_pos), plain.estimate(without)
    assert a.wear == pytest.approx(b.wear, abs=1e-6)
    with pytest.raises(InputDataError, match="column 'position' is missing.*ripple"):
        est.estimate(ObservationTable.from_arrays(speed=v, tau_f=tau, load_torque=0.1, temperature=40.0))


def test_cli_commission_json_has_the_contract_keys_and_estimate_names_the_calibration(tmp_path, capsys):
    base = synth_observations(n_cycles=12, seed=3, temperature=(20.0, 50.0))
    write_csv(base, tmp_path / "base.csv")
    test = synth_observations(n_cycles=2, seed=8, model="paper+wear", wear=30.0)
    write_csv(test, tmp_path / "w30.csv")
    out = tmp_path / "j1.yaml"
    assert main(["commission", str(tmp_path / "base.csv"), "--joint", "joint_1", "--out", str(out), "--json",
                 "--no-diagnose"]) == 0
    doc = json.loads(capsys.readouterr().out)
    for k in ("joint", "model", "parameters", "valid", "cv_rmse", "noise_floor", "verdict", "suggestion",
              "wear_calibration", "warnings", "out"):
        assert k in doc, k
    assert doc["parameters"]["Fc0"]["stderr"] > 0 and doc["out"] == str(out)
    assert main(["estimate", str(tmp_path / "w30.csv"), "--params", str(out), "--json"]) == 0
    est = json.loads(capsys.readouterr().out)["estimates"]
    assert len(est) == 2 and {e["wear_calibration"] for e in est} == {DEFAULT_WEAR_CALIBRATION}
    for e in est:
        assert set(e) >= {"source", "joint", "cycle", "estimate", "std", "temperature", "level", "method"}
        assert abs(e["estimate"] - 30.0) < 3 * e["std"] + 1.0


def test_cli_commission_refuses_unidentifiable_data_in_one_line_and_writes_nothing(tmp_path, capsys):
    t = synth_observations(n_cycles=6, seed=1, speeds=(2.0, 10.0, 50.0, 100.0))
    write_csv(t, tmp_path / "b.csv")
    out = tmp_path / "x.yaml"
    assert main(["commission", str(tmp_path / "b.csv"), "--joint", "j", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "4 distinct speed(s)" in err and not out.exists()
    assert main(["commission", str(tmp_path / "b.csv"), "--joint", "j", "--out", str(out),
                 "--gear-ratio", "100"]) == 2
    assert "go together" in capsys.readouterr().err and not out.exists()


def test_a_wear_calibration_file_is_used_and_named(tmp_path):
    f = tmp_path / "cal.yaml"
    f.write_text(yaml.safe_dump({"Fsw": 1.2e-3, "vsw": 2.0, "Fvw": -4e-7, "source": "reducer swap 2025"}))
    t = synth_observations(n_cycles=8, seed=6, temperature=(20.0, 50.0))
    r = commission(t, joint="j", wear_calibration=str(f), diagnose_baseline=False, cv_folds=0)
    assert r.wear.label == "file:cal.yaml" and r.wear["Fsw"] == 1.2e-3 and r.wear.source == "reducer swap 2025"
    assert math.isfinite(r.rmse)


def _bag_with_temperature_topic(table: ObservationTable, path: Path, joint: str) -> None:
    """A bag as the suite records it: observations without a temperature, /joint_temperature beside them."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from jointwear_ros.io.typestore import jointwear_typestore

    store = jointwear_typestore()
    obs_t, temp_t = "jointwear_msgs/msg/FrictionObservation", "sensor_msgs/msg/Temperature"
    Obs, Temp = store.types[obs_t], store.types[temp_t]
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    msgs = []
    for i in range(len(table)):
        t = float(table["time"][i])
        for k in range(3):  # the joint's temperature during the window before the observation
            ts = t - 8.0 + 3.0 * k
            msgs.append((ts, 1, Temp(header=Header(stamp=Time(sec=int(ts), nanosec=int((ts % 1) * 1e9)), frame_id=joint),
                                     temperature=float(table["temperature"][i]), variance=0.0)))
        fields = {f: float(table[f][i]) for f in ("speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus",
                                                   "load_torque", "position")}
        msgs.append((t, 0, Obs(header=Header(stamp=Time(sec=int(t), nanosec=int((t % 1) * 1e9)), frame_id=""),
                               joint_name=joint, cycle_id=int(table["cycle"][i]), samples_plus=0, samples_minus=0, source="",
                               temperature=math.nan, **fields)))
    msgs.sort(key=lambda m: m[0])
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = [w.add_connection("/friction_observations", obs_t, typestore=store),
                 w.add_connection("/joint_temperature", temp_t, typestore=store)]
        for ts, c, m in msgs:
            w.write(conns[c], int(ts * 1e9), store.serialize_cdr(m, (obs_t, temp_t)[c]))


def test_a_bag_without_observation_temperatures_takes_them_from_joint_temperature(tmp_path, capsys):
    from jointwear_ros.io.observations import read_observations

    t = synth_observations(n_cycles=12, seed=7, temperature=(20.0, 50.0))
    bag = tmp_path / "baseline"
    _bag_with_temperature_topic(t, bag, "joint_3")
    tables = read_observations(bag)
    assert list(tables) == ["joint_3"]
    assert np.allclose(tables["joint_3"]["temperature"], t["temperature"])
    out = tmp_path / "j3.yaml"
    assert main(["commission", str(bag), "--joint", "joint_3", "--out", str(out), "--no-diagnose", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["valid"]["temperature"][0] == pytest.approx(float(np.min(t["temperature"])))
    assert load_parameter_set_info(str(out)).provenance["data"] == [str(bag)]


def test_history_import_reestimates_observation_tables_with_a_set(tmp_path, capsys):
    base = synth_observations(n_cycles=10, seed=3, temperature=(20.0, 50.0))
    write_csv(base, tmp_path / "base.csv")
    out = tmp_path / "j1.yaml"
    assert main(["commission", str(tmp_path / "base.csv"), "--joint", "joint_1", "--out", str(out),
                 "--no-diagnose"]) == 0
    test = synth_observations(n_cycles=3, seed=8, model="paper+wear", wear=30.0)
    write_csv(test, tmp_path / "w30.csv")
    db = tmp_path / "h.sqlite"
    capsys.readouterr()
    # the synthetic table counts its time from 0: the history needs to know when that was
    assert main(["history", "import", str(tmp_path / "w30.csv"), "--db", str(db), "--reestimate",
                 "--params", str(out), "--json"]) == 2
    assert "--time-origin" in capsys.readouterr().err and not db.exists()
    assert main(["history", "import", str(tmp_path / "w30.csv"), "--db", str(db), "--reestimate",
                 "--params", str(out), "--time-origin", "2026-01-05T06:00:00Z", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["added"] == 3 and doc["analysis_versions"][0].startswith("joint:j1:")


@pytest.mark.slow
def test_the_documented_command_sequence_runs_as_written(tmp_path):
    import os
    import re
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    text = (root / "docs" / "commissioning.md").read_text(encoding="utf-8")
    block = re.search(r"^```sh\n(.*?)^```$", text, re.S | re.M).group(1)
    script = f'jointwear() {{ "{sys.executable}" -m jointwear_ros "$@"; }}\n' + block
    env = dict(os.environ, PYTHONPATH=str(root), MPLBACKEND="Agg")
    r = subprocess.run(["bash", "-e", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "joint_3.yaml").is_file() and (tmp_path / "report" / "commission.png").is_file()
    est = json.loads(r.stdout[re.search(r'\{\s*"estimates"', r.stdout).start():])["estimates"]
    assert all(e["estimate"] > 50 for e in est)  # ref-2011r on this joint: a confident error


def test_the_live_monitor_takes_a_joint_side_set_by_path_and_screens_in_the_suites_units(tmp_path):
    import shutil

    from jointwear_ros.contract import CycleState, CycleStatus
    from jointwear_ros.monitor import MonitorConfig, WearMonitor
    from jointwear_ros.observer import FrictionObservationData

    path = tmp_path / "base.yaml"
    shutil.copy(load_parameter_set_info("arm6-base").path, path)
    info = load_parameter_set_info(str(path))
    m, p = info.model(), info.parameters()
    sf, tf = info.units.speed_factor, info.units.torque_factor
    mon = WearMonitor(MonitorConfig(joint_name="joint_1", method="joint", params=str(path)))
    speeds = (2.0, 20.0, 47.0, 110.0, 250.0)  # motor side, as the observer publishes them
    mon.on_status(CycleStatus(cycle_id=3, state=CycleState.RUNNING, speeds_total=len(speeds), joint_name="joint_1"), now=9.0)
    results = []
    for i, v in enumerate(speeds):
        tau = float(m.evaluate(p, speed=v * sf, load_torque=0.1 * tf, temperature=40.0, wear=30.0)) / tf
        results += mon.add(FrictionObservationData(
            stamp=10.0 + i, joint_name="joint_1", cycle_id=3, speed=v, tau_f=tau, tau_f_std=3e-4,
            tau_plus=0.1 + tau, tau_minus=0.1 - tau, load_torque=0.1, temperature=40.0, position=0.0,
            samples_plus=500, samples_minus=500))
    assert len(results) == 1 and results[0].result is not None
    r = results[0].result
    assert r.wear == pytest.approx(30.0, abs=1.0) and r.info["parameter_set"] == "arm6-base"
    assert mon.rejected_count == 0
    values = dict(results[0].values)
    assert values["wear_calibration"] == "paper"  # /diagnostics names the calibration
    # what the std is made of: no unknown temperature here, and no covariance in the shipped set
    assert float(values["wear_std_temperature"]) == 0 and "wear_std_model" not in values

    # the same set with a covariance of its Coulomb level (1 N·m std): its part is in /diagnostics too
    path.write_text(path.read_text() + "covariance:\n  names: [Fc0]\n  matrix: [[1.0]]\n")
    mon = WearMonitor(MonitorConfig(joint_name="joint_1", method="joint", params=str(path)))
    mon.on_status(CycleStatus(cycle_id=4, state=CycleState.RUNNING, speeds_total=len(speeds), joint_name="joint_1"), now=9.0)
    for i, v in enumerate(speeds):
        tau = float(m.evaluate(p, speed=v * sf, load_torque=0.1 * tf, temperature=40.0, wear=30.0)) / tf
        results = mon.add(FrictionObservationData(
            stamp=10.0 + i, joint_name="joint_1", cycle_id=4, speed=v, tau_f=tau, tau_f_std=3e-4,
            tau_plus=0.1 + tau, tau_minus=0.1 - tau, load_torque=0.1, temperature=40.0, position=0.0,
            samples_plus=500, samples_minus=500))
    values = dict(results[0].values)
    assert float(values["wear_std_model"]) > 0 and float(values["wear_std"]) > float(values["wear_std_model"])


def test_wear_parameters_calibrated_from_a_table_of_known_wear(tmp_path):
    """A history across a reducer replacement: cycles at known wear 0 and 40 fit Fsw, vsw, Fvw."""
    base = synth_observations(n_cycles=12, seed=11, temperature=(20.0, 50.0))
    worn = synth_observations(n_cycles=12, seed=12, temperature=(20.0, 50.0), model="paper+wear", wear=40.0)
    known = ObservationTable({n: np.concatenate([np.asarray(base.get(n, 0.0) * np.ones(len(base))),
                                                 np.asarray(worn[n])]) for n in worn.names}, source="known")
    cal = tmp_path / "known_wear.csv"
    write_csv(known, cal)
    r = commission(base, joint="j", wear_calibration=str(cal), wear_table=known, diagnose_baseline=False, cv_folds=0)
    truth = load_parameter_set_info("ref-2011r").values
    assert r.wear.label == "file:known_wear.csv" and "known wear" in r.wear.source
    assert r.wear["Fsw"] == pytest.approx(truth["Fsw"], rel=0.15)
    assert r.wear["vsw"] == pytest.approx(truth["vsw"], rel=0.25)


def test_the_bound_of_a_set_with_an_extra_term_is_the_bound_of_its_core_model(tmp_path):
    """A term of another input is a known offset: the Fisher information about w is the core model's."""
    from jointwear_ros.estimation import crb_multi_speed

    path = _ripple_set(tmp_path)
    speeds = [10.0, 40.0, 80.0]
    a = crb_multi_speed(None, path, speeds, 30.0)
    b = crb_multi_speed(None, "ref-2011r", speeds, 30.0)
    assert a == pytest.approx(b, rel=1e-12) and math.isfinite(a)


def test_a_fitted_parameter_past_its_physical_bound_is_named_for_holding_in_a_bounded_frame_only():
    """A fit that widened a data-scaled bound past the physical one (Fstm 147.7 where the loader takes [0, 10],
    seen live) would write a set the loader refuses: commissioning holds such a parameter at its bound."""
    from types import SimpleNamespace

    from jointwear_ros.commission.core import _outside_physical_bounds
    from jointwear_ros.model import SetUnits, paper_wear_model

    m = paper_wear_model()
    params = {n: SimpleNamespace(value=p.value) for n, p in m.make_params().items()}  # the defaults: in bounds
    params["Fstm"] = SimpleNamespace(value=147.667)
    fit = SimpleNamespace(free=list(m.param_names), params=params)
    assert _outside_physical_bounds(m, fit, SetUnits()) == {"Fstm": (147.667, 10.0)}
    joint_side = SetUnits(frame="joint", gear_ratio=100.0, torque_scale=50.0)
    assert joint_side.joint_side and _outside_physical_bounds(m, fit, joint_side) == {}  # not bounded there
    params["Fstm"] = SimpleNamespace(value=2.0)
    assert _outside_physical_bounds(m, fit, SetUnits()) == {}


def test_a_later_cycle_at_the_planned_speeds_and_loads_fits_the_commissioned_sets_valid_ranges():
    """A commissioned set's valid speeds reach the speed-level match (5 %) beyond the measured ones and its loads a
    tenth of their span: a later cycle's measured speed and load scatter about the planned ones (the live Panda's
    test cycle swept 80.0416 rad/s against its baseline's fastest 80.0379, and the estimator dropped it). Beyond
    that margin the monitor still refuses, naming the range."""
    from jointwear_ros.monitor.validation import screen_observation
    from jointwear_ros.observer import FrictionObservationData

    t = synth_observations(n_cycles=6, seed=3)
    r = commission(t, joint="j", diagnose_baseline=False)
    v = np.abs(np.asarray(t.speed, dtype=float))
    ld = np.abs(np.asarray(t["load_torque"], dtype=float))
    span = float(ld.max() - ld.min())
    assert r.valid["speed"] == (pytest.approx(0.95 * v.min()), pytest.approx(1.05 * v.max()))
    assert r.valid["load_torque"] == (pytest.approx(max(0.0, ld.min() - 0.1 * span)), pytest.approx(ld.max() + 0.1 * span))
    valid = r.parameter_set("j").observation_valid()

    def obs(speed, load):
        return FrictionObservationData(stamp=1.0, joint_name="j", cycle_id=1, speed=speed, tau_f=0.09, tau_f_std=3e-4,
                                       tau_plus=0.19, tau_minus=0.01, load_torque=load, temperature=float("nan"),
                                       position=0.0, samples_plus=500, samples_minus=500)

    mid = float(np.median(ld))
    for speed in (float(v.max()) * 1.0001, float(v.min()) * 0.999):
        kept, why = screen_observation(obs(speed, mid), valid)
        assert kept is not None and kept.speed == speed and why == ""
    kept, why = screen_observation(obs(float(v.max()) * 1.2, mid), valid)
    assert kept is None and "outside the parameter set's valid range" in why
    kept, why = screen_observation(obs(float(np.median(v)), float(ld.max()) + 0.5 * span), valid)
    assert kept is None and "|load_torque|" in why
