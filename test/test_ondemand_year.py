"""A simulated year: production estimates and the cycle on demand against a nightly cycle (jointwear_ros.trend.year)."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from jointwear_ros.contract import DiagnosticLevel
from jointwear_ros.errors import InputDataError
from jointwear_ros.monitor.core import CONFIRM_MEMORY
from jointwear_ros.trend import WearPath, YearResult, simulate_year
from jointwear_ros.trend.year import STD_CYCLE

SEEDS = range(5)


@pytest.fixture(scope="module")
def years() -> dict[int, YearResult]:
    return {seed: simulate_year(seed=seed) for seed in SEEDS}


@pytest.mark.parametrize("seed", SEEDS)
def test_production_year_meets_the_done_when_with_the_default_settings(seed: int, years: dict[int, YearResult]) -> None:
    r = years[seed]
    assert r.growing == ("joint_2", "joint_3") and r.flat == ("joint_1", "joint_4", "joint_5", "joint_6")
    assert r.std_prod == (2 * STD_CYCLE,) * 6 and r.nightly.cycles == r.nights == 365
    for j in r.growing:
        first = r.production.first_error[j]
        nightly = r.nightly.first_error[j]
        assert first is not None and nightly is not None
        assert first <= nightly + 3, (j, first, nightly)
    assert r.production.false_errors == 0 and r.nightly.false_errors == 0
    assert r.production.cycles <= 0.10 * r.nights
    assert r.asked_fraction == r.production.cycles / 365


def test_each_reason_to_ask_occurs_in_a_year(years: dict[int, YearResult]) -> None:
    kinds: dict[str, int] = {}
    for r in years.values():
        for k, v in r.production.asked_by_kind().items():
            kinds[k] = kinds.get(k, 0) + v
    assert set(kinds) == {"straddle", "crossing", "quiet"}


def test_a_joint_production_cannot_tell_gets_its_level_only_from_the_cycle() -> None:
    r = simulate_year((WearPath("joint_1", 40.0), WearPath("joint_2", 10.0)), nights=30, p_quiet=1.0,
                      quiet_spells=(), seed=3)
    lv = r.production.levels
    first_cycle = r.production.cycle_nights[0]
    assert first_cycle >= 1
    assert (lv[:first_cycle] == -1).all()  # no level at all from "cannot tell"
    assert r.production.first_error["joint_1"] == first_cycle
    assert lv[first_cycle, 0] == int(DiagnosticLevel.ERROR)
    assert {k for _, _, k, _ in r.production.asks} == {"quiet"}


def test_the_year_is_deterministic_per_seed(years: dict[int, YearResult]) -> None:
    a, b, c = years[1], simulate_year(seed=1), years[2]
    assert a.production.asks == b.production.asks and np.array_equal(a.production.levels, b.production.levels)
    assert a.nightly.first_error == b.nightly.first_error
    assert not np.array_equal(a.production.levels, c.production.levels)


def test_the_year_confirms_over_the_wear_monitors_memory() -> None:
    assert inspect.signature(simulate_year).parameters["confirm_memory"].default == CONFIRM_MEMORY


def test_a_noisier_production_estimate_near_the_warning_level_can_read_error() -> None:
    # the limit the docs state: the level rule reads ERROR at w >= 35 from any one estimate, so a flat joint at 29
    # read with twice the cycle's std shows ERROR on some nights of some years; the nightly cycle never does
    joints = (WearPath("joint_1", 29.0), WearPath("joint_2", 10.0))
    rs = [simulate_year(joints, seed=s, quiet_spells=()) for s in range(6)]
    assert sum(r.production.false_errors for r in rs) > 0
    assert sum(r.nightly.false_errors for r in rs) == 0


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"std_prod": (1.0, 2.0)}, "std_prod"),
    ({"std_cycle": 0.0}, "std_cycle"),
    ({"quiet_spells": (("joint_9", 1, 2),)}, "joint_9"),
    ({"nights": 0}, "nights"),
    ({"p_quiet": 1.5}, "p_quiet"),
])
def test_bad_year_settings_are_one_input_data_error(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputDataError, match=match):
        simulate_year(**kwargs)  # type: ignore[arg-type]
