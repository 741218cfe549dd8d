"""Recorder under load: a six-joint 1 kHz /joint_states stream plus a test cycle's traffic, for minutes.

A publisher process sends, for ``--seconds`` (default 300):

- ``/joint_states`` (six joints, RELIABLE depth 1000 as joint_sim) at 1 kHz,
- ``/velocity_controller/commands`` at 100 Hz (test_cycle's command_rate),
- ``/test_cycle/status`` at 10 Hz (status_rate),
- ``/jointwear/friction_observations`` at 1 Hz, ``/jointwear/wear_estimate``
  every 10 s, and a ``/diagnostics`` array at 1 Hz,

paced on the wall clock (messages due are sent at once when the publisher
falls behind, so the totals are exact). A recorder process (the real node,
``python -m jointwear_ros.nodes.recorder``, default parameters: 0.5 s sync,
fsync, zstd) records everything. At the end the publisher waits for every
reliable message to be acknowledged and prints its counts; the recorder is
stopped with SIGINT and its bag is read back (``bag_info`` with the CRC check).
Prints, per topic, published vs recorded and the DDS-reported lost count, and
the recorder's CPU (``/proc/<pid>/stat``) and peak memory. Measures only.

Usage: python bench/bench_recorder_load.py [--seconds S]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

JOINTS = 6
RATES = {  # topic: Hz
    "/joint_states": 1000.0,
    "/velocity_controller/commands": 100.0,
    "/test_cycle/status": 10.0,
    "/jointwear/friction_observations": 1.0,
    "/jointwear/wear_estimate": 0.1,
    "/diagnostics": 1.0,
}


def publisher(seconds: float) -> int:
    """The publisher process: paced publishing, then acks; prints JSON counts on stdout."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate
    from rclpy.duration import Duration
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray

    rclpy.init()
    node = rclpy.create_node("bench_load_pub")
    reliable = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    pubs = {
        "/joint_states": node.create_publisher(JointState, "/joint_states", reliable),
        "/velocity_controller/commands": node.create_publisher(Float64MultiArray, "/velocity_controller/commands",
                                                                reliable),
        "/test_cycle/status": node.create_publisher(TestCycleStatus, "/test_cycle/status", 10),
        "/jointwear/friction_observations": node.create_publisher(FrictionObservation,
                                                                   "/jointwear/friction_observations", 10),
        "/jointwear/wear_estimate": node.create_publisher(WearEstimate, "/jointwear/wear_estimate", 10),
        "/diagnostics": node.create_publisher(DiagnosticArray, "/diagnostics", 10),
    }
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not all(p.get_subscription_count() for p in pubs.values()):
        rclpy.spin_once(node, timeout_sec=0.05)
    time.sleep(1.0)
    names = [f"joint_{i}" for i in range(JOINTS)]
    js = JointState(name=names, position=[0.0] * JOINTS, velocity=[0.0] * JOINTS, effort=[0.0] * JOINTS)
    sent = dict.fromkeys(RATES, 0)

    def make(topic: str, i: int) -> object:
        if topic == "/joint_states":
            js.header.stamp = node.get_clock().now().to_msg()
            js.position = [0.001 * i + k for k in range(JOINTS)]
            js.effort = [12.5 + 1e-4 * i] * JOINTS
            return js
        if topic == "/velocity_controller/commands":
            return Float64MultiArray(data=[0.0, 0.5, 0.0, 0.0, 0.0, 0.0])
        if topic == "/test_cycle/status":
            return TestCycleStatus(joint_name="joint_1", cycle_id=1 + i // 300, state=TestCycleStatus.RUNNING,
                                   speeds_done=(i // 40) % 8, speeds_total=8, current_speed=40.0)
        if topic == "/jointwear/friction_observations":
            return FrictionObservation(joint_name="joint_1", cycle_id=1 + i // 30, speed=40.0, tau_f=0.05,
                                       tau_f_std=0.001, samples_plus=400, samples_minus=400)
        if topic == "/jointwear/wear_estimate":
            return WearEstimate(joint_name="joint_1", cycle_id=1 + i, method="paper", wear=20.0, wear_std=3.0,
                                speeds=[10.0, 20.0, 40.0], per_speed_wear=[20.0, 21.0, 19.0], alarm_threshold=35.0)
        st = DiagnosticStatus(name="bench: load", hardware_id="joint_1", message="ok",
                              values=[KeyValue(key="i", value=str(i))])
        return DiagnosticArray(status=[st])

    t0 = time.monotonic()
    end = t0 + seconds
    while True:
        now = min(time.monotonic(), end)
        for topic, rate in RATES.items():
            due = int((now - t0) * rate) + 1
            while sent[topic] < due:
                pubs[topic].publish(make(topic, sent[topic]))
                sent[topic] += 1
        if now >= end:
            break
        time.sleep(0.0005)
    for p in pubs.values():
        p.wait_for_all_acked(Duration(seconds=30.0))
    elapsed = time.monotonic() - t0
    print(json.dumps({"sent": sent, "seconds": elapsed}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _peak_rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=300.0, help="publishing time (default 300)")
    ap.add_argument("--publisher", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.publisher:
        return publisher(a.seconds)

    from jointwear_ros.io.bags import bag_info, find_bags
    from jointwear_ros.nodes.runtime import loopback_env

    env = loopback_env(domain_id=int(os.environ.get("ROS_DOMAIN_ID", "52")))
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "bags"
        rec = subprocess.Popen(
            [sys.executable, "-m", "jointwear_ros.nodes.recorder", "--ros-args", "-p", f"output_dir:={out}",
             "-p", "exclude:=['^/rosout$', '^/parameter_events$']", "-p", "diagnostics_topic:=/recorder/diagnostics"],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        time.sleep(2.0)
        pub = subprocess.Popen([sys.executable, __file__, "--publisher", "--seconds", str(a.seconds)],
                               env=env, stdout=subprocess.PIPE, text=True)
        # the recorder's CPU is measured over the publishing window (after discovery settled)
        cpu0, t0 = _cpu_seconds(rec.pid), time.monotonic()
        stdout, _ = pub.communicate(timeout=a.seconds + 180)
        cpu1, t1 = _cpu_seconds(rec.pid), time.monotonic()
        time.sleep(1.0)
        rss = _peak_rss_mb(rec.pid)
        rec.send_signal(signal.SIGINT)
        _, err = rec.communicate(timeout=120)
        report = json.loads(stdout.strip().splitlines()[-1])
        bags = find_bags(out)
        info = bag_info(bags[-1]) if bags else None
    sent, secs = report["sent"], report["seconds"]
    print(f"recorder load: {a.seconds:.0f} s of publishing ({secs:.0f} s until every message was acknowledged), "
          f"recorder exit {rec.returncode}")
    print(f"{'topic':34} {'published':>10} {'recorded':>10} {'lost':>6} {'missing':>8}")
    tot_p = tot_r = 0
    for topic in RATES:
        got = info.topics.get(topic, {}).get("count", 0) if info else 0
        lost = info.messages_lost.get(topic, 0) if info else 0
        tot_p += sent[topic]
        tot_r += got
        print(f"{topic:34} {sent[topic]:10d} {got:10d} {lost:6d} {sent[topic] - got:8d}")
    print(f"{'total':34} {tot_p:10d} {tot_r:10d} {'':6} {tot_p - tot_r:8d}")
    cpu = cpu1 - cpu0
    print(f"recorder CPU: {cpu:.1f} s over {t1 - t0:.0f} s = {100 * cpu / (t1 - t0):.1f} % of one core, "
          f"{1e6 * cpu / max(tot_r, 1):.0f} us per recorded message; peak RSS {rss:.0f} MiB; "
          f"bag {info.message_count if info else 0} messages incl. the recorder's own /diagnostics")
    if rec.returncode != 0:
        print(err[-2000:])
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
