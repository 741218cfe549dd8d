"""Friction observer speed: offline throughput and the live node's CPU use at 2 kHz.

1. Offline: ``observe_arrays`` (the replay path) on synthetic 8-speed test
   cycles at 2 kHz, in JointState samples per second (target >= 1,000,000).
   For comparison, the per-sample path the live node uses (``on_joint_state``
   per sample) on the same data.
2. Live: the ``friction_observer`` console script in a child process, fed
   ``sensor_msgs/JointState`` at 2 kHz (plus the test-cycle status stream) by
   this process over loopback DDS; the child's CPU time is read from
   ``/proc/<pid>/stat`` over the streaming period (target <= 20 % of one core).
   The observations it publishes are counted to show it kept up.
3. A whole robot (docs/robot.md): six joints in every JointState at 500 Hz, a robot cycle
   (joints tested one after another), one ``friction_observer`` process serving all six
   (``--robot``): its CPU, the observations per joint; offline, the per-joint split of the
   same stream (``observe_arrays`` per joint, and ``replay_bag`` on its MCAP bag) in samples/s.

Usage: python bench/run_all.py observer   (or python bench/bench_observer.py [--seconds S])
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jointwear_ros.contract import status_to_msg  # noqa: E402
from jointwear_ros.observer import FrictionObserverCore, ObserverConfig, observe_arrays  # noqa: E402
from jointwear_ros.observer.synthetic import synthetic_cycle  # noqa: E402

RATE = 2000.0


def _cycles(n: int, speeds: tuple[float, ...] = (10, 20, 30, 40, 50, 80, 120, 160)):
    """n consecutive synthetic cycles at 2 kHz as one stream."""
    ts, ps, vs, es, sts = [], [], [], [], []
    t0 = 100.0
    for k in range(n):
        c = synthetic_cycle(speeds=speeds, rate=RATE, seed=k, cycle_id=k + 1, t0=t0)
        ts.append(c.stamps)
        ps.append(c.position)
        vs.append(c.velocity)
        es.append(c.effort)
        sts += c.statuses
        t0 = float(c.stamps[-1]) + 1.0 / RATE
    return np.concatenate(ts), np.concatenate(ps), np.concatenate(vs), np.concatenate(es), sts


def bench_offline() -> None:
    t, p, v, e, statuses = _cycles(6)
    cfg = ObserverConfig()
    best = float("inf")
    out = None
    for _ in range(5):
        t_start = time.perf_counter()
        out = observe_arrays(cfg, t, p, v, e, statuses)
        best = min(best, time.perf_counter() - t_start)
    assert out is not None
    print(f"offline observe_arrays: {t.size} samples, 6 cycles x 8 speeds, {len(out.observations)} observations, "
          f"{len(out.rejections)} rejections")
    print(f"  best of 5: {best * 1e3:.1f} ms -> {t.size / best / 1e6:.2f} M samples/s (target >= 1.00)")
    # the per-sample path of the live node, on one cycle
    n1 = t.size // 6
    core = FrictionObserverCore(cfg)
    st_t = [s.stamp for s in statuses]
    j = 0
    t_start = time.perf_counter()
    tl, pl, vl, el = t[:n1].tolist(), p[:n1].tolist(), v[:n1].tolist(), e[:n1].tolist()
    for i in range(n1):
        while j < len(st_t) and st_t[j] <= tl[i]:
            core.on_status(statuses[j])
            j += 1
        core.on_joint_state(tl[i], pl[i], vl[i], el[i])
    dt = time.perf_counter() - t_start
    print(f"  per-sample on_joint_state (live path): {n1 / dt / 1e6:.2f} M samples/s "
          f"({dt / n1 * 1e6:.2f} us/sample, {dt / n1 * RATE * 100:.2f} % of a core at 2 kHz)")


def _cpu_seconds(pid: int) -> float:
    """utime + stime of a process and its waited-for children, from /proc/<pid>/stat."""
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read().rsplit(")", 1)[1].split()
    ticks = sum(int(x) for x in fields[11:15])  # utime stime cutime cstime (fields 14-17)
    return ticks / os.sysconf("SC_CLK_TCK")


_SINGLE_THREADED = (
    "import sys; from jointwear_ros.nodes.friction_observer import FrictionObserverNode; "
    "from jointwear_ros.nodes.runtime import run_node; raise SystemExit(run_node(FrictionObserverNode, sys.argv[1:]))"
)


def bench_live(seconds: float, executor: str = "events") -> float:
    """CPU % of one core of the observer process; ``executor``: events (the node's) or single (rclpy's Python one)."""
    import rclpy
    from jointwear_msgs.msg import FrictionObservation, TestCycleStatus
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState

    from jointwear_ros.nodes.friction_observer import high_rate_qos, seconds_to_stamp

    ns = "/bench_obs"
    speeds = (20, 40, 80, 160, 120, 50)
    c = synthetic_cycle(speeds=speeds, rate=RATE, seed=1, cycle_id=1, t0=100.0)
    n = min(c.stamps.size, int(seconds * RATE))
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    exe = Path(sys.executable).parent / "friction_observer"
    head = [str(exe)] if executor == "events" else [sys.executable, "-c", _SINGLE_THREADED]
    cmd = [*head, "--ros-args", "--params-file", str(ROOT / "config" / "friction_observer.yaml"),
           "-p", f"joint_states_topic:={ns}/joint_states", "-p", f"status_topic:={ns}/status",
           "-p", f"observations_topic:={ns}/observations", "-p", "joints:=[joint_1]", "--log-level", "warn"]
    child = subprocess.Popen(cmd, env=env)
    rclpy.init()
    node = rclpy.create_node("bench_observer_feed")
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    got: list[FrictionObservation] = []
    try:
        js = node.create_publisher(JointState, f"{ns}/joint_states", high_rate_qos())
        st = node.create_publisher(TestCycleStatus, f"{ns}/status", high_rate_qos())
        node.create_subscription(FrictionObservation, f"{ns}/observations", got.append, high_rate_qos())
        end = time.monotonic() + 30
        while time.monotonic() < end and not (js.get_subscription_count() and st.get_subscription_count()
                                              and node.count_publishers(f"{ns}/observations")):
            ex.spin_once(timeout_sec=0.05)
        time.sleep(1.0)
        idle0, w0 = _cpu_seconds(child.pid), time.monotonic()
        time.sleep(2.0)
        idle = (_cpu_seconds(child.pid) - idle0) / (time.monotonic() - w0)

        msg = JointState()
        msg.name = ["joint_0", "joint_1"]
        statuses = [status_to_msg(s, TestCycleStatus) for s in c.statuses]
        st_t = [s.stamp for s in c.statuses]
        j = 0
        cpu0, wall0, own0 = _cpu_seconds(child.pid), time.monotonic(), time.process_time()
        for i in range(n):
            ts = float(c.stamps[i])
            while j < len(statuses) and st_t[j] <= ts:
                st.publish(statuses[j])
                j += 1
            msg.header.stamp = seconds_to_stamp(ts)
            msg.position = [0.0, float(c.position[i])]
            msg.velocity = [0.0, float(c.velocity[i])]
            msg.effort = [0.0, float(c.effort[i])]
            js.publish(msg)
            if i % 8 == 7:  # pace: 2 kHz on average
                ahead = wall0 + (i + 1) / RATE - time.monotonic()
                if ahead > 0:
                    ex.spin_once(timeout_sec=0)
                    time.sleep(ahead)
        wall = time.monotonic() - wall0
        cpu = _cpu_seconds(child.pid) - cpu0
        own = time.process_time() - own0
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            ex.spin_once(timeout_sec=0.05)
        label = "EventsExecutor (the node's default)" if executor == "events" else "rclpy SingleThreadedExecutor"
        print(f"live friction_observer, {label}, at {n / wall:.0f} Hz JointState input for {wall:.1f} s "
              f"({n} samples, 2 joints per message):")
        print(f"  observer process CPU: {100 * cpu / wall:.1f} % of one core (target <= 20 %); idle {100 * idle:.1f} %")
        print(f"  feeding process CPU: {100 * own / wall:.1f} % of one core")
        print(f"  observations received: {len(got)} of the {len(speeds)} speeds "
              f"({', '.join(f'{m.speed:.0f}' for m in got)} rad/s)")
        return 100 * cpu / wall
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        child.send_signal(2)
        try:
            child.wait(timeout=10)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()


ROBOT_JOINTS = [f"joint_{k}" for k in range(1, 7)]
ROBOT_RATE = 500.0


def _robot_cycle():
    from jointwear_ros.observer.synthetic import synthetic_robot_cycle

    return synthetic_robot_cycle(ROBOT_JOINTS, [10.0, 20.0, 45.0, 15.0, 25.0, 5.0], (30, 45, 60, 80), rate=ROBOT_RATE,
                                 seed=3, noise_std=0.004)


def bench_robot_offline() -> None:
    """The per-joint split offline: observe_arrays per joint, and replay_bag of the robot cycle's bag."""
    import tempfile

    from jointwear_ros.fleet.synthetic_bags import write_robot_cycle_bag
    from jointwear_ros.io.params import node_params_from_yaml
    from jointwear_ros.replay import replay_bag

    cyc = _robot_cycle()
    n = cyc.stamps.size
    best = float("inf")
    n_obs = 0
    for _ in range(3):
        t0 = time.perf_counter()
        n_obs = 0
        for k, j in enumerate(ROBOT_JOINTS):
            out = observe_arrays(ObserverConfig(joint_name=j), cyc.stamps, cyc.position[:, k], cyc.velocity[:, k],
                                 cyc.effort[:, k], cyc.statuses)
            n_obs += len(out.observations)
        best = min(best, time.perf_counter() - t0)
    print(f"robot cycle, {len(ROBOT_JOINTS)} joints at {ROBOT_RATE:g} Hz: {n} JointStates ({n * len(ROBOT_JOINTS)} "
          f"joint samples), {n_obs} observations")
    print(f"  observe_arrays per joint: {n * len(ROBOT_JOINTS) / best / 1e6:.2f} M joint samples/s "
          f"({n / best / 1e3:.0f} k JointStates/s)")
    with tempfile.TemporaryDirectory() as tmp:
        bag = write_robot_cycle_bag(Path(tmp) / "bag", cyc)
        op = node_params_from_yaml(ROOT / "config" / "friction_observer.yaml", "friction_observer")
        mp = node_params_from_yaml(ROOT / "config" / "wear_estimator.yaml", "wear_estimator")
        from jointwear_ros.io.bags import read_messages

        t0 = time.perf_counter()
        n_read = sum(1 for _ in read_messages(bag, topics=["/joint_states", "/test_cycle/status"]))
        t_read = time.perf_counter() - t0
        t0 = time.perf_counter()
        rep = replay_bag(bag, op, {**mp, "method": "paper"})
        dt = time.perf_counter() - t0
    print(f"  replay_bag (read MCAP + deserialize + split + 6 observer cores + 6 monitors, method paper): "
          f"{dt:.2f} s -> {n / dt / 1e3:.1f} k JointStates/s; {len(rep.observations)} observations, "
          f"{sum(c.result is not None for c in rep.cycles)} estimates")
    print(f"    of which reading and deserializing the {n_read} messages alone: {t_read:.2f} s "
          f"({100 * t_read / dt:.0f} %); the rest is the 6 wear estimates and the per-joint cores")


def bench_robot_live(seconds: float) -> float:
    """CPU % of one core of one observer process serving six joints at 500 Hz."""
    import rclpy
    from jointwear_msgs.msg import FrictionObservation, TestCycleStatus
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState

    from jointwear_ros.nodes.friction_observer import high_rate_qos, seconds_to_stamp

    ns = "/bench_robot"
    cyc = _robot_cycle()
    n = min(cyc.stamps.size, int(seconds * ROBOT_RATE))
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    exe = Path(sys.executable).parent / "friction_observer"
    cmd = [str(exe), "--ros-args", "--params-file", str(ROOT / "config" / "friction_observer.yaml"),
           "-p", f"joint_states_topic:={ns}/joint_states", "-p", f"status_topic:={ns}/status",
           "-p", f"observations_topic:={ns}/observations", "--log-level", "warn"]
    child = subprocess.Popen(cmd, env=env)
    rclpy.init()
    node = rclpy.create_node("bench_robot_feed")
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    got: list[FrictionObservation] = []
    try:
        js = node.create_publisher(JointState, f"{ns}/joint_states", high_rate_qos())
        st = node.create_publisher(TestCycleStatus, f"{ns}/status", high_rate_qos())
        node.create_subscription(FrictionObservation, f"{ns}/observations", got.append, high_rate_qos())
        end = time.monotonic() + 30
        while time.monotonic() < end and not (js.get_subscription_count() and st.get_subscription_count()
                                              and node.count_publishers(f"{ns}/observations")):
            ex.spin_once(timeout_sec=0.05)
        time.sleep(1.0)
        idle0, w0 = _cpu_seconds(child.pid), time.monotonic()
        time.sleep(2.0)
        idle = (_cpu_seconds(child.pid) - idle0) / (time.monotonic() - w0)
        msg = JointState()
        msg.name = list(ROBOT_JOINTS)
        statuses = [status_to_msg(s, TestCycleStatus) for s in cyc.statuses]  # joints, joints_done set
        st_t = [s.stamp for s in cyc.statuses]
        j = 0
        cpu0, wall0 = _cpu_seconds(child.pid), time.monotonic()
        for i in range(n):
            ts = float(cyc.stamps[i])
            while j < len(statuses) and st_t[j] <= ts:
                st.publish(statuses[j])
                j += 1
            msg.header.stamp = seconds_to_stamp(ts)
            msg.position = cyc.position[i].tolist()
            msg.velocity = cyc.velocity[i].tolist()
            msg.effort = cyc.effort[i].tolist()
            js.publish(msg)
            if i % 4 == 3:  # pace: 500 Hz on average
                ahead = wall0 + (i + 1) / ROBOT_RATE - time.monotonic()
                if ahead > 0:
                    ex.spin_once(timeout_sec=0)
                    time.sleep(ahead)
        wall = time.monotonic() - wall0
        cpu = _cpu_seconds(child.pid) - cpu0
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            ex.spin_once(timeout_sec=0.05)
        per_joint = {jn: sum(o.joint_name == jn for o in got) for jn in ROBOT_JOINTS}
        print(f"live friction_observer serving {len(ROBOT_JOINTS)} joints, at {n / wall:.0f} Hz JointState input "
              f"({len(ROBOT_JOINTS)} joints per message) for {wall:.1f} s:")
        print(f"  observer process CPU: {100 * cpu / wall:.1f} % of one core; idle {100 * idle:.1f} %")
        print(f"  observations per joint: {per_joint}")
        return 100 * cpu / wall
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
        child.send_signal(2)
        try:
            child.wait(timeout=10)
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="live streaming time, s (at most one cycle, ~11 s)")
    ap.add_argument("--offline-only", action="store_true")
    ap.add_argument("--robot", action="store_true", help="only the whole-robot figures (6 joints at 500 Hz)")
    a = ap.parse_args()
    if a.robot:
        bench_robot_offline()
        if not a.offline_only:
            bench_robot_live(max(a.seconds, 60.0))
        return 0
    bench_offline()
    bench_robot_offline()
    if not a.offline_only:
        events = bench_live(a.seconds, "events")
        single = bench_live(a.seconds, "single")
        print(f"CPU ratio SingleThreadedExecutor / EventsExecutor: {single / events:.1f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
