"""The standard prognostics scores of the trend's backtest (issue 28, item 6): α-λ accuracy and prognostic horizon
as Saxena et al. (IJPHM 2010) and NASA's progpy define them, on hand-computed runs and against progpy itself."""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointwear_ros.trend import TrendConfig
from jointwear_ros.trend.backtest import (
    NightlyBacktest,
    alpha_lambda,
    backtest_joint,
    joint_run,
    prognostic_horizon,
    score_prognostics,
    trial_summary,
    tta_probability,
)
from jointwear_ros.trend.families import EPOCH0, make_family

EOL = 100.0
T = np.arange(0.0, 100.0, 1.0)  # a prediction every day of a run from 0 to its event on day 100
TRUE = EOL - T


def test_perfect_predictor_passes_alpha_lambda_and_has_the_whole_run_as_horizon():
    for lam in (0.0, 0.25, 0.5, 0.75, 0.9):
        assert alpha_lambda(T, TRUE, EOL, 0.0, lam=lam) is True
    assert prognostic_horizon(T, TRUE, EOL) == 100.0
    assert prognostic_horizon(T, TRUE, EOL, stay=True) == 100.0


def test_always_late_predictor_fails_alpha_lambda_and_never_enters_the_zone():
    late = TRUE * 1.3  # 30 % late at every time: outside the 20 % cone wherever it is taken
    for lam in (0.0, 0.5, 0.9):
        assert alpha_lambda(T, late, EOL, 0.0, lam=lam) is False
    # 6 days late: outside the ±5 day zone (α = 0.05 of EoL 100) at every prediction
    assert math.isnan(prognostic_horizon(T, TRUE + 6.0, EOL))
    assert math.isnan(prognostic_horizon(T, TRUE + 6.0, EOL, stay=True))


def test_converging_predictor_meets_the_criteria_only_once_it_has_converged():
    # the predicted RUL is 30 exp(-t / 20) days late: 30 at t = 0, 2.5 at t = 50, within 5 from t = 20 ln 6 = 35.8
    conv = TRUE + 30.0 * np.exp(-T / 20.0)
    assert alpha_lambda(T, conv, EOL, 0.0, lam=0.0) is False  # 130 against the cone [80, 120]
    assert alpha_lambda(T, conv, EOL, 0.0, lam=0.5) is True  # 52.5 in [40, 60]
    assert prognostic_horizon(T, conv, EOL) == 64.0  # first within at t = 36
    assert prognostic_horizon(T, conv, EOL, stay=True) == 64.0
    assert prognostic_horizon(T, conv, EOL, alpha=0.1) == 100.0 - 22.0  # within 10 from t = 20 ln 3 = 21.97


def test_alpha_lambda_cone_is_relative_to_the_true_rul_and_the_horizon_zone_to_eol():
    late4 = TRUE + 4.0  # always 4 days late
    assert alpha_lambda(T, late4, EOL, 0.0, lam=0.5) is True  # 54 in [40, 60]
    assert alpha_lambda(T, late4, EOL, 0.0, lam=0.9) is False  # 14 outside [8, 12]: the cone narrows
    assert prognostic_horizon(T, late4, EOL) == 100.0  # ±5 days all along: the zone does not
    # the zone is α times the run's length from its origin: a run starting on day 60 is 40 days long (±2)
    assert math.isnan(prognostic_horizon(T[60:], late4[60:], EOL, t_origin=60.0))
    # t_λ counts from t_P: from t_P = 60, λ = 0.5 is day 80, true RUL 20, cone [16, 24]
    assert alpha_lambda(T, TRUE + 5.0, EOL, 60.0) is False
    assert alpha_lambda(T, TRUE + 5.0, EOL, 0.0) is True


def test_horizon_first_entry_against_staying_within():
    wobble = TRUE + np.where(T == 50.0, 9.0, 0.0)  # one prediction outside the zone on day 50
    assert prognostic_horizon(T, wobble, EOL) == 100.0
    assert prognostic_horizon(T, wobble, EOL, stay=True) == 49.0


def test_beta_criterion_counts_the_mass_inside():
    rng = np.random.default_rng(1)
    # at t = 50 (true RUL 50, cone [40, 60]): 70 % of the samples inside
    inside = rng.uniform(41.0, 59.0, 70)
    outside = rng.uniform(61.0, 90.0, 30)
    s = np.tile(np.r_[inside, outside], (len(T), 1))
    assert alpha_lambda(T, s, EOL, 0.0, beta=0.5) is True
    assert alpha_lambda(T, s, EOL, 0.0, beta=0.8) is False


def test_no_prediction_before_the_event_cannot_be_scored():
    assert alpha_lambda(T[:40], TRUE[:40], EOL, 0.0) is None  # nothing at or after t_λ = 50
    assert math.isnan(prognostic_horizon(np.array([100.0, 110.0]), np.array([0.0, 0.0]), EOL))
    no_pred = np.full(len(T), np.inf)  # the trend saw no growth: "never" is outside every cone
    assert alpha_lambda(T, no_pred, EOL, 0.0) is False
    assert math.isnan(prognostic_horizon(T, no_pred, EOL))


def _oracle(j, rul_of):
    """A backtest of ``j`` whose median is ``rul_of(true time to alarm)`` on every night (growth always)."""
    days = (np.asarray(j.times) - EPOCH0) / 86400.0
    cross = np.array([j.segment_crossing(float(d)) for d in days])
    tta = cross - days
    med = rul_of(tta)
    n = len(days)
    return NightlyBacktest(days=days, level=np.zeros(n, int), growth=np.ones(n, bool), lo90=med - 1.0, median=med,
                           hi90=med + 1.0, true_tta=tta, true_wear=np.asarray(j.true_wear(days), float),
                           count=np.arange(1, n + 1))


def test_step_joint_is_scored_over_the_segment_after_its_unrecorded_replacement():
    j = make_family("step", 1, days=180, seed=3)[0]
    b = _oracle(j, lambda x: x)
    run = joint_run(j, b, 35.0)
    assert run is not None
    idx, t_p, eol = run
    assert b.days[idx[0] - 1] < j.step_day <= t_p == b.days[idx[0]]
    assert eol == pytest.approx(j.step_day + (35.0 - j.w_after) / j.rate_after, abs=1e-6)


def test_score_prognostics_per_family_for_a_perfect_and_a_late_predictor():
    joints = make_family("linear", 4, days=180, seed=5) + make_family("flat", 2, days=180, seed=5)
    cfg = TrendConfig()
    perfect = score_prognostics(joints, [_oracle(j, lambda x: x) for j in joints], cfg)
    late = score_prognostics(joints, [_oracle(j, lambda x: 1.3 * x) for j in joints], cfg)
    # 30 days late: outside every joint's zone (±5 % of a run of at most 180 days)
    late30 = score_prognostics(joints, [_oracle(j, lambda x: x + 30.0) for j in joints], cfg)
    lin = perfect["linear"]
    assert lin["alpha_lambda"] == 1.0 and lin["alpha_lambda_joints"] >= 3
    assert lin["ph_joints"] >= 1 and lin["ph_median_rel"] == 1.0 and lin["ph_never"] == 0
    assert late["linear"]["alpha_lambda"] == 0.0
    assert late["linear"]["ph_never"] == 0  # 30 % of a shrinking RUL enters the zone near the event
    assert late["linear"]["ph_median_rel"] < 0.5
    assert late30["linear"]["ph_never"] == late30["linear"]["ph_joints"] and late30["linear"]["ph_median_days"] == 0
    assert perfect["flat"]["alpha_lambda_joints"] == 0  # their alarm lies years beyond the history
    assert perfect["all"]["alpha_lambda_joints"] == lin["alpha_lambda_joints"]


def test_the_distribution_behind_the_beta_criterion_is_the_one_whose_quantiles_the_backtest_reports():
    j = make_family("accelerating", 1, days=70, seed=4)[0]
    cfg = TrendConfig()
    b = backtest_joint(j, cfg, EPOCH0)
    n = len(b.days) - 1
    assert b.growth[n] and np.isfinite(b.hi90[n])
    assert tta_probability(j, cfg, n, 0.0, b.lo90[n]) == pytest.approx(0.05, abs=1e-6)
    assert tta_probability(j, cfg, n, 0.0, b.median[n]) == pytest.approx(0.5, abs=1e-6)
    assert tta_probability(j, cfg, n, b.lo90[n], b.hi90[n]) == pytest.approx(0.9, abs=1e-6)


def test_trial_counts_the_medians_within_the_alpha_cone_of_the_true_time():
    def row(median, true=100.0, profile="linear"):
        lo = median - 10.0 if math.isfinite(median) else math.nan
        return {"profile": profile, "true": true, "lo90": lo, "median": median, "hi90": median + 10.0,
                "level": 0, "line_width": 20.0}

    rows = [row(115.0), row(81.0), row(125.0), row(79.0), row(math.nan), row(100.0, profile="flat")]
    s = trial_summary(rows)
    assert s["growing"] == 5 and s["median_within_20pct"] == pytest.approx(2 / 5)


# --- against NASA's progpy (a test dependency; skipped where it is not installed) -------------------------------

def _profile(t, toe_samples):
    from progpy.predictors import ToEPredictionProfile
    from progpy.uncertain_data import UnweightedSamples

    prof = ToEPredictionProfile()
    for ti, s in zip(t, toe_samples):
        prof.add_prediction(float(ti), UnweightedSamples([{"alarm": float(x)} for x in s]))
    return prof


def _synthetic_runs(n=12, m=40):
    """Runs with a bias that shrinks (or not) and a spread, times of prediction irregular, EoL 60-200."""
    rng = np.random.default_rng(28)
    for _ in range(n):
        eol = float(rng.uniform(60.0, 200.0))
        t = np.sort(rng.uniform(0.0, eol, 15))
        bias0, decay, spread = rng.uniform(-0.4, 0.4), rng.uniform(0.0, 3.0), rng.uniform(0.02, 0.3)
        offset = float(rng.choice([0.0, 0.3 * eol]))  # some runs always late by 30 % of their EoL
        r_true = eol - t
        rel = bias0 * np.exp(-decay * t / eol)
        samples = (r_true * (1.0 + rel) + offset)[:, None] + (spread * r_true)[:, None] * rng.standard_normal(
            (len(t), m))
        yield t, eol, samples


def test_alpha_lambda_and_horizon_agree_with_progpy():
    pytest.importorskip("progpy")
    from progpy.metrics import alpha_lambda as pp_alpha_lambda
    from progpy.metrics import prognostic_horizon as pp_horizon

    outcomes = {"al": set(), "ph": set()}
    for t, eol, rul in _synthetic_runs():
        prof = _profile(t, t[:, None] + rul)
        for lam in (0.25, 0.5, 0.75):
            for beta in (0.5, 0.8):
                ours = alpha_lambda(t, rul, eol, 0.0, alpha=0.2, lam=lam, beta=beta)
                theirs = pp_alpha_lambda(prof, {"alarm": eol}, lam * eol, 0.2, beta)["alarm"]
                assert ours == bool(theirs), (eol, lam, beta)
                outcomes["al"].add(ours)
        for a in (0.05, 0.1, 0.2):
            half = a * eol

            def crit(tte, gt, half=half):
                pib = tte.percentage_in_bounds({k: [v - half, v + half] for k, v in gt.items()})
                return {k: pib[k] >= 0.5 for k in gt}

            ours_ph = prognostic_horizon(t, rul, eol, alpha=a)
            theirs_ph = pp_horizon(prof, crit, {"alarm": eol})["alarm"]
            if theirs_ph is None:
                assert math.isnan(ours_ph)
            else:
                assert ours_ph == pytest.approx(theirs_ph, rel=1e-12)
            outcomes["ph"].add(theirs_ph is None)
    assert outcomes["al"] == {True, False} and outcomes["ph"] == {True, False}  # both outcomes compared
