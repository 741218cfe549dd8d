"""Replay speed: ``replay_bag`` on recorded demo bags, wall time and passes over the bag.

For each bag given (e.g. the bags of a ``jointwear demo`` / ``jointwear demo --joints 3`` run;
none given: one synthetic night's bag of the fleet generator, written to a temporary directory),
``replay_bag`` runs ``--repeat`` times with the config files' settings and the recorded ones;
printed: the bag's size and messages, the passes over the bag (``AnyReader`` opens) and the
median wall time of one replay.

Figures (2-core shared machine): a one-joint demo bag (1.8 MB, 22 498 messages) 4 passes, 3.63 s
before the one-pass reader, 1 pass, 3.29 s after; a 3-joint robot demo bag (6.8 MB, 87 409
messages) 4 passes, 12.27 s before, 1 pass, 8.88 s after.

Usage: python bench/bench_replay.py [BAG ...] [--repeat N]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bags", nargs="*")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    from rosbags.highlevel import AnyReader

    from jointwear_ros.fleet.reanalysis import default_node_params
    from jointwear_ros.io.bags import bag_info
    from jointwear_ros.replay import replay_bag

    opens = [0]
    enter = AnyReader.__enter__

    def counting_enter(self: AnyReader) -> AnyReader:
        opens[0] += 1
        return enter(self)

    AnyReader.__enter__ = counting_enter  # type: ignore[method-assign]
    observer, estimator = default_node_params()
    if not args.bags:
        import tempfile

        from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_cycle_bag

        tmp = tempfile.TemporaryDirectory(prefix="bench_replay_")
        args.bags = [str(write_cycle_bag(Path(tmp.name) / "night", fleet_specs(1, 1, 1)[0]))]
    print(f"{'bag':<60} {'MB':>6} {'messages':>9} {'passes':>6} {'replay s':>9}")
    for bag in args.bags:
        info = bag_info(bag)
        size = sum(f.stat().st_size for f in Path(bag).rglob("*") if f.is_file()) / 1e6
        times: list[float] = []
        passes = 0
        for _ in range(max(1, args.repeat)):
            opens[0] = 0
            t0 = time.perf_counter()
            replay_bag(bag, observer, estimator)
            times.append(time.perf_counter() - t0)
            passes = opens[0]
        n = info.message_count
        print(f"{str(bag)[-60:]:<60} {size:6.1f} {n:9d} {passes:6d} {statistics.median(times):9.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
