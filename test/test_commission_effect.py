"""Commissioning carries a found effect into the set, and judges a clean baseline against the right noise floor.

A ripple hidden in the simulated joint is found on the baseline, validated on held-out cycles and carried
into the model by default (before/after CV RMSE in the result, the verdict in the set); a model given
explicitly is kept. A baseline whose ``tau_f_std`` is the within-sweep error only (a bag's: 9x below the
scatter from sweep to sweep) is judged against the scatter between sweeps: nothing is missing.
"""

from __future__ import annotations

import numpy as np
import pytest

from jointwear_ros.commission import commission
from jointwear_ros.data import synth_observations
from jointwear_ros.estimation import make_estimator
from jointwear_ros.types import ObservationTable
from jointwear_ros.workbench.compare import METHOD_STD, METHOD_SWEEP


def _cycles(table: ObservationTable) -> list[ObservationTable]:
    cyc = np.asarray(table["cycle"])
    return [ObservationTable({n: np.asarray(table[n])[cyc == c] for n in table.names}) for c in np.unique(cyc)]


@pytest.fixture(scope="module")
def ripple_baseline() -> ObservationTable:
    # the documented reproduction (docs/commissioning.md): cobot-j3 with a hidden position ripple
    return synth_observations(n_cycles=16, seed=21, params="cobot-j3", temperature=(18, 52), effects=["ripple"])


def test_a_found_effect_that_validates_on_held_out_cycles_is_carried_into_the_set(ripple_baseline):
    r = commission(ripple_baseline, joint="joint_3", wear_calibration="paper")
    assert r.verdict == "found" and r.suggestion and r.suggestion.startswith("ripple(position")
    assert r.carried == r.suggestion and r.suggestion in r.spec and r.suggestion in r.set_spec
    assert r.cv_rmse_after < 0.6 * r.cv_rmse_before and r.cv_rmse == pytest.approx(r.cv_rmse_after)
    assert r.verdict_after == "nothing_missing" and r.validation == "held-out cycles"
    assert any("carried into the model" in w for w in r.warnings)
    doc = r.to_dict()
    assert doc["carried"] == r.suggestion and doc["cv_rmse_before"] > doc["cv_rmse_after"]
    pset = r.parameter_set("r0")
    assert "verdict found" in pset.description and "carried" in pset.description
    assert pset.provenance["verdict"] == "found" and pset.provenance["carried"] == r.suggestion
    # the set estimates a joint with the same ripple at true wear 30 correctly (doc: 29-31)
    test = synth_observations(n_cycles=3, seed=71, params="cobot-j3", model="paper+wear", wear=30.0,
                              temperature=(25, 50), position=(0.3, 0.3), effects=["ripple"])
    est = make_estimator("joint", params=pset)
    wears = [est.estimate(c).wear for c in _cycles(test)]
    assert all(29.0 <= w <= 31.0 for w in wears), wears


def test_an_explicit_model_is_kept_and_the_finding_only_reported(ripple_baseline):
    r = commission(ripple_baseline, joint="joint_3", wear_calibration="paper", model_explicit=True)
    assert r.verdict == "found" and r.carried is None and "ripple" not in r.spec
    assert any("given explicitly" in w and "--model" in w for w in r.warnings)
    pset = r.parameter_set("r0")
    assert "NOT in the model" in pset.description and pset.provenance["verdict"] == "found"
    off = commission(ripple_baseline, joint="joint_3", wear_calibration="paper", carry_found=False,
                     diagnose_baseline=False)
    assert off.carried is None and off.verdict == "not run"


def test_a_clean_baseline_with_a_within_sweep_tau_f_std_is_nothing_missing():
    # as a bag's observations: tau_f_std is the batch-means error within one sweep (1.7e-4), the scatter
    # from sweep to sweep is the simulator's noise_std (1.5e-3)
    t = synth_observations(n_cycles=12, seed=2, params="cobot-j3", temperature=(18, 52))
    cols = {n: np.asarray(t[n], dtype=float) for n in t.names}
    cols["tau_f_std"] = np.full(len(t), 1.7e-4)
    r = commission(ObservationTable(cols, source="bag-like"), joint="joint_3", wear_calibration="paper")
    assert r.verdict == "nothing_missing", r.summary
    assert r.noise_method == METHOD_SWEEP and r.noise_consistent
    assert 0.0011 < r.noise_floor < 0.002 and 0.0011 < r.noise_std < 0.002
    # the same data with an honest tau_f_std keep the chi-square floor
    honest = commission(t, joint="joint_3", wear_calibration="paper")
    assert honest.verdict == "nothing_missing" and honest.noise_method == METHOD_STD


def test_an_effect_of_epoch_time_stamps_gets_a_spline_whose_range_survives_the_spec():
    # a bag's time column is seconds since 1970: printed with 6 digits its range collapsed to one value and the
    # spline of it was refused ("lo=1795690000.0 must be below hi=1795690000.0"), failing the whole diagnosis
    from jointwear_ros.workbench import diagnose

    t = synth_observations(n_cycles=16, seed=5, effects=["time_drift"])
    cols = {n: np.asarray(t[n], dtype=float) for n in t.names}
    tt = cols["time"]
    cols["time"] = 1.7956e9 + 1000.0 * (tt - tt.min()) / np.ptp(tt)  # a baseline recorded over 1000 s
    d = diagnose(ObservationTable(cols, source="epoch"), "paper", n_bootstrap=0)
    assert "time" in {c for v in d.variables if v.significant for c in v.columns}
    splines = [c.term for c in d.candidates if c.term.startswith("spline(time")]
    assert splines and all("lo=1795600000, hi=1795601000" in s for s in splines), splines
