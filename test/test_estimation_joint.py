"""Joint wear and temperature estimation over the speeds of one cycle (one shared unknown T)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from test_estimation_paper import MODEL, PARAMS, friction, table

from jointwear_ros.errors import InputDataError
from jointwear_ros.estimation import make_estimator
from jointwear_ros.estimation._common import log_sum_exp
from jointwear_ros.estimation.crb import crb_multi_speed
from jointwear_ros.estimation.joint import JointEstimator
from jointwear_ros.types import ObservationTable, WearEstimator

SPEEDS = np.array([0.0, 20.0, 40.0, 60.0, 100.0, 150.0])


@pytest.mark.parametrize(("w0", "t0"), [(35.0, 40.0), (10.0, 28.0), (60.0, 52.0), (80.0, 33.0)])
def test_noise_free_observations_give_back_true_wear_and_temperature(w0, t0):
    obs = table(SPEEDS, friction(SPEEDS, w0, t0))
    res = JointEstimator(point="map").estimate(obs)
    assert res.wear == pytest.approx(w0, abs=1e-3)
    assert res.temperature == pytest.approx(t0, abs=1e-2)
    mean = JointEstimator().estimate(obs)
    assert mean.wear == pytest.approx(w0, abs=0.35)
    assert mean.temperature == pytest.approx(t0, abs=0.8)
    assert mean.wear_low < w0 < mean.wear_high
    assert 0.0 < mean.wear_std < 1.5 and 0.0 < mean.temperature_std < 2.0


def test_measured_temperature_fixes_t_and_gives_back_true_wear():
    tau = friction(SPEEDS, 35.0, 44.0)
    res = JointEstimator(point="map").estimate(table(SPEEDS, tau, temperature=44.0))
    assert res.wear == pytest.approx(35.0, abs=1e-4)
    assert res.temperature == 44.0 and res.temperature_std == 0.0
    assert res.info["prior"] == "measured"
    np.testing.assert_allclose(res.per_speed_wear, 35.0, atol=1.0 / 32.0)
    # a measurement on some rows only: the cycle's T is their mean
    part = JointEstimator(point="map").estimate(table(SPEEDS, tau, temperature=[44.0] + [np.nan] * 5))
    assert part.wear == pytest.approx(35.0, abs=1e-4)
    # the measurement can be ignored on request
    unk = JointEstimator(use_temperature=False).estimate(table(SPEEDS, tau, temperature=44.0))
    assert unk.info["prior"] != "measured" and unk.temperature_std > 0


def test_joint_estimator_is_built_by_the_factory_and_follows_the_protocol():
    est = make_estimator("joint", prior="uniform:30:50", noise_std=0.002)
    assert isinstance(est, WearEstimator) and est.name == "joint"
    res = est.estimate(table(SPEEDS, friction(SPEEDS, 35.0, 41.0)))
    assert res.method == "joint" and len(res.per_speed_wear) == SPEEDS.size
    assert res.to_dict()["temperature"] == pytest.approx(res.temperature)


def test_spread_of_estimates_is_near_the_multi_speed_bound_and_unbiased():
    rng = np.random.default_rng(11)
    runs = 200
    temps = rng.uniform(25.0, 55.0, runs)
    tau = friction(SPEEDS[None, :], 35.0, temps[:, None]) + rng.normal(0.0, 0.0015, (runs, SPEEDS.size))
    out = JointEstimator().estimate_arrays(SPEEDS, 0.1, tau)
    bound_std = np.sqrt(crb_multi_speed(MODEL, PARAMS, SPEEDS, 35.0))
    std = out["wear"].std(ddof=1)
    # sampling error of a std from 200 runs is ~5 %; of a mean ~0.06
    assert 0.8 * bound_std < std < 1.25 * bound_std
    assert abs(out["wear"].mean() - 35.0) < 0.25
    # the reported posterior std is calibrated
    assert out["wear_std"].mean() == pytest.approx(std, rel=0.2)
    assert np.abs(out["temperature"] - temps).mean() < 2.0


def test_bimodal_likelihood_keeps_both_modes():
    # at 100 rad/s the wear term first falls (viscous part) then rises: a friction just below
    # the unworn value is explained by a small w and by a larger one
    v = np.array([100.0])
    w = np.linspace(0.0, 100.0, 20001)
    g = friction(v[0], w) - friction(v[0], 0.0)
    z = 0.5 * g.min()
    roots = w[np.flatnonzero(np.diff(np.sign(g - z)))]
    assert roots.size == 2
    est = JointEstimator(point="map", noise_std=2e-5)
    res = est.estimate(table(v, friction(v, 0.0) + z, temperature=40.0))
    assert res.info["posterior_modes"] == 2
    assert min(abs(res.wear - r) for r in roots) < 0.05
    assert res.wear_low <= roots[0] + 0.1 and res.wear_high >= roots[1] - 0.1


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"point": "median"}, "point"),
        ({"prior": "weird:1"}, "temperature distribution"),
        ({"noise_std": -1.0}, "noise_std"),
        ({"wear_step": 0.0}, "wear_step"),
        ({"wear_range": (10.0, 5.0)}, "wear_range"),
        ({"n_temperature": 1}, "n_temperature"),
    ],
)
def test_joint_estimator_rejects_bad_options(kwargs, match):
    with pytest.raises(InputDataError, match=match):
        JointEstimator(**kwargs)


def test_joint_estimator_rejects_bad_observations():
    est = JointEstimator()
    with pytest.raises(InputDataError, match="empty"):
        est.estimate(table([], []))
    with pytest.raises(InputDataError, match="negative"):
        est.estimate(table([-5.0, 40.0], [0.1, 0.1]))
    with pytest.raises(InputDataError, match="not finite"):
        est.estimate(table([5.0, 40.0], [np.nan, 0.1]))
    with pytest.raises(InputDataError, match="load_torque"):
        est.estimate(ObservationTable.from_arrays(speed=[40.0], tau_f=[0.1]))
    with pytest.raises(InputDataError, match="columns"):
        est.estimate_arrays(SPEEDS, 0.1, np.zeros((3, 2)))


CELL_SPEEDS = np.array([20.0, 40.0, 45.0, 55.0, 65.0, 80.0, 120.0, 160.0])


@pytest.mark.parametrize("true_t", [20.0, 62.0])
def test_a_joint_outside_the_temperature_prior_is_called_unexplained_not_a_confident_wrong_wear(true_t):
    """A cell at 20 degC (below the default prior U(25, 55)) pins T at the prior's edge and biases w: the
    fit says so and widens the std by the Birge ratio, so the truth lies within 3 std again."""
    rng = np.random.default_rng(7)
    tau = friction(CELL_SPEEDS, 30.0, true_t) + rng.normal(0.0, 0.0015, CELL_SPEEDS.size)
    res = JointEstimator(noise_std=0.0015).estimate(table(CELL_SPEEDS, tau))
    assert res.info["fit_p"] < 1e-3
    assert res.info["temperature_at_prior_edge"] is True
    assert "unexplained" in res.info["misfit"] and "edge of its prior" in res.info["misfit"]
    assert abs(res.wear - 30.0) <= 3.0 * res.wear_std, (res.wear, res.wear_std)
    assert res.wear_low <= 30.0 <= res.wear_high
    # the same cycle with the temperature measured: T is no longer assumed, the model explains it
    known = JointEstimator(noise_std=0.0015).estimate(table(CELL_SPEEDS, tau, temperature=true_t))
    assert known.info["fit_p"] > 1e-3 and "misfit" not in known.info
    assert abs(known.wear - 30.0) <= 3.0 * known.wear_std


def test_a_cycle_the_model_explains_keeps_its_std_and_says_nothing():
    rng = np.random.default_rng(3)
    tau = friction(CELL_SPEEDS, 30.0, 40.0) + rng.normal(0.0, 0.0015, CELL_SPEEDS.size)
    est = JointEstimator(noise_std=0.0015)
    res = est.estimate(table(CELL_SPEEDS, tau))
    assert res.info["fit_dof"] == CELL_SPEEDS.size - 2 and res.info["fit_p"] > 1e-3
    assert "misfit" not in res.info and "temperature_at_prior_edge" not in res.info
    post = est.posterior(CELL_SPEEDS, 0.1, tau, 0.0015)
    assert res.wear_std == pytest.approx(max(post.wear_std, 1.0 / 32.0 / np.sqrt(12.0)))


@given(est=st.floats(0.0, 100.0), a=st.floats(0.0, 100.0), b=st.floats(0.0, 100.0), scale=st.floats(0.5, 50.0))
def test_a_widened_interval_contains_the_old_one_and_stays_in_the_wear_range(est, a, b, scale):
    from jointwear_ros.estimation.joint import widen_interval

    low, high = min(a, b), max(a, b)
    lo, hi = widen_interval(est, low, high, scale, (0.0, 100.0))
    assert 0.0 <= lo <= low <= high <= hi <= 100.0


def test_the_estimators_on_a_set_take_model_noise_and_wear_range_from_one_place():
    # joint, bayes and paper took their model and set by three hand-written copies, and joint and bayes checked
    # noise_std and wear_range by two more: one base and two checks in _common now serve them all
    from jointwear_ros.estimation import BayesEstimator, PaperEstimator
    from jointwear_ros.estimation._common import SetModelBase, check_noise_std, check_wear_range

    for cls in (JointEstimator, BayesEstimator, PaperEstimator):
        est = cls(MODEL, PARAMS, noise_std=0.002)
        assert isinstance(est, SetModelBase)
        assert est.params.valuesdict() == PARAMS.valuesdict() and est.param_set is None
        assert est.full_model.spec == est.model.spec == MODEL.spec and est.extra is None and est.noise_std == 0.002
    assert check_noise_std(0.002) == 0.002 and check_wear_range((0, 80)) == (0.0, 80.0)
    for cls in (JointEstimator, BayesEstimator):
        with pytest.raises(InputDataError, match=r"^noise_std = 0\.0 must be a positive number \(normalized torque\)$"):
            cls(MODEL, PARAMS, noise_std=0.0)
        with pytest.raises(InputDataError, match=r"^wear_range = \(5\.0, 5\.0\): needs finite low < high$"):
            cls(MODEL, PARAMS, wear_range=(5.0, 5.0))


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 6), st.integers(1, 9)), elements=st.floats(-700.0, 700.0)),
       st.sampled_from([0, 1]), st.booleans())
def test_log_sum_exp_is_scipys_on_arrays_with_a_finite_maximum(a, axis, overwrite):
    from scipy.special import logsumexp

    want = logsumexp(a, axis=axis)
    given_a = a.copy()
    got = log_sum_exp(given_a, axis=axis, overwrite=overwrite)
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    if not overwrite:
        np.testing.assert_array_equal(given_a, a)  # the input is left as it was
