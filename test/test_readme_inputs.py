"""Wrong inputs the README's flows met are refused with one line, exit 2, nothing written (issue 24, point 6)."""

from __future__ import annotations

import csv
import time
from pathlib import Path

import pytest

from jointwear_ros.cli import main as cli_main
from jointwear_ros.history import EstimateRecord, HistoryStore


@pytest.fixture
def db(tmp_path):
    path = tmp_path / "h.db"
    with HistoryStore(f"sqlite:///{path}") as store:
        store.add_estimates([EstimateRecord(robot="cell_7", joint=j, cycle_id=1, time=time.time() - 86400,
                                            wear=20.0, wear_std=1.0) for j in ("joint_1", "joint_3")])
    return path


@pytest.mark.parametrize(("args", "says"), [
    (["--robot", "cell_7", "--joint", "jiont_3", "--kind", "regrease"], "its joints: joint_1, joint_3"),
    (["--robot", "cell7", "--joint", "joint_3", "--kind", "regrease"], "robots there: cell_7"),
    (["--robot", "cell_7", "--joint", "joint_3", "--kind", "regreese"], "choose one of regrease"),
    (["--robot", "cell_7", "--joint", "joint_3", "--kind", "regrease", "--time", "2099-01-01T00:00"], "in the future"),
])
def test_maintenance_refuses_a_misspelt_robot_joint_or_kind_and_a_future_time(db, args, says, capsys):
    assert cli_main(["history", "maintenance", "--db", str(db), *args]) == 2
    err = capsys.readouterr().err
    assert says in err and len(err.strip().splitlines()) == 1, err
    with HistoryStore(f"sqlite:///{db}") as store:
        assert store.maintenance() == []
    assert cli_main(["history", "maintenance", "--db", str(db), "--robot", "cell_7", "--joint", "joint_3",
                     "--kind", "regrease"]) == 0


def test_fit_refuses_temperatures_outside_the_sets_range(tmp_path, capsys):
    assert cli_main(["data", "synth", str(tmp_path / "obs.csv"), "--cycles", "12"]) == 0
    rows = list(csv.DictReader(line for line in (tmp_path / "obs.csv").open() if not line.startswith("#")))
    for r in rows:
        r["temperature"] = str(float(r["temperature"]) + 273.15)
    with (tmp_path / "kelvin.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    capsys.readouterr()
    assert cli_main(["model", "fit", str(tmp_path / "kelvin.csv"), "--model", "paper", "--params", "ref-2011r"]) == 2
    err = capsys.readouterr().err
    assert "outside the valid range [20, 60]" in err and "kelvin" in err and len(err.strip().splitlines()) == 1
    # the same table in degC fits
    assert cli_main(["model", "fit", str(tmp_path / "obs.csv"), "--model", "paper", "--params", "ref-2011r"]) == 0


def test_a_maintenance_event_needs_an_existing_history(tmp_path, capsys):
    assert cli_main(["history", "maintenance", "--db", str(tmp_path / "none.db"), "--robot", "r", "--joint", "j",
                     "--kind", "regrease"]) == 2
    assert "no such history file" in capsys.readouterr().err and not Path(tmp_path / "none.db").exists()


def test_a_range_or_list_starting_with_a_minus_sign_is_a_value(tmp_path, capsys):
    """docs/workbench.md's `data synth ... --position -2.5:2.5` ran into argparse's 'expected one argument'."""
    assert cli_main(["data", "synth", str(tmp_path / "x.csv"), "--cycles", "2", "--position", "-2.5:2.5"]) == 0
    assert cli_main(["data", "synth", str(tmp_path / "y.csv"), "--cycles", "2", "--position", "-1e-1:2"]) == 0
    capsys.readouterr()
    with pytest.raises(SystemExit):  # an option that does not exist is still one
        cli_main(["data", "synth", str(tmp_path / "z.csv"), "--no-such-flag"])
