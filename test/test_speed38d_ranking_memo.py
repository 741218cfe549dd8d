"""A second ranking of the same residual against another noise floor redoes only the nested tests (issue 29, item 6).

``diagnose`` ranks the columns against the noise floor and, when the residual is above it, again against the
scatter between sweeps; the permuted designs do not depend on the floor, so the second ranking takes them from
the first (``residual_dependence(memo=...)``) and must give what a ranking of its own gives.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np

from jointwear_ros.data import NOISE_STD, synth_observations
from jointwear_ros.workbench import fit_model, parse_spec, residual_dependence
from jointwear_ros.workbench.fit import model_inputs
from jointwear_ros.workbench.residual_tests import ResidualSpace


def _same(a, b) -> bool:
    return [asdict(x) for x in a] == [asdict(x) for x in b]


def test_a_second_noise_floor_reuses_the_permuted_designs_and_gives_the_same_ranking(monkeypatch):
    table = synth_observations(n_cycles=12, seed=5, effects=["load_viscous"], irrelevant=2)
    fit = fit_model(parse_spec("paper"), table, cv_folds=0)
    tangent = fit.model.jacobian(fit.params, fit.free, **model_inputs(fit.model, table))
    components = fit.model.components(fit.params, **model_inputs(fit.model, table))
    kw = {"tangent": tangent, "components": components, "seed": 3}
    alone = {nf: residual_dependence(table, fit.residuals, noise=nf, **kw) for nf in (NOISE_STD, 2.5 * NOISE_STD)}
    assert not _same(alone[NOISE_STD], alone[2.5 * NOISE_STD])  # the floor changes the ranking's p-values

    batches = []
    in_sse = ResidualSpace.in_sse

    def counted(self, d):
        if d.shape[0] > 1:
            batches.append(d.shape[0])
        return in_sse(self, d)

    monkeypatch.setattr(ResidualSpace, "in_sse", counted)
    memo: dict = {}
    first = residual_dependence(table, fit.residuals, noise=NOISE_STD, memo=memo, **kw)
    solved = len(batches)
    assert solved and memo
    batches.clear()
    second = residual_dependence(table, fit.residuals, noise=2.5 * NOISE_STD, memo=memo, **kw)
    # only the pair the screen picks against the new floor, when it is another one, is solved again
    assert len(batches) < solved / 4
    assert _same(first, alone[NOISE_STD]) and _same(second, alone[2.5 * NOISE_STD])
    # another residual in the same memo is not mistaken for the first
    other = residual_dependence(table, np.asarray(fit.residuals)[::-1].copy(), noise=NOISE_STD, memo=memo, **kw)
    assert batches and _same(other, residual_dependence(table, np.asarray(fit.residuals)[::-1].copy(),
                                                        noise=NOISE_STD, **kw))
