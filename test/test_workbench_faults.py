"""The workbench on ordinary tables (issue 20): few-valued columns, small tables, outliers."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jointwear_ros.cli import main as cli_main
from jointwear_ros.data.synth import synth_observations
from jointwear_ros.io.tables import write_csv
from jointwear_ros.types import ObservationTable
from jointwear_ros.workbench.diagnose import VERDICTS, diagnose, find_outliers
from jointwear_ros.workbench.render import diagnosis_summary


def _with(t, **cols):
    return ObservationTable(columns={**t.columns, **cols}, source=t.source)


def run(args, capsys):
    rc = cli_main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


def test_small_tables_and_few_valued_columns_give_a_verdict(tmp_path, capsys):
    """8 cycles with an on/off flag, an operator id (3 values) and a constant column (was: internal error
    "Length t is not enough for k=3"), and the suite's own ``data synth --cycles 11``."""
    t = synth_observations(n_cycles=8, seed=2)
    rng = np.random.default_rng(2)
    cyc = np.asarray(t["cycle"])
    flag = {c: float(rng.integers(0, 2)) for c in np.unique(cyc)}
    op = {c: float(rng.integers(1, 4)) for c in np.unique(cyc)}
    t = _with(t, door_open=np.array([flag[c] for c in cyc]), operator=np.array([op[c] for c in cyc]),
              const=np.full(len(t), 7.0))
    p = tmp_path / "few.csv"
    write_csv(t, p)
    rc, out, err = run(["model", "diagnose", p, "--model", "paper", "--json"], capsys)
    assert rc == 0, err
    assert json.loads(out)["verdict"] in VERDICTS
    s11 = tmp_path / "s11.csv"
    assert run(["data", "synth", "--cycles", "11", s11], capsys)[0] == 0
    rc, out, err = run(["model", "diagnose", s11, "--model", "standard", "--json"], capsys)
    assert rc == 0 and json.loads(out)["verdict"] in VERDICTS, err


@pytest.fixture(scope="module")
def clean_diagnosis():
    """The clean table both outlier cases are planted in, and its diagnosis (the same for both)."""
    t = synth_observations(n_cycles=40, seed=3)
    return t, diagnose(t, "paper", n_bootstrap=0)


@pytest.mark.parametrize("rows", [(37, 151), (150, 151)])
@pytest.mark.slow
def test_two_outliers_in_a_clean_table_are_named_and_never_found(rows, clean_diagnosis):
    t, clean = clean_diagnosis
    tau = np.array(t["tau_f"], dtype=float)
    tau[list(rows)] += 0.01  # about 7 noise std
    bad = _with(t, tau_f=tau)
    d = diagnose(bad, "paper", n_bootstrap=0)
    assert d.verdict != "found", diagnosis_summary(d)
    assert sorted(o.row for o in d.outliers) == sorted(rows)
    assert "outlying observation(s)" in diagnosis_summary(d) and f"row {rows[0]}" in diagnosis_summary(d)
    assert sorted(x["row"] for x in d.to_dict()["outliers"]) == sorted(rows)
    assert clean.outliers == [] and clean.verdict == "nothing_missing"


def test_outliers_are_not_reported_for_structure_or_clean_noise():
    t = synth_observations(n_cycles=20, seed=5)
    rng = np.random.default_rng(5)
    r = rng.normal(0.0, 0.0015, len(t))
    assert find_outliers(t, r) == []
    r2 = r + 0.01 * (np.asarray(t["temperature"]) > np.median(t["temperature"]))  # half the rows: structure
    assert find_outliers(t, r2) == []
