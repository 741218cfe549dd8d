"""``jointwear model fit`` never shows a parameter past its term's physical bound unflagged.

On data at the paper's scale the terms' bounds are the physical ones a set in the paper's frame is held to, and
the fit widens them tenfold like any bound made by the scaling when it ends on one: on ``cobot-j3`` with a hidden
load-viscous effect and a load that hardly moves (0-0.01), the load Stribeck speed ``vstm`` (physical
[0.1, 500]) came out 637.7 and the fit was called converged. It keeps the data's value (the workbench shows what
the data say), but names it in ``outside_physical``, the message and the text, and is not converged.
"""

from __future__ import annotations

import json

import pytest

from jointwear_ros.cli import main
from jointwear_ros.data import synth_observations
from jointwear_ros.io.tables import write_csv
from jointwear_ros.model import parse_model_spec
from jointwear_ros.model.scaling import DataScales, scale_parameters
from jointwear_ros.types import ObservationTable
from jointwear_ros.units import TableUnits
from jointwear_ros.workbench import fit_model, parse_spec


def _unpinned(effects: list[str]) -> ObservationTable:
    return synth_observations(n_cycles=8, seed=0, params="cobot-j3", temperature=(18, 52), load=(0.0, 0.01),
                              effects=effects)


@pytest.fixture(scope="module")
def unpinned_csv(tmp_path_factory):
    return write_csv(_unpinned(["load_viscous"]), tmp_path_factory.mktemp("bounds") / "obs.csv")


def test_a_parameter_a_widened_bound_let_past_its_physical_bound_is_named_and_the_fit_not_converged(
        unpinned_csv, capsys):
    assert main(["model", "fit", str(unpinned_csv), "--model", "paper", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    vstm = doc["parameters"]["vstm"]["value"]
    assert vstm == pytest.approx(637.747, rel=1e-3) and doc["parameters"]["vstm"]["max"] == 5000.0  # the data's
    assert doc["outside_physical"] == [{"name": "vstm", "value": vstm, "min": 0.1, "max": 500.0}]
    assert doc["converged"] is False and doc["success"] is False  # was True
    assert "outside its physical bounds" in doc["message"] and "vstm = 637.7" in doc["message"]


def test_the_text_output_names_the_parameter_outside_its_physical_bounds(unpinned_csv, capsys):
    assert main(["model", "fit", str(unpinned_csv), "--model", "paper"]) == 0
    out = capsys.readouterr().out
    assert "# outside its physical bounds (not converged): vstm = 637.7" in out and "outside [0.1, 500]" in out
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[-1:] == ["converged"])
    assert lines[head + 2].split()[-1] == "False"  # the converged column (True before)
    assert next(line for line in lines if line.split()[:1] == ["vstm"]).endswith("outside [0.1, 500]")


@pytest.mark.parametrize("effects, spec, name", [
    (["load_viscous"], "paper", "vstm"),  # 637.7, converged
    ([], "paper + x_stribeck(lube_hours)", "vstm"),  # a clean joint: 1106, converged
    (["lubrication"], "paper + x_stribeck(lube_hours)", "vstm"),  # 554.9 (the table commissioning carries it on)
])
def test_every_parameter_past_its_physical_bound_on_paper_scale_data_is_named(effects, spec, name):
    m = parse_spec(spec)
    f = fit_model(m, _unpinned(effects), m.make_params())
    specs = {sp.name: sp for term in m.terms for sp in term.params}
    past = {n for n in f.free if not specs[n].min <= f.params[n].value <= specs[n].max}
    assert name in past and set(f.outside_physical) == past and not f.success
    assert f.outside_physical[name] == (specs[name].min, specs[name].max)


def test_only_the_terms_own_bounds_in_a_frame_not_declared_joint_side_are_physical():
    from jointwear_ros.workbench.fit import physical_bound_names

    t = _unpinned([])
    m = parse_model_spec("paper")
    p0, auto = scale_parameters(m, m.make_params(), DataScales.from_table(t))
    assert {"vstm", "vs0", "Fc0", "Fv0"} <= physical_bound_names(m, p0, auto, t)  # the paper's scale
    joint = ObservationTable(dict(t.columns), source="j", units=TableUnits("joint"))
    assert physical_bound_names(m, p0, auto, joint) == frozenset()  # the normalized frame's bounds do not hold
    big = ObservationTable({**t.columns, "tau_f": t["tau_f"] * 150.0}, source="big")  # 150x the paper's friction
    p1, auto1 = scale_parameters(m, m.make_params(), DataScales.from_table(big))
    assert "Fc0" in auto1 and "Fc0" not in physical_bound_names(m, p1, auto1, big)  # scaled: the data's numbers
