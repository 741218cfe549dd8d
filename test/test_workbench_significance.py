"""The workbench's significance tests: written once, named, calibrated under the null, and rendered in words."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.workbench import dependence
from jointwear_ros.workbench.dependence import VariableDependence
from jointwear_ros.workbench.render import shape_hint, variable_dict
from jointwear_ros.workbench.significance import guarded, holm, nested_test, permutation_p


def _nested_p_values(rng: np.random.Generator, reps: int, sigma: float, noise: float | None, effect: float = 0.0,
                     n: int = 60, k: int = 3) -> np.ndarray:
    """p-values of adding k random columns to an intercept-and-slope fit, ``reps`` times."""
    out = []
    for _ in range(reps):
        x = rng.uniform(0.0, 1.0, n)
        small = np.column_stack([np.ones(n), x])
        extra = rng.normal(size=(n, k))
        y = 0.3 + 0.5 * x + effect * extra[:, 0] + rng.normal(0.0, sigma, n)
        large = np.column_stack([small, extra])
        sse_small = float(np.sum((y - small @ np.linalg.lstsq(small, y, rcond=None)[0]) ** 2))
        sse = float(np.sum((y - large @ np.linalg.lstsq(large, y, rcond=None)[0]) ** 2))
        out.append(nested_test(sse_small - sse, sse, k, n - large.shape[1], noise).p_value)
    return np.array(out)


@pytest.mark.parametrize(("noise", "method"), [(None, "F"), (0.01, "chi-square")])
def test_the_nested_test_holds_its_level_under_the_null_and_finds_an_effect(noise, method):
    rng = np.random.default_rng(21)
    assert nested_test(1.0, 1.0, 3, 50, noise).method == method
    p = _nested_p_values(rng, 600, 0.01, noise)
    assert 0.03 <= float(np.mean(p < 0.05)) <= 0.075  # 5 % +- 2.5 binomial standard errors
    assert float(np.mean(_nested_p_values(rng, 50, 0.01, noise, effect=0.01) < 0.01)) > 0.9


def test_a_noise_floor_that_is_too_optimistic_cannot_invent_effects():
    # the error variance is max(noise^2, residual variance): a floor a third of the real noise changes nothing
    p = _nested_p_values(np.random.default_rng(22), 600, 0.01, noise=0.01 / 3)
    assert float(np.mean(p < 0.05)) <= 0.08


def test_the_permutation_p_value_is_uniform_under_the_null_and_falls_beyond_the_permutations():
    rng = np.random.default_rng(23)
    p = np.array([permutation_p(float(rng.normal()), rng.normal(size=199)) for _ in range(800)])
    assert 0.03 <= float(np.mean(p <= 0.05)) <= 0.075
    null = rng.gumbel(size=199)
    far = [permutation_p(v, null) for v in (null.max() + 0.5, null.max() + 2.0, null.max() + 5.0)]
    assert far[0] <= 1 / 200 and far[0] > far[1] > far[2] > 0


def test_the_guard_keeps_the_parametric_p_only_when_the_permutations_back_it():
    assert guarded(1e-6, 0.01) == 1e-6
    assert guarded(1e-6, 0.3) == 0.3
    assert guarded(0.4, 0.3) == 0.4


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1.0, allow_nan=False), min_size=1, max_size=30))
def test_holm_never_lowers_a_p_value_keeps_the_order_and_stays_a_probability(p):
    adj = holm(p)
    assert all(a >= b - 1e-15 and 0.0 <= a <= 1.0 for a, b in zip(adj, p, strict=True))
    order = np.argsort(p, kind="stable")
    assert all(adj[i] <= adj[j] + 1e-15 for i, j in itertools.pairwise(order))
    assert adj[int(order[0])] == pytest.approx(min(1.0, len(p) * p[int(order[0])]))


TEST_CLASSES = [dependence.SmootherTest, dependence.ModulationTest, dependence.PeriodogramTest,
                dependence.ChangepointTest, dependence.PairTest, dependence.ScreenTest]


@pytest.mark.parametrize("cls", TEST_CLASSES)
def test_each_named_test_says_its_statistic_its_p_value_and_its_assumptions(cls):
    doc = cls.__doc__ or ""
    assert cls.name and "Assumption" in doc and "p-value" in doc


def test_the_ranking_reports_the_tests_by_their_names():
    from jointwear_ros.data import synth_observations
    from jointwear_ros.workbench import fit_model, parse_spec

    t = synth_observations(n_cycles=12, effects=["ripple"], seed=2)
    fit = fit_model(parse_spec("paper"), t, cv_folds=0)
    names = {c.name for c in TEST_CLASSES}
    dep = dependence.residual_dependence(t, fit.residuals, n_perm=19)
    assert dep and all(set(v.tests) <= names and v.test in names for v in dep)
    top = dep[0]
    assert top.name == "position" and top.shape == "periodic" and shape_hint(top).startswith("periodic in position")


@pytest.mark.parametrize(
    ("fields", "hint"),
    [
        ({"name": "time", "shape": "step", "changepoint": 1234567.891}, "step in time at 1.23457e+06"),
        ({"name": "temperature", "shape": "scales", "scaled_term": "load_stribeck"},
         "scales the model's load_stribeck with temperature"),
        ({"name": "lube_hours", "monotone": "decreasing"}, "smooth in lube_hours, decreasing"),
        ({"name": "load_torque,temperature", "shape": "interaction"}, "interaction of load_torque and temperature"),
        ({"name": "load_torque,motor_temperature", "shape": "adds"}, "motor_temperature adds to load_torque"),
        ({"name": "ambient", "shape": "scales", "scaled_term": "temp_viscous", "speed_dependent": True,
          "speed_region": (100.0, math.inf)}, "scales the model's temp_viscous with ambient, mostly at 100+ rad/s"),
    ],
)
def test_the_renderer_says_the_shape_the_evidence_points_to(fields, hint):
    v = VariableDependence(p_value=0.001, p_raw=0.0001, explained_share=0.3, test="smoother", significant=True,
                           **fields)
    assert shape_hint(v) == hint == variable_dict(v)["shape_hint"]


def test_a_column_s_data_holds_no_sentence_and_the_renderer_s_json_adds_them_in_place():
    v = VariableDependence("ambient", 0.001, 0.0001, 0.3, "smoother", True, shape="scales", scaled_term="temp_viscous",
                           speed_dependent=True, speed_region=(100.0, math.inf))
    data, doc = v.to_dict(), variable_dict(v)
    assert not [x for x in data.values() if isinstance(x, str) and " " in x]  # names and numbers only
    assert "shape_hint" not in data and "label" not in data["speed_region"]
    assert list(doc) == [*list(data)[:3], "shape_hint", *list(data)[3:]]
    assert doc["speed_region"] == {"lo": 100.0, "hi": math.inf, "label": "100+ rad/s"}
    assert {k: x for k, x in doc.items() if k != "shape_hint"} == {**data, "speed_region": doc["speed_region"]}
