"""The paper's estimator, Eq. (10)-(11): fast and grid implementations, inputs, reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from jointwear_ros.errors import InputDataError
from jointwear_ros.estimation import PaperEstimator, PaperGridEstimator, WearInverse, make_estimator
from jointwear_ros.model import load_parameter_set, paper_wear_model
from jointwear_ros.types import ObservationTable, WearEstimator, WearResult

MODEL = paper_wear_model()
PARAMS = MODEL.make_params(load_parameter_set("ref-2011r"))
SPEEDS = np.array([0.0, 10.0, 25.0, 40.0, 47.0, 80.0, 120.0, 150.0])


def friction(speed, wear=35.0, temperature=40.0, load=0.1):
    return MODEL.evaluate(PARAMS, speed=speed, load_torque=load, temperature=temperature, wear=wear)


def table(speed, tau, temperature=None, load=0.1):
    cols = dict(speed=speed, tau_f=tau, load_torque=load)
    if temperature is not None:
        cols["temperature"] = temperature
    return ObservationTable.from_arrays(**cols)


@pytest.mark.parametrize("method", ["paper", "paper-grid"])
def test_noise_free_observation_with_measured_temperature_gives_back_true_wear(method):
    # above the wear term's turning point (where g_v(w0) > 0) the minimiser is unique; one estimator for the
    # four wears (its inverse per speed is built once), so a table kept from an earlier call must not leak into the next
    est = make_estimator(method, seed=0)
    for w0 in (0.0, 35.0, 50.0, 70.0):
        res = est.estimate(table(SPEEDS, friction(SPEEDS, w0), temperature=40.0))
        tol = 1e-6 if method == "paper" else 0.05 + 1e-9
        np.testing.assert_allclose(res.per_speed_wear, w0, atol=tol)
        assert isinstance(res, WearResult) and res.method == method


def test_estimators_satisfy_the_common_protocol():
    for method in ("paper", "paper-grid"):
        est = make_estimator(method, seed=1)
        assert isinstance(est, WearEstimator)
        assert est.name == method


def test_fast_and_grid_agree_within_grid_resolution_sample_by_sample():
    # speeds where g_v has a unique minimiser for these data (at higher speeds a z just below 0
    # has two exact minimisers: the fast one takes the smaller, the grid whichever grid point is nearer)
    speeds = np.array([0.0, 10.0, 25.0, 40.0, 47.0, 60.0])
    rng = np.random.default_rng(7)
    temps = rng.normal(40, 3, speeds.size)
    tau = friction(speeds, 35.0, temps) + rng.normal(0, 0.0015, speeds.size)
    fast = PaperEstimator(rng=np.random.default_rng(3), n_samples=50)
    grid = PaperGridEstimator(rng=np.random.default_rng(3), n_samples=50, grid_step=0.1)
    u = np.random.default_rng(3).random((speeds.size, 50))
    for i, v in enumerate(speeds):
        a = fast._solve_sampled(float(v), 0.1, tau[i:i + 1], u[i:i + 1])
        b = grid._solve_sampled(float(v), 0.1, tau[i:i + 1], u[i:i + 1])
        np.testing.assert_allclose(a, b, atol=0.05 + 1e-3)  # half a grid step + table error
    wf, _ = fast.estimate_rows(speeds, 0.1, tau)
    wg, _ = grid.estimate_rows(speeds, 0.1, tau)
    np.testing.assert_allclose(wf, wg, atol=0.05)


def test_tabulated_inverse_matches_exact_solution_and_model():
    for v in (0.0, 47.0, 280.0):
        inv = WearInverse(MODEL, PARAMS, v)
        z = np.random.default_rng(1).uniform(inv.z_nodes[0], inv.z_nodes[-1], 20000)
        err = np.abs(inv(z) - inv.exact(z))
        assert np.percentile(err, 99.5) < 1e-3
        assert err.max() < 0.2
        w = inv.exact(z)
        # an exact solution is a minimiser: no grid point does better
        grid = np.linspace(0, 100, 2001)
        best = np.min(np.abs(z[:200, None] - inv.g(grid)[None, :]), axis=1)
        assert np.all(np.abs(z[:200] - inv.g(w[:200])) <= best + 1e-12)
        # g is the model's wear effect
        np.testing.assert_allclose(inv.g(grid), friction(v, grid) - friction(v, 0.0), atol=1e-15)


def test_unknown_temperature_uses_the_uniform_samples_and_is_reproducible():
    tau = friction(SPEEDS, 35.0, 43.0)
    a = make_estimator("paper", seed=11).estimate(table(SPEEDS, tau))
    b = make_estimator("paper", seed=11).estimate(table(SPEEDS, tau))
    c = make_estimator("paper", seed=12).estimate(table(SPEEDS, tau))
    assert a.per_speed_wear == b.per_speed_wear
    assert a.per_speed_wear != c.per_speed_wear
    assert a.info["n_samples"] == 200 and a.info["temperature_range"] == [30.0, 50.0]
    assert all(s > 0 for s in a.info["per_speed_sample_std"])
    assert 30 < a.wear < 40 and 0 < a.wear_std < 10
    assert a.wear_low <= a.wear <= a.wear_high


def test_measured_temperature_rows_and_unknown_rows_mix():
    temps = np.array([np.nan, 40.0, np.nan, 45.0])
    sp = np.array([25.0, 40.0, 47.0, 80.0])
    tau = friction(sp, 20.0, np.nan_to_num(temps, nan=40.0))
    res = make_estimator("paper", seed=2).estimate(table(sp, tau, temperature=temps))
    assert res.info["known_temperature"] == [False, True, False, True]
    assert res.per_speed_wear[1] == pytest.approx(20.0, abs=1e-6)
    assert res.per_speed_wear[3] == pytest.approx(20.0, abs=1e-6)


@pytest.mark.parametrize("method", ["paper", "paper-grid"])
@pytest.mark.parametrize(
    ("cols", "message"),
    [
        (dict(speed=[], tau_f=[], load_torque=[]), "empty"),
        (dict(speed=[40.0, 50.0], tau_f=[0.09, np.nan], load_torque=[0.1, 0.1]), r"row 1 .*tau_f nan is not finite"),
        (dict(speed=[-40.0], tau_f=[0.09], load_torque=0.1), r"row 0: speed -40 is negative"),
        (dict(speed=[np.inf], tau_f=[0.09], load_torque=0.1), "not finite"),
        (dict(speed=[40.0], tau_f=[0.09]), "load_torque' is missing"),
        (dict(speed=[40.0], tau_f=[0.09], load_torque=[np.nan]), "load_torque nan is not finite"),
    ],
)
def test_bad_input_raises_input_data_error_with_a_clear_message(method, cols, message):
    with pytest.raises(InputDataError, match=message):
        make_estimator(method, seed=0).estimate(ObservationTable(cols))


def test_factory_rejects_unknown_method_and_bad_options():
    with pytest.raises(InputDataError, match="unknown wear estimation method 'nope'"):
        make_estimator("nope")
    with pytest.raises(InputDataError, match="temperature_range"):
        make_estimator("paper", temperature_range=(50, 30))
    with pytest.raises(InputDataError, match="estimator 'paper'"):
        make_estimator("paper", bogus_option=1)


def test_default_load_option_fills_a_missing_load_column():
    tau = friction(np.array([40.0]), 35.0, 40.0, load=0.1)
    res = make_estimator("paper", default_load=0.1).estimate(
        ObservationTable.from_arrays(speed=[40.0], tau_f=tau, temperature=[40.0]))
    assert res.wear == pytest.approx(35.0, abs=1e-6)


def test_make_estimator_names_an_unknown_option_and_keeps_a_real_type_error():
    """A caller's wrong option is InputDataError (exit 2); a TypeError inside an estimator is not disguised."""
    with pytest.raises(InputDataError, match="takes no option frobnicate"):
        make_estimator("joint", frobnicate=1)
    with pytest.raises(TypeError):  # a wrongly typed value reaches the constructor and fails there, unmapped
        make_estimator("paper-grid", grid_step="coarse")
