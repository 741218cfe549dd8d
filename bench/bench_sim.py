"""Speed of the simulated joint: the pure core and the joint_sim node.

Prints, for 500 Hz and 2 kHz:
- core: the default 8-speed test cycle (CycleRunner + JointSim, commands at
  100 Hz) stepped as fast as Python goes: sim seconds per wall second; and a
  six-joint robot cycle (RobotCycleRunner + RobotSim) with its planned and
  simulated duration;
- node: joint_sim as a child process, the clock source, with 1 and 6 joints,
  asked to run at real_time_factor R: the factor it achieves (sim time on
  /clock per wall second) and the CPU it uses (% of one core), for a few R.
Measures; asserts nothing.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jointwear_ros.cycle import (  # noqa: E402
    CycleConfig,
    CycleRunner,
    JointReading,
    RobotCycleRunner,
    plan_cycle,
    plan_robot_cycle,
)
from jointwear_ros.sim import JointSim, JointSimConfig, RobotSim  # noqa: E402

SIX = [f"joint_{i}" for i in range(1, 7)]


def core_cycle(rate: float) -> tuple[float, float]:
    sim = JointSim(JointSimConfig(wear=20.0), seed=1)
    cfg = CycleConfig()
    runner = CycleRunner(cfg)
    runner.start(plan_cycle(cfg, start_position=0.0), 1, 0.0)
    dt = 1.0 / rate
    every = int(rate / 100)
    k = 0
    t0 = time.perf_counter()
    while runner.running:
        if k % every == 0:
            s = sim.sample()
            sim.set_command(runner.update(sim.time, JointReading(sim.time, s.position, s.velocity, s.effort)))
        sim.step(dt)
        sim.sample()
        k += 1
    return sim.time, time.perf_counter() - t0


def robot_cycle(rate: float) -> tuple[float, float, float]:
    """Six joints, default speeds, tested in turn: (planned s, simulated s, wall s)."""
    configs = {j: CycleConfig(joint_name=j) for j in SIX}
    sim = RobotSim(SIX, [JointSimConfig(wear=20.0)] * 6, seeds=range(6))
    runner = RobotCycleRunner(configs)
    plan = plan_robot_cycle(configs, start_positions=dict.fromkeys(SIX, 0.0))
    runner.start(plan, 1, 0.0, dict.fromkeys(SIX, 0.0))
    dt = 1.0 / rate
    every = int(rate / 100)
    k = 0
    t0 = time.perf_counter()
    while runner.running:
        if k % every == 0:
            pos, vel, eff = sim.sample()
            cmd = runner.update(sim.time, {j: JointReading(sim.time, pos[i], vel[i], eff[i]) for i, j in enumerate(SIX)})
            sim.set_commands([cmd[j] for j in SIX])
        sim.step(dt)
        sim.sample()
        k += 1
    return plan.duration, sim.time, time.perf_counter() - t0


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def node_rate(rate: float, rtf: float, seconds: float = 4.0, joints: int = 1) -> tuple[float, float]:
    import rclpy
    from rosgraph_msgs.msg import Clock

    from jointwear_ros.nodes.runtime import loopback_env

    cmd = [sys.executable, "-m", "jointwear_ros.nodes.joint_sim", "--ros-args",
           "-p", f"publish_rate:={rate}", "-p", "publish_clock:=true", "-p", f"real_time_factor:={rtf}"]
    if joints > 1:
        cmd += ["-p", f"joints:=[{', '.join(SIX[:joints])}]"]
    proc = subprocess.Popen(cmd, env=loopback_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("bench_clock", context=ctx)
    stamps: list[tuple[float, float]] = []
    node.create_subscription(
        Clock, "/clock", lambda m: stamps.append((time.monotonic(), m.clock.sec + m.clock.nanosec * 1e-9)), 100
    )
    from rclpy.executors import SingleThreadedExecutor

    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        end = time.monotonic() + 30.0
        while len(stamps) < 20 and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
        cpu0, w0, n0 = _cpu_seconds(proc.pid), time.monotonic(), len(stamps)
        while time.monotonic() < w0 + seconds:
            ex.spin_once(timeout_sec=0.05)
        cpu1, w1 = _cpu_seconds(proc.pid), time.monotonic()
        got = stamps[n0:]
        achieved = (got[-1][1] - got[0][1]) / (got[-1][0] - got[0][0]) if len(got) > 2 else float("nan")
        return achieved, 100.0 * (cpu1 - cpu0) / (w1 - w0)
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        proc.send_signal(2)
        proc.wait(10)


def main() -> None:
    print(f"machine load average: {os.getloadavg()[0]:.1f} (2 cores shared)")
    print("core: default 8-speed cycle, JointSim + CycleRunner")
    print(f"{'rate Hz':>8} {'sim s':>7} {'wall s':>7} {'x real time':>12}")
    for rate in (500.0, 2000.0):
        sim_s, wall = core_cycle(rate)
        print(f"{rate:8.0f} {sim_s:7.1f} {wall:7.2f} {sim_s / wall:12.1f}")
    print("core: six-joint robot cycle, default speeds, RobotSim + RobotCycleRunner")
    print(f"{'rate Hz':>8} {'planned s':>10} {'sim s':>7} {'wall s':>7} {'x real time':>12}")
    for rate in (500.0,):
        planned, sim_s, wall = robot_cycle(rate)
        print(f"{rate:8.0f} {planned:10.1f} {sim_s:7.1f} {wall:7.2f} {sim_s / wall:12.1f}")
    print("node: joint_sim as clock source (publishes every sample as a JointState)")
    print(f"{'joints':>6} {'rate Hz':>8} {'asked x':>8} {'achieved x':>11} {'CPU %':>6}")
    for joints, rate, rtf in ((1, 500.0, 1.0), (6, 500.0, 1.0), (1, 500.0, 4.0), (6, 500.0, 4.0), (6, 500.0, 16.0),
                              (1, 2000.0, 1.0), (6, 2000.0, 1.0)):
        achieved, cpu = node_rate(rate, rtf, joints=joints)
        print(f"{joints:6d} {rate:8.0f} {rtf:8.1f} {achieved:11.2f} {cpu:6.0f}")


if __name__ == "__main__":
    main()
