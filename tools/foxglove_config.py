"""Write the cell's Foxglove layout and the matching diagnostic_aggregator analyzers.

    python tools/foxglove_config.py                       # the shipped files: robot_1, joint_1..joint_6
    python tools/foxglove_config.py --robot cell_7 --joints joint_1,joint_2,joint_3 --out my_cell/

``config/foxglove/jointwear-cell.json`` (import in Foxglove: Layouts, Import from file):
Diagnostics Summary of ``/diagnostics`` and a Detail panel per node, plots of the wear estimate and
the trend per joint, and tau_f against speed per joint from the friction observations.
``config/foxglove/jointwear_analyzers.yaml`` (``ros2 run diagnostic_aggregator aggregator_node
--ros-args --params-file ...``): the cell's statuses under ``/<robot>/nodes/<node>``,
``/<robot>/joints/<joint>`` and ``/<robot>/robot``. Topic and status names are the suite's defaults
(config/*.yaml); test/test_foxglove_config.py checks them against a running cell.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "config" / "foxglove"
LAYOUT = "jointwear-cell.json"
ANALYZERS = "jointwear_analyzers.yaml"

DIAGNOSTICS = "/diagnostics"
ESTIMATE = "/jointwear/wear_estimate"
TREND = "/jointwear/wear_trend"
OBSERVATIONS = "/jointwear/friction_observations"
#: nodes with one status per joint, "<node>: <joint>"
JOINT_NODES = ("joint_sim", "test_cycle", "friction_observer", "wear_estimator", "wear_trend")
DEFAULT_JOINTS = tuple(f"joint_{i}" for i in range(1, 7))


def _plot(title: str, paths: list[dict[str, Any]], **extra: Any) -> dict[str, Any]:
    return {"title": title, "paths": paths, "showXAxisLabels": True, "showYAxisLabels": True, "showLegend": True,
            "legendDisplay": "floating", "isSynced": True, "xAxisVal": "timestamp", **extra}


def _series(topic: str, joint: str, field: str, label: str) -> dict[str, Any]:
    return {"value": f'{topic}{{joint_name=="{joint}"}}.{field}', "enabled": True, "timestampMethod": "headerStamp",
            "label": label}


def layout(joints: list[str]) -> dict[str, Any]:
    """The Foxglove layout (configById / layout tree) for a cell with ``joints``."""
    cfg: dict[str, Any] = {
        "DiagnosticSummary!cell": {"topicToRender": DIAGNOSTICS, "minLevel": 0, "pinnedIds": [],
                                   "hardwareIdFilter": "", "sortByLevel": True},
        "Plot!wear": _plot("wear estimate per joint (w_hat; alarm 35)",
                           [_series(ESTIMATE, j, "wear", j) for j in joints]),
        "Plot!trend": _plot("time to alarm per joint, 90 % lower bound (days)",
                            [_series(TREND, j, "time_to_alarm_lo90", j) for j in joints]),
        "Plot!tau_f": _plot("static friction tau_f against speed (per joint)",
                            [_series(OBSERVATIONS, j, "tau_f", j) for j in joints], xAxisVal="custom",
                            xAxisPath={"value": f"{OBSERVATIONS}.speed", "enabled": True}),
    }
    details = []
    for node in JOINT_NODES:
        pid = f"DiagnosticStatusPanel!{node}"
        cfg[pid] = {"topicToRender": DIAGNOSTICS, "selectedName": f"{node}: {joints[0]}", "collapsedSections": []}
        details.append(pid)
    cfg["DiagnosticStatusPanel!robot"] = {"topicToRender": DIAGNOSTICS, "selectedName": "test_cycle: robot",
                                          "collapsedSections": []}
    details.append("DiagnosticStatusPanel!robot")

    def stack(ids: list[str], direction: str = "column") -> Any:
        if len(ids) == 1:
            return ids[0]
        half = len(ids) // 2
        return {"first": stack(ids[:half], direction), "second": stack(ids[half:], direction),
                "direction": direction, "splitPercentage": 100.0 * half / len(ids)}

    cfg["Tab!cell"] = {"activeTabIdx": 0, "tabs": [
        {"title": "wear", "layout": {"first": "Plot!wear", "second": "Plot!trend", "direction": "column"}},
        {"title": "friction", "layout": "Plot!tau_f"},
        {"title": "nodes", "layout": {"first": stack(details[:3]), "second": stack(details[3:]), "direction": "row"}},
    ]}
    return {"configById": cfg, "globalVariables": {}, "userNodes": {}, "linkedGlobalVariables": [],
            "playbackConfig": {"speed": 1}, "layout": {"first": "DiagnosticSummary!cell", "second": "Tab!cell",
                                                       "direction": "row", "splitPercentage": 35}}


def analyzers(robot: str, joints: list[str]) -> dict[str, Any]:
    """diagnostic_aggregator parameters: per node, per joint and the robot's own status, under ``/<robot>``."""
    generic = "diagnostic_aggregator/GenericAnalyzer"
    nodes: dict[str, Any] = {}
    for node in JOINT_NODES:
        expected = [f"{node}: {j}" for j in joints] + (["test_cycle: robot"] if node == "test_cycle" else [])
        nodes[node] = {"type": generic, "path": node, "startswith": [f"{node}:"], "expected": expected}
    nodes["recorder"] = {"type": generic, "path": "recorder", "startswith": ["recorder:"]}
    per_joint = {j: {"type": generic, "path": j, "regex": [rf"^[a-z_]+: {re.escape(j)}$"]} for j in joints}
    return {"analyzers": {"ros__parameters": {
        "path": robot,
        "nodes": {"type": "diagnostic_aggregator/AnalyzerGroup", "path": "nodes", "analyzers": nodes},
        "joints": {"type": "diagnostic_aggregator/AnalyzerGroup", "path": "joints", "analyzers": per_joint},
        "robot": {"type": generic, "path": "robot", "expected": ["test_cycle: robot"]},
    }}}


def render(robot: str, joints: list[str]) -> dict[str, str]:
    """File name -> text of both files."""
    head = ("# diagnostic_aggregator analyzers for a jointwear cell (written by tools/foxglove_config.py).\n"
            "# ros2 run diagnostic_aggregator aggregator_node --ros-args --params-file jointwear_analyzers.yaml\n")
    return {LAYOUT: json.dumps(layout(joints), indent=2) + "\n",
            ANALYZERS: head + yaml.safe_dump(analyzers(robot, joints), sort_keys=False, width=120)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robot", default="robot_1", help="robot name: the aggregator's top path (default robot_1)")
    ap.add_argument("--joints", default=",".join(DEFAULT_JOINTS), help="comma-separated joint names")
    ap.add_argument("--out", default=str(OUT), help="output folder (default config/foxglove)")
    args = ap.parse_args(argv)
    joints = [j.strip() for j in args.joints.split(",") if j.strip()]
    if not joints:
        ap.error("--joints: give at least one joint name")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in render(args.robot, joints).items():
        (out / name).write_text(text, encoding="utf-8")
        print(f"wrote {out / name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
