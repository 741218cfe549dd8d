"""The model package after the layering: a term's start grid moves to the data as the scaling module moves it.

``Term.guess`` (in ``model/model.py``, below the terms) scales its start points with ``dimensions.scale_factor``
so that it does not import ``model/scaling.py`` (which sits above the terms); these tests hold the two ways to
one answer, and the names that moved down from the workbench to one object each.
"""

from __future__ import annotations

import numpy as np
import pytest

from jointwear_ros import model, workbench
from jointwear_ros.model import TERMS, parse_spec
from jointwear_ros.model.scaling import DataScales, scale_grid


def _same_grid(got: list[dict[str, float]], want: list[dict[str, float]]) -> bool:
    return len(got) == len(want) and all(g == pytest.approx(w, rel=1e-12) for g, w in zip(got, want, strict=True))


SPEEDS = [np.array([0.01, 0.5]), np.array([0.02, 2.5]), np.array([2.0, 250.0]), np.array([100.0, 9000.0])]


@pytest.mark.parametrize("name", sorted(TERMS))
@pytest.mark.parametrize("speed", SPEEDS, ids=lambda s: f"max{s.max():g}")
def test_a_terms_guess_is_its_start_grid_scaled_as_the_scaling_module_scales_it(name, speed):
    term = TERMS[name]()
    x = {"speed": speed}
    expected = scale_grid(term, term.start_points(x), DataScales.of(speed=speed))
    assert _same_grid(term.guess(x), expected), (term.guess(x), expected)


@pytest.mark.parametrize("spec", ["ripple(position, w0=3)", "x_stribeck(lube_hours)", "step(time, at=5, width=1)"])
def test_a_shapes_guess_is_its_start_grid_scaled_as_the_scaling_module_scales_it(spec):
    term = parse_spec(f"coulomb + {spec}").terms[-1]
    x = {"speed": np.array([0.01, 0.4]), "position": np.linspace(0, 6, 2), "lube_hours": np.array([1.0, 9.0]),
         "time": np.array([0.0, 10.0])}
    expected = scale_grid(term, term.start_points(x), DataScales.of(speed=x["speed"]))
    assert _same_grid(term.guess(x), expected), (term.guess(x), expected)


def test_the_workbench_offers_the_models_registry_and_resolver_not_copies():
    assert workbench.SHAPES is model.SHAPES
    assert workbench.parse_spec is model.parse_spec and workbench.resolve_term is model.resolve_term
    assert workbench.register_shape is model.register_shape
