"""The Cramér-Rao bound, Eq. (13)-(14): closed forms, consistency between methods, bad inputs."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest
from scipy import integrate, stats

from jointwear_ros.errors import InputDataError
from jointwear_ros.estimation.crb import (
    crb_known_temperature,
    crb_multi_speed,
    crb_per_speed,
    fisher_information,
)
from jointwear_ros.estimation.priors import normal_prior, uniform_prior
from jointwear_ros.model import Coulomb, Model, ParamSpec, Term, load_parameter_set, paper_wear_model

SIGMA = 0.0015


class LinWear(Term):
    """(a0 + a1 v) w: linear in wear."""

    name = "lin_wear"
    variables = ("speed", "wear")
    params: ClassVar[tuple[ParamSpec, ...]] = (ParamSpec("a0", "-", 9e-4, -1, 1, ""), ParamSpec("a1", "-", -3e-6, -1, 1, ""))
    equation = "(a0 + a1 v) w"

    def value(self, x, p):  # type: ignore[no-untyped-def]
        v = np.asarray(x["speed"], dtype=float)
        return (p["a0"] + p["a1"] * v) * np.asarray(x["wear"], dtype=float)


class LinTemp(Term):
    """(b0 + b1 v) T: linear in temperature."""

    name = "lin_temp"
    variables = ("speed", "temperature")
    params: ClassVar[tuple[ParamSpec, ...]] = (ParamSpec("b0", "-", 1e-3, -1, 1, ""), ParamSpec("b1", "-", -1e-5, -1, 1, ""))
    equation = "(b0 + b1 v) T"

    def value(self, x, p):  # type: ignore[no-untyped-def]
        v = np.asarray(x["speed"], dtype=float)
        return (p["b0"] + p["b1"] * v) * np.asarray(x["temperature"], dtype=float)


def _linear() -> tuple[Model, dict[str, float]]:
    m = Coulomb() + LinWear() + LinTemp()
    return m, {"Fc0": 0.04, "a0": 9e-4, "a1": -3e-6, "b0": 1e-3, "b1": -1e-5}


def _ab(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return 9e-4 - 3e-6 * v, 1e-3 - 1e-5 * v


REF = (paper_wear_model(), load_parameter_set("ref-2011r"))


def test_bound_equals_closed_form_linear_gaussian_per_speed() -> None:
    m, p = _linear()
    v = np.array([0.0, 30.0, 100.0, 200.0])
    a, b = _ab(v)
    s = 3.0
    expected = (SIGMA**2 + b**2 * s**2) / a**2
    got = crb_per_speed(m, p, v, 35.0, prior=normal_prior(40.0, s), noise_std=SIGMA)
    np.testing.assert_allclose(got, expected, rtol=2e-3)
    # b = 0 at 100 rad/s: T does not matter there, the known-T bound
    assert got[2] == pytest.approx(SIGMA**2 / a[2] ** 2, rel=1e-3)


def test_bound_equals_closed_form_linear_gaussian_shared_temperature() -> None:
    m, p = _linear()
    v = np.array([0.0, 60.0, 200.0])
    a, b = _ab(v)
    s = 3.0
    cov = SIGMA**2 * np.eye(3) + s**2 * np.outer(b, b)
    expected = 1.0 / float(a @ np.linalg.solve(cov, a))
    res = fisher_information(m, p, v, 35.0, prior=normal_prior(40.0, s), shared_temperature=True)
    assert res.bound[0] == pytest.approx(expected, rel=max(1e-2, 5 * float(res.rel_error[0])))
    assert crb_multi_speed(m, p, v, 35.0, prior=normal_prior(40.0, s)) == pytest.approx(float(res.bound[0]))


def test_bound_with_uniform_prior_matches_direct_integral_of_the_marginal() -> None:
    # y = c + a w + b T + e, T ~ U(lo, hi): p(y) is a uniform convolved with a Gaussian
    m, p = _linear()
    lo, hi, v = 30.0, 50.0, 0.0
    a, b = (float(x[0]) for x in _ab(np.array([v])))

    def dens(y: float) -> float:
        x1, x2 = (y - b * lo) / SIGMA, (y - b * hi) / SIGMA  # no cancellation: cdf below the middle, sf above
        d = stats.norm.cdf(x1) - stats.norm.cdf(x2) if x1 + x2 < 0 else stats.norm.sf(x2) - stats.norm.sf(x1)
        return float(d) / (b * (hi - lo))

    def ddens(y: float) -> float:
        return float(stats.norm.pdf((y - b * lo) / SIGMA) - stats.norm.pdf((y - b * hi) / SIGMA)) / (b * (hi - lo) * SIGMA)

    info, _ = integrate.quad(lambda y: ddens(y) ** 2 / max(dens(y), 1e-300), b * lo - 10 * SIGMA, b * hi + 10 * SIGMA,
                             points=[b * lo, b * hi], limit=400, epsabs=0.0, epsrel=1e-10)
    expected = 1.0 / (a**2 * info)
    got = crb_per_speed(m, p, [v], 35.0, prior=uniform_prior(lo, hi))
    assert got[0] == pytest.approx(expected, rel=1e-3)


def test_known_temperature_bound_is_sigma_squared_over_slope_squared() -> None:
    m, p = _linear()
    v = np.array([0.0, 50.0])
    a, _ = _ab(v)
    np.testing.assert_allclose(crb_known_temperature(m, p, v, 35.0), SIGMA**2 / a**2, rtol=1e-6)
    assert crb_known_temperature(m, p, v, 35.0, shared=True) == pytest.approx(SIGMA**2 / float(np.sum(a**2)))


@pytest.mark.parametrize("prior", [uniform_prior(25.0, 55.0), normal_prior(40.0, 3.0)], ids=["uniform", "normal"])
def test_multi_speed_bound_is_at_most_the_best_single_speed_bound(prior: object) -> None:
    m, p = REF
    speeds = [0.0, 20.0, 40.0, 80.0]
    single = crb_per_speed(m, p, speeds, 35.0, prior=prior)  # type: ignore[arg-type]
    multi = crb_multi_speed(m, p, speeds, 35.0, prior=prior)  # type: ignore[arg-type]
    assert multi <= single.min()
    # and at least the known-temperature bound of the same observations
    assert multi >= crb_known_temperature(m, p, speeds, 35.0, shared=True)


def test_multi_speed_bound_of_one_speed_is_the_per_speed_bound() -> None:
    m, p = REF
    assert crb_multi_speed(m, p, [47.0], 35.0) == pytest.approx(float(crb_per_speed(m, p, [47.0], 35.0)[0]))


@pytest.mark.parametrize("prior", [uniform_prior(25.0, 55.0), normal_prior(40.0, 3.0)], ids=["uniform", "normal"])
def test_quadrature_and_monte_carlo_agree_within_the_stated_error(prior: object) -> None:
    m, p = REF
    speeds = [10.0, 45.0, 120.0]
    q = fisher_information(m, p, speeds, 35.0, prior=prior)  # type: ignore[arg-type]
    mc = fisher_information(m, p, speeds, 35.0, prior=prior, method="monte-carlo", n_samples=20_000, seed=4)  # type: ignore[arg-type]
    assert np.all(mc.stderr > 0)
    assert np.all(np.abs(mc.information - q.information) <= 4.0 * mc.stderr)
    # the shared-T bound: quasi-Monte Carlo against plain Monte Carlo
    qs = fisher_information(m, p, speeds, 35.0, prior=prior, shared_temperature=True)  # type: ignore[arg-type]
    ms = fisher_information(m, p, speeds, 35.0, prior=prior, shared_temperature=True, method="monte-carlo", seed=5)  # type: ignore[arg-type]
    assert abs(float(ms.information[0] - qs.information[0])) <= 4.0 * float(np.hypot(ms.stderr[0], qs.stderr[0]))


def test_quadrature_bound_is_insensitive_to_node_counts() -> None:
    m, p = REF
    speeds = [0.0, 47.0, 150.0]
    base = crb_per_speed(m, p, speeds, 35.0, prior=normal_prior(40.0, 3.0))
    fine = crb_per_speed(m, p, speeds, 35.0, prior=normal_prior(40.0, 3.0), n_temperature=500, n_noise=48)
    np.testing.assert_allclose(base, fine, rtol=2e-3)


def test_bound_is_smallest_in_the_papers_speed_region() -> None:
    m, p = REF
    speeds = np.linspace(0.0, 140.0, 15)
    b = crb_per_speed(m, p, speeds, 35.0, prior=normal_prior(40.0, 3.0))
    assert 25.0 <= speeds[int(np.argmin(b))] <= 60.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"speeds": [-1.0]}, "non-negative"),
        ({"speeds": []}, "empty"),
        ({"speeds": [np.nan]}, "finite"),
        ({"noise_std": 0.0}, "noise_std"),
        ({"wear": np.inf}, "wear"),
        ({"method": "simpson"}, "choose one of"),
        ({"n_temperature": 1}, "n_temperature"),
        ({"prior": "triangle:1:2"}, "temperature distribution"),
    ],
)
def test_bound_rejects_bad_inputs_with_a_clear_message(kwargs: dict[str, object], match: str) -> None:
    m, p = REF
    args: dict[str, object] = {"speeds": [40.0], "wear": 35.0}
    args.update(kwargs)
    speeds, wear = args.pop("speeds"), args.pop("wear")
    with pytest.raises(InputDataError, match=match):
        crb_per_speed(m, p, speeds, wear, **args)  # type: ignore[arg-type]
