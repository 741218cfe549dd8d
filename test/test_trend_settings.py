"""The trend's settings declared once (TrendConfig's field metadata is the wear_trend node's parameters), the
trend package's modules in their order, and the trend report ranking levels as the contract does."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import pytest
import yaml

from jointwear_ros.contract import DiagnosticLevel
from jointwear_ros.errors import ParameterError
from jointwear_ros.settings import declarations, from_mapping, settings_of
from jointwear_ros.trend import TrendConfig, TrendResult
from jointwear_ros.trend.report import rank_key

ROOT = Path(__file__).resolve().parents[1]
TREND = ROOT / "jointwear_ros" / "trend"
#: the trend package's modules by role, each importing only those before it (trend/__init__.py says so)
ORDER = ("config", "members", "filters", "alarm", "states", "prior", "segments", "analysis", "families",
         "backtest", "report", "ondemand", "year")


def test_the_nodes_trend_parameters_are_the_configs_settings_under_their_parameter_names():
    from jointwear_ros.nodes import wear_trend

    decls = {d.name: d for d in wear_trend.PARAMETERS}
    cfg = TrendConfig()
    for name, setting in settings_of(TrendConfig).items():
        assert decls[setting.name] == setting
        assert decls[setting.name].default == getattr(cfg, name)
    assert [d.name for d in declarations(TrendConfig)] == ["alarm_threshold", "warn_threshold", "horizon_days",
                                                            "min_estimates"]
    assert set(wear_trend.LIVE_PARAMETERS) >= {d.name for d in declarations(TrendConfig)}


def test_the_params_file_says_the_configs_defaults():
    params = yaml.safe_load((ROOT / "config" / "wear_trend.yaml").read_text())["wear_trend"]["ros__parameters"]
    for d in declarations(TrendConfig):
        assert params[d.name] == d.default, d.name


def test_the_config_from_node_parameters_takes_integers_for_doubles_and_ignores_the_nodes_own():
    cfg = from_mapping(TrendConfig, {"alarm_threshold": 40, "warn_threshold": 25.0, "horizon_days": 10,
                                     "min_estimates": 7, "robot": "robot_1", "retry_period": 1.0, "alarm": 99.0})
    assert (cfg.alarm, cfg.warn, cfg.horizon_days, cfg.min_estimates) == (40.0, 25.0, 10.0, 7)
    assert isinstance(cfg.alarm, float) and isinstance(cfg.horizon_days, float)
    assert from_mapping(TrendConfig, {}) == TrendConfig()


@pytest.mark.parametrize(("values", "match"), [
    ({"warn_threshold": 300.0}, r"^warn_threshold=300: outside the declared range \[0.0, 100.0\]$"),
    ({"horizon_days": 5000.0}, r"^horizon_days=5000: outside the declared range \[0.0, 3650.0\] days$"),
    ({"alarm_threshold": math.nan}, r"^alarm_threshold=nan: not a finite number$"),
])
def test_a_bad_parameter_is_refused_in_one_line_naming_the_parameter(values, match):
    with pytest.raises(ParameterError, match=match):
        from_mapping(TrendConfig, values)


def _imports(path: Path) -> set[str]:
    """The sibling modules of the trend package that ``path`` imports (anywhere in it)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module:
                out.add(node.module.split(".")[0])
            else:
                out.update(a.name for a in node.names)
    return out


def test_the_trend_modules_by_role_import_only_those_before_them():
    modules = sorted(p.stem for p in TREND.glob("*.py") if p.stem != "__init__")
    assert sorted(ORDER) == modules
    for i, name in enumerate(ORDER):
        later = _imports(TREND / f"{name}.py") - set(ORDER[:i])
        assert not later, f"trend/{name}.py imports {sorted(later)}, not before it in {ORDER}"


def _result(level: int, joint: str) -> TrendResult:
    return TrendResult("robot_1", joint, 0, 0, math.nan, math.nan, math.nan, math.nan, None, level, "", False,
                       math.nan, math.nan, 1)


def test_the_trend_report_ranks_levels_as_the_contract_and_the_plant_page_do():
    lv = DiagnosticLevel
    rs = [_result(level, f"joint_{level}") for level in (lv.OK, lv.ERROR, lv.STALE, lv.WARN, 7)]
    # a byte the contract does not define ranks above ERROR (contract.level_rank), as on the plant page
    assert [r.level for r in sorted(rs, key=rank_key)] == [7, lv.ERROR, lv.WARN, lv.STALE, lv.OK]
