"""Workbench fits in any units: start values, bounds and grids from the data; a parameter on a bound is named.

The real arm: the published friction model of the Franka Emika Panda (seven harmonic-drive joints, joint
side, N·m; Gaz et al., IEEE RA-L 2019, :mod:`jointwear_ros.data.published`), swept at 0.001-0.5 rad/s as a
plateau test measures it.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jointwear_ros.cli import main
from jointwear_ros.data import panda_friction_sweep, synth_observations
from jointwear_ros.io.tables import write_csv
from jointwear_ros.types import ObservationTable
from jointwear_ros.workbench import DataScales, diagnose, fit_model, parse_spec
from jointwear_ros.workbench.baseline import plain_standard_fit


def panda_sweep(joint: int) -> ObservationTable:
    """Joint ``joint`` (0-based) of the Panda: the friction sweep a plateau test measures, N·m, 0.001-0.5 rad/s."""
    return panda_friction_sweep(joint, noise=0.002, seed=0)


def plain_least_squares_rmse(table: ObservationTable, nonnegative: bool = False) -> float:
    """A plain scipy fit of Fc + Fs exp(-|v/vs|^1.3) + Fv v (no bounds but vs > 0; ``nonnegative``: Fc, Fs, Fv >= 0),
    best of a start grid."""
    return plain_standard_fit(table.speed, table.tau_f, vs_range=(1e-3, 1.0), nonnegative=nonnegative).rmse


def joint_side(table: ObservationTable, gear: float = 120.0, scale: float = 150.0) -> ObservationTable:
    """The same observations recorded joint side: speed / gear, torques x scale (N·m)."""
    cols = {n: table[n].copy() for n in table.names}
    cols["speed"] = cols["speed"] / gear
    for c in ("tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque"):
        if c in cols:
            cols[c] = cols[c] * scale
    return ObservationTable(cols, source=f"{table.source} (joint side)")


def run_main(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    try:
        rc = main(list(args))
    except SystemExit as exc:
        rc = int(exc.code or 0)
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.mark.parametrize("joint", range(7))
def test_standard_fit_of_a_panda_joint_in_newton_metres_reaches_a_plain_least_squares_fit(joint):
    table = panda_sweep(joint)
    # unconstrained, as the plain fit (a Panda's friction rises from 0 at the lowest speeds: a negative Stribeck)
    free = fit_model(parse_spec("standard"), table, cv_folds=0, physical=False)
    plain = plain_least_squares_rmse(table)
    assert free.rmse <= plain * 1.001, (free.rmse, plain)
    # by default the physical signs hold (Fs, Fv >= 0), and it reaches the plain fit with the same signs
    fit = fit_model(parse_spec("standard"), table, cv_folds=0)
    assert fit.params["Fs"].value >= 0 and fit.params["Fv"].value >= 0
    assert fit.rmse <= plain_least_squares_rmse(table, nonnegative=True) * 1.01  # an optimum on the bounds
    assert fit.success and not fit.at_bound, fit.message
    # the terms' own numbers (made for the paper's motor side, normalized torque) stop short of it
    unscaled = fit_model(parse_spec("standard"), table, cv_folds=0, rescale=False, physical=False)
    assert unscaled.rmse > free.rmse * 1.05


def test_model_fit_json_on_a_panda_sweep_keeps_its_keys_and_names_no_bound(tmp_path, capsys):
    table = panda_sweep(3)
    path = write_csv(table, tmp_path / "panda_j4.csv")
    rc, out, err = run_main(capsys, "model", "fit", str(path), "--model", "standard", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    for key in ("rmse", "cv_rmse", "aic", "bic", "params", "parameters", "at_bound", "converged"):
        assert key in doc, key
    assert set(doc["parameters"]) == {"Fc0", "Fs", "vs", "Fv"}
    assert doc["at_bound"] == [] and doc["converged"] is True
    assert all(p["at_bound"] is None for p in doc["parameters"].values())
    assert doc["rmse"] <= plain_least_squares_rmse(table, nonnegative=True) * 1.01
    assert doc["parameters"]["Fs"]["value"] >= 0 and doc["parameters"]["Fv"]["value"] >= 0
    assert doc["scales"]["speed_factor"] == 0.01 and doc["scales"]["torque_factor"] == 1.0


def test_a_parameter_ending_on_its_bound_is_named_with_the_bound_and_the_fit_is_not_converged(tmp_path, capsys):
    # friction below zero at low speed: the Coulomb level Fc0 >= 0 must end on its bound
    v = np.linspace(1.0, 200.0, 40)
    y = -0.05 + 1e-3 * v + np.random.default_rng(1).normal(0.0, 1e-4, v.size)
    table = ObservationTable({"speed": v, "tau_f": y, "cycle": np.arange(v.size, dtype=float)}, source="neg")
    fit = fit_model(parse_spec("coulomb + viscous"), table, cv_folds=0)
    assert [(h.name, h.side, h.bound) for h in fit.at_bound] == [("Fc0", "lower", 0.0)]
    assert not fit.success and "Fc0" in fit.message and "bound" in fit.message
    path = write_csv(table, tmp_path / "neg.csv")
    rc, out, err = run_main(capsys, "model", "fit", str(path), "--model", "coulomb + viscous", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["converged"] is False and doc["success"] is False
    assert doc["at_bound"] == [{"name": "Fc0", "value": doc["parameters"]["Fc0"]["value"], "bound": 0.0,
                                "side": "lower"}]
    assert doc["parameters"]["Fc0"]["at_bound"] == "lower" and doc["parameters"]["Fv"]["at_bound"] is None
    rc, out, err = run_main(capsys, "model", "fit", str(path), "--model", "coulomb + viscous")
    assert rc == 0, err
    assert "# on a bound (not converged): Fc0 = " in out and "lower bound 0" in out


def test_a_scaled_bound_the_fit_ends_on_is_widened_until_the_optimum_is_inside():
    # a Stribeck speed far above the paper-scaled upper bound (500 rad/s): widened tenfold, then free
    v = np.geomspace(1.0, 250.0, 30)
    y = 0.05 + 0.04 * np.exp(-np.abs(v / 2000.0) ** 1.3) + np.random.default_rng(2).normal(0, 1e-5, v.size)
    table = ObservationTable({"speed": v, "tau_f": y}, source="slow stribeck")
    fit = fit_model(parse_spec("coulomb + stribeck"), table, cv_folds=0)
    assert fit.params["vs"].max > 500.0
    assert fit.rmse < 5e-5


@pytest.fixture(scope="module")
def clean_reference():
    return synth_observations(n_cycles=40, seed=0)


def test_a_clean_joint_recorded_joint_side_in_newton_metres_is_nothing_missing(clean_reference, tmp_path, capsys):
    path = write_csv(joint_side(clean_reference), tmp_path / "joint_side.csv")
    rc, out, err = run_main(capsys, "model", "diagnose", str(path), "--model", "paper", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["verdict"] == "nothing_missing", doc["summary"]
    assert doc["suggestion"] is None
    assert doc["noise_floor"]["consistent"] is True and doc["noise_floor"]["value"] == pytest.approx(0.225)
    assert doc["converged"] is True and doc["at_bound"] == []


def test_joint_side_paper_fit_recovers_the_rescaled_parameters(clean_reference):
    fit = fit_model(parse_spec("paper"), joint_side(clean_reference), cv_folds=0)
    ref = fit_model(parse_spec("paper"), clean_reference, cv_folds=0)
    assert fit.success and not fit.at_bound
    assert fit.rmse == pytest.approx(ref.rmse * 150.0, rel=1e-3)
    assert fit.params["Fc0"].value == pytest.approx(ref.params["Fc0"].value * 150.0, rel=1e-2)
    assert fit.params["vstm"].value == pytest.approx(ref.params["vstm"].value / 120.0, rel=1e-2)
    assert fit.params["Fv0"].value == pytest.approx(ref.params["Fv0"].value * 150.0 * 120.0, rel=5e-2)


def test_data_scales_are_decades_of_the_papers_and_keep_paper_units_unchanged(clean_reference):
    assert DataScales.from_table(clean_reference).identity
    s = DataScales.from_table(joint_side(clean_reference))
    assert (s.speed, s.torque) == (0.01, 100.0)
    assert s.factor("s/rad") == 1e4 and s.factor("degC") == 1.0 and s.factor("-", "Fctm") == 1.0


@pytest.fixture(scope="module")
def small_reference(clean_reference):
    """The first 12 cycles of the clean reference, their fit and diagnosis: what every scaled copy is compared with."""
    small = clean_reference.select(np.asarray(clean_reference["cycle"]) < 12)
    base = fit_model(parse_spec("paper"), small, cv_folds=0)
    return small, base, diagnose(small, base, n_bootstrap=0)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(exp=st.integers(min_value=-3, max_value=4), mant=st.floats(min_value=1.0, max_value=9.9))
def test_scaling_the_torque_by_k_scales_the_fit_by_k_with_the_same_verdict(small_reference, exp, mant):
    k = mant * 10.0**exp
    small, base, d0 = small_reference
    cols = {n: small[n].copy() for n in small.names}
    for c in ("tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque"):
        cols[c] = cols[c] * k
    scaled = ObservationTable(cols, source=f"x{k:g}")
    fit = fit_model(parse_spec("paper"), scaled, cv_folds=0)
    assert fit.rmse == pytest.approx(base.rmse * k, rel=2e-2)
    assert fit.params["Fc0"].value == pytest.approx(base.params["Fc0"].value * k, rel=2e-2)
    assert fit.params["Fctm"].value == pytest.approx(base.params["Fctm"].value, rel=2e-2)
    assert fit.success == base.success and not fit.at_bound
    d1 = diagnose(scaled, fit, n_bootstrap=0)
    assert d1.verdict == d0.verdict == "nothing_missing"
