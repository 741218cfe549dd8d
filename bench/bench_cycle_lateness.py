"""How far past its sweep ends a late control loop carries the joint (docs/nodes-sim-cycle.md, "Late control updates").

Core (deterministic): CycleRunner driving the simulated joint (JointSim at 500 Hz, window centre 0),
each control update ``late`` s after ``control_period`` (node clock), at 20 and 40 degC; the
largest travel past a sweep end (forward past B, reverse or approach past A) per speed, in mrad,
for the runner as it is (braking one measured update interval early) and for the plain
``sqrt(2 a rem)`` braking it had before, beside each speed's stopping allowance.

``--bag PATH`` (a demo's bags directory or one bag): the same figure from a real run, joint
states attributed to the speed under test by the ``/test_cycle/status`` stamps (sim time).
Measures; asserts nothing.
"""

from __future__ import annotations

import argparse
import bisect
import sys
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jointwear_ros.cycle import (  # noqa: E402
    CycleConfig,
    CycleRunner,
    CycleState,
    JointReading,
    Phase,
    plan_cycle,
    run_up,
    stop_allowance,
)
from jointwear_ros.sim import JointSim, JointSimConfig  # noqa: E402

SPEEDS = (10.0, 40.0, 80.0, 120.0, 160.0)
LATE = (0.0, 0.004, 0.012, 0.03, 0.06, 0.1, 0.2)


class PlainBraking(CycleRunner):
    """The runner with the braking of before: no lead (``sqrt(2 a rem)``)."""

    @property
    def lead(self) -> float:
        return 0.0


def overshoot(runner_cls: type[CycleRunner], late: float, temperature: float) -> tuple[str, dict[float, float]]:
    cfg = CycleConfig()
    sim = JointSim(JointSimConfig(temperature=temperature), seed=0)
    plan = plan_cycle(cfg, list(SPEEDS), 0.0, 0.0)
    runner = runner_cls(cfg)
    runner.start(plan, 1, 0.0)
    nxt, out = 0.0, {}
    while runner.running and sim.time < 300.0:
        if sim.time + 1e-9 >= nxt:
            s = sim.sample()
            sim.set_command(runner.update(sim.time, JointReading(sim.time, s.position, s.velocity, s.effort)))
            nxt = sim.time + cfg.control_period + late
        sim.step(0.002)
        if runner.running and runner.phase in (Phase.FORWARD, Phase.REVERSE, Phase.SETTLE):
            sp = plan.speeds[min(runner.speeds_done, len(plan.speeds) - 1)]
            o = max(sim.position - sp.end, sp.start - sim.position)
            out[sp.speed] = max(out.get(sp.speed, -1.0), o)
    return runner.state.name if runner.state != CycleState.DONE else "", out


def core() -> None:
    cfg = CycleConfig()
    print("core: travel past the sweep ends, mrad (JointSim 500 Hz, commands every 10 ms + late)")
    print("allowance: " + "  ".join(f"{v:g}: {1000 * stop_allowance(v / cfg.gear_ratio, cfg):.0f}" for v in SPEEDS)
          + f"  (+ limit_margin {1000 * cfg.limit_margin:.0f})")
    head = "  ".join(f"{v:>6g}" for v in SPEEDS)
    print(f"{'temp':>5} {'late ms':>7} {'braking':>8}  {head}")
    for temperature in (40.0, 20.0):
        for late in LATE:
            for name, cls in (("lead", CycleRunner), ("plain", PlainBraking)):
                state, out = overshoot(cls, late, temperature)
                cells = "  ".join(f"{1000 * out.get(v, float('nan')):6.1f}" for v in SPEEDS)
                print(f"{temperature:5g} {1000 * late:7g} {name:>8}  {cells}  {state}")


def from_bag(path: str) -> None:
    from jointwear_ros.contract import status_from_msg
    from jointwear_ros.io.bags import find_bags, read_messages

    cfg = CycleConfig()
    for bag in find_bags(path) or [Path(path)]:
        status, states = [], []
        for m in read_messages(bag, topics=["/test_cycle/status", "/joint_states"]):
            (status if m.topic == "/test_cycle/status" else states).append(m.msg)
        st = sorted((status_from_msg(s) for s in status), key=lambda s: s.stamp)
        stamps = [s.stamp for s in st]
        worst: dict[float, dict[str, float]] = defaultdict(dict)
        for msg in states:
            t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
            i = bisect.bisect_right(stamps, t) - 1
            if i < 0 or st[i].state != CycleState.RUNNING or st[i].current_speed <= 0.0:
                continue
            s = st[i]
            names = list(msg.name)
            if s.joint_name not in names:
                continue
            p = msg.position[names.index(s.joint_name)]
            reach = s.window_half_width + run_up(s.current_speed / cfg.gear_ratio, cfg)
            o = max(p - (s.window_center + reach), (s.window_center - reach) - p)
            v = s.current_speed
            worst[v][s.joint_name] = max(worst[v].get(s.joint_name, -1.0), o)
        print(f"{bag}: travel past the sweep ends, mrad, worst joint (last status: {st[-1].state if st else '-'})")
        for v in sorted(worst):
            j, o = max(worst[v].items(), key=lambda kv: kv[1])
            print(f"  {v:6g} rad/s: {1000 * o:6.1f} ({j}; allowance {1000 * stop_allowance(v / cfg.gear_ratio, cfg):.0f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bag", help="a demo's bags directory or one bag: measure a real run instead of the core")
    args = ap.parse_args()
    if args.bag:
        from_bag(args.bag)
    else:
        core()


if __name__ == "__main__":
    main()
