"""The estimator registry: one list of names, behaviour read from the capabilities each class declares."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from jointwear_ros.errors import InputDataError
from jointwear_ros.estimation import (
    ESTIMATORS,
    BayesEstimator,
    Capabilities,
    EstimatorRegistry,
    JointEstimator,
    PaperEstimator,
    capabilities_of,
    make_estimator,
)
from jointwear_ros.estimation.case_study import CaseSetup, run_case_study
from jointwear_ros.estimation.study import StudySetup, run_study

ROOT = Path(__file__).resolve().parents[1]


def test_the_built_in_estimators_are_registered_in_order_and_each_declares_its_capabilities():
    assert list(ESTIMATORS) == ["paper", "paper-grid", "bayes", "joint"]
    for name, cls in ESTIMATORS.items():
        assert cls.name == name
        assert "capabilities" in vars(cls), f"{cls.__qualname__} inherits its capabilities instead of declaring them"
        assert capabilities_of(cls).summary
    assert [n for n in ESTIMATORS if ESTIMATORS.capabilities(n).cycle] == ["joint"]
    assert [n for n in ESTIMATORS if ESTIMATORS.capabilities(n).temperature_samples] == ["paper", "paper-grid"]
    assert {n: ESTIMATORS.capabilities(n).temperature_assumption for n in ESTIMATORS} == {
        "paper": "range", "paper-grid": "range", "bayes": "prior", "joint": "prior"}
    # the options a capability names are options the class takes
    for n in ESTIMATORS:
        caps, opts = ESTIMATORS.capabilities(n), ESTIMATORS.options(n)
        assert caps.temperature_assumption != "range" or "temperature_range" in opts
        assert caps.temperature_assumption != "prior" or "prior" in opts
        assert not caps.temperature_samples or "n_samples" in opts
        assert not caps.points or "point" in opts
        assert not caps.needs_seed or {"seed", "rng"} <= opts


def test_point_names_map_to_each_estimators_own_point_and_the_estimator_takes_them():
    bayes, joint = ESTIMATORS.capabilities("bayes"), ESTIMATORS.capabilities("joint")
    assert (bayes.point("map"), bayes.point("mode"), bayes.point("mean")) == ("mode", "mode", "mean")
    assert (joint.point("mode"), joint.point("map"), joint.point("mean")) == ("map", "map", "mean")
    assert ESTIMATORS.capabilities("paper").point("mode") is None
    for name in ("bayes", "joint"):
        caps = ESTIMATORS.capabilities(name)
        for p in ("mode", "mean", "map"):
            assert make_estimator(name, point=caps.point(p)).point == caps.point(p)


def test_lookup_ignores_case_and_spaces_and_an_unknown_name_lists_the_registered_ones():
    assert ESTIMATORS.get_class(" Paper-Grid ") is ESTIMATORS["paper-grid"]
    assert "joint" in ESTIMATORS and "magic" not in ESTIMATORS and 3 not in ESTIMATORS
    with pytest.raises(InputDataError, match="unknown wear estimation method 'magic'; choose one of paper, "
                                             "paper-grid, bayes, joint"):
        make_estimator("magic")
    with pytest.raises(KeyError):
        ESTIMATORS["magic"]


def test_registering_refuses_a_taken_name_and_what_is_not_an_estimator():
    reg = EstimatorRegistry(PaperEstimator)

    class Other(PaperEstimator):
        name = "paper"

    with pytest.raises(InputDataError, match="'paper' is taken by .*PaperEstimator"):
        reg.register(Other)
    assert reg.register(Other, replace=True) is Other and reg["paper"] is Other
    assert reg.register(Other) is Other  # the same class again: nothing to refuse
    with pytest.raises(InputDataError, match="needs a 'name' and an estimate"):
        reg.register(type("Nameless", (), {"estimate": lambda self, t: None}))
    with pytest.raises(InputDataError, match="needs a 'name' and an estimate"):
        reg.register(type("NoEstimate", (), {"name": "x"}))
    assert list(reg) == ["paper"] and len(reg) == 1


def test_an_estimator_without_capabilities_gets_the_defaults():
    class Plain:
        name = "plain"

        def estimate(self, table):  # pragma: no cover - never called
            raise AssertionError

    assert capabilities_of(Plain) == capabilities_of(Plain()) == Capabilities()
    assert not Capabilities().cycle and Capabilities().temperature_assumption == "none"


class _CycleBayes(BayesEstimator):
    """bayes under another name, declared a cycle estimator: the study must follow the flag, not the name."""

    name = "bayes-by-cycle"
    capabilities = Capabilities(summary="test", cycle=True, temperature_assumption="prior")


class _PerSpeedJoint(JointEstimator):
    name = "joint-per-speed"
    capabilities = Capabilities(summary="test", temperature_assumption="prior")


def test_the_study_and_the_case_study_follow_the_cycle_flag_not_the_name():
    setup = StudySetup(speeds=(40.0, 65.0), runs=40, seed=2)
    assert run_study(_CycleBayes(), setup, crb=False).mode == "cycle"
    assert run_study(_PerSpeedJoint(), setup, crb=False).mode == "per-speed"
    assert run_study(make_estimator("joint"), setup, crb=False).mode == "cycle"
    case = CaseSetup(speeds=(40.0,), n_indices=20, alarm_index=10, seed=1)
    with pytest.raises(InputDataError, match="'mine' is a cycle estimator.*\\(paper, paper-grid, bayes\\)"):
        run_case_study({"mine": _CycleBayes()}, case)
    res = run_case_study({"mine": _PerSpeedJoint()}, case)
    assert np.isfinite(res.methods["mine"]["mean"]).all()


def test_no_module_branches_on_an_estimator_name():
    """Behaviour keyed on a method-name string (``method in ("paper", ...)``, ``name == "joint"``) is what the
    capabilities replace; the estimator classes' own ``name = ...`` and docs are not such branches."""
    pattern = re.compile(r"""(method|name|\.name\b[^=\n]*)\s*(==|!=|in|not in)\s*\(?\s*["'](paper|paper-grid|bayes|joint)["']""")
    hits = []
    for path in sorted((ROOT / "jointwear_ros").rglob("*.py")):
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            if pattern.search(line) and not line.lstrip().startswith(("#", ">>>")):
                hits.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not hits, "\n".join(hits)
