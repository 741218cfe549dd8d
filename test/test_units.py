"""Units travel with the data: declared by tables, converted in one core module, a unit slip refused in one line
naming the flag that fixes it, parameter sets read strictly. No ROS graph."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.cli import main
from jointwear_ros.errors import InputDataError, ParameterSetError
from jointwear_ros.io.tables import read_csv, write_csv
from jointwear_ros.model import load_parameter_set_info
from jointwear_ros.types import ObservationTable
from jointwear_ros.units import (
    SUITE_UNITS,
    SetUnits,
    TableUnits,
    UnitError,
    check_for_set,
    convert_temperature,
    to_set_frame,
    to_suite,
)

SET = "arm6-wrist"  # a shipped joint-side set (gear 80, 4 N·m per normalized unit): no commissioning needed
TRUE_WEAR = 35.0


# -- the core -------------------------------------------------------------------------------------
@given(frame=st.sampled_from(["motor_normalized", "joint"]),
       gear=st.one_of(st.none(), st.floats(0.5, 500.0)), scale=st.one_of(st.none(), st.floats(0.01, 1000.0)),
       speed=st.sampled_from(["rad/s", "rpm", "deg/s"]), temp=st.sampled_from(["degC", "K", "degF"]),
       torque=st.sampled_from(["N·m", "mN·m"]))
@settings(max_examples=60, deadline=None)
def test_a_units_line_reads_back_as_written(frame, gear, scale, speed, temp, torque):
    u = TableUnits(frame, gear, scale, speed_unit=speed, temperature_unit=temp,
                   torque_unit=torque if frame == "joint" else "normalized", declared=True)
    back = TableUnits.parse_header(u.header())
    assert back is not None and back.frame == u.frame and back.speed_unit == speed and back.temperature_unit == temp
    for key in ("gear_ratio", "torque_scale"):
        a, b = getattr(u, key), getattr(back, key)
        assert (a is None and b is None) or math.isclose(a, b, rel_tol=1e-5)


@given(gear=st.floats(1.0, 300.0), scale=st.floats(0.05, 500.0),
       speed=st.lists(st.floats(0.01, 300.0), min_size=1, max_size=6))
@settings(max_examples=60, deadline=None)
def test_suite_to_a_joint_frame_and_back_is_the_identity(gear, scale, speed):
    n = len(speed)
    t = ObservationTable({"speed": np.array(speed), "tau_f": np.full(n, 0.07), "load_torque": np.full(n, 0.2),
                          "temperature": np.full(n, 40.0)}, source="t", units=SUITE_UNITS)
    su = SetUnits("joint", gear, scale)
    joint = to_set_frame(t, su)
    assert joint.units.frame == "joint" and np.allclose(joint["tau_f"], 0.07 * scale)
    back = to_suite(joint, joint.units, su)
    for col in ("speed", "tau_f", "load_torque", "temperature"):
        assert np.allclose(back[col], t[col])


@given(c=st.floats(-40.0, 120.0))
def test_temperatures_in_kelvin_and_fahrenheit_convert_to_celsius(c):
    assert math.isclose(float(convert_temperature(np.array([c + 273.15]), "K")[0]), c, abs_tol=1e-9)
    assert math.isclose(float(convert_temperature(np.array([c * 9 / 5 + 32]), "degF")[0]), c, abs_tol=1e-9)


@pytest.mark.parametrize("line", ["# units: frame=joint gear_ratio=x", "# units: frame=wrist",
                                  "# units: speed=furlong/s", "# units: colour=blue", "# units: frame"])
def test_a_malformed_units_line_is_refused_naming_it(tmp_path, line):
    p = tmp_path / "t.csv"
    p.write_text(f"{line}\nspeed,tau_f\n10,0.07\n", encoding="utf-8")
    with pytest.raises(InputDataError, match="units"):
        read_csv(p)


def test_a_joint_side_table_without_a_gear_ratio_is_refused_naming_the_flags():
    t = ObservationTable({"speed": np.array([0.1]), "tau_f": np.array([0.3])}, source="t")
    with pytest.raises(UnitError, match="--gear-ratio G --torque-scale S"):
        to_suite(t, TableUnits("joint"), SetUnits())


def test_a_table_in_kelvin_against_a_set_names_kelvin():
    pset = load_parameter_set_info("ref-2011r")
    t = ObservationTable({"speed": np.array([10.0, 47.0]), "tau_f": np.array([0.08, 0.07]),
                          "temperature": np.array([300.0, 310.0])}, source="t", units=SUITE_UNITS)
    with pytest.raises(UnitError, match=r"in kelvin\? add --temperature-unit K"):
        check_for_set(t, pset, SUITE_UNITS)


# -- the commands ---------------------------------------------------------------------------------
def _rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if not ln.startswith("#")]
    r = list(csv.DictReader(lines))
    return list(r[0]), r


def _rewrite(src: Path, dst: Path, change) -> Path:
    """``src`` without its units line (a hand-made table), each row changed by ``change``."""
    header, rows = _rows(src)
    with dst.open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, header)
        w.writeheader()
        for r in rows:
            change(r)
            w.writerow(r)
    return dst


def _scale(cols, f):
    def change(r):
        for c in cols:
            r[c] = repr(float(r[c]) * f)
    return change


def _shift_temp(f):
    def change(r):
        r["temperature"] = repr(f(float(r["temperature"])))
    return change


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    d = tmp_path_factory.mktemp("units")
    motor, joint = d / "motor.csv", d / "joint.csv"
    common = ["--params", SET, "--wear", str(TRUE_WEAR), "--cycles", "2", "--position", "0.3",
              "--temperature", "25:45", "--seed", "5"]
    assert main(["data", "synth", str(motor), *common]) == 0
    assert main(["data", "synth", str(joint), *common, "--joint-side"]) == 0
    torques = ["tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque"]
    out = {"motor": motor, "joint": joint}
    out["plain_motor"] = _rewrite(motor, d / "plain_motor.csv", lambda r: None)
    out["plain_joint"] = _rewrite(joint, d / "plain_joint.csv", lambda r: None)
    out["kelvin"] = _rewrite(motor, d / "kelvin.csv", _shift_temp(lambda t: t + 273.15))
    out["fahrenheit"] = _rewrite(motor, d / "fahrenheit.csv", _shift_temp(lambda t: t * 9 / 5 + 32))
    out["hot"] = _rewrite(motor, d / "hot.csv", _shift_temp(lambda t: t + 30.0))
    out["rpm"] = _rewrite(motor, d / "rpm.csv", _scale(["speed"], 60 / (2 * math.pi)))
    out["degs"] = _rewrite(motor, d / "degs.csv", _scale(["speed"], 180 / math.pi))
    out["mnm"] = _rewrite(joint, d / "mnm.csv", _scale(torques, 1000.0))
    return out


def _estimate(capsys, path, *flags):
    rc = main(["estimate", str(path), "--params", SET, "--json", *flags])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _assert_right(out):
    for e in json.loads(out)["estimates"]:
        assert abs(e["estimate"] - TRUE_WEAR) <= 3 * e["std"] + 1e-9, e


@pytest.mark.parametrize("table, flags, hint", [
    ("kelvin", [], "--temperature-unit K"),
    ("fahrenheit", [], "--temperature-unit degF"),
    ("rpm", [], "--speed-unit rpm"),
    ("degs", [], "--speed-unit deg/s"),
    ("plain_joint", [], "add --joint-side"),
    ("plain_motor", ["--joint-side"], "drop --joint-side"),
    ("mnm", ["--joint-side"], "--torque-unit mN·m"),
    ("hot", [], "hotter than in the data the set was made from"),
    ("motor", ["--joint-side"], "the table declares its units"),
])
def test_estimate_refuses_a_unit_slip_in_one_line_naming_the_fix(tables, capsys, table, flags, hint):
    rc, out, err = _estimate(capsys, tables[table], *flags)
    assert rc == 2 and out == "" and err.count("\n") == 1 and hint in err, err


@pytest.mark.parametrize("table, flags", [
    ("motor", []), ("joint", []), ("plain_joint", ["--joint-side"]), ("kelvin", ["--temperature-unit", "K"]),
    ("fahrenheit", ["--temperature-unit", "degF"]), ("rpm", ["--speed-unit", "rpm"]),
    ("degs", ["--speed-unit", "deg/s"]), ("mnm", ["--joint-side", "--torque-unit", "mN·m"]),
])
def test_estimate_with_declared_or_flagged_units_is_right(tables, capsys, table, flags):
    rc, out, err = _estimate(capsys, tables[table], *flags)
    assert rc == 0, err
    _assert_right(out)


def test_history_reestimate_refuses_a_joint_hotter_than_the_set_and_stores_nothing(tables, tmp_path, capsys):
    db = tmp_path / "h.db"
    rc = main(["history", "import", str(tables["hot"]), "--db", str(db), "--reestimate", "--params", SET,
               "--time-origin", "2026-01-01T00:00:00Z"])
    err = capsys.readouterr().err
    assert rc == 2 and "hotter" in err and err.count("\n") == 1 and not db.exists()


@pytest.fixture(scope="module")
def baselines(tmp_path_factory):
    d = tmp_path_factory.mktemp("baseline")
    joint = d / "joint.csv"
    assert main(["data", "synth", str(joint), "--params", SET, "--cycles", "6", "--temperature", "18:52",
                 "--seed", "1", "--joint-side"]) == 0
    torques = ["tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque"]
    return {"plain_joint": _rewrite(joint, d / "plain_joint.csv", lambda r: None),
            "kelvin": _rewrite(joint, d / "kelvin.csv", _shift_temp(lambda t: t + 273.15)),
            "mnm": _rewrite(joint, d / "mnm.csv", _scale(torques, 1000.0))}


@pytest.mark.parametrize("table, flags, hint", [
    ("plain_joint", [], "--gear-ratio G --torque-scale S"),
    ("kelvin", ["--gear-ratio", "80", "--torque-scale", "4"], "--temperature-unit K"),
    ("mnm", ["--gear-ratio", "80", "--torque-scale", "4"], "--torque-unit mN·m"),
])
def test_commission_refuses_a_unit_slip_and_writes_nothing(baselines, tmp_path, capsys, table, flags, hint):
    out = tmp_path / "set.yaml"
    rc = main(["commission", str(baselines[table]), "--joint", "joint_5", "--out", str(out), "--no-diagnose",
               *flags])
    err = capsys.readouterr().err
    assert rc == 2 and hint in err and err.count("\n") == 1 and not out.exists(), err


def test_model_fit_refuses_kelvin_without_a_set_and_converts_with_the_flag(tables, capsys):
    assert main(["model", "fit", str(tables["kelvin"]), "--model", "standard", "--folds", "0"]) == 2
    assert "--temperature-unit K" in capsys.readouterr().err
    assert main(["model", "fit", str(tables["kelvin"]), "--model", "standard", "--folds", "0",
                 "--temperature-unit", "K"]) == 0


# -- strict parameter sets ------------------------------------------------------------------------
def _set_file(tmp_path: Path, change) -> Path:
    doc = yaml.safe_load(Path(load_parameter_set_info("cobot-j3").path).read_text(encoding="utf-8"))
    change(doc)
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(doc), encoding="utf-8")
    return p


@pytest.mark.parametrize("change, match", [
    (lambda d: d["parameters"].pop("Fsw"), "Fsw of model .* missing"),
    (lambda d: d["parameters"].update(Fxx=0.1), "Fxx are not parameters of model"),
    (lambda d: d.update(sensitivity=3), "unknown key"),
    (lambda d: d.update(format=2), "newer jointwear"),
    (lambda d: d["units"].update(temperature="K"), "a set is in degC"),
])
def test_a_malformed_set_is_refused_never_defaulted(tmp_path, change, match):
    with pytest.raises(ParameterSetError, match=match):
        load_parameter_set_info(str(_set_file(tmp_path, change)))


def test_a_set_missing_a_parameter_gives_no_wear_number(tmp_path, tables, capsys):
    p = _set_file(tmp_path, lambda d: d["parameters"].pop("Fsw"))
    assert main(["estimate", str(tables["motor"]), "--params", str(p)]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and "Fsw" in cap.err


def test_tables_the_suite_writes_declare_their_units(tables, tmp_path):
    assert read_csv(tables["joint"]).units.frame == "joint"
    assert read_csv(tables["motor"]).units == SUITE_UNITS
    t = read_csv(tables["joint"])
    write_csv(t, tmp_path / "again.csv")
    assert read_csv(tmp_path / "again.csv").units.gear_ratio == 80.0


def test_commission_skips_a_bag_it_cannot_read_and_names_it(tmp_path, capsys):
    from jointwear_ros.data import synth_observations
    from jointwear_ros.io.tables import write_bag

    table = synth_observations(n_cycles=6, params="cobot-j3", temperature=(18.0, 52.0), seed=3)
    good = write_bag(table, tmp_path / "good_bag", joint_name="joint_3")
    foreign = tmp_path / "failed_cycle_bag"
    foreign.mkdir()  # what a cycle that failed before its first observation leaves: nothing to read
    out = tmp_path / "j3.yaml"
    assert main(["commission", str(good), str(foreign), "--joint", "joint_3", "--out", str(out), "--no-diagnose",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert out.exists() and len(doc["skipped_inputs"]) == 1 and "failed_cycle_bag" in doc["skipped_inputs"][0]
    assert main(["commission", str(foreign), "--joint", "joint_3", "--out", str(tmp_path / "x.yaml")]) == 2
    assert "no input could be read" in capsys.readouterr().err and not (tmp_path / "x.yaml").exists()
