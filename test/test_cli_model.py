"""``jointwear model curve``: the README's command, table, plot and argument errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from jointwear_ros.cli import main


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "jointwear_ros", *args], capture_output=True, text=True, timeout=60)


def test_curve_json_prints_model_md_values_and_components():
    r = run_cli(
        "model", "curve", "--params", "ref-2011r", "--load", "0.1", "--temperature", "40",
        "--wear", "35", "--speeds", "0,10,25,47,80,150,280", "--json",
    )
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["speed"] == [0, 10, 25, 47, 80, 150, 280]
    np.testing.assert_allclose(out["tau_f"], [0.11085, 0.10447, 0.09628, 0.09072, 0.09092, 0.10839, 0.15694], atol=1e-5)
    assert set(out["components"]) == {
        "coulomb", "load_coulomb", "load_stribeck", "temp_stribeck", "temp_viscous", "wear_stribeck", "wear_viscous",
    }
    np.testing.assert_allclose(np.sum(list(out["components"].values()), axis=0), out["tau_f"], rtol=1e-12)


def test_curve_table_and_plot(tmp_path, capsys):
    png = tmp_path / "curve.png"
    assert main(["model", "curve", "--wear", "35", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "wear_stribeck" in out and "0.09072" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--params", "nope"], "unknown parameter set 'nope'"),
        (["--wear", "abc"], "--wear: 'abc' is not a number"),
        (["--speeds", "0,ten"], "--speeds: 'ten' is not a number"),
        (["--temperature", "90"], "temperature = 90 is outside the valid range"),
        (["--wear", "150"], "wear = 150 is outside"),
        (["--speeds", "-5"], "negative"),
        (["--load", "nan"], "not finite"),
        (["--bogus"], "unrecognized arguments"),
    ],
)
def test_bad_arguments_give_one_line_error_and_exit_code_2(args, message):
    r = run_cli("model", "curve", *args)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert message in lines[0]
    assert r.stdout == ""
