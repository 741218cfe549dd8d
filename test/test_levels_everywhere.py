"""One alarm, one meaning on the ROS graph: five wear_trend nodes (one per robot) reload the 30-joint example plant
(OK, WARN, ERROR, STALE, near-threshold, a held outlier, a partial cycle) and their ``/diagnostics`` and
``WearTrend`` give every joint the condition level and the forecast that ``trend --json`` gives (its own, the
trend's; the plant's STALE-by-age is serve's and trend's, the node reports the joint's condition).

The other surfaces of the same plant (serve's page, ``/api/joints``, ``/metrics``, the fleet page) are checked in
test_serve.py; the wear_estimator against the trend over one sequence in test_condition.py.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import spin_until  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from jointwear_msgs.msg import WearTrend  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

from jointwear_ros.contract import DiagnosticLevel  # noqa: E402
from jointwear_ros.nodes.wear_trend import WearTrendNode  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
from plant_example import OUTLIER_JOINT, PARTIAL_JOINT, ROBOTS, write_plant  # noqa: E402

pytestmark = pytest.mark.ros

LATCHED = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=100,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def test_wear_trend_diagnostics_and_wear_trend_agree_with_trend_json_on_a_30_joint_plant(ros_context, tmp_path):
    db = str(tmp_path / "plant.db")
    write_plant(db)
    r = subprocess.run([sys.executable, "-m", "jointwear_ros", "trend", "--db", db, "--json"],
                       capture_output=True, text=True, check=True, cwd=ROOT)
    tj = {(j["robot"], j["joint"]): j for j in json.loads(r.stdout)["joints"]}
    assert len(tj) == 30
    ns = "/levels_everywhere"
    probe = rclpy.create_node("levels_probe", context=ros_context)
    trends: list[WearTrend] = []
    diags: list[DiagnosticArray] = []
    probe.create_subscription(WearTrend, f"{ns}/wear_trend", trends.append, LATCHED)
    probe.create_subscription(DiagnosticArray, f"{ns}/diagnostics", diags.append, 100)
    nodes = [WearTrendNode(context=ros_context, parameter_overrides=[
        Parameter("db_url", value=db), Parameter("robot", value=robot),
        Parameter("estimate_topic", value=f"{ns}/wear_estimate"), Parameter("trend_topic", value=f"{ns}/wear_trend"),
        Parameter("diagnostics_topic", value=f"{ns}/diagnostics"), Parameter("diagnostics_period", value=0.2),
        Parameter("buffer_path", value=str(tmp_path / f"{robot}.pending.jsonl")),
    ]) for robot in ROBOTS]
    ex = SingleThreadedExecutor(context=ros_context)
    for n in [probe, *nodes]:
        ex.add_node(n)
    try:
        def statuses() -> dict[tuple[str, str], object]:
            out = {}
            for arr in diags:
                for s in arr.status:
                    if s.name.startswith("wear_trend: ") and s.name != "wear_trend: history":
                        out[tuple(s.hardware_id.split("/", 1))] = s
            return out

        spin_until(ex, lambda: len({(t.robot, t.joint_name) for t in trends}) == 30 and len(statuses()) == 30,
                   60.0, "30 joints' WearTrend and /diagnostics")
        last = {(t.robot, t.joint_name): t for t in trends}
        st = statuses()
        for key, j in tj.items():
            want = j["trend_level"]  # the joint's condition level (trend --json's level adds the plant's STALE)
            assert DiagnosticLevel(last[key].level).name == want, key
            level = st[key].level
            assert DiagnosticLevel(level[0] if isinstance(level, bytes) else int(level)).name == want, key
            values = {kv.key: kv.value for kv in st[key].values}
            assert last[key].alarm_expected is j["alarm_expected"], key
            assert values["alarm_expected"] == ("true" if j["alarm_expected"] else "false"), key
            assert float(values["level_wear"]) == pytest.approx(j["condition"]["wear"], abs=1e-3), key
        assert last[OUTLIER_JOINT].confirmation == "unconfirmed" and last[PARTIAL_JOINT].evidence == "partial"
    finally:
        for n in nodes:
            n.destroy_node()
        probe.destroy_node()
