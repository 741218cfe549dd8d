"""One declaration per node (io/params.ParamDecl, nodes/runtime.node_parameters) and one reader of node
configuration (resources.node_config): every configured value is declared and within its declaration."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.errors import InputDataError, ParameterError
from jointwear_ros.io.params import ParamDecl
from jointwear_ros.resources import node_config

pytest.importorskip("rclpy")
from jointwear_ros.nodes.runtime import NODES, ROBOT_NODES, node_parameter, node_parameters


@pytest.mark.parametrize("node", NODES)
def test_every_configured_parameter_of_every_node_is_declared_and_within_its_declaration(node):
    config = node_config(node)
    assert config, f"config/{node}.yaml has no {node} section"
    for name, value in config.items():
        decl = node_parameter(node, name)
        assert decl is not None, f"config/{node}.yaml sets {name}, which {node} does not declare"
        assert decl.check(value) == value or isinstance(decl.default, float)  # an int given for a double
    decls = node_parameters(node)
    assert ("joints" in decls) == (node in ROBOT_NODES) and "use_sim_time" in decls
    for d in decls.values():  # a range fits its default
        if d.min is not None and d.max is not None:
            assert d.min <= d.default <= d.max, d


def test_a_joints_own_setting_has_its_node_level_declaration_and_unknown_names_have_none():
    d, wear = node_parameter("joint_sim", "joint_3.wear"), node_parameters("joint_sim")["wear"]
    assert d is not None and d.name == "joint_3.wear" and (d.min, d.max, d.default) == (wear.min, wear.max, wear.default)
    assert node_parameter("joint_sim", "no_such_setting") is None
    assert node_parameter("wear_trend", "joint_1.alarm_threshold") is None  # wear_trend has no per-joint settings
    with pytest.raises(ValueError, match="unknown node 'cell'"):
        node_parameters("cell")


RANGED = ParamDecl("warn_threshold", 30.0, "wear of WARN", 0.0, 100.0)


@settings(deadline=None, derandomize=True)
@given(st.one_of(st.integers(-1000, 1000), st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
                 st.text(max_size=4)))
def test_check_takes_a_number_within_the_range_and_refuses_anything_else_with_the_reason(value):
    ok = (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
          and 0.0 <= value <= 100.0)
    if ok:
        got = RANGED.check(value)
        assert isinstance(got, float) and got == value
    else:
        with pytest.raises(ParameterError, match=r"^warn_threshold"):
            RANGED.check(value)


def test_check_leaves_text_and_dynamic_parameters_to_the_node():
    assert ParamDecl("method", "paper", "estimator").check("joint") == "joint"
    assert ParamDecl("include", [], "regexes", dynamic=True).check(["^/a$"]) == ["^/a$"]
    assert ParamDecl("buffer_max", 10, "count").check(12) == 12
    with pytest.raises(ParameterError, match="is an integer"):
        ParamDecl("buffer_max", 10, "count").check(1.5)


def test_node_config_reads_the_node_and_wildcard_sections_of_a_params_file_and_says_what_is_wrong(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text("/**:\n  ros__parameters:\n    use_sim_time: true\n"
                 "wear_trend:\n  ros__parameters:\n    robot: cell_7\n    nested: {a: 1}\n"
                 "other:\n  ros__parameters:\n    robot: nope\n")
    assert node_config("wear_trend", f) == {"use_sim_time": True, "robot": "cell_7", "nested.a": 1}
    assert node_config("no_such_node") == {}  # the package has no config for it
    (tmp_path / "bad.yaml").write_text("a: [unclosed\n")
    with pytest.raises(InputDataError, match=r"bad.yaml: not valid YAML"):
        node_config("wear_trend", tmp_path / "bad.yaml")
    with pytest.raises(InputDataError, match=r"missing.yaml: no such parameter file"):
        node_config("wear_trend", tmp_path / "missing.yaml")
    (tmp_path / "list.yaml").write_text("- 1\n")
    with pytest.raises(InputDataError, match="not a ROS 2 parameter file"):
        node_config("wear_trend", tmp_path / "list.yaml")
