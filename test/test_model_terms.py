"""The friction model core: MODEL.md's check values, derivatives, composition."""

from __future__ import annotations

import numpy as np
import pytest

from jointwear_ros.errors import ModelError, ParameterError, ParameterSetError
from jointwear_ros.model import (
    TERMS,
    Coulomb,
    Model,
    Viscous,
    available_parameter_sets,
    load_parameter_set,
    load_parameter_set_info,
    paper_wear_model,
    parse_model_spec,
)

SPEEDS = np.array([0, 10, 25, 47, 80, 150, 280], dtype=float)

# MODEL.md "Check values (ref-2011r, wear parameters as above)"
CHECK_TABLE = [
    ((40, 0.1, 0), [0.07900, 0.07498, 0.07148, 0.07277, 0.08127, 0.10823, 0.16198]),
    ((40, 0.1, 35), [0.11085, 0.10447, 0.09628, 0.09072, 0.09092, 0.10839, 0.15694]),
    ((30, 0.1, 0), [0.06900, 0.06737, 0.06790, 0.07436, 0.08860, 0.12397, 0.19148]),
    ((50, 0.1, 0), [0.08900, 0.08312, 0.07638, 0.07337, 0.07708, 0.09774, 0.14221]),
    ((40, 0.5, 0), [0.13500, 0.11351, 0.09786, 0.09686, 0.10527, 0.13223, 0.18598]),
]


@pytest.fixture(scope="module")
def ref() -> dict[str, float]:
    return load_parameter_set("ref-2011r").valuesdict()


@pytest.mark.parametrize(("cond", "expected"), CHECK_TABLE)
def test_reference_model_reproduces_model_md_check_table(cond, expected, ref):
    T, tm, w = cond
    tau = paper_wear_model().evaluate(ref, speed=SPEEDS, load_torque=tm, temperature=T, wear=w)
    np.testing.assert_allclose(tau, expected, atol=1e-5, rtol=0)


def test_check_table_evaluates_vectorised_in_one_call(ref):
    T = np.array([c[0][0] for c in CHECK_TABLE], dtype=float)[:, None]
    tm = np.array([c[0][1] for c in CHECK_TABLE])[:, None]
    w = np.array([c[0][2] for c in CHECK_TABLE], dtype=float)[:, None]
    tau = paper_wear_model().evaluate(ref, speed=SPEEDS[None, :], load_torque=tm, temperature=T, wear=w)
    assert tau.shape == (5, 7)
    np.testing.assert_allclose(tau, [c[1] for c in CHECK_TABLE], atol=1e-5, rtol=0)


def test_wear_35_raises_friction_at_47_by_the_papers_0017(ref):
    m = paper_wear_model()
    d = m.evaluate(ref, v=47.0, tau_m=0.1, T=40.0, w=35.0) - m.evaluate(ref, v=47.0, tau_m=0.1, T=40.0, w=0.0)
    assert d == pytest.approx(0.0179, abs=2e-4)


def test_paper_printed_set_differs_only_in_fsw_and_gives_ten_times_the_increase():
    ref = load_parameter_set("ref-2011r").valuesdict()
    printed = load_parameter_set("paper-printed").valuesdict()
    assert {k for k in ref if ref[k] != printed[k]} == {"Fsw"}
    m = paper_wear_model()
    d = m.evaluate(printed, v=47.0, tau_m=0.1, T=40.0, w=35.0) - m.evaluate(printed, v=47.0, tau_m=0.1, T=40.0, w=0.0)
    assert d == pytest.approx(0.187, abs=2e-3)


def test_components_sum_to_the_total_and_are_named_by_term(ref):
    m = paper_wear_model()
    inputs = dict(speed=SPEEDS, load_torque=0.3, temperature=45.0, wear=20.0)
    comps = m.components(ref, **inputs)
    assert list(comps) == m.term_names
    np.testing.assert_allclose(sum(comps.values()), m.evaluate(ref, **inputs), rtol=1e-12)


def _random_inputs(rng: np.random.Generator, n: int = 50) -> dict[str, np.ndarray]:
    return dict(
        speed=np.concatenate([[0.0, 0.5], rng.uniform(1.0, 280.0, n - 2)]),
        load_torque=rng.uniform(0.05, 0.8, n) * rng.choice([-1, 1], n),
        temperature=rng.uniform(22.0, 58.0, n),
        wear=np.concatenate([[0.0, 35.0], rng.uniform(0.5, 100.0, n - 2)]),
    )


@pytest.mark.parametrize("name", sorted(TERMS))
def test_every_term_parameter_gradient_matches_finite_differences(name, ref):
    term = TERMS[name]()
    p = {s.name: ref.get(s.name, s.default) for s in term.params}
    x = _random_inputs(np.random.default_rng(1))
    analytic = term.param_gradient(x, p)
    assert set(analytic) == set(term.param_names)
    for pn in term.param_names:
        h = 1e-6 * max(abs(p[pn]), 1e-3)
        hi, lo = dict(p), dict(p)
        hi[pn] += h
        lo[pn] -= h
        numeric = (term.value(x, hi) - term.value(x, lo)) / (2 * h)
        np.testing.assert_allclose(analytic[pn], numeric, rtol=1e-5, atol=1e-9, err_msg=f"{name}.{pn}")


@pytest.mark.parametrize("name", sorted(TERMS))
@pytest.mark.parametrize("var", ["wear", "temperature", "load_torque"])
def test_every_term_input_gradient_matches_finite_differences(name, var, ref):
    term = TERMS[name]()
    p = {s.name: ref.get(s.name, s.default) for s in term.params}
    x = _random_inputs(np.random.default_rng(2))
    if var == "wear":  # the w -> 0 limit is one-sided; test it separately
        x["wear"] = np.maximum(x["wear"], 0.5)
    h = 1e-5
    hi, lo = dict(x), dict(x)
    hi[var] = x[var] + h
    lo[var] = x[var] - h
    numeric = (term.value(hi, p) - term.value(lo, p)) / (2 * h)
    np.testing.assert_allclose(term.input_gradient(x, p, var), numeric, rtol=1e-5, atol=1e-9)


def test_wear_derivative_at_zero_wear_is_the_one_sided_limit(ref):
    m = paper_wear_model()
    v = np.array([0.0, 5.0, 47.0])
    d = m.input_gradient("w", ref, speed=v, load_torque=0.1, temperature=40.0, wear=0.0)
    h = 1e-7
    fwd = (m.evaluate(ref, speed=v, load_torque=0.1, temperature=40.0, wear=h)
           - m.evaluate(ref, speed=v, load_torque=0.1, temperature=40.0, wear=0.0)) / h
    np.testing.assert_allclose(d, fwd, rtol=1e-4, atol=1e-9)
    assert np.all(np.isfinite(d))


def test_model_jacobian_has_one_column_per_parameter_and_matches_gradients(ref):
    m = paper_wear_model()
    x = _random_inputs(np.random.default_rng(3), 20)
    J = m.jacobian(ref, **x)
    assert J.shape == (20, len(m.param_names))
    g = m.param_gradient(ref, ["vs0"], **x)
    np.testing.assert_array_equal(J[:, m.param_names.index("vs0")], g["vs0"])


def test_terms_compose_with_plus_and_print_back_as_spec():
    m = Coulomb() + Viscous()
    assert isinstance(m, Model)
    assert m.spec == "coulomb + viscous"
    assert parse_model_spec(m.spec).term_names == m.term_names
    assert (m + parse_model_spec("stribeck")).spec == "coulomb + viscous + stribeck"
    assert sum([Coulomb(), Viscous()]).spec == "coulomb + viscous"


@pytest.mark.parametrize(
    ("spec", "n_terms"), [("standard", 3), ("paper", 5), ("paper+wear", 7), ("paper + wear", 7), ("paper + wear_viscous", 6)]
)
def test_named_model_specs_expand_to_their_terms(spec, n_terms):
    assert len(parse_model_spec(spec).terms) == n_terms


@pytest.mark.parametrize(
    ("spec", "match"),
    [("", "empty"), ("paper + nonsense", "unknown term 'nonsense'"), ("coulomb + coulomb", "twice"), ("coulomb + ", "malformed")],
)
def test_bad_model_specs_are_refused_with_a_clear_message(spec, match):
    with pytest.raises(ModelError, match=match):
        parse_model_spec(spec)


def test_parameter_name_clash_between_terms_is_an_error():
    class MyCoulomb(Coulomb):
        name = "my_coulomb"

    with pytest.raises(ModelError, match="clash.*Fc0"):
        Coulomb() + MyCoulomb()


def test_missing_input_and_missing_parameter_are_clear_errors(ref):
    m = paper_wear_model()
    with pytest.raises(ModelError, match="needs input.*wear"):
        m.evaluate(ref, speed=1.0, load_torque=0.1, temperature=40.0)
    with pytest.raises(ParameterError, match="missing parameter.*Fsw"):
        m.evaluate({k: v for k, v in ref.items() if k != "Fsw"}, speed=1.0, load_torque=0.1, temperature=40.0, wear=1.0)


def test_parameters_carry_units_and_bounds_from_the_terms():
    p = paper_wear_model().make_params(load_parameter_set("ref-2011r"))
    assert p["vs0"].unit == "rad/s" and p["vs0"].value == 30.0
    assert p["FsT"].unit == "1/degC"
    assert all(q.in_bounds() for q in p.values())
    assert p.free() == list(p)


def test_parameter_sets_are_listed_and_unknown_ones_name_the_known():
    assert {"ref-2011r", "paper-printed"} <= set(available_parameter_sets())
    with pytest.raises(ParameterSetError, match="unknown parameter set 'nope'.*ref-2011r"):
        load_parameter_set("nope")
    info = load_parameter_set_info("ref-2011r")
    assert info.valid["temperature"] == (20.0, 60.0)


# -- the workbench hints each term carries (linear parameters, starting points, meaning) -------------------
_HINT_X = {
    "speed": np.linspace(0.5, 250.0, 40),
    "load_torque": np.linspace(0.02, 0.5, 40),
    "temperature": np.linspace(20.0, 60.0, 40),
    "wear": np.linspace(1.0, 60.0, 40),
}


@pytest.mark.parametrize("name", sorted(TERMS))
def test_every_term_is_linear_in_the_parameters_it_names_and_only_in_those_it_could(name):
    term = TERMS[name]()
    p = {ps.name: ps.default for ps in term.params}
    assert all(v != 0 for v in p.values())  # an amplitude at 0 would hide its shape parameters' nonlinearity
    assert set(term.linear) <= set(term.param_names)
    g0 = term.param_gradient(_HINT_X, p)
    for k in term.param_names:
        moved = term.param_gradient(_HINT_X, {**p, k: p[k] * 1.7 + 0.01})
        # a linear parameter's Jacobian column does not move with it; a nonlinear one's does
        same = np.allclose(moved[k], g0[k], rtol=1e-9, atol=1e-14)
        assert same == (k in term.linear), f"{name}: {k} linear is {k in term.linear}, the gradient says {same}"


@pytest.mark.parametrize("name", sorted(TERMS))
def test_every_terms_starting_points_name_only_its_nonlinear_parameters_and_move_with_the_datas_speed(name):
    term = TERMS[name]()
    assert set(term.relative) == set(term.param_names)  # and a start and bounds relative to the data's levels
    paper = term.guess(_HINT_X)
    assert paper == term.start_points(_HINT_X)  # data at the paper's scale keep the numbers as written
    for point in paper:
        assert set(point) <= set(term.param_names) - set(term.linear)
    joint_side = term.guess({**_HINT_X, "speed": _HINT_X["speed"] / 100.0})
    for a, b in zip(paper, joint_side, strict=True):
        for k, v in a.items():
            assert b[k] == pytest.approx(v * 0.01 ** term.dimension(k).speed)
    if term.candidate:  # the diagnosis lists it with its meaning, and it has something to fit
        assert term.meaning and term.describe_effect() == term.meaning
        assert term.linear
