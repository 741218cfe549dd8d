"""Recorder throughput: JointState messages published at a fixed rate vs messages in the bag.

A recorder process (Python executor or rclpy's EventsExecutor) records
/joint_states while this process publishes N messages at each rate (RELIABLE,
depth 1000, as joint_sim does); the bag is then read back and counted. Also
prints the recorder's CPU time per message. Measures only; asserts nothing.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from jointwear_ros.io.bags import bag_info, find_bags

RATES = (500.0, 2000.0, 4000.0)
SECONDS = 3.0
CHILD = """
import sys
from jointwear_ros.nodes.runtime import run_node
from jointwear_ros.nodes.recorder import RecorderNode
raise SystemExit(run_node(RecorderNode, sys.argv[2:], events=sys.argv[1] == "events"))
"""


def run(mode: str, rate: float, out: Path) -> tuple[int, int, float]:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    args = ["--ros-args", "-p", f"output_dir:={out}", "-p", "include:=['^/joint_states$']"]
    proc = subprocess.Popen([sys.executable, "-c", CHILD, mode, *args], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rclpy.init()
    node = rclpy.create_node("bench_recorder_pub")
    pub = node.create_publisher(JointState, "/joint_states", QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
    end = time.monotonic() + 30
    while pub.get_subscription_count() < 1 and time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.05)
    time.sleep(0.5)
    n = int(rate * SECONDS)
    msg = JointState(name=["joint_0", "joint_1"], position=[0.0, 0.0], velocity=[0.0, 0.0], effort=[0.0, 0.0])
    t0 = time.perf_counter()
    for i in range(n):
        msg.position[1] = float(i)
        pub.publish(msg)
        due = t0 + (i + 1) / rate
        while time.perf_counter() < due:
            pass
    time.sleep(1.0)
    node.destroy_node()
    rclpy.try_shutdown()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=60)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    bags = find_bags(out)
    got = bag_info(bags[-1]).topics.get("/joint_states", {}).get("count", 0) if bags else 0
    return n, got, cpu


def main() -> int:
    print(f"{'executor':>9} {'rate Hz':>8} {'sent':>6} {'recorded':>9} {'lost %':>7} {'CPU s':>6} {'us/msg':>7}")
    for mode in ("python", "events"):
        for rate in RATES:
            with tempfile.TemporaryDirectory() as d:
                n, got, cpu = run(mode, rate, Path(d))
            print(f"{mode:>9} {rate:8.0f} {n:6d} {got:9d} {100 * (n - got) / n:7.1f} {cpu:6.2f} {1e6 * cpu / max(n, 1):7.0f}",
                  flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
