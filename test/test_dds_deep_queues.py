"""A subscription deeper than 5000 keeps its depth only with the shipped Fast DDS profile.

Fast DDS caps every DataReader at its resource limit ``max_samples`` (5000) whatever depth the
subscription asks: ``demo --production`` gave production_observer a 28205-deep ``/joint_states``
queue and a starved observer still lost 3945 states. ``config/dds/deep_reader_queues.xml`` lifts the
readers' limits; ``deep_queue_env`` gives it to a node's process. Here one process publishes 12000
messages into a 20000-deep subscription it does not take from yet, then takes them (the profile must
be in the environment before Fast DDS starts, so each case is its own interpreter).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from jointwear_ros.nodes.runtime import FASTDDS_PROFILES_VAR, deep_queue_env, loopback_env

pytestmark = pytest.mark.ros

SCRIPT = r"""
import json, sys, time
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64

n, depth = int(sys.argv[1]), int(sys.argv[2])
rclpy.init()
pub_node, sub_node = rclpy.create_node("deep_pub"), rclpy.create_node("deep_sub")
qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST)
got = []
sub_node.create_subscription(Float64, "/deep_queue_check", lambda m: got.append(m.data), qos)
pub = pub_node.create_publisher(Float64, "/deep_queue_check", qos)
end = time.monotonic() + 20.0
while pub.get_subscription_count() == 0 and time.monotonic() < end:
    time.sleep(0.05)
for i in range(n):
    pub.publish(Float64(data=float(i)))
time.sleep(0.5)
ex = SingleThreadedExecutor()
ex.add_node(sub_node)
quiet = time.monotonic()
while time.monotonic() - quiet < 1.0:
    before = len(got)
    ex.spin_once(timeout_sec=0.1)
    if len(got) != before:
        quiet = time.monotonic()
print(json.dumps({"received": len(got), "first": got[0] if got else None, "last": got[-1] if got else None}))
"""


def _queued(env: dict[str, str], n: int, depth: int) -> dict:
    run = subprocess.run([sys.executable, "-c", SCRIPT, str(n), str(depth)], env=env, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


def test_the_profile_lets_a_subscription_queue_its_whole_depth_beyond_fast_dds_5000():
    env = loopback_env(int(os.environ["ROS_DOMAIN_ID"]))
    env.pop(FASTDDS_PROFILES_VAR, None)
    plain = _queued(env, 12000, 20000)
    deep = _queued(deep_queue_env(env), 12000, 20000)
    print(f"without the profile {plain}, with it {deep}")
    assert plain["received"] < 12000  # the cap the profile exists for (Fast DDS's default max_samples, 5000)
    assert deep == {"received": 12000, "first": 0.0, "last": 11999.0}
    # a depth below the messages queued still keeps the newest `depth` (KEEP_LAST), not the first 5000
    assert _queued(deep_queue_env(env), 12000, 8000) == {"received": 8000, "first": 4000.0, "last": 11999.0}


def test_an_environment_naming_its_own_profile_keeps_it(tmp_path):
    own = tmp_path / "mine.xml"
    assert deep_queue_env({FASTDDS_PROFILES_VAR: str(own)})[FASTDDS_PROFILES_VAR] == str(own)
    shipped = deep_queue_env({})[FASTDDS_PROFILES_VAR]
    assert shipped.endswith("config/dds/deep_reader_queues.xml") and os.path.isfile(shipped)
