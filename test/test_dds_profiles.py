"""The suite's Fast DDS profiles (``config/dds/``), each measured against Fast DDS without it.

- ``prompt_acks.xml``, every jointwear process's: a reliable writer heartbeats every 50 ms, so
  ``wait_for_all_acked`` returns once the reader has the data. Fast DDS's default heartbeat (3 s) made a
  node's 0.5 s wait on its way out always run out, its last messages unconfirmed.
- ``deep_reader_queues.xml``: a subscription deeper than 5000 keeps its depth. Fast DDS caps every
  DataReader at its resource limit ``max_samples`` (5000) whatever depth the subscription asks:
  ``demo --production`` gave production_observer a 28205-deep ``/joint_states`` queue and a starved
  observer still lost 3945 states. ``deep_queue_env`` gives it to a node's process. Here one process
  publishes 7000 messages into an 8000-deep subscription it does not take from yet, then takes them.

A profile must be in the environment before Fast DDS starts, so each case is its own interpreter.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from jointwear_ros.nodes.runtime import (
    DEEP_QUEUES_PROFILE,
    FASTDDS_PROFILES_VAR,
    PROMPT_ACKS_PROFILE,
    deep_queue_env,
    loopback_env,
    use_prompt_acks,
)
from jointwear_ros.resources import config_path

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
    # 7000 messages: beyond the cap, and each taken costs the spinning executor about 0.4 ms (12000 took 21 s)
    plain = _queued(env, 7000, 8000)
    deep = _queued(deep_queue_env(env), 7000, 8000)
    print(f"without the profile {plain}, with it {deep}")
    assert plain["received"] < 7000  # the cap the profile exists for (Fast DDS's default max_samples, 5000)
    assert deep == {"received": 7000, "first": 0.0, "last": 6999.0}
    # a depth beyond the cap but below the messages queued keeps the newest `depth` (KEEP_LAST), not the first 5000
    assert _queued(deep_queue_env(env), 7000, 6000) == {"received": 6000, "first": 1000.0, "last": 6999.0}


def test_an_environment_naming_its_own_profile_keeps_it(tmp_path):
    own = tmp_path / "mine.xml"
    assert deep_queue_env({FASTDDS_PROFILES_VAR: str(own)})[FASTDDS_PROFILES_VAR] == str(own)
    shipped = deep_queue_env({})[FASTDDS_PROFILES_VAR]
    assert shipped.endswith("config/dds/deep_reader_queues.xml") and os.path.isfile(shipped)


#: A reliable subscriber in its own process (in one process Fast DDS delivers and acknowledges at once)
ACK_READER = r"""
import sys, time
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64

rclpy.init()
node = rclpy.create_node("acks_sub")
node.create_subscription(Float64, "/prompt_acks_check", lambda m: print(m.data, flush=True),
                         QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
end = time.monotonic() + 60.0
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
"""

#: ... and a publisher that waits (``argv[1]`` s) for each of three messages to be acknowledged
ACK_WRITER = r"""
import json, sys, time
import rclpy
from rclpy.duration import Duration
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64

rclpy.init()
node = rclpy.create_node("acks_pub")
pub = node.create_publisher(Float64, "/prompt_acks_check", QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
end = time.monotonic() + 30.0
while pub.get_subscription_count() == 0 and time.monotonic() < end:
    time.sleep(0.05)
time.sleep(0.5)
acked = []
for i in range(3):
    pub.publish(Float64(data=float(i)))
    acked.append(pub.wait_for_all_acked(Duration(seconds=float(sys.argv[1]))))
print(json.dumps(acked))
"""


def _acks(env: dict[str, str], timeout: float) -> tuple[list[bool], int]:
    """Whether each of three messages was acknowledged within ``timeout`` s, and how many the reader printed."""
    reader = subprocess.Popen([sys.executable, "-c", ACK_READER], env=env, stdout=subprocess.PIPE, text=True)
    try:
        run = subprocess.run([sys.executable, "-c", ACK_WRITER, str(timeout)], env=env, capture_output=True,
                             text=True, timeout=120)
        assert run.returncode == 0, run.stderr[-2000:]
        acked = json.loads(run.stdout.strip().splitlines()[-1])
    finally:
        reader.terminate()
        out, _ = reader.communicate(timeout=30)
    return acked, len(out.split())


def test_with_the_suite_profile_a_wait_for_acknowledgements_returns_once_the_reader_has_the_data():
    env = loopback_env(int(os.environ["ROS_DOMAIN_ID"]))
    env.pop(FASTDDS_PROFILES_VAR, None)
    # Fast DDS's own 3 s heartbeat: the reader has every message, and a 1 s wait runs out on those that no
    # heartbeat fell on (2.6-3.0 s each measured)
    acked, received = _acks(env, 1.0)
    assert received == 3 and not all(acked), acked
    use_prompt_acks(env)
    assert env[FASTDDS_PROFILES_VAR].endswith("config/dds/prompt_acks.xml")
    assert _acks(env, 2.0) == ([True, True, True], 3)  # about 0.06 s each measured
    # the deep-queue profile keeps the prompt acknowledgements
    assert _acks(deep_queue_env(env), 2.0) == ([True, True, True], 3)


def _writers(name: str) -> list[str]:
    root = ET.parse(config_path(name)).getroot()  # well-formed (Fast DDS's parser let a "--" in a comment pass)
    writers = [w for w in root.iter() if w.tag.endswith("data_writer")]
    for w in writers:
        w.tail = None
    return [ET.tostring(w, encoding="unicode") for w in writers]


def test_the_deep_queue_profile_carries_the_same_writer_profile_and_a_users_profile_is_kept(tmp_path):
    assert _writers(PROMPT_ACKS_PROFILE) and _writers(DEEP_QUEUES_PROFILE) == _writers(PROMPT_ACKS_PROFILE)
    own = str(tmp_path / "mine.xml")
    env = {FASTDDS_PROFILES_VAR: own}
    use_prompt_acks(env)
    assert env[FASTDDS_PROFILES_VAR] == own and deep_queue_env(env)[FASTDDS_PROFILES_VAR] == own
    env = {}
    use_prompt_acks(env)  # the suite's own profile is replaced by the deep one where a node needs deep queues
    assert deep_queue_env(env)[FASTDDS_PROFILES_VAR].endswith("config/dds/deep_reader_queues.xml")


def test_an_installation_without_the_profile_file_leaves_the_variable_unset(monkeypatch, tmp_path):
    import jointwear_ros.resources as resources

    monkeypatch.setattr(resources, "config_path", lambda name: tmp_path / "config" / name)
    env: dict[str, str] = {}
    use_prompt_acks(env)
    assert env == {}
