"""A setting declared once (jointwear_ros.settings): the config dataclass's field metadata gives the node's
declarations, its per-joint settings and the config from parameter values (node, YAML, --set, replay)."""

from __future__ import annotations

import ast
import dataclasses
import json
import re
from collections.abc import Mapping
from pathlib import Path

import pytest

from jointwear_ros.cli import main
from jointwear_ros.cycle import CycleConfig, plan_cycle
from jointwear_ros.errors import ParameterError
from jointwear_ros.resources import node_config
from jointwear_ros.settings import ParamDecl, declarations, from_mapping, per_joint, setting, settings_of
from jointwear_ros.sim import JointSimConfig

PKG = Path(__file__).resolve().parents[1] / "jointwear_ros"


@dataclasses.dataclass(frozen=True)
class DwellCycleConfig(CycleConfig):
    """CycleConfig plus one new setting: the one line a new cycle setting takes."""

    dwell_time: float = setting(0.5, description="time at rest at the window centre, s", unit="s",
                                range=(0.0, 10.0), per_joint=True)


def test_a_new_cycle_setting_is_one_field_declared_on_the_node_checked_and_per_joint():
    pytest.importorskip("rclpy")
    from jointwear_ros.nodes import test_cycle

    decls = {d.name: d for d in test_cycle.parameters(DwellCycleConfig)}
    d = decls["dwell_time"]
    assert (d.default, d.min, d.max, d.unit, d.read_only) == (0.5, 0.0, 10.0, "s", False)
    assert "dwell_time" in per_joint(DwellCycleConfig)
    # every setting of the plain config is declared the same, and the node's own settings still are
    assert {n: decls[n] for n in settings_of(CycleConfig)} == settings_of(CycleConfig)
    assert {"command_rate", "hold_tolerance", "joints"} <= set(decls)
    # taken from parameter values, a joint's own over the node-level value, range-checked
    values = {"dwell_time": 1, "joint_3.dwell_time": 2.5}
    assert from_mapping(DwellCycleConfig, values).dwell_time == 1.0
    assert from_mapping(DwellCycleConfig, values, joint="joint_3").dwell_time == 2.5
    assert from_mapping(DwellCycleConfig, values, joint="joint_2").dwell_time == 1.0
    with pytest.raises(ParameterError, match=r"^joint_3\.dwell_time=20: outside the declared range \[0\.0, 10\.0\] s$"):
        from_mapping(DwellCycleConfig, {"joint_3.dwell_time": 20.0}, joint="joint_3")


def test_the_test_cycle_node_declares_exactly_the_cycle_settings_and_its_own():
    pytest.importorskip("rclpy")
    from jointwear_ros.nodes import test_cycle

    cycle = settings_of(CycleConfig)
    own = [d.name for d in test_cycle.PARAMETERS if d.name not in cycle]
    assert own == ["joint_name", "joints", "command_topic", "joint_states_topic", "state_timeout_wall",
                   "hold_tolerance", "sweep", "arm", "command_rate", "status_rate", "first_cycle_id", "motion_enabled",
                   "simulator", "diagnostics_period"]
    assert test_cycle.PER_JOINT == per_joint(CycleConfig)
    # not parameters: set by the node (joint_name, control_period = 1 / command_rate) or fixed
    assert set(f.name for f in dataclasses.fields(CycleConfig)) - set(cycle) == {
        "joint_name", "control_period", "position_tolerance", "move_timeout_factor"}
    # no hand list of the cycle's fields is left in the node or the CLI
    for path in ("nodes/test_cycle.py", "cli/cycle_cmd.py"):
        text = (PKG / path).read_text()
        assert "_CYCLE_FIELDS" not in text and "_PLAN_FIELDS" not in text and "_cycle_value" not in text, path


def test_the_simulator_node_declares_every_joint_sim_setting_per_joint():
    pytest.importorskip("rclpy")
    from jointwear_ros.nodes import joint_sim

    decls = {d.name: d for d in joint_sim.PARAMETERS}
    for name, d in settings_of(JointSimConfig).items():
        assert decls[name] == d and name in joint_sim.PER_JOINT
    assert {"seed", "max_velocity"} <= set(joint_sim.PER_JOINT)  # the node's own per-joint settings
    assert decls["hidden_effects"].default == ""  # a comma list string, parsed into the field's tuple
    assert "_sim_value" not in (PKG / "nodes/joint_sim.py").read_text()


@pytest.mark.parametrize(("cls", "node", "own"), [
    (CycleConfig, "test_cycle", ("joint_limits", (-1.2, 1.2), (-1.5, 1.5))),
    (JointSimConfig, "joint_sim", ("temperature", 45.0, 40.0)),
])
def test_every_joint_of_the_shipped_config_builds_its_config(cls, node, own):
    params = node_config(node)
    for j in params["joints"]:
        cfg = from_mapping(cls, params, joint=j)
        cfg.check()
        for name in settings_of(cls):
            expected = params.get(f"{j}.{name}", params.get(name))
            if expected is not None and name != "hidden_effects":
                got = getattr(cfg, name)
                assert (list(got) if isinstance(got, tuple) else got) == expected, (j, name)
    name, joint_3, node_level = own  # joint_3's own value over the node-level one
    assert getattr(from_mapping(cls, params, joint="joint_3"), name) == joint_3
    assert getattr(from_mapping(cls, params, joint="joint_1"), name) == node_level


def test_from_mapping_takes_ros_parameter_types_as_the_fields_types():
    cfg = from_mapping(CycleConfig, {"speeds": [10, 20], "joint_limits": [-1, 1], "max_speed": 200, "max_speeds": 4,
                                     "command_topic": "/x"}, joint_name="joint_2", control_period=0.02)
    assert cfg.speeds == (10.0, 20.0) and all(type(v) is float for v in cfg.speeds)
    assert cfg.joint_limits == (-1.0, 1.0) and type(cfg.max_speed) is float and cfg.max_speeds == 4
    assert (cfg.joint_name, cfg.control_period) == ("joint_2", 0.02)
    assert from_mapping(CycleConfig, {}) == CycleConfig()
    sim = from_mapping(JointSimConfig, {"hidden_effects": "ripple, lubrication", "params": "ref-2011r", "wear": 35})
    assert sim.hidden_effects == ("ripple", "lubrication") and sim.wear == 35.0


@pytest.mark.parametrize(("values", "match"), [
    ({"joint_limits": [-1.0, 0.0, 1.0]}, r"^joint_limits must be \[low, high\], got \[-1\.0, 0\.0, 1\.0\]$"),
    ({"speeds": "10,20"}, r"^speeds is a list, not '10,20'$"),
    ({"speeds": [10.0, "fast"]}, r"^speeds is a list of numbers"),
    ({"max_speed": True}, r"^max_speed is a number \(default 280 rad/s\), not True$"),
    ({"max_speeds": 2.5}, r"^max_speeds is an integer \(default 32\), not 2\.5$"),
    ({"max_speed": 2e6}, r"^max_speed=2e\+06: outside the declared range \[0\.001, 1000000\.0\] rad/s$"),
    ({"approach_speed": float("nan")}, r"^approach_speed=nan: not a finite number$"),
])
def test_from_mapping_refuses_a_bad_value_in_one_line_naming_setting_unit_and_range(values, match):
    with pytest.raises(ParameterError, match=match) as err:
        from_mapping(CycleConfig, values)
    assert "\n" not in str(err.value)


def test_a_hidden_effect_the_simulator_does_not_know_is_refused_by_name():
    with pytest.raises(ParameterError, match="unknown hidden effect.*bogus"):
        from_mapping(JointSimConfig, {"hidden_effects": "ripple, bogus"})


def test_setting_declares_a_tuple_default_as_the_list_ros_takes():
    d = settings_of(CycleConfig)["speeds"]
    assert isinstance(d, ParamDecl) and d.default == list(CycleConfig().speeds) and d.per_joint
    assert settings_of(CycleConfig)["gear_ratio"].read_only
    assert [x.name for x in declarations(CycleConfig)] == list(settings_of(CycleConfig))


def test_cycle_schedule_reads_the_params_file_as_the_node_does(capsys, tmp_path):
    # a setting the schedule does not need is still range-checked, as the node would at start-up
    f = tmp_path / "test_cycle.yaml"
    f.write_text("test_cycle:\n  ros__parameters:\n    joints: [joint_1, joint_2]\n    joint_2:\n"
                 "      approach_speed: 500.0\n")
    rc = main(["cycle", "schedule", "--params-file", str(f)])
    out = capsys.readouterr()
    assert rc == 2 and out.out == "" and len(out.err.strip().splitlines()) == 1, out.err
    assert "joint_2.approach_speed=500: outside the declared range [0.001, 100.0] rad/s" in out.err
    # every cycle setting of the file is used: a slower approach makes the planned cycle longer
    f.write_text("test_cycle:\n  ros__parameters:\n    joints: [joint_1]\n    approach_speed: 0.1\n")
    assert main(["cycle", "schedule", "--params-file", str(f), "--json"]) == 0
    seconds = json.loads(capsys.readouterr().out)["joints"][0]["seconds"]
    assert seconds == pytest.approx(plan_cycle(CycleConfig(approach_speed=0.1)).duration)
    assert seconds > plan_cycle(CycleConfig()).duration


def _imported(path: Path) -> set[str]:
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            out.add("." * node.level + (node.module or ""))
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_settings_is_pure_and_the_robot_nodes_plumbing_has_no_import_circle():
    assert {m for m in _imported(PKG / "settings.py") if m.startswith(".")} == {".errors"}
    assert not {m for m in _imported(PKG / "settings.py") if m.split(".")[0] in ("rclpy", "rcl_interfaces")}
    # nodes.joints builds on nodes.runtime, never the other way (function-local imports included)
    assert ".runtime" in _imported(PKG / "nodes/joints.py")
    assert ".joints" not in _imported(PKG / "nodes/runtime.py")


# --- param=, default_factory=, one range check (check_ranges) and one node-declaration helper -------------------

def _thresholds() -> type:
    """A config whose field ``alarm`` is the parameter ``alarm_threshold`` and whose ``options`` default is made."""

    @dataclasses.dataclass(frozen=True)
    class Thresholds:
        alarm: float = setting(35.0, description="wear of ERROR", unit="%", range=(0.0, 100.0), per_joint=True,
                               param="alarm_threshold")
        options: Mapping[str, float] = setting(default_factory=dict, description="extra options")

    return Thresholds


def test_param_names_the_node_parameter_when_it_is_not_the_field():
    Thresholds = _thresholds()
    d = declarations(Thresholds)[0]
    assert (d.name, d.default, d.min, d.max) == ("alarm_threshold", 35.0, 0.0, 100.0)
    assert per_joint(Thresholds) == ("alarm_threshold",)
    # read under the parameter's name (a joint's own too); the field's name is not a parameter
    assert from_mapping(Thresholds, {"alarm_threshold": 40, "alarm": 99.0}).alarm == 40.0
    own = {"alarm_threshold": 40, "joint_2.alarm_threshold": 45.0}
    assert from_mapping(Thresholds, own, joint="joint_2").alarm == 45.0
    with pytest.raises(ParameterError, match=r"^alarm_threshold=300: outside the declared range \[0\.0, 100\.0\] %$"):
        from_mapping(Thresholds, {"alarm_threshold": 300.0})
    # the trend's alarm and warn are the wear_trend node's alarm_threshold and warn_threshold, by the same means
    from jointwear_ros.trend import TrendConfig

    assert [d.name for d in declarations(TrendConfig)] == ["alarm_threshold", "warn_threshold", "horizon_days",
                                                            "min_estimates"]
    cfg = from_mapping(TrendConfig, {"alarm_threshold": 40, "warn_threshold": 20.0, "alarm": 99.0})
    assert (cfg.alarm, cfg.warn) == (40.0, 20.0)


def test_default_factory_makes_each_configs_own_mutable_default():
    Thresholds = _thresholds()
    a, b = Thresholds(), Thresholds()
    assert a.options == {} and a.options is not b.options
    assert declarations(Thresholds)[1].default == {}
    from jointwear_ros.monitor import MonitorConfig

    f = {f.name: f for f in dataclasses.fields(MonitorConfig)}["estimator_options"]
    assert f.default_factory is dict and f.default is dataclasses.MISSING  # no None standing for "none"
    assert MonitorConfig().estimator_options == {}
    assert settings_of(MonitorConfig)["estimator_options"].default == ""  # the node takes a JSON object string
    with pytest.raises(TypeError, match="one of them"):
        setting(1.0, default_factory=float, description="both")


def _configs():
    """Each config with settings, how it is checked (its error type, the prefix of its messages)."""
    from jointwear_ros.cycle import CycleRequestError
    from jointwear_ros.errors import InputDataError
    from jointwear_ros.monitor import MonitorConfig
    from jointwear_ros.observer import ObserverConfig
    from jointwear_ros.trend import TrendConfig

    return [(CycleConfig, CycleRequestError, "test cycle setting "), (JointSimConfig, ParameterError, "joint sim: "),
            (ObserverConfig, InputDataError, "observer setting "), (MonitorConfig, InputDataError, ""),
            (TrendConfig, InputDataError, "trend setting ")]


def _build(cls, **values):
    cfg = cls(**values)
    if hasattr(cfg, "check"):  # the cycle and the simulator check on use, the others when built
        cfg.check()
    return cfg


def test_every_declared_range_is_enforced_at_construction_in_one_line():
    checked = 0
    for cls, error, prefix in _configs():
        for name, d in settings_of(cls).items():
            if d.min is None and d.max is None:
                continue
            unit = f" {d.unit}" if d.unit else ""
            width = d.max - d.min
            below = d.min - 1 if isinstance(d.default, int) else d.min - max(width * 0.5, abs(d.min) * 0.5)
            above = d.max + 1 if isinstance(d.default, int) else d.max + max(width * 0.5, 1.0)
            for v in (below, above):
                line = f"{prefix}{d.name}={v:g}: outside the declared range [{d.min}, {d.max}]{unit}"
                with pytest.raises(error, match=f"^{re.escape(line)}$"):
                    _build(cls, **{name: v})
                checked += 1
            with pytest.raises(error, match=rf"^{prefix}{d.name}=nan: not a finite number"):
                _build(cls, **{name: float("nan")})
    assert checked > 100  # every ranged setting of the five configs, each way


@pytest.mark.parametrize("name", ["min_samples", "n_batches"])
def test_the_stricter_hand_checks_are_declared_ranges_refused_as_parameters(name):
    from jointwear_ros.monitor import MonitorConfig
    from jointwear_ros.observer import ObserverConfig
    from jointwear_ros.trend import TrendConfig

    for cls, param, low in ((ObserverConfig, name, 2), (CycleConfig, "max_speeds", 1),
                            (MonitorConfig, "min_observations", 1), (TrendConfig, "min_estimates", 2)):
        d = settings_of(cls)[param]
        assert d.min == low
        key = f"joint_2.{param}" if d.per_joint else param  # a joint's own value, where it may have one
        with pytest.raises(ParameterError, match=rf"^{key}={low - 1}: outside the declared range \[{low}, {d.max}\]$"):
            from_mapping(cls, {key: low - 1}, joint="joint_2")
    pytest.importorskip("rclpy")  # the node declares the range (the CLI's --set and the node refuse it)
    from jointwear_ros.nodes.runtime import node_parameters

    assert node_parameters("friction_observer")[name].min == 2


def test_a_new_setting_with_a_range_and_no_hand_check_is_refused_at_construction():
    from jointwear_ros.errors import InputDataError
    from jointwear_ros.observer import ObserverConfig

    @dataclasses.dataclass(frozen=True)
    class SettleObserverConfig(ObserverConfig):
        settle_skip: float = setting(0.1, description="s skipped after reaching speed", unit="s", range=(0.0, 1.0))

    with pytest.raises(InputDataError, match=r"^observer setting settle_skip=2: outside the declared range "
                                             r"\[0\.0, 1\.0\] s$"):
        SettleObserverConfig(settle_skip=2.0)
    from jointwear_ros.cycle import CycleRequestError

    with pytest.raises(CycleRequestError, match=r"^test cycle setting dwell_time=20: outside the declared range "
                                                r"\[0\.0, 10\.0\] s$"):
        DwellCycleConfig(dwell_time=20.0).check()


def test_the_robot_nodes_build_their_declarations_with_one_helper():
    import jointwear_ros.settings as settings_module

    for node in ("test_cycle", "joint_sim", "friction_observer", "wear_estimator"):
        text = (PKG / "nodes" / f"{node}.py").read_text()
        assert "PARAMETERS, LIVE_PARAMETERS, PER_JOINT = node_declarations(" in text, node
        assert "for d in PARAMETERS if" not in text, node  # LIVE_PARAMETERS, PER_JOINT not assembled by hand
    own = (ParamDecl("topic", "/x", "output", read_only=True),)
    decls = settings_module.node_declarations(DwellCycleConfig, own, own)
    assert decls.parameters == (*own, *declarations(DwellCycleConfig), *own)
    assert decls.per_joint == per_joint(DwellCycleConfig)
    assert decls.live == tuple(d.name for d in declarations(DwellCycleConfig) if not d.read_only)
