"""Issue 11 shapes: ripple at any frequency with harmonics, step, B-spline, scaled terms.

Analytic parameter gradients against central differences, the spec grammar
(round trip, clear errors on hostile input), and recovery of a known shape.
"""

from __future__ import annotations

import random
import string

import numpy as np
import pytest

from jointwear_ros.errors import JointwearError, ModelError
from jointwear_ros.model.shapes import Step
from jointwear_ros.model.specs import resolve_term
from jointwear_ros.workbench import HarmonicRipple, Spline, fit_model, parse_spec

RNG = np.random.default_rng(7)
N = 60
INPUTS = {
    "speed": RNG.uniform(0.0, 250.0, N),
    "load_torque": RNG.uniform(0.02, 0.5, N),
    "temperature": RNG.uniform(25.0, 55.0, N),
    "position": RNG.uniform(-2.5, 2.5, N),
    "time": RNG.uniform(0.0, 40 * 86400.0, N),
    "hours_running": RNG.uniform(0.0, 8.0, N),
}

SPECS = [
    "ripple(position, w0=17.2)",
    "ripple(position, w0=3, k=3)",
    "step(time, at=1500000, width=30000)",
    "spline(hours_running, lo=0, hi=8, n=6)",
    "scale(load_stribeck, temperature)",
    "scale(temp_viscous, load_torque)",
    "scale(stribeck, temperature, load_torque)",
]


def _values(term) -> dict[str, float]:
    """A point away from zero for every parameter (amplitudes too, so shape derivatives are not zero)."""
    out = {}
    for ps in term.params:
        v = ps.default if ps.default != 0.0 else 0.003
        if term.name.startswith("step") and ps.name.endswith("_s"):
            v = 5 * 86400.0
        out[ps.name] = v
    return out


@pytest.mark.parametrize("spec", SPECS)
def test_shape_parameter_gradients_match_central_differences(spec):
    term = resolve_term(spec)
    assert term is not None
    p = _values(term)
    grad = term.param_gradient(INPUTS, p)
    assert list(grad) == list(term.param_names)
    for name in term.param_names:
        h = 1e-6 * max(1.0, abs(p[name]))
        hi, lo = dict(p), dict(p)
        hi[name] += h
        lo[name] -= h
        fd = (term.value(INPUTS, hi) - term.value(INPUTS, lo)) / (2 * h)
        scale = max(float(np.max(np.abs(fd))), 1e-12)
        np.testing.assert_allclose(grad[name], fd, rtol=1e-5, atol=1e-6 * scale, err_msg=f"{spec}: {name}")


@pytest.mark.parametrize("spec", SPECS)
def test_shape_spec_round_trips_through_the_model_spec(spec):
    model = parse_spec(f"paper + {spec}")
    assert model.term_names[-1] == spec
    again = parse_spec(model.spec)
    assert again.spec == model.spec
    assert again.param_names == model.param_names


def test_ripple_without_options_keeps_the_issue_3_names():
    t = resolve_term("ripple(position)")
    assert isinstance(t, HarmonicRipple) and t.name == "ripple(position)"
    assert t.param_names == ("ripple_position_a", "ripple_position_b", "ripple_position_w")


def test_scale_reshapes_the_stribeck_amplitude_like_one_plus_a_x():
    # Fs*S(v; vs) + x*Fs'*S(v; vs) == Fs*(1 + (Fs'/Fs)*x)*S(v; vs)
    model = parse_spec("stribeck + scale(stribeck, temperature)")
    p = {"Fs": 0.03, "vs": 20.0, "scale_stribeck_temperature_Fs": 0.03 * 0.01, "scale_stribeck_temperature_vs": 20.0}
    v, T = INPUTS["speed"], INPUTS["temperature"]
    expect = 0.03 * (1 + 0.01 * T) * np.exp(-np.abs(v / 20.0) ** 1.3)
    np.testing.assert_allclose(model.evaluate(p, speed=v, temperature=T), expect, rtol=1e-12)


def test_spline_basis_leaves_out_the_constant_and_clips_outside_its_range():
    t = Spline("x", lo=0.0, hi=1.0, n=5)
    b = t.basis(np.array([-1.0, 0.0, 0.5, 1.0, 2.0]))
    assert b.shape == (5, 4)
    np.testing.assert_allclose(b[0], b[1])  # clipped to lo
    np.testing.assert_allclose(b[-1], b[-2])  # clipped to hi
    assert np.all(b[1] == 0.0)  # at lo only the left-out first basis function is non-zero


def test_step_fit_recovers_a_known_level_change():
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0.0, 100.0, 300))
    y = 0.05 + np.where(t > 62.0, -0.006, 0.0) + rng.normal(0.0, 0.0015, t.size)
    from jointwear_ros.types import ObservationTable

    table = ObservationTable({"speed": np.full(t.size, 10.0), "tau_f": y, "time": t})
    fit = fit_model(parse_spec("coulomb + step(time, at=55, width=2)"), table, cv_folds=0)
    assert fit.success, fit.message
    a, c = fit.params["step_time_a"], fit.params["step_time_c"]
    assert abs(a.value + 0.006) < 4 * fit.stderr("step_time_a")
    assert abs(c.value - 62.0) < 1.0
    # the width is at most the one given: a gradual change is a spline's job
    assert fit.params["step_time_s"].value <= 2.0


def test_step_width_is_bounded_by_the_option_so_a_held_out_cycle_next_to_the_change_stays_on_its_side():
    spec = {p.name: p for p in Step("time", at=55.0, width=2.0).params}
    assert spec["step_time_s"].default == 2.0 and spec["step_time_s"].max == 2.0 and spec["step_time_s"].min > 0
    # cycles one day apart, a level change between day 6 and 7; one cycle held out per fold
    rng = np.random.default_rng(5)
    day = np.repeat(np.arange(12.0), 10)
    y = 0.05 + np.where(day > 6.5, -0.006, 0.0) + rng.normal(0.0, 0.0015, day.size)
    from jointwear_ros.types import ObservationTable

    table = ObservationTable({"speed": np.full(day.size, 10.0), "tau_f": y, "time": day + rng.uniform(0, 0.02, day.size),
                              "cycle": day})
    fit = fit_model(parse_spec("coulomb + step(time, at=6.5, width=0.12)"), table, cv_folds=12)
    assert fit.cv_rmse < 1.2 * 0.0015


def test_ripple_fit_started_at_the_right_frequency_finds_a_fast_ripple():
    rng = np.random.default_rng(4)
    pos = rng.uniform(-2.5, 2.5, 400)
    y = 0.05 + 0.003 * np.sin(17.0 * pos + 0.3) + rng.normal(0.0, 0.0015, pos.size)
    from jointwear_ros.types import ObservationTable

    table = ObservationTable({"speed": np.full(pos.size, 10.0), "tau_f": y, "position": pos})
    fit = fit_model(parse_spec("coulomb + ripple(position, w0=16.9)"), table, cv_folds=0)
    w = fit.params["ripple_position_w"]
    assert abs(w.value - 17.0) < 4 * fit.stderr("ripple_position_w") + 1e-3
    amp = np.hypot(fit.params["ripple_position_a"].value, fit.params["ripple_position_b"].value)
    assert abs(amp - 0.003) < 0.0005


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("ripple(position, k=9)", "k=9 harmonics"),
        ("ripple(position, k=1.5)", "must be a whole number"),
        ("ripple(position, w0=-1)", "w0=-1.0 must be in"),
        ("ripple(position, q=1)", "unknown option(s) q"),
        ("ripple(position, w0=abc)", "is not a number"),
        ("ripple(w0=3, position)", "after an option"),
        ("ripple(position, w0=1, w0=2)", "given twice"),
        ("step(time)", "needs the option at=VALUE"),
        ("step(time, at=1, width=0)", "width=0.0 must be > 0"),
        ("spline(x, lo=1, hi=1)", "must be below hi"),
        ("spline(x, lo=0, hi=1, n=2)", "n=2 basis functions"),
        ("scale(nosuch, temperature)", "'nosuch' is not a built-in term"),
        ("scale(stribeck)", "takes a term name and one or two column names"),
        ("scale(stribeck, a, b, c)", "one or two column names"),
        ("ripple(tau_f, w0=3)", "is the measured friction"),
        ("spline(x, lo=0, hi=inf)", "not a finite number"),
    ],
)
def test_bad_shape_specs_give_a_clear_model_error(spec, message):
    with pytest.raises(ModelError, match=message.replace("(", r"\(").replace(")", r"\)").replace(".", r"\.")):
        parse_spec(f"paper + {spec}")


def test_hostile_spec_strings_never_crash_with_anything_but_a_model_error():
    rng = random.Random(11)
    alphabet = string.ascii_letters + string.digits + "_(),=+.- *:e"
    pieces = ["ripple(", "step(", "spline(", "scale(", "position", "time", "w0=", "k=", "at=", "lo=", "hi=",
              "n=", ",", ")", "+", "stribeck", "1e308", "nan", "-0", "="]
    for _ in range(600):
        if rng.random() < 0.5:
            text = "".join(rng.choice(pieces) for _ in range(rng.randint(1, 8)))
        else:
            text = "".join(rng.choice(alphabet) for _ in range(rng.randint(1, 30)))
        try:
            parse_spec(text)
        except JointwearError:
            pass


# -- one registry ----------------------------------------------------------------------------------------------
def test_one_registry_holds_every_shape_and_one_ripple():
    from jointwear_ros.model.shapes import CandidateTerm
    from jointwear_ros.workbench import SHAPES

    assert list(SHAPES) == ["lin", "x_stribeck", "x_viscous", "exp_viscous", "inter", "ripple", "step", "spline",
                            "scale"]
    assert SHAPES["ripple"] is HarmonicRipple
    assert [c for c in SHAPES.values() if "ripple" in c.__name__.lower()] == [HarmonicRipple]
    assert all(issubclass(c, CandidateTerm) and c.shape == s for s, c in SHAPES.items())
    # the fixed library's choice is on the shape: the ripple only for angle-like columns, options-only shapes never
    assert [s for s, c in SHAPES.items() if c.offered_for("hours_running")] == ["lin", "x_stribeck", "x_viscous",
                                                                                  "exp_viscous"]
    assert [s for s, c in SHAPES.items() if c.offered_for("position")] == ["lin", "x_stribeck", "x_viscous",
                                                                             "exp_viscous", "ripple"]


@pytest.mark.parametrize("spec", [*SPECS, "lin(x)", "x_stribeck(x)", "x_viscous(x)", "exp_viscous(x)", "inter(x,y)",
                                  "ripple(position)"])
def test_every_shapes_hints_name_its_own_parameters(spec):
    term = resolve_term(spec)
    x = {**INPUTS, "x": RNG.uniform(0.0, 5.0, N), "y": RNG.uniform(1.0, 2.0, N)}
    assert term.linear and set(term.linear) <= set(term.param_names)
    for point in term.guess(x):
        assert set(point) <= set(term.param_names) - set(term.linear)
    assert term.describe_effect() and "{" not in term.describe_effect()


def test_register_shape_adds_a_shape_to_the_grammar_and_refuses_a_taken_name():
    from jointwear_ros.model.shapes import Lin
    from jointwear_ros.workbench import SHAPES, register_shape

    class Doubled(Lin):
        """``2*a*x`` (a test shape)."""

        shape = "jw_test_doubled"

        def value(self, x, p):
            return 2.0 * super().value(x, p)

        def param_gradient(self, x, p):
            return {k: 2.0 * v for k, v in super().param_gradient(x, p).items()}

    try:
        assert register_shape(Doubled) is Doubled and SHAPES["jw_test_doubled"] is Doubled
        model = parse_spec("coulomb + jw_test_doubled(temperature)")
        assert model.term_names[-1] == "jw_test_doubled(temperature)" and model.terms[-1].linear == (
            "jw_test_doubled_temperature_a",)
        assert register_shape(Doubled) is Doubled  # the same class again: no error

        class Other(Lin):
            shape = "jw_test_doubled"

        with pytest.raises(ModelError, match="'jw_test_doubled' is taken by"):
            register_shape(Other)
        with pytest.raises(ModelError, match="not a CandidateTerm subclass"):
            register_shape(int)
    finally:
        SHAPES.pop("jw_test_doubled", None)
    with pytest.raises(ModelError, match="unknown term shape 'jw_test_doubled'"):
        parse_spec("coulomb + jw_test_doubled(temperature)")


def test_an_installed_package_offers_a_shape_through_the_entry_point_group(tmp_path, monkeypatch):
    from jointwear_ros.workbench import SHAPES

    (tmp_path / "jw_test_shapes.py").write_text(
        "from jointwear_ros.model.shapes import Lin\n\n"
        "class Tripled(Lin):\n"
        "    shape = 'jw_test_tripled'\n\n"
        "    def value(self, x, p):\n"
        "        return 3.0 * super().value(x, p)\n", encoding="utf-8")
    dist = tmp_path / "jw_test_shapes-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: jw-test-shapes\nVersion: 1.0\n", encoding="utf-8")
    (dist / "entry_points.txt").write_text("[jointwear.shapes]\njw_test_tripled = jw_test_shapes:Tripled\n",
                                           encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        model = parse_spec("coulomb + jw_test_tripled(temperature)")
        assert type(model.terms[-1]).__name__ == "Tripled" and "jw_test_tripled" in SHAPES
    finally:
        SHAPES.pop("jw_test_tripled", None)
