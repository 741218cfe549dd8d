"""The pure trend core: Kalman bank, time to alarm, levels, segments, revisions; and its proof on a synthetic fleet."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.data.fleet import EPOCH0, ESTIMATOR_NOISE, make_fleet
from jointwear_ros.errors import InputDataError
from jointwear_ros.trend import DAY, TrendConfig, analyze_joint, collapse_revisions, kalman_llt, last_segment
from jointwear_ros.trend.backtest import backtest_joint, score_at_lead, score_fleet
from jointwear_ros.trend.filters import _transition
from jointwear_ros.trend.members import RatePrior

T0 = 1.7e9


def _series(n, rate, w0=10.0, std=0.85, seed=0):
    rng = np.random.default_rng(seed)
    t = T0 + DAY * np.arange(n)
    return t, w0 + rate * np.arange(n) + rng.normal(0, std, n), np.full(n, std)


def test_kalman_filter_recovers_a_linear_rate_with_a_bounded_std():
    t, w, s = _series(120, 0.15)
    f = kalman_llt((t - t[0]) / DAY, w, s, TrendConfig(), q=1e-6)
    level, rate = f.mean[-1]
    assert abs(rate - 0.15) < 3 * math.sqrt(f.cov[-1, 1, 1]) and math.sqrt(f.cov[-1, 1, 1]) < 0.01
    assert abs(level - (10 + 0.15 * 119)) < 3 * math.sqrt(f.cov[-1, 0, 0]) < 1.5


def test_growing_joint_gets_an_interval_holding_the_true_time_and_a_warn_within_the_horizon():
    t, w, s = _series(90, 0.25, w0=10.0)  # true wear 32.25 at the last night: 11 days to 35
    r = analyze_joint(t, w, s)
    assert r.growth_detected and r.level_name == "WARN"
    assert r.time_to_alarm is not None
    assert r.time_to_alarm.lo90 <= 11.0 <= r.time_to_alarm.hi90
    assert r.time_to_alarm.hi90 - r.time_to_alarm.lo90 < 11.0
    assert abs(r.rate_per_day - 0.25) < 3 * r.rate_std


def test_slow_growth_far_from_the_alarm_is_ok_with_a_time_to_alarm():
    r = analyze_joint(*_series(90, 0.05, w0=5.0))  # ~ 9.5 now, 500 days to go
    assert r.level_name == "OK" and r.time_to_alarm is not None
    assert r.time_to_alarm.lo90 > 30.0 and r.time_to_alarm.lo90 <= 510.0


def test_flat_joint_has_no_growth_detected_and_stays_ok():
    r = analyze_joint(*_series(150, 0.0, w0=25.0))
    assert not r.growth_detected and r.time_to_alarm is None and r.level_name == "OK"
    assert "no growth detected" in r.message


def test_wear_at_the_alarm_is_error_with_zero_time_to_alarm():
    r = analyze_joint(*_series(40, 0.1, w0=36.0))
    assert r.level_name == "ERROR" and r.time_to_alarm is not None and r.time_to_alarm.median == 0.0
    r2 = analyze_joint(*_series(40, 0.0, w0=33.0))
    assert r2.level_name != "ERROR"


def test_too_few_estimates_give_no_trend():
    r = analyze_joint(*_series(4, 1.0, w0=20.0))
    assert r.time_to_alarm is None and r.level_name == "OK" and "a trend needs 5" in r.message


def test_maintenance_starts_a_new_segment():
    t, w, s = _series(100, 0.25, w0=5.0)
    w[60:] = 2.0 + np.random.default_rng(1).normal(0, 0.85, 40)  # reducer replaced on day 60
    r = analyze_joint(t, w, s, maintenance_times=[T0 + 59.5 * DAY])
    assert r.segments == 2 and r.estimates == 40 and r.estimates_total == 100
    assert r.level_name == "OK" and r.time_to_alarm is None
    assert analyze_joint(t, w, s).estimates == 100


def test_revisions_of_a_cycle_keep_the_newest_and_restarted_ids_are_kept():
    t = np.array([0.0, 30.0, 86400.0, 86430.0, 2 * 86400.0])
    c = np.array([1, 1, 2, 2, 1])  # cycle 1 revised; cycle 1 again a day later = restarted test_cycle
    assert collapse_revisions(t, c, 3600.0).tolist() == [1, 3, 4]


def test_last_segment_after_the_last_event_before_the_last_estimate():
    t = np.arange(10.0)
    assert last_segment(t, [4.5]) == (5, 4.5, 2)
    assert last_segment(t, [])[0] == 0
    assert last_segment(t, [20.0])[0] == 10  # an event after the last estimate: no estimate in it yet
    assert last_segment(t, [-5.0, 4.5]) == (5, 4.5, 3)


def test_bad_estimates_are_refused_with_the_index():
    t, w, s = _series(10, 0.1)
    w[3] = np.nan
    with pytest.raises(InputDataError, match="estimate 3 is not usable"):
        analyze_joint(t, w, s)
    with pytest.raises(InputDataError, match="accel_noise"):
        TrendConfig(accel_noise=(-1.0,))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1e7), st.floats(-50, 150), st.floats(0.01, 20)), min_size=1, max_size=30))
def test_any_finite_history_gives_a_level_and_ordered_quantiles(rows):
    t = T0 + np.array([r[0] for r in rows])
    r = analyze_joint(t, [x[1] for x in rows], [x[2] for x in rows])
    assert r.level in (0, 1, 2) and math.isfinite(r.wear) and r.wear_std > 0
    if r.time_to_alarm is not None:
        q = r.time_to_alarm
        assert 0 <= q.lo90 <= q.median <= q.hi90


# --------------------------------------------------------------------------- the synthetic fleet (fixed seeds)


@pytest.fixture(scope="module")
def fleet():
    return make_fleet(n_joints=40, days=240, seed=11)


class _Backtests(Sequence):
    """The fleet's nightly backtests (default config), each joint's run once for the module and shared by the
    tests that score them (the quick flat-joint test runs only the flat joints')."""

    def __init__(self, joints):
        self.joints, self.runs = joints, {}

    def __len__(self):
        return len(self.joints)

    def __getitem__(self, i):
        if i not in self.runs:
            self.runs[i] = backtest_joint(self.joints[i], TrendConfig(), EPOCH0)
        return self.runs[i]


@pytest.fixture(scope="module")
def backtests(fleet):
    return _Backtests(fleet)


def test_fleet_has_the_estimators_calibrated_noise_and_known_truth(fleet):
    j = fleet[0]
    resid = np.concatenate([f.wear - f.true for f in fleet])
    assert 0.7 < resid.std() < 1.6
    assert ESTIMATOR_NOISE.std(np.array([20.0]))[0] == pytest.approx(0.86)
    assert j.segment_crossing(0.0) > 0
    assert {f.profile for f in fleet} == {"linear", "accelerating", "flat", "maintained"}


@pytest.mark.slow
def test_interval_holds_the_true_time_to_alarm_for_most_growing_joints_and_is_narrower_than_it(fleet, backtests):
    """Issue 13's acceptance: at the night each growing joint's true time to alarm reaches the horizon."""
    cfg = TrendConfig()
    s = score_at_lead(fleet, cfg, EPOCH0, lead_days=cfg.horizon_days, backtests=backtests)
    assert s["joints"] >= 15
    assert s["coverage"] >= 0.80, s
    assert s["median_width_over_true"] <= 1.0, s


def test_no_flat_joint_ever_warns(fleet, backtests):
    flat = [i for i, j in enumerate(fleet) if j.profile == "flat"]
    assert len(flat) == 10
    for i in flat:
        b = backtests[i]
        assert (b.level == 0).all(), (fleet[i].robot, fleet[i].joint, int((b.level > 0).sum()))


@pytest.mark.slow
def test_fleet_scores_are_in_their_targets(fleet, backtests):
    s = score_fleet(fleet, TrendConfig(), EPOCH0, 240, backtests=backtests)
    assert s["coverage"] >= 0.85, s
    assert s["false_per_1000"] <= 1.0, s
    assert s["joints_missed"] == 0 and s["median_lead_days"] > 10.0, s
    assert abs(s["median_lag_days"]) < 5.0, s


def _kalman_on_matrices(t, y, r, cfg, q, order, prior):
    """The filter of :func:`kalman_llt` written on numpy matrices (its form before the plain-float one)."""
    var = np.asarray(r, float) ** 2
    m = np.zeros(order)
    m[0], m[1] = cfg.level_prior_mean, prior.mean
    P = np.diag([cfg.level_prior_std ** 2, prior.std ** 2, cfg.accel_prior_std ** 2][:order])
    means, covs, lls, total = [], [], [], 0.0
    for k in range(len(t)):
        if k > 0:
            F, Q = _transition(max(t[k] - t[k - 1], 0.0), order, q, cfg.level_noise)
            m = F @ m
            P = F @ P @ F.T + Q
        s_ = P[0, 0] + var[k]
        v = y[k] - m[0]
        total += -0.5 * (math.log(2 * math.pi * s_) + v * v / s_)
        K = P[:, 0] / s_
        m = m + K * v
        P = P - np.outer(K, P[0, :])
        P = 0.5 * (P + P.T)
        means.append(m)
        covs.append(P)
        lls.append(total)
    return means, covs, lls


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 40), st.sampled_from([2, 3]), st.sampled_from([1e-6, 1e-4, 1e-2]))
def test_the_plain_float_filter_is_the_matrix_filter(seed, n, order, q):
    """Irregular steps (repeated times included), a rate prior, both orders: each state, covariance and
    log-likelihood equal to the matrix form's to rounding (relative to each step's largest entry)."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0.0, 400.0, n))
    t[n // 2] = t[max(n // 2 - 1, 0)]
    y, r = rng.normal(20.0, 5.0, n), rng.uniform(0.5, 3.0, n)
    cfg = TrendConfig()
    prior = RatePrior(mean=float(rng.normal(0.0, 0.1)), std=float(rng.uniform(0.01, 1.0)))
    got = kalman_llt(t, y, r, cfg, q, order, prior)
    means, covs, lls = _kalman_on_matrices(t, y, r, cfg, q, order, prior)
    assert got.mean.shape == (n, order) and got.cov.shape == (n, order, order) and got.loglik.shape == (n,)
    for k in range(n):
        for a, b in ((got.mean[k], means[k]), (got.cov[k], covs[k])):
            assert np.max(np.abs(a - b)) <= 1e-11 * np.max(np.abs(b))
        assert got.loglik[k] == pytest.approx(lls[k], rel=1e-12, abs=1e-12)
