"""The cell's Foxglove layout and diagnostic_aggregator analyzers name only what the suite publishes.

The shipped files are what tools/foxglove_config.py writes; then the suite's six nodes run on loopback
DDS (real processes, their config files) and every topic, message field and diagnostic status name the
layout and the analyzers reference must be seen on that graph.
"""

from __future__ import annotations

import json
import os
import re
import sys
import time
from pathlib import Path

import pytest
import yaml

pytest.importorskip("rclpy")

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import foxglove_config as fc  # noqa: E402

LAYOUT = ROOT / "config" / "foxglove" / fc.LAYOUT
ANALYZERS = ROOT / "config" / "foxglove" / fc.ANALYZERS


def test_the_shipped_files_are_what_the_generator_writes():
    files = fc.render("robot_1", list(fc.DEFAULT_JOINTS))
    assert LAYOUT.read_text(encoding="utf-8") == files[fc.LAYOUT], "run python tools/foxglove_config.py"
    assert ANALYZERS.read_text(encoding="utf-8") == files[fc.ANALYZERS], "run python tools/foxglove_config.py"


def references() -> dict[str, set]:
    """What the layout and the analyzers name: topics, (topic, field) pairs, joints, status names/prefixes/regexes."""
    lay = json.loads(LAYOUT.read_text())
    out: dict[str, set] = {"topics": set(), "fields": set(), "names": set(), "prefixes": set(), "regexes": set()}
    panel_ids = set(re.findall(r'"((?:\w| )+![\w]+)"', json.dumps(lay["layout"])))
    for tab in lay["configById"].get("Tab!cell", {}).get("tabs", []):
        panel_ids |= set(re.findall(r'"((?:\w| )+![\w]+)"', json.dumps(tab["layout"])))
    assert panel_ids <= set(lay["configById"]), "the layout tree names a panel without a config"
    assert set(lay["configById"]) <= panel_ids, "a panel config is not placed in the layout"
    for pid, cfg in lay["configById"].items():
        if "topicToRender" in cfg:
            out["topics"].add(cfg["topicToRender"])
        if cfg.get("selectedName"):
            out["names"].add(cfg["selectedName"])
        for p in cfg.get("paths", []) + ([cfg["xAxisPath"]] if "xAxisPath" in cfg else []):
            m = re.fullmatch(r'(/[\w/]+)(?:\{(\w+)=="([^"]+)"\})?\.(\w+)', p["value"])
            assert m, f"{pid}: message path {p['value']!r} not understood"
            out["topics"].add(m.group(1))
            out["fields"].add((m.group(1), m.group(4)))
            if m.group(2):
                out["fields"].add((m.group(1), m.group(2)))
    params = yaml.safe_load(ANALYZERS.read_text())["analyzers"]["ros__parameters"]

    def walk(node: dict) -> None:
        for v in node.values():
            if isinstance(v, dict) and "type" in v:
                assert v["type"] in ("diagnostic_aggregator/GenericAnalyzer", "diagnostic_aggregator/AnalyzerGroup")
                out["names"] |= set(v.get("expected", []))
                out["prefixes"] |= set(v.get("startswith", []))
                out["regexes"] |= set(v.get("regex", []))
                walk(v.get("analyzers", {}))

    walk(params)
    return out


def _msg_fields(type_name: str) -> set[str]:
    pkg, _, name = type_name.split("/")
    if pkg == "jointwear_msgs":
        text = (ROOT / "msg_defs" / "msg" / f"{name}.msg").read_text()
        return {ln.split()[1] for ln in text.splitlines() if ln.strip() and not ln.startswith("#")
                and "=" not in ln.split("#")[0]}
    raise AssertionError(f"no field list for {type_name}")


def test_every_topic_field_and_status_name_referenced_is_published_by_the_running_suite(tmp_path,
                                                                                        ros_context_per_test):
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor

    from jointwear_ros.history import EstimateRecord, HistoryStore
    from jointwear_ros.nodes.cell import start_child, stop_children
    from jointwear_ros.nodes.runtime import loopback_env

    refs = references()
    assert refs["names"] and refs["prefixes"] and refs["regexes"] and refs["topics"]
    db = tmp_path / "history.db"
    with HistoryStore(str(db)) as store:  # wear_trend reloads robot_1's history and reports every joint
        store.add_estimates([EstimateRecord("robot_1", j, k + 1, 1.7e9 + 86400.0 * k, 10.0, 0.8)
                             for j in fc.DEFAULT_JOINTS for k in range(6)])
    domain = int(os.environ["ROS_DOMAIN_ID"])
    env = loopback_env(domain)
    params = {
        "recorder": {"use_sim_time": True, "output_dir": str(tmp_path / "bags")},
        "joint_sim": {"use_sim_time": False, "publish_clock": True},
        "test_cycle": {"use_sim_time": True, "simulator": True},
        "friction_observer": {"use_sim_time": True},
        "wear_estimator": {"use_sim_time": True},
        "wear_trend": {"db_url": str(db), "robot": "robot_1"},
    }
    children = [start_child(name, p, env, tmp_path) for name, p in params.items()]
    ctx = ros_context_per_test
    node = rclpy.create_node("jointwear_names_probe", context=ctx)
    seen: set[str] = set()
    node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: seen.update(s.name for s in m.status), 100)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    topics: dict[str, list[str]] = {}
    try:
        deadline = time.monotonic() + 120

        def missing() -> list[str]:
            gone = sorted(refs["names"] - seen)
            gone += [p for p in refs["prefixes"] if not any(n.startswith(p) for n in seen)]
            gone += [r for r in refs["regexes"] if not any(re.match(r, n) for n in seen)]
            gone += sorted(refs["topics"] - set(topics))
            return gone

        while missing():
            for c in children:
                assert c.alive(), f"{c.name} exited: {c.log_tail()}"
            assert time.monotonic() < deadline, f"never seen on the cell's graph: {missing()}"
            ex.spin_once(timeout_sec=0.1)
            topics = dict(node.get_topic_names_and_types())
    finally:
        ex.shutdown()
        node.destroy_node()
        stop_children(children)
    assert topics["/diagnostics"] == ["diagnostic_msgs/msg/DiagnosticArray"]
    for topic, field in refs["fields"]:
        (type_name,) = topics[topic]
        assert field in _msg_fields(type_name), f"{topic} ({type_name}) has no field {field!r}"
    # each joint regex picks that joint's statuses of every per-joint node, and nothing else
    for j in fc.DEFAULT_JOINTS:
        (rx,) = [r for r in refs["regexes"] if r.endswith(f"{j}$")]
        assert {n for n in seen if re.match(rx, n)} == {f"{node}: {j}" for node in fc.JOINT_NODES}
