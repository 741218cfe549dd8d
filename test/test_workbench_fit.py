"""Fitting model specs to observations: recovery of known parameters, honest standard errors,
fixed parameters, non-convergence as a result, AIC/BIC, cross-validation grouped by cycle,
and user terms loaded by dotted path or entry point."""

from __future__ import annotations

import math
import re
import textwrap

import numpy as np
import pytest

from jointwear_ros.data import NOISE_STD, synth_observations
from jointwear_ros.errors import ModelError
from jointwear_ros.model import load_parameter_set
from jointwear_ros.types import ObservationTable
from jointwear_ros.workbench import diagnose, fit_model, group_folds, parse_spec
from jointwear_ros.workbench.fit import information_criteria

STANDARD_TRUTH = {"Fc0": 0.05, "Fs": 0.03, "vs": 15.0, "Fv": 3.0e-4}
SPEEDS = np.array([1.0, 3.0, 6.0, 10.0, 15.0, 22.0, 32.0, 47.0, 70.0, 110.0, 170.0, 250.0])


def standard_table(seed: int, cycles: int = 20, extra: float = 0.0) -> ObservationTable:
    """Observations of the standard model (known truth) plus ``extra * v^2``, noise sigma_e."""
    rng = np.random.default_rng(seed)
    v = np.tile(SPEEDS, cycles)
    y = parse_spec("standard").evaluate(STANDARD_TRUTH, speed=v) + extra * v**2
    y = y + rng.normal(0.0, NOISE_STD, v.size)
    return ObservationTable(
        {"speed": v, "tau_f": y, "tau_f_std": np.full(v.size, NOISE_STD),
         "cycle": np.repeat(np.arange(cycles, dtype=float), SPEEDS.size)},
        source=f"standard-seed{seed}",
    )


@pytest.fixture(scope="module")
def paper_table() -> ObservationTable:
    return synth_observations(n_cycles=40, seed=3)


def test_fit_recovers_the_paper_parameters_within_their_standard_errors(paper_table):
    truth = load_parameter_set("ref-2011r").valuesdict()
    model = parse_spec("paper")
    # start away from the truth: every parameter scaled by 0.7 or 1.4
    start = {n: truth[n] * (1.4 if i % 2 else 0.7) for i, n in enumerate(model.param_names)}
    fit = fit_model(model, paper_table, start, cv_folds=0)
    assert fit.success, fit.message
    assert fit.n == 400 and fit.n_free == len(model.param_names)
    assert 0.8 * NOISE_STD < fit.rmse < 1.2 * NOISE_STD
    for name in model.param_names:
        se = fit.stderr(name)
        assert 0 < se < abs(truth[name]), (name, se)
        z = (fit.params[name].value - truth[name]) / se
        assert abs(z) < 4.0, (name, fit.params[name].value, truth[name], se)


def test_standard_errors_match_the_spread_of_estimates_over_seeds():
    names = list(STANDARD_TRUTH)
    est, se = [], []
    for seed in range(40):
        fit = fit_model(parse_spec("standard"), standard_table(seed), cv_folds=0)
        assert fit.success, fit.message
        est.append([fit.params[n].value for n in names])
        se.append([fit.stderr(n) for n in names])
    est_a, se_a = np.array(est), np.array(se)
    spread = est_a.std(axis=0, ddof=1)
    for i, n in enumerate(names):
        assert 0.7 < spread[i] / se_a[:, i].mean() < 1.4, (n, spread[i], se_a[:, i].mean())
        bias = est_a[:, i].mean() - STANDARD_TRUTH[n]
        assert abs(bias) < 4.0 * spread[i] / math.sqrt(len(est)), (n, bias)


def test_correlations_are_reported_for_free_parameters():
    fit = fit_model(parse_spec("standard"), standard_table(0), cv_folds=0)
    assert fit.free == ["Fc0", "Fs", "vs", "Fv"]
    assert fit.correlations.shape == (4, 4)
    np.testing.assert_allclose(np.diag(fit.correlations), 1.0)
    np.testing.assert_allclose(fit.correlations, fit.correlations.T, atol=1e-12)
    assert fit.correlation("Fc0", "Fv") < -0.3  # level and slope trade off
    d = fit.to_dict()
    assert d["correlations"]["Fc0"]["Fv"] == pytest.approx(fit.correlation("Fc0", "Fv"))


def test_fixed_parameters_keep_their_value_and_the_rest_is_refitted(paper_table):
    model = parse_spec("paper")
    free_fit = fit_model(model, paper_table, cv_folds=0)
    fit = fit_model(model, paper_table, {"Tv0": 25.0, "vsT": 0.25}, fixed=("Tv0", "vsT"), cv_folds=0)
    assert fit.params["Tv0"].value == 25.0 and fit.params["vsT"].value == 0.25
    assert not fit.params["Tv0"].vary and fit.params["Tv0"].stderr is None
    assert fit.n_free == free_fit.n_free - 2
    assert "Tv0" not in fit.free and "vsT" not in fit.free
    assert fit.success and fit.rmse < 1.1 * NOISE_STD  # true values fixed: still fits
    # AIC counts free parameters only
    assert fit.aic == pytest.approx(information_criteria(fit.ssr, fit.n, fit.n_free)[0])
    # a wrong fixed value costs accuracy, and the others move to compensate
    bad = fit_model(model, paper_table, {"Tv0": 60.0}, fixed=("Tv0",), cv_folds=0)
    assert bad.params["Tv0"].value == 60.0
    assert bad.rmse > fit.rmse
    # the vary flag of a Parameters object works the same way
    p = model.make_params(load_parameter_set("ref-2011r"))
    p.set_vary(["Tv0", "vsT"], False)
    via_flag = fit_model(model, paper_table, p, cv_folds=0)
    assert via_flag.n_free == fit.n_free
    assert via_flag.rmse == pytest.approx(fit.rmse, rel=1e-6)


def test_non_convergence_returns_a_result_not_an_exception(paper_table):
    model = parse_spec("paper")
    far = {n: 1.0 for n in ("vstm", "vs0", "Tv0")}
    fit = fit_model(model, paper_table, far, n_starts=1, max_nfev=2, cv_folds=5)
    assert fit.success is False
    assert "evaluations" in fit.message or "max_nfev" in fit.message
    assert math.isfinite(fit.rmse) and math.isfinite(fit.cv_rmse)
    assert fit.to_dict()["success"] is False


def test_a_term_that_evaluates_to_nan_gives_an_unsuccessful_result(tmp_path, monkeypatch):
    (tmp_path / "jw_nan_term.py").write_text(textwrap.dedent("""
        import numpy as np
        from jointwear_ros.model import ParamSpec, Term

        class Broken(Term):
            name = "broken"
            variables = ("speed",)
            params = (ParamSpec("Fb", "-", 0.01, -1.0, 1.0),)
            equation = "nan"

            def value(self, x, p):
                return np.full(np.shape(x["speed"]), np.nan)
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    fit = fit_model(parse_spec("standard + jw_nan_term:Broken"), standard_table(0))
    assert fit.success is False
    assert fit.message
    assert not math.isfinite(fit.rmse)


def test_aic_and_bic_follow_the_gaussian_formula_and_bic_prefers_the_true_model():
    table = standard_table(1)
    true = fit_model(parse_spec("standard"), table, cv_folds=0)
    n, k = true.n, true.n_free
    assert true.aic == pytest.approx(n * math.log(true.ssr / n) + 2 * k)
    assert true.bic == pytest.approx(n * math.log(true.ssr / n) + k * math.log(n))
    too_small = fit_model(parse_spec("coulomb + viscous"), table, cv_folds=0)
    too_big = fit_model(parse_spec("standard + x_stribeck(cycle)"), table, cv_folds=0)
    assert true.bic < too_small.bic and true.bic < too_big.bic
    assert too_big.ssr <= true.ssr  # more parameters never fit worse ...
    assert too_big.n_free == k + 2  # ... but pay for them


def test_folds_keep_every_test_cycle_together():
    table = synth_observations(n_cycles=12, seed=0)
    folds = group_folds(table, k=5)
    assert set(np.unique(folds)) == {0, 1, 2, 3, 4}
    for _, cyc in table.groups("cycle"):
        idx = np.flatnonzero(np.isin(table["cycle"], cyc["cycle"]))
        assert np.unique(folds[idx]).size == 1
    # fewer cycles than folds: as many folds as cycles; no cycle column: rows are the groups
    assert np.unique(group_folds(synth_observations(n_cycles=3, seed=0), k=5)).size == 3
    no_cycle = ObservationTable({"speed": SPEEDS, "tau_f": SPEEDS})
    f = group_folds(no_cycle, k=4)
    assert np.unique(f).size == 4 and np.bincount(f).tolist() == [3, 3, 3, 3]


def test_cross_validated_residuals_are_predictions_for_held_out_cycles():
    table = standard_table(2, cycles=10)
    model = parse_spec("coulomb + viscous")  # linear: each fold's refit has a closed form
    folds = group_folds(table, k=5)
    fit = fit_model(model, table, folds=folds)
    assert fit.cv_residuals is not None
    v, y = table.speed, table.tau_f
    design = np.column_stack([np.ones_like(v), v])
    expected = np.empty_like(y)
    for f in np.unique(folds):
        test = folds == f
        coef, *_ = np.linalg.lstsq(design[~test], y[~test], rcond=None)
        expected[test] = design[test] @ coef - y[test]
    np.testing.assert_allclose(fit.cv_residuals, expected, atol=1e-7)
    assert fit.cv_rmse == pytest.approx(float(np.sqrt(np.mean(expected**2))), rel=1e-5)
    assert fit.cv_rmse > fit.rmse
    assert math.isnan(fit_model(model, table, cv_folds=0).cv_rmse)


USER_TERM = textwrap.dedent('''
    """A user's own friction term: quadratic drag."""
    import numpy as np
    from jointwear_ros.model import ParamSpec, Term

    class Quadratic(Term):
        """Quadratic drag ``Fq * v^2`` (Fq in s^2/rad^2)."""

        name = "quadratic"
        variables = ("speed",)
        params = (ParamSpec("Fq", "s2/rad2", 0.0, -1.0, 1.0, "quadratic drag"),)
        equation = "Fq*v^2"

        def value(self, x, p):
            return p["Fq"] * np.abs(x["speed"]) ** 2
''')


@pytest.fixture
def user_term_module(tmp_path, monkeypatch):
    (tmp_path / "jw_user_terms.py").write_text(USER_TERM)
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def test_user_term_loaded_by_dotted_path_is_fitted_and_found(user_term_module):
    table = standard_table(4, extra=2.0e-7)
    spec = "standard + jw_user_terms:Quadratic"
    fit = fit_model(parse_spec(spec), table)
    assert fit.spec == "coulomb + stribeck + viscous + jw_user_terms:Quadratic"
    assert parse_spec(fit.spec).param_names == fit.model.param_names  # the spec round-trips
    assert fit.success
    assert abs(fit.params["Fq"].value - 2.0e-7) < 4.0 * fit.stderr("Fq")
    # offered to diagnose as an extra candidate, it is the effect that is missing
    diag = diagnose(table, "standard", extra_terms=[parse_spec("jw_user_terms:Quadratic").terms[0]])
    assert diag.candidates[0].term == "jw_user_terms:Quadratic"
    assert diag.missing_effect_found


def test_user_term_registered_as_an_entry_point_is_found_by_name(user_term_module):
    dist = user_term_module / "jw_user_terms-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: jw-user-terms\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[jointwear.terms]\nquad_drag = jw_user_terms:Quadratic\n")
    model = parse_spec("standard + quad_drag")
    assert model.term_names[-1] == "quad_drag"
    assert "Fq" in model.param_names


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("standard + nosuch", "unknown term 'nosuch'"),
        ("standard + wobble(position)", "unknown term shape 'wobble'"),
        ("standard + jw_missing_module:Thing", "cannot import module 'jw_missing_module'"),
        ("standard + math:pi", "is not a jointwear_ros.model.Term subclass"),
        ("standard + lin(tau_f)", "is the measured friction"),
        ("standard + inter(load_torque)", "takes 2 column name(s)"),
        ("standard + (", "malformed model spec"),
    ],
)
def test_bad_model_specs_raise_a_model_error_naming_the_problem(spec, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        parse_spec(spec)
