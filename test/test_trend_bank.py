"""Issue 23: the model bank (steady members next to adaptive ones), exact intervals on fixed seeds, the WARN and
ERROR boundaries, the prediction horizon, why a bound is open, an unrecorded step, the fleet as a prior."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_trend_core import T0, _series  # one synthetic series helper for both trend test modules

from jointwear_ros.contract import DiagnosticLevel
from jointwear_ros.errors import InputDataError
from jointwear_ros.trend import (
    DAY,
    RatePrior,
    TrendConfig,
    analyze_joint,
    bank_members,
    fleet_prior,
    pool_prior,
    sibling_fit,
    trend_states,
)
from jointwear_ros.trend.backtest import backtest_joint, line_limit, score_calibration
from jointwear_ros.trend.families import EPOCH0, FAMILIES, make_family
from jointwear_ros.trend.states import unbounded_reason


def _issue_linear():
    """The issue's planner case: 60 nightly estimates (std 0.85), wear growing 0.25/day, 50 days from the alarm."""
    return _series(60, 0.25, w0=35 - 0.25 * 109, seed=3)


# --------------------------------------------------------------------------- exact intervals (fixed seeds)


def test_issue_linear_joint_gets_the_exact_interval_around_the_true_50_days():
    r = analyze_joint(*_issue_linear())
    q = r.time_to_alarm
    assert q is not None and r.level_name == "OK"
    assert (q.lo90, q.median, q.hi90) == pytest.approx(LINEAR_EXPECTED, abs=0.02)
    assert q.lo90 <= 50.0 <= q.hi90 and q.unbounded_reason is None  # was "39 days to never"


def test_warn_joint_gets_the_exact_interval_and_weights_sum_to_one():
    r = analyze_joint(*_series(90, 0.25, w0=10.0))  # true wear 32.25 at the last night: 11 days to 35
    q = r.time_to_alarm
    assert r.level_name == "WARN"
    assert (q.lo90, q.median, q.hi90) == pytest.approx(WARN_EXPECTED, abs=0.02)
    assert sum(q.model_weights.values()) == pytest.approx(1.0, abs=1e-3)
    assert max(q.model_weights, key=q.model_weights.get) == "line"


LINEAR_EXPECTED = (46.068, 49.919, 54.355)
WARN_EXPECTED = (8.457, 9.843, 11.311)


def test_adaptive_members_alone_give_their_exact_interval():
    """Pins the random-walk and quadratic forecasts (q tau^3/3, q tau^5/20): issue 13's bank on the WARN joint."""
    cfg = TrendConfig(efold_days=(), prior_line=0.0, prior_accelerated=0.0, step_rate_per_day=0.0)
    q = analyze_joint(*_series(90, 0.25, w0=10.0), cfg=cfg).time_to_alarm
    assert (q.lo90, q.median, q.hi90) == pytest.approx((6.295, 10.080, 15.478), abs=0.02)
    assert q.model_weights["line"] == 0.0


def test_accelerated_member_alone_gives_its_exact_interval_around_the_truth():
    """Pins the accelerated shape's forecast basis e (exp(tau / e) - 1): the paper's law, e = 90 d, 100 nights."""
    rng = np.random.default_rng(4)
    d = np.arange(100.0)
    w = 3 + 0.05 * 90 * np.expm1(d / 90) + rng.normal(0, 0.85, 100)
    cfg = TrendConfig(efold_days=(90.0,), accel_noise=(), jerk_noise=(), prior_line=0.0, prior_accelerated=1.0)
    q = analyze_joint(T0 + DAY * d, w, np.full(100, 0.85), cfg=cfg).time_to_alarm
    assert (q.lo90, q.median, q.hi90) == pytest.approx((85.573, 89.356, 93.331), abs=0.02)  # truth 89.39


def test_interval_quantiles_are_the_5_50_95_points_of_the_mixture():
    """A planted change of the quantile levels (e.g. 10 / 90 %) moves the interval: the mixture's own CDF says."""
    t, w, s = _issue_linear()
    cfg = TrendConfig()
    st_ = trend_states((t - t[0]) / DAY, w, s, cfg, rows=np.array([len(t) - 1]), keep=True)
    lo, med, hi = st_.quantiles[0]
    from jointwear_ros.trend.alarm import crossing_curves, forecast_basis, tau_grid

    tau = tau_grid(cfg.max_horizon_days)
    members = bank_members(cfg)
    F = sum(c.weight * crossing_curves(c.mean[None], c.cov[None], *forecast_basis(members[c.member], tau, cfg), cfg.alarm)[0]
            for c in st_.mixtures[0])
    assert np.interp(lo, tau, F) == pytest.approx(0.05, abs=2e-3)
    assert np.interp(med, tau, F) == pytest.approx(0.50, abs=2e-3)
    assert np.interp(hi, tau, F) == pytest.approx(0.95, abs=2e-3)


def test_prediction_horizon_caps_the_interval():
    """A slow joint: its upper bound lies beyond a short horizon (unbounded, and says so) and within the default."""
    t, w, s = _series(120, 0.03, w0=10.0, std=0.4, seed=7)  # ~ 700 days to go
    r = analyze_joint(t, w, s)
    q = r.time_to_alarm
    assert q is not None and math.isfinite(q.hi90) and q.hi90 > 500
    short = analyze_joint(t, w, s, cfg=TrendConfig(max_horizon_days=q.median))
    assert short.time_to_alarm is not None and math.isinf(short.time_to_alarm.hi90)
    assert short.time_to_alarm.lo90 == pytest.approx(q.lo90, rel=0.02)
    assert "horizon" in short.time_to_alarm.unbounded_reason or "acceleration" in short.time_to_alarm.unbounded_reason


# --------------------------------------------------------------------------- the WARN and ERROR boundaries


def test_alarm_expected_exactly_when_the_lower_bound_is_within_the_horizon_on_both_sides():
    t, w, s = _issue_linear()
    lo = analyze_joint(t, w, s).time_to_alarm.lo90
    within = analyze_joint(t, w, s, cfg=TrendConfig(horizon_days=lo + 0.05))
    assert within.alarm_expected and within.forecast.state == "within_horizon"
    assert not analyze_joint(t, w, s, cfg=TrendConfig(horizon_days=lo - 0.05)).alarm_expected
    assert analyze_joint(t, w, s, cfg=TrendConfig(horizon_days=lo)).alarm_expected  # "within": <=
    # the forecast never moves the condition level: the same estimates, the same level at every horizon
    levels = {analyze_joint(t, w, s, cfg=TrendConfig(horizon_days=h)).level for h in (lo - 0.05, lo, lo + 0.05)}
    assert len(levels) == 1


def test_error_exactly_when_the_standing_estimate_is_at_or_above_the_alarm_on_both_sides():
    t, w, s = _series(40, 0.1, w0=20.0)
    r = analyze_joint(t, w, s)
    newest = r.level_wear
    assert newest == w[-1]  # the standing estimate: the newest, confirmed
    above = analyze_joint(t, w, s, cfg=TrendConfig(alarm=newest - 0.01))
    below = analyze_joint(t, w, s, cfg=TrendConfig(alarm=newest + 0.01))
    assert above.level_name == "ERROR"
    assert below.level_name == "WARN"  # just below the alarm: within the estimate's 95 % bound
    assert analyze_joint(t, w, s, cfg=TrendConfig(alarm=newest)).level_name == "ERROR"  # "at or above": >=


def test_the_backtests_nightly_warn_is_exactly_the_lower_bound_within_the_horizon_on_both_sides():
    """The backtest's nightly flags (``trend_states``' level: WARN an alarm expected within the horizon, ERROR the
    trend's wear at the alarm), checked at their boundaries as the condition level is above."""
    t, w, s = _issue_linear()
    days = (t - t[0]) / DAY
    last = np.array([len(t) - 1])
    lo = float(trend_states(days, w, s, TrendConfig(), rows=last).quantiles[0, 0])
    assert trend_states(days, w, s, TrendConfig(horizon_days=lo), rows=last).level[0] == DiagnosticLevel.WARN
    assert trend_states(days, w, s, TrendConfig(horizon_days=lo - 0.05), rows=last).level[0] == DiagnosticLevel.OK


def test_the_backtests_nightly_error_is_exactly_the_trends_wear_at_or_above_the_alarm():
    t, w, s = _series(40, 0.1, w0=20.0)
    days = (t - t[0]) / DAY
    last = np.array([len(t) - 1])
    wear = float(trend_states(days, w, s, TrendConfig(), rows=last).wear[0])
    assert trend_states(days, w, s, TrendConfig(alarm=wear), rows=last).level[0] == DiagnosticLevel.ERROR
    assert trend_states(days, w, s, TrendConfig(alarm=wear + 0.01), rows=last).level[0] != DiagnosticLevel.ERROR


def test_no_alarm_expected_without_growth_even_when_the_lower_bound_would_be_near():
    t, w, s = _series(60, 0.0, w0=33.0, seed=2)
    r = analyze_joint(t, w, s)
    assert not r.growth_detected and not r.alarm_expected and r.time_to_alarm is None
    assert r.level_name == "WARN"  # in the warning band: the condition says so, the forecast does not


# --------------------------------------------------------------------------- what the bank does


def test_steady_joint_approaches_the_straight_line_limit():
    t, w, s = _issue_linear()
    r = analyze_joint(t, w, s)
    lim = line_limit((t - t[0]) / DAY, w, s, TrendConfig())[-1]
    width, limit = r.time_to_alarm.hi90 - r.time_to_alarm.lo90, lim[2] - lim[0]
    assert width <= 2.0 * limit, (width, limit)
    assert r.rate_std < 0.025  # issue 13's bank: 0.027-0.043


def test_accelerating_joint_moves_the_weight_off_the_line_and_keeps_the_truth_inside():
    j = make_family("accelerating", 1, days=180, seed=0)[0]  # the paper's shape
    cut = 110
    r = analyze_joint(j.times[:cut], j.wear[:cut], j.wear_std[:cut])
    d = (j.times[cut - 1] - EPOCH0) / DAY
    true = j.segment_crossing(d) - d
    q = r.time_to_alarm
    assert q.model_weights["line"] < 0.05
    assert sum(v for k, v in q.model_weights.items() if k != "line") > 0.95
    assert q.lo90 <= true <= q.hi90


def test_a_step_without_a_maintenance_event_is_found_and_the_trend_follows_it():
    t, w, s = _series(120, 0.2, w0=5.0, seed=5)
    rng = np.random.default_rng(9)
    w[70:] = 2.0 + 0.15 * np.arange(50) + rng.normal(0, 0.85, 50)  # reducer replaced on day 70, not recorded
    r = analyze_joint(t, w, s)
    assert r.step_probability > 0.99 and abs(r.step_time - t[70]) < 1.5 * DAY
    assert abs(r.rate_per_day - 0.15) < 3 * r.rate_std and "without a maintenance event" in r.message
    assert r.as_dict()["step_probability"] == r.step_probability
    steady = analyze_joint(*_issue_linear())
    assert steady.step_probability < 0.05


def test_unbounded_reason_names_acceleration_or_a_rate_near_zero():
    t, w, s = _series(12, 0.1, w0=8.0, seed=4)
    q = analyze_joint(t, w, s).time_to_alarm
    assert math.isinf(q.hi90) and q.unbounded_reason.startswith("acceleration not identified")
    assert q.as_dict()["hi90"] == math.inf and q.as_dict()["unbounded_reason"] == q.unbounded_reason
    steady_only = TrendConfig(accel_noise=(), jerk_noise=(), prior_line=0.6, prior_accelerated=0.4,
                              growth_probability=0.5)
    t, w, s = _series(30, 0.03, w0=8.0, seed=0)
    r = analyze_joint(t, w, s, cfg=steady_only)
    assert r.time_to_alarm is not None and math.isinf(r.time_to_alarm.hi90)
    assert r.time_to_alarm.unbounded_reason.startswith("rate not distinguishable from zero")
    assert analyze_joint(*_issue_linear()).time_to_alarm.unbounded_reason is None


def test_unbounded_reason_is_none_for_a_bounded_row():
    t, w, s = _issue_linear()
    cfg = TrendConfig()
    st_ = trend_states((t - t[0]) / DAY, w, s, cfg, rows=np.array([len(t) - 1]))
    assert unbounded_reason(st_, 0, bank_members(cfg), cfg) is None


def test_bad_bank_settings_are_refused():
    with pytest.raises(InputDataError, match="prior weights"):
        TrendConfig(prior_line=0.8, prior_accelerated=0.4)
    with pytest.raises(InputDataError, match="efold_days"):
        TrendConfig(efold_days=(0.0,))
    with pytest.raises(InputDataError, match="evidence_temperature"):
        TrendConfig(evidence_temperature=0.0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 3e7), st.floats(-20, 120), st.floats(0.05, 10)), min_size=5, max_size=25))
def test_any_history_gives_weights_summing_to_one_and_ordered_quantiles(rows):
    t = T0 + np.array([r[0] for r in rows])
    r = analyze_joint(t, [x[1] for x in rows], [x[2] for x in rows])
    assert sum(r.model_weights.values()) == pytest.approx(1.0, abs=2e-3)
    assert 0.0 <= r.step_probability <= 1.0 + 1e-9
    if r.time_to_alarm is not None:
        q = r.time_to_alarm
        assert 0 <= q.lo90 <= q.median <= q.hi90
        assert (q.unbounded_reason is None) == math.isfinite(q.hi90)


# --------------------------------------------------------------------------- the fleet as a prior


def _siblings(n=12, seed=0):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        t = np.arange(120.0)
        rate = rng.uniform(0.12, 0.18)
        out.append((t, 5.0 + rate * t + rng.normal(0, 0.85, 120), np.full(120, 0.85)))
    return out


def test_fleet_prior_is_the_siblings_rate_distribution():
    pr = fleet_prior(_siblings())
    assert pr is not None and pr.joints == 12
    assert 0.13 < pr.mean < 0.17 and 0.01 <= pr.std < 0.05
    assert pr.weights is not None and sum(pr.weights) == pytest.approx(1.0)
    assert pool_prior([sibling_fit(*x) for x in _siblings(4)]) is None  # too few siblings: no prior
    assert sibling_fit(np.arange(3.0), np.ones(3), np.ones(3)) is None


def test_a_young_joint_gets_a_useful_interval_from_its_siblings():
    pr = fleet_prior(_siblings())
    t, w, s = _series(10, 0.15, w0=20.0, seed=8)  # 10 estimates; true time to alarm 15 / 0.15 - 9 = 91 days
    alone = analyze_joint(t, w, s)
    helped = analyze_joint(t, w, s, prior=pr)
    assert helped.time_to_alarm is not None and helped.time_to_alarm.lo90 <= 91.0 <= helped.time_to_alarm.hi90
    assert helped.time_to_alarm.hi90 - helped.time_to_alarm.lo90 <= 0.6 * 91.0
    assert alone.time_to_alarm is None or not alone.time_to_alarm.lo90 <= 91.0 <= alone.time_to_alarm.hi90
    assert helped.as_dict()["fleet_prior"]["joints"] == 12 and alone.as_dict()["fleet_prior"] is None


def _unlike_its_siblings(seed):
    """A joint that accelerates (the paper's shape, rate 0.1 wear/day e-folding in 60 days, 60 nightly estimates from
    w = 5) where its siblings wear linearly; its true time to alarm is 48.5 days after the last estimate."""
    rng = np.random.default_rng(seed)
    d = np.arange(60.0)
    y = 5.0 + 6.0 * np.expm1(d / 60.0) + rng.normal(0, 0.85, 60)
    return T0 + d * DAY, y, np.full(60, 0.85), 60.0 * math.log1p(30.0 / 6.0) - 59.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_joint_unlike_its_siblings_is_covered_again_by_the_contaminated_fleet_prior(seed):
    fits = [sibling_fit(*x) for x in _siblings(20)]
    t, y, s, true = _unlike_its_siblings(seed)
    own = analyze_joint(t, y, s).time_to_alarm
    trusting = analyze_joint(t, y, s, prior=pool_prior(fits)).time_to_alarm
    robust_prior = pool_prior(fits, unlike=0.4)
    robust = analyze_joint(t, y, s, prior=robust_prior)
    assert own.lo90 <= true <= own.hi90
    # the fleet alone says "linear, 0.15 wear/day": the accelerating joint's alarm is predicted too late
    assert trusting.lo90 > true
    # P(unlike its siblings) = 0.4: every member is also weighed under the default prior, and the evidence of
    # the acceleration brings the earliest time back
    tta = robust.time_to_alarm
    assert tta is not None and tta.lo90 <= true <= tta.hi90 and tta.lo90 < trusting.lo90
    assert sum(robust.model_weights.values()) == pytest.approx(1.0, abs=1e-3)
    assert robust.as_dict()["fleet_prior"]["unlike"] == 0.4


def test_contaminated_prior_of_a_joint_like_its_siblings_keeps_the_fleets_sharpness():
    fits = [sibling_fit(*x) for x in _siblings(20)]
    t, w, s = _series(60, 0.15, w0=5.0, seed=4)  # like its siblings (0.12-0.18 wear/day)
    true = 30.0 / 0.15 - 59.0
    trusting = analyze_joint(t, w, s, prior=pool_prior(fits)).time_to_alarm
    robust = analyze_joint(t, w, s, prior=pool_prior(fits, unlike=0.4)).time_to_alarm
    own = analyze_joint(t, w, s).time_to_alarm
    for x in (trusting, robust):
        assert x.lo90 <= true <= x.hi90
    assert robust.hi90 - robust.lo90 <= 1.1 * (trusting.hi90 - trusting.lo90) < own.hi90 - own.lo90


def test_type2_member_weights_follow_the_siblings_above_a_floor():
    fits = [sibling_fit(*x) for x in _siblings(20)]
    mean, t2 = pool_prior(fits), pool_prior(fits, weights="type2", floor=0.2)
    d = np.asarray(RatePrior().member_weights(TrendConfig()))
    assert t2.weights[0] > mean.weights[0] > d[0]  # linear siblings: the line, more so by the marginal likelihood
    assert (np.asarray(t2.weights) >= 0.2 * d / 1.2 - 1e-12).all()  # the floor: no member ruled out
    assert (t2.mean, t2.std) == (mean.mean, mean.std)
    for bad in ({"weights": "median"}, {"floor": 0.0}, {"floor": 1.5}, {"unlike": 1.0}, {"unlike": -0.1}):
        with pytest.raises(InputDataError):
            pool_prior(fits, **bad)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.lists(st.floats(1e-6, 1.0), min_size=9, max_size=9), min_size=2, max_size=12),
       st.floats(0.01, 1.0))
def test_type2_pooled_weights_are_a_distribution_with_every_member_above_its_floor(rows, floor):
    from jointwear_ros.trend import SiblingFit

    cfg = TrendConfig()
    d = np.asarray(RatePrior().member_weights(cfg))
    fits = [SiblingFit(0.1, 1e-4, np.asarray(r) / sum(r)) for r in rows]
    w = np.asarray(pool_prior(fits, cfg, min_joints=2, weights="type2", floor=floor).weights)
    assert w.sum() == pytest.approx(1.0) and (w >= floor * d / (1.0 + floor) - 1e-12).all()


def test_default_rate_prior_reproduces_no_prior():
    t, w, s = _issue_linear()
    a = analyze_joint(t, w, s)
    b = analyze_joint(t, w, s, prior=RatePrior(std=TrendConfig().slope_prior_std))
    assert a.time_to_alarm.as_dict() == b.time_to_alarm.as_dict()


def test_trend_cli_fleet_prior_from_the_store(tmp_path, capsys):
    from jointwear_ros.cli import main as cli_main
    from jointwear_ros.history import EstimateRecord, HistoryStore

    db = tmp_path / "h.db"
    recs = []
    for i, (t, w, s) in enumerate(_siblings(6, seed=3)):
        n = 10 if i == 0 else len(t)  # robot_0's joint is young
        recs += [EstimateRecord(f"robot_{i}", "joint_2", k + 1, T0 + DAY * t[k], float(w[k]), float(s[k]),
                                params="ref-2011r") for k in range(n)]
    with HistoryStore(db) as store:
        store.add_estimates(recs)
    assert cli_main(["trend", "--db", str(db), "--json", "--fleet-prior", "--robot", "robot_0"]) == 0
    (j,) = json.loads(capsys.readouterr().out)["joints"]
    assert j["fleet_prior"]["joints"] == 5 and j["fleet_prior"]["source"] == "fleet: type ref-2011r/joint_2"
    assert cli_main(["trend", "--db", str(db), "--json", "--robot", "robot_0"]) == 0
    (k,) = json.loads(capsys.readouterr().out)["joints"]
    assert k["fleet_prior"] is None and set(k) == set(j)


# --------------------------------------------------------------------------- calibration (fixed seed)


@pytest.fixture(scope="module")
def calibration_set():
    return [j for i, f in enumerate(FAMILIES) if f in ("linear", "accelerating", "flat", "step")
            for j in make_family(f, 3, days=150, seed=5, first=3 * i)]


def test_calibration_backtest_keeps_coverage_narrows_and_never_warns_a_flat_joint(calibration_set):
    cfg = TrendConfig()
    runs = [backtest_joint(j, cfg, EPOCH0) for j in calibration_set]
    s = score_calibration(calibration_set, cfg, EPOCH0, 150, min_estimates=60, backtests=runs)
    assert s["all"]["coverage"] >= 0.8, s["all"]
    assert s["all"]["median_width_over_true"] <= 0.6, s["all"]
    assert s["linear"]["median_width_over_line"] <= 2.0, s["linear"]
    assert s["flat"]["flat_warn_nights"] == 0 and s["all"]["false_error_nights"] == 0
    assert s["step"]["early_warn_per_1000"] <= 5.0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-0.5, 1.0), st.floats(1e-8, 0.09)), min_size=2, max_size=30))
def test_pooled_prior_is_a_proper_prior_within_its_clips(rows):
    from jointwear_ros.trend import SiblingFit

    cfg = TrendConfig()
    m = len(bank_members(cfg))
    fits = [SiblingFit(r, v, np.full(m, 1.0 / m)) for r, v in rows]
    pr = pool_prior(fits, cfg, min_joints=2)
    assert pr is not None and pr.joints == len(rows)
    assert 0.01 <= pr.std <= cfg.slope_prior_std
    assert min(r for r, _ in rows) - 1e-12 <= pr.mean <= max(r for r, _ in rows) + 1e-12
    assert sum(pr.weights) == pytest.approx(1.0) and min(pr.weights) > 0


def test_fleet_priors_fall_back_from_the_joint_type_to_the_parameter_set():
    from types import SimpleNamespace

    from jointwear_ros.history.trends import fleet_priors

    hist = {}
    for i, (t, w, s) in enumerate(_siblings(7, seed=1)):
        name = "joint_1" if i < 3 else f"joint_{i}"  # three joint_1s (too few alone), seven of one parameter set
        recs = [SimpleNamespace(time=T0 + DAY * t[k], wear=float(w[k]), wear_std=float(s[k]), cycle_id=k + 1,
                                params="ref-2011r") for k in range(len(t))]
        hist[(f"robot_{i}", name)] = (recs, [])
    pri = fleet_priors(hist, TrendConfig())
    assert pri[("robot_0", "joint_1")].source == "fleet: parameter set ref-2011r"
    assert all(p is not None and p.joints == 6 for p in pri.values())  # leave-one-out: never its own sibling
    assert fleet_priors(hist, TrendConfig(), min_joints=8) == dict.fromkeys(hist)


def test_trend_plot_shows_the_interval_and_every_models_weight(tmp_path, monkeypatch):
    import jointwear_ros.plots as plots
    from jointwear_ros.trend.report import plot_trend

    seen = {}
    real = plots.save_figure

    def keep(fig, path):
        seen["fig"] = fig
        labels = [t.get_text() for t in fig.axes[1].get_yticklabels()]
        seen["labels"] = labels
        seen["legend"] = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        return real(fig, path)

    monkeypatch.setattr(plots, "save_figure", keep)
    t, w, s = _series(120, 0.2, w0=5.0, seed=5)
    w[70:] = 2.0 + 0.15 * np.arange(50) + np.random.default_rng(9).normal(0, 0.85, 50)
    r = analyze_joint(t, w, s, robot="cell_7", joint="joint_3")
    out = plot_trend(tmp_path / "p.png", r, TrendConfig(), t, w, s)
    assert out.stat().st_size > 10_000
    assert sorted(seen["labels"]) == sorted(m.name for m in bank_members(TrendConfig()))
    assert "alarm time 90 %" in seen["legend"] and "predicted crossing (median)" in seen["legend"]
    assert any(x.startswith("step without a maintenance event") for x in seen["legend"])
    assert any(x.startswith("fit: line after the step") for x in seen["legend"])


# --------------------------------------------------------------------------- the issue's trial and the scores' error


def test_trial_scores_each_joint_once_at_its_60th_estimate_and_the_line_limit_bounds_it():
    from jointwear_ros.trend.backtest import score_trial, trial_summary
    from jointwear_ros.trend.families import make_trial_set

    joints = make_trial_set(seeds=(100,), per_family=4)
    s = score_trial(joints, TrendConfig(), EPOCH0)
    assert s["joints"] == 12 and len(s["rows"]) == 12
    assert [x["profile"] for x in s["rows"]] == ["linear"] * 4 + ["accelerating"] * 4 + ["flat"] * 4
    j = joints[0]
    d = (j.times[159] - EPOCH0) / DAY  # the look: the last of estimates 100-159
    assert s["rows"][0]["true"] == pytest.approx(j.segment_crossing(d) - d)
    compared = 0
    for x, jj in zip(s["rows"], joints):  # the interval is the one the trend gives on those 60 estimates
        q = analyze_joint(jj.times[100:160], jj.wear[100:160], jj.wear_std[100:160]).time_to_alarm
        if q is not None and q.median > 0:
            assert (x["lo90"], x["median"]) == pytest.approx((q.lo90, q.median), rel=1e-9)
            assert x["hi90"] == q.hi90 or x["hi90"] == pytest.approx(q.hi90, rel=1e-9)
            compared += 1
    assert compared >= 4
    assert s["flat_warn"] == 0
    for x in s["rows"]:
        assert x["w_line"] + x["w_accelerated"] + x["w_adaptive"] == pytest.approx(1.0)
    # a bank of the line alone is no wider than its straight-line limit allows (the limit: the flat-prior line)
    line = TrendConfig(prior_line=1.0, prior_accelerated=0.0, accel_noise=(), jerk_noise=(), step_rate_per_day=0.0)
    sl = score_trial([x for x in joints if x.profile == "linear"], line, EPOCH0)
    for x in sl["rows"]:
        if 1 <= x["true"] <= 365 and math.isfinite(x["lo90"]):
            assert (x["hi90"] - x["lo90"]) == pytest.approx(x["line_width"], rel=0.1)
    rows = [dict(x) for x in s["rows"]]
    rows[0].update(lo90=math.nan, hi90=math.nan, true=10.0)  # no interval: a miss, infinitely wide
    t = trial_summary(rows)
    assert t["no_interval"] == 1 + s["no_interval"] - (1 if math.isnan(s["rows"][0]["lo90"]) else 0)


def test_coverage_standard_error_counts_joints_not_nights():
    from jointwear_ros.trend.backtest import _cluster_se

    # two joints, all nights in or all out: pooled 50 %, and the error of two samples, however many nights
    assert _cluster_se([(1000, 1000), (1000, 0)]) == pytest.approx(0.5, rel=1e-9)
    assert _cluster_se([(10, 10), (10, 0)]) == pytest.approx(0.5, rel=1e-9)
    assert _cluster_se([(50, 45)] * 10) == pytest.approx(0.0, abs=1e-12)
    assert math.isnan(_cluster_se([(50, 45)])) and math.isnan(_cluster_se([(50, 45), (0, 0)]))


@settings(max_examples=30, deadline=None)
@given(st.floats(0.0, 34.0), st.floats(-0.2, 0.5), st.floats(1e-5, 1e-2), st.floats(0.01, 2.0), st.floats(0.001, 0.1))
def test_crossing_probability_never_falls_with_the_days_ahead(level, rate, q, level_sd, rate_sd):
    """Wear does not come back down: once the alarm is likely by tau it stays so later, although the random-walk
    member's Gaussian P(wear(tau) >= alarm) falls back towards 1/2 far ahead (its variance grows as tau^3)."""
    from jointwear_ros.trend import crossing_cdf
    from jointwear_ros.trend.alarm import tau_grid

    cfg = TrendConfig()
    tau = tau_grid(cfg.max_horizon_days)
    F = crossing_cdf(np.array([[level, rate]]), np.diag([level_sd ** 2, rate_sd ** 2])[None], q, cfg, tau)[0]
    assert np.all(np.diff(F) >= 0.0)
    var = level_sd ** 2 + (rate_sd * tau) ** 2 + q * tau ** 3 / 3
    gauss = 0.5 * (1 + np.vectorize(math.erf)((level + rate * tau - cfg.alarm) / np.sqrt(2 * var)))
    assert F == pytest.approx(np.maximum.accumulate(gauss), abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 6), st.integers(1, 12), st.integers(0, 2 ** 31 - 1))
def test_type2_weights_maximize_the_marginal_likelihood_of_the_histories(m, n, seed):
    """The empirical-Bayes member weights: a distribution at which no member's share can grow the marginal
    likelihood sum_j log sum_m pi_m L_jm (the optimum's condition), whatever prior the posteriors were made with."""
    from jointwear_ros.trend import type2_weights

    rng = np.random.default_rng(seed)
    lik = np.exp(rng.normal(0, 3, (n, m)))
    prior = rng.dirichlet(np.ones(m))
    post = lik * prior
    post /= post.sum(axis=1, keepdims=True)
    pi = type2_weights(post, prior)
    assert pi.sum() == pytest.approx(1.0) and (pi >= 0).all()
    grad = (lik / (lik @ pi)[:, None]).mean(axis=0)  # d/d pi_m of the mean log-likelihood
    assert grad.max() <= 1.0 + 1e-2  # = 1 where pi_m > 0, <= 1 where pi_m = 0

    def objective(p):
        return float(np.log(lik @ p).sum())

    assert objective(pi) >= max(objective(prior), objective(np.full(m, 1.0 / m))) - 1e-9
