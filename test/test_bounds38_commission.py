"""Commissioning never writes a set outside the terms' physical bounds, whichever of its fits is kept.

The first fit was held to the physical bounds already (``Fstm`` 147.7 against [0, 10], seen live); the refit with
a found effect carried into the model was not. The reproduction: a low-speed lubrication effect hidden in
``cobot-j3`` with a load that hardly moves (0-0.01): the baseline finds ``x_stribeck(lube_hours)`` and carries it,
and in the refit the load Stribeck speed ``vstm``, which that effect trades off against, walked to 555 against its
physical [0.1, 500]. The set was written and the loader refused it.
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from jointwear_ros.cli import main
from jointwear_ros.commission import core
from jointwear_ros.data import synth_observations
from jointwear_ros.io.tables import write_csv
from jointwear_ros.model import SetUnits, load_parameter_set_info, paper_wear_model


def test_a_carried_effects_refit_past_a_physical_bound_is_held_there_and_its_set_loads(tmp_path, capsys):
    t = synth_observations(n_cycles=8, seed=0, params="cobot-j3", temperature=(18, 52), load=(0.0, 0.01),
                           effects=["lubrication"])
    write_csv(t, tmp_path / "base.csv")
    out = tmp_path / "j.yaml"
    assert main(["commission", str(tmp_path / "base.csv"), "--joint", "j", "--out", str(out), "--json",
                 "--wear-calibration", "paper"]) == 0
    doc = json.loads(capsys.readouterr().out)
    back = load_parameter_set_info(str(out))  # the loader refused it before: vstm = 554.9 outside [0.1, 500]
    assert back.values["vstm"] == 500.0 and "x_stribeck(lube_hours)" in back.spec
    assert doc["carried"] == "x_stribeck(lube_hours)"  # the refit is the one kept
    assert doc["parameters"]["vstm"]["value"] == 500.0 and doc["fixed"]["vstm"] == 500.0
    assert any(w.startswith("parameter vstm = 554.9") and "outside its physical bounds: held at 500" in w
               for w in doc["warnings"])


def test_the_helper_holds_every_parameter_a_refit_walks_out_until_none_is(monkeypatch):
    """Holding one parameter can push another past its bound in the refit: that one is held too, and every
    held parameter is named once."""
    m = paper_wear_model()
    defaults = {n: p.value for n, p in m.make_params().items()}
    rounds = [{"Fstm": 147.7}, {"vstm": 612.0}, {}]
    seen: list[dict[str, float]] = []

    def fake_fit(model, table, scales, fixed, cv_folds, folds, warm=None):
        seen.append(dict(fixed))
        values = dict(defaults, **rounds[len(seen) - 1], **{k: v for k, v in fixed.items()})
        free = [n for n in model.param_names if n not in fixed]
        return SimpleNamespace(free=free, params={n: SimpleNamespace(value=v) for n, v in values.items()})

    monkeypatch.setattr(core, "_fit", fake_fit)
    fit, fixed, notes = core._fit_within_physical_bounds(m, None, None, {"FsT": 0.0}, 5, None, SetUnits())
    assert seen == [{"FsT": 0.0}, {"FsT": 0.0, "Fstm": 10.0}, {"FsT": 0.0, "Fstm": 10.0, "vstm": 500.0}]
    assert fixed == {"FsT": 0.0, "Fstm": 10.0, "vstm": 500.0}
    assert [n.split(" = ")[0] for n in notes] == ["parameter Fstm", "parameter vstm"]
    assert fit.params["vstm"].value == 500.0
    seen.clear()
    rounds[:] = [{"Fstm": 147.7}]
    joint = SetUnits(frame="joint", gear_ratio=100.0, torque_scale=50.0)  # not bounded there: kept as fitted
    fit, fixed, notes = core._fit_within_physical_bounds(m, None, None, {}, 5, None, joint)
    assert len(seen) == 1 and fixed == {} and notes == [] and fit.params["Fstm"].value == pytest.approx(147.7)
