"""The temperature priors' own uniform and normal laws give what scipy.stats gives, and estimating loads no
scipy.stats (it costs a wear_estimator's start about 0.9 s of CPU on a 2-core EPYC)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats
from scipy.special import chdtrc

from jointwear_ros.estimation.priors import NormalLaw, UniformLaw, _gauss_legendre_01, normal_prior, uniform_prior

SETTINGS = settings(max_examples=100, deadline=None, derandomize=True)
locs = st.floats(-273.0, 1e4, allow_nan=False)
scales = st.floats(1e-6, 1e4, allow_nan=False)
#: probabilities with the edges and those outside [0, 1] drawn often
probs = st.one_of(st.sampled_from([0.0, 1.0, -0.1, 1.1, 1e-300, 1 - 1e-16, np.nan]), st.floats(0.0, 1.0))
points = st.one_of(st.sampled_from([np.inf, -np.inf, np.nan]), st.floats(-1e5, 1e5))


def _same(a, b) -> None:
    np.testing.assert_allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=1e-13, atol=0.0,
                               equal_nan=True)


@pytest.mark.parametrize("mine_of, ref_of", [(NormalLaw, stats.norm), (UniformLaw, stats.uniform)],
                         ids=["normal", "uniform"])
@SETTINGS
@given(locs, scales, st.lists(probs, min_size=1, max_size=5), st.lists(points, min_size=1, max_size=5))
def test_the_law_is_scipys(mine_of, ref_of, loc, scale, q, x):
    mine, ref = mine_of(loc, scale), ref_of(loc=loc, scale=scale)
    _same(mine.ppf(q), ref.ppf(q))
    _same(mine.cdf(x), ref.cdf(x))
    _same(mine.logpdf(x), ref.logpdf(x))
    _same(mine.pdf(x), ref.pdf(x))
    _same([mine.mean(), mine.std()], [ref.mean(), ref.std()])
    _same(mine.ppf(q[0]), ref.ppf(q[0]))  # a scalar in, a scalar out
    assert np.ndim(mine.ppf(q[0])) == 0 and np.ndim(mine.cdf(x[0])) == 0


def test_the_priors_use_them_and_their_quadrature_is_unchanged():
    for prior, ref in ((uniform_prior(30, 50), stats.uniform(30, 20)), (normal_prior(40, 3), stats.norm(40, 3))):
        t, w = prior.quadrature(64)
        _same(t, ref.ppf(_gauss_legendre_01(64)[0]))
        _same([prior.mean, prior.std], [ref.mean(), ref.std()])
        _same(prior.support(), ref.interval(1.0 - 1e-9))
        assert abs(w.sum() - 1.0) < 1e-12


@SETTINGS
@given(st.floats(0.0, 1e4), st.integers(1, 500))
def test_the_fit_probability_is_scipys_chi2_tail(chi2, dof):
    _same(chdtrc(dof, chi2), stats.chi2.sf(chi2, dof))


def test_an_estimate_loads_no_scipy_stats():
    code = (
        "import sys, json\n"
        "from jointwear_ros.estimation import make_estimator\n"
        "from jointwear_ros.data.synth import synth_observations\n"
        "obs = synth_observations(1, speeds=(10, 40, 80, 160, 240), model='paper+wear', wear=30.0, seed=1)\n"
        "out = {}\n"
        "for method in ('paper', 'bayes', 'joint'):\n"
        "    out[method] = float(make_estimator(method).estimate(obs).wear)\n"
        "print(json.dumps({'stats': 'scipy.stats' in sys.modules, 'wear': out}))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["stats"] is False
    assert all(abs(w - 30.0) < 15.0 for w in d["wear"].values()), d
