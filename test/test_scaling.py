"""One home for fits in the data's units (jointwear_ros.model.scaling): the data's scales, each parameter's
dimension declared on its term, starts and bounds for the workbench and commissioning, the one bound detector."""

from __future__ import annotations

import copy
import pickle
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.model import TERMS, Parameter, Parameters, ParamSpec, Term
from jointwear_ros.model.scaling import (
    RELATIVE,
    BoundHit,
    DataScales,
    data_parameters,
    on_bound,
    scale_grid,
    scale_parameters,
    speed_starts,
)
from jointwear_ros.model.terms import Dimension, param_dimension
from jointwear_ros.workbench import parse_spec


class Ageing(Term):
    """A user term: ``Fa*h``, Fa a torque per hour (unit ``1/h``, which implies no dimension)."""

    name = "ageing"
    variables = ("speed", "hours")
    params = (ParamSpec("Fa", "1/h", 1e-3, 0.0, 1.0, "friction per hour"),)
    dimensions: ClassVar[Mapping[str, Dimension]] = {"Fa": Dimension(torque=1)}

    def value(self, x, p):
        return p["Fa"] * np.asarray(x["hours"], dtype=float) + 0.0 * np.asarray(x["speed"], dtype=float)


def test_every_built_in_parameter_has_one_dimension_and_one_row_of_multipliers():
    names = {s.name for t in TERMS.values() for s in t.params}
    assert set(RELATIVE) == names
    for cls in TERMS.values():
        for s in cls.params:
            assert param_dimension(s.name) == cls().dimension(s.name), s.name
    # a torque per load torque is declared on its term (its unit "-" would say a torque)
    assert param_dimension("Fctm") == Dimension(torque=1, load=-1)
    assert param_dimension("Fvw") == Dimension(torque=1, speed=-1, wear=-1)
    assert param_dimension("Tv0") == Dimension(temperature=1)


def test_one_data_scales_serve_commissioning_levels_and_workbench_decades():
    s = DataScales.of(speed=[0.02, 2.0], tau_f=[10.0, 14.0, 30.0], load_torque=[0.0, 60.0], temperature=[18, 52])
    assert (s.speed, s.torque) == (0.01, 100.0)
    assert s.level(Dimension(torque=1, speed=-1)) == pytest.approx(30.0 / 2.0)
    assert s.level(Dimension(torque=1, load=-1)) == pytest.approx(0.5)
    assert s.factor(Dimension(torque=1, load=-1)) == 1.0 and s.factor(Dimension(torque=1, speed=-1)) == 1e4
    p = data_parameters(["vs0", "Fv0"], s)
    assert p["vs0"].value == pytest.approx(0.1 * 2.0) and p["Fv0"].max == pytest.approx(1e3 * 15.0)
    assert speed_starts(["Fc0", "vs0", "vsT"], s) == [{"vs0": f * 2.0} for f in (0.03, 0.1, 0.3)]
    nothing = DataScales()
    assert nothing.identity and nothing.level(Dimension(torque=1)) == 1.0


@settings(max_examples=20, deadline=None)
@given(exp_t=st.integers(-3, 4), exp_v=st.integers(-3, 2))
def test_a_user_terms_declared_dimension_moves_its_start_and_bounds_with_the_data(exp_t, exp_v):
    model = parse_spec("coulomb + viscous") + Ageing()
    s = DataScales(speed_level=100.0 * 10.0**exp_v, torque_level=0.1 * 10.0**exp_t)
    out, auto = scale_parameters(model, model.make_params(), s)
    assert out["Fa"].value == pytest.approx(1e-3 * 10.0**exp_t) and out["Fa"].max == pytest.approx(10.0**exp_t)
    assert out["Fv"].max == pytest.approx(0.01 * 10.0 ** (exp_t - exp_v))
    assert {"Fa", "Fc0", "Fv"} <= auto
    grid = scale_grid(TERMS["stribeck"](), [{"vs": 20.0}], s)
    assert grid == [{"vs": pytest.approx(20.0 * 10.0**exp_v)}]


def test_a_bound_hit_is_one_type_for_both_fits_reading_as_its_triple():
    p = Parameters([Parameter("a", 0.0, 0.0, 1.0), Parameter("b", 3.0, -1.0, 3.0), Parameter("c", 0.5, 0.0, 1.0)])
    hits = on_bound(p)
    assert hits == [("a", 0.0, 0.0), ("b", 3.0, 3.0)]
    assert [h.side for h in hits] == ["lower", "upper"]
    assert on_bound(p, ["b"]) == [BoundHit("b", 3.0, 3.0, "upper")]
    h = hits[1]
    back = pickle.loads(pickle.dumps(h))
    assert back == h and back.side == "upper" and copy.deepcopy(h).side == "upper"
    assert h.to_dict() == {"name": "b", "value": 3.0, "bound": 3.0, "side": "upper"}
    assert str(h) == "b = 3 on its upper bound 3"
