"""The Hammersley-Chapman-Robbins bound: exact divergences, twins, and where the CRB cannot be reached."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import norm

from jointwear_ros.cli import main as cli_main
from jointwear_ros.errors import InputDataError
from jointwear_ros.estimation import make_estimator
from jointwear_ros.estimation.crb import crb_known_temperature, crb_per_speed
from jointwear_ros.estimation.hcr import _chi2, hcr_per_speed
from jointwear_ros.estimation.priors import normal_prior
from jointwear_ros.estimation.study import StudySetup, run_study
from jointwear_ros.model import load_parameter_set, paper_wear_model

M, P = paper_wear_model(), load_parameter_set("ref-2011r")
SIG = 0.0015
PAPER_T = normal_prior(40, 3)


def test_chi2_of_one_gaussian_is_the_closed_form():
    # N(d, s^2) from N(0, s^2): chi2 = exp(d^2 / s^2) - 1
    for k in (0.01, 0.5, 2.0, 5.0):
        got = _chi2(np.array([0.1]), np.array([0.0]), k * SIG, SIG)
        assert got == pytest.approx(math.expm1(k * k), rel=1e-9)


def test_chi2_of_a_mixture_matches_adaptive_quadrature():
    b = np.array([0.070, 0.073, 0.0745, 0.080])
    w = np.array([0.1, 0.4, 0.3, 0.2])
    shift = 0.004

    def mix(y, s=0.0):
        return float(np.sum(w * norm.pdf(y, b + s, SIG)))

    ref, _ = quad(lambda y: mix(y, shift) ** 2 / mix(y) - mix(y, shift), 0.03, 0.13, points=list(b), limit=400)
    assert _chi2(b, np.log(w), shift, SIG) == pytest.approx(ref, rel=1e-6)


def test_with_temperature_known_the_bound_at_a_monotone_speed_is_the_gaussian_crb():
    known = normal_prior(40, 1e-4)  # T practically known: h is one Gaussian of width sigma
    r = hcr_per_speed(M, P, [40.0], 35.0, prior=known)
    ref = crb_known_temperature(M, P, [40.0], 35.0, temperature=40.0)
    assert r.bound[0] == pytest.approx(float(ref[0]), rel=2e-3)
    assert math.isnan(r.twin_wear[0])


def test_hcr_equals_crb_where_the_crb_is_reachable_and_exceeds_it_near_a_twin():
    speeds = [0.0, 40.0, 80.0, 112.0, 130.0]
    r = hcr_per_speed(M, P, speeds, 35.0, prior=PAPER_T)
    crb = crb_per_speed(M, P, speeds, 35.0, prior=PAPER_T)
    np.testing.assert_allclose(r.crb, crb)
    assert np.all(r.bound >= r.crb)
    assert np.all(r.ratio[:3] < 1.02)  # reachable: HCR ~ CRB
    assert r.ratio[3] > 1.5 and r.ratio[4] > 20  # w = 0 gives nearly the friction of w = 35
    assert r.test_point[3] == pytest.approx(-35.0) and r.test_point[4] == pytest.approx(-35.0)


def test_a_twin_wear_gives_the_same_friction_at_every_temperature_and_an_infinite_bound():
    r = hcr_per_speed(M, P, [200.0], 35.0, prior=PAPER_T)
    twin = float(r.twin_wear[0])
    assert math.isinf(r.bound[0]) and 0 <= twin <= 100 and abs(twin - 35.0) > 1.0
    temps = np.linspace(30, 50, 9)
    f35 = M.evaluate(P, speed=200.0, load_torque=0.1, temperature=temps, wear=35.0)
    ftw = M.evaluate(P, speed=200.0, load_torque=0.1, temperature=temps, wear=twin)
    assert np.max(np.abs(f35 - ftw)) < 1e-4 * SIG  # far below sigma_e: indistinguishable


def test_bad_inputs_are_errors():
    with pytest.raises(InputDataError, match="wear range"):
        hcr_per_speed(M, P, [40.0], 120.0)
    with pytest.raises(InputDataError, match="speed"):
        hcr_per_speed(M, P, [-1.0], 35.0)
    with pytest.raises(InputDataError, match="noise_std"):
        hcr_per_speed(M, P, [40.0], 35.0, noise_std=0.0)


def test_study_reports_the_hcr_column_and_json_null_for_infinite(capsys):
    setup = StudySetup(speeds=(40.0, 120.0, 200.0), runs=200, true_wear=35.0, seed=1)
    res = run_study(make_estimator("bayes", prior=PAPER_T), setup, hcr=True)
    assert res.hcr is not None and res.twin_wear is not None
    assert res.hcr[0] == pytest.approx(res.crb[0], rel=0.02) and res.hcr[1] > 5 * res.crb[1]
    assert math.isinf(res.hcr[2]) and np.isfinite(res.twin_wear[2])
    assert cli_main(["study", "--runs", "200", "--speeds", "40,120,200", "--method", "paper", "--hcr",
                     "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["hcr"][2] is None and out["twin_wear"][2] == pytest.approx(float(res.twin_wear[2]))
    assert out["hcr"][0] == pytest.approx(out["crb"][0], rel=0.02) and "hcr_meaning" in out
    assert cli_main(["study", "--runs", "200", "--speeds", "40,120", "--method", "paper", "--hcr", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "hcr" in text and "twin w" in text
    assert cli_main(["study", "--method", "joint", "--hcr", "--quiet", "--runs", "50"]) == 2
    assert "--hcr" in capsys.readouterr().err
