"""A setting declared once, for the friction observer and the wear monitor: ObserverConfig's and MonitorConfig's
field metadata give the nodes' declarations, their per-joint settings and the configs from parameter values
(node, params YAML, a bag's recorded settings, fleet re-analysis)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from jointwear_ros.errors import ParameterError
from jointwear_ros.monitor import MonitorConfig
from jointwear_ros.observer import ObserverConfig
from jointwear_ros.resources import node_config
from jointwear_ros.settings import from_mapping, per_joint, setting, settings_of

PKG = Path(__file__).resolve().parents[1] / "jointwear_ros"

OBSERVER_SETTINGS = [
    "gear_ratio", "torque_scale", "speed_tolerance", "speed_tolerance_min", "max_speed_std", "max_speed_std_min",
    "min_constant_fraction", "min_samples", "edge_trim", "pass_gap", "n_batches", "reorder_margin", "poll_grace",
    "temperature_wait", "max_buffer_seconds",
]
MONITOR_SETTINGS = [
    "method", "params", "seed", "warn_threshold", "alarm_threshold", "use_measured_temperature", "done_timeout",
    "idle_timeout", "min_observations", "observation_noise_std", "estimator_options",
]


@dataclasses.dataclass(frozen=True)
class SettleObserverConfig(ObserverConfig):
    """ObserverConfig plus one new setting: the one line a new observer setting takes."""

    settle_skip: float = setting(0.1, description="s skipped after each speed reversal", unit="s",
                                 range=(0.0, 5.0), per_joint=True)


@dataclasses.dataclass(frozen=True)
class DriftMonitorConfig(MonitorConfig):
    """MonitorConfig plus one new setting."""

    drift_limit: float = setting(2.0, description="wear change per cycle that is a step", unit="%",
                                 range=(0.0, 50.0), per_joint=True)


def _node(name: str):
    pytest.importorskip("rclpy")
    import importlib

    return importlib.import_module(f"jointwear_ros.nodes.{name}")


@pytest.mark.parametrize(("node", "cls", "names", "own", "own_per_joint"), [
    ("friction_observer", ObserverConfig, OBSERVER_SETTINGS,
     ["joint_name", "joint_states_topic", "status_topic", "temperature_topic", "observations_topic", "poll_period",
      "diagnostics_period"], []),
    ("wear_estimator", MonitorConfig, MONITOR_SETTINGS,
     ["joint_name", "hardware_id", "diagnostics_period", "observations_topic", "status_topic", "production_status_topic",
      "estimate_topic",
      "diagnostics_topic"], ["hardware_id"]),
])
def test_the_node_declares_exactly_its_configs_settings_and_its_own(node, cls, names, own, own_per_joint):
    module = _node(node)
    decls = {d.name: d for d in module.PARAMETERS}
    settings = settings_of(cls)
    assert list(settings) == names
    assert {n: decls[n] for n in settings} == settings  # the node declares each setting as the config does
    assert [n for n in decls if n not in settings] == own
    assert set(module.PER_JOINT) == set(per_joint(cls)) | set(own_per_joint)
    assert set(per_joint(cls)) == set(names)  # every observer / estimator setting may be a joint's own
    assert set(module.LIVE_PARAMETERS) == set(names)  # and is live; the node's own are read at start-up
    assert not hasattr(cls, "from_mapping")  # no hand mapping of the fields left


def test_the_declared_ranges_defaults_and_units_are_the_configs():
    obs, mon = settings_of(ObserverConfig), settings_of(MonitorConfig)
    assert (obs["gear_ratio"].default, obs["gear_ratio"].min, obs["gear_ratio"].max) == (100.0, 1e-6, 1e6)
    assert (obs["edge_trim"].min, obs["edge_trim"].max, obs["pass_gap"].unit) == (0.0, 0.99, "s")
    assert (obs["min_samples"].default, obs["min_samples"].min, obs["min_samples"].max) == (20, 2, 1_000_000)
    assert (mon["warn_threshold"].min, mon["warn_threshold"].max, mon["warn_threshold"].unit) == (0.0, 100.0, "%")
    assert mon["estimator_options"].default == ""  # the node takes a JSON object string
    assert MonitorConfig().estimator_options == {}  # the config a mapping
    for cls in (ObserverConfig, MonitorConfig):
        for name, d in settings_of(cls).items():
            assert not d.read_only and d.description, name


@pytest.mark.parametrize(("node", "cls", "build", "new", "joint_value"), [
    ("friction_observer", SettleObserverConfig, "observer_config", "settle_skip", 0.3),
    ("wear_estimator", DriftMonitorConfig, "monitor_config", "drift_limit", 5.0),
])
def test_a_new_setting_is_one_field_declared_on_the_node_per_joint_and_checked(node, cls, build, new, joint_value):
    module = _node(node)
    decls = {d.name: d for d in module.parameters(cls)}
    assert new in decls and decls[new] == settings_of(cls)[new]
    assert new in [d.name for d in module.parameters(cls) if d.per_joint]
    assert {d.name for d in module.parameters(cls)} - {new} == {d.name for d in module.PARAMETERS}
    # the node's config of a joint: the joint's own value over the node-level one
    values = {new: 1, f"joint_2.{new}": joint_value}
    cfg = getattr(module, build)(values, "joint_2", cls)
    assert (cfg.joint_name, getattr(cfg, new)) == ("joint_2", joint_value)
    assert getattr(getattr(module, build)(values, "joint_1", cls), new) == 1.0
    lo, hi = decls[new].min, decls[new].max
    with pytest.raises(ParameterError, match=rf"^joint_2\.{new}=99: outside the declared range \[{lo}, {hi}\] "):
        from_mapping(cls, {f"joint_2.{new}": 99.0}, joint="joint_2")


def test_from_mapping_takes_ros_parameter_types_as_the_fields_types():
    obs = from_mapping(ObserverConfig, {"gear_ratio": 50, "max_buffer_seconds": 60, "min_samples": 30,
                                        "status_topic": "/x"}, joint_name="joint_2")
    assert (obs.gear_ratio, obs.max_buffer_seconds, obs.min_samples, obs.joint_name) == (50.0, 60.0, 30, "joint_2")
    assert type(obs.gear_ratio) is float and type(obs.min_samples) is int
    mon = from_mapping(MonitorConfig, {"warn_threshold": 20, "seed": 7, "use_measured_temperature": False,
                                       "estimator_options": '{"n_samples": 200}', "hardware_id": "r1/j1"})
    assert (mon.warn_threshold, mon.seed, mon.use_measured_temperature) == (20.0, 7, False)
    assert type(mon.warn_threshold) is float and mon.estimator_options == {"n_samples": 200}
    # a params YAML nests options (estimator_options.n_samples): a mapping is taken as it is; "" is none
    assert from_mapping(MonitorConfig, {"estimator_options": {"n_samples": 50}}).estimator_options == {"n_samples": 50}
    assert from_mapping(MonitorConfig, {"estimator_options": ""}) == MonitorConfig()
    assert from_mapping(ObserverConfig, {}) == ObserverConfig()


@pytest.mark.parametrize(("cls", "values", "joint", "match"), [
    (ObserverConfig, {"gear_ratio": 0.0}, None, r"^gear_ratio=0: outside the declared range \[1e-06, 1000000\.0\]$"),
    (ObserverConfig, {"joint_2.torque_scale": -1.0}, "joint_2",
     r"^joint_2\.torque_scale=-1: outside the declared range \[1e-09, 1000000000\.0\] N·m$"),
    (ObserverConfig, {"min_samples": 2.5}, None, r"^min_samples is an integer \(default 20\), not 2\.5$"),
    (ObserverConfig, {"speed_tolerance": "fast"}, None, r"^speed_tolerance is a number \(default 0\.1\), not 'fast'$"),
    (ObserverConfig, {"pass_gap": float("nan")}, None, r"^pass_gap=nan: not a finite number$"),
    (MonitorConfig, {"warn_threshold": 150}, None,
     r"^warn_threshold=150: outside the declared range \[0\.0, 100\.0\] %$"),
    (MonitorConfig, {"use_measured_temperature": "yes"}, None, r"^use_measured_temperature is true or false"),
    (MonitorConfig, {"estimator_options": "[1, 2]"}, None, r"^estimator_options = '\[1, 2\]' is not a JSON object$"),
    (MonitorConfig, {"estimator_options": "{n_samples"}, None,
     r"^estimator_options = '\{n_samples' is not a JSON object: "),
])
def test_a_bad_value_is_refused_in_one_line_naming_the_setting(cls, values, joint, match):
    with pytest.raises(ParameterError, match=match) as err:
        from_mapping(cls, values, joint=joint)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(("node", "cls", "names", "own"), [
    ("friction_observer", ObserverConfig, OBSERVER_SETTINGS, ("torque_scale", 60.0)),
    ("wear_estimator", MonitorConfig, MONITOR_SETTINGS, ("alarm_threshold", 31.0)),
])
def test_every_joint_of_the_shipped_config_builds_its_config(node, cls, names, own):
    params = node_config(node)
    name, value = own
    params[f"joint_5.{name}"] = value  # a joint's own value, as a params YAML nests it under the joint
    for j in params["joints"]:
        cfg = from_mapping(cls, params, joint=j, joint_name=j)
        checked = []
        for n in settings_of(cls):
            expected = params.get(f"{j}.{n}", params.get(n))
            if expected is not None and n != "estimator_options":
                assert getattr(cfg, n) == expected, (j, n)
                checked.append(n)
        assert checked == [n for n in names if n != "estimator_options"]
        assert cfg.joint_name == j
        assert (getattr(cfg, name) == value) == (j == "joint_5")


def test_replay_and_the_nodes_build_the_configs_one_way():
    # replay (and the fleet re-analysis and history import --reestimate through it) and the nodes build the
    # configs with settings.from_mapping; no hand mapping of a field is left
    replay = (PKG / "replay.py").read_text()
    assert "from_mapping(ObserverConfig" in replay and "from_mapping(MonitorConfig" in replay
    assert "_estimator_options" not in replay and ".from_mapping(" not in replay
    for path in ("nodes/friction_observer.py", "nodes/wear_estimator.py"):
        text = (PKG / path).read_text()
        assert "Config.from_mapping" not in text and "_options(" not in text, path
