"""``jointwear data ...``: synthetic observation tables with hidden effects, and a look at a table."""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path

from . import UsageError
from .common import check_output_dir, check_output_file, format_table, parse_float, parse_float_list, print_json

__all__ = ["register"]

#: Most rows (cycles x speeds) a synthetic table may have.
MAX_ROWS = 1_000_000
#: Columns of a synthetic table that a FrictionObservation bag cannot hold.
_NOT_IN_BAG = ("lube_hours", "hours_running", "motor_temperature", "wear")


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from ..data import DEFAULT_SPEEDS, EFFECT_FAMILIES, NOISE_STD

    p = sub.add_parser("data", help="synthetic observation tables with hidden effects; inspect a table")
    dsub = p.add_subparsers(dest="data_command", metavar="ACTION", parser_class=type(p))
    dsub.required = True

    s = dsub.add_parser(
        "synth",
        help="write an observation table from the reference model plus hidden effects",
        description="Observations from the reference model (Eq. 6, or 9 with --wear) with cycle temperatures, "
                    "load torques and window positions drawn at random, noise sigma_e, and optional hidden "
                    f"effects: {', '.join(EFFECT_FAMILIES)}.",
    )
    s.add_argument("out", metavar="OUT", help="output: FILE.csv, or a new bag directory (rosbag2, MCAP)")
    s.add_argument("--cycles", type=int, default=40, help="test cycles (default 40)")
    s.add_argument("--speeds", default=",".join(f"{v:g}" for v in DEFAULT_SPEEDS),
                   help="speeds of a cycle, comma list or START:STOP:COUNT, rad/s")
    s.add_argument("--hidden", action="append", default=[], choices=sorted(EFFECT_FAMILIES), metavar="EFFECT",
                   help=f"hide an effect in the data; repeatable ({', '.join(EFFECT_FAMILIES)})")
    s.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    s.add_argument("--params", default="ref-2011r", help="parameter set of the reference model")
    s.add_argument("--temperature", default="25:55", help="cycle temperature range LO:HI, degC, or one value")
    s.add_argument("--load", default="0.02:0.5", help="load torque range LO:HI, normalized, or one value")
    s.add_argument("--position", default="-2.5:2.5", help="window position range LO:HI, rad, or one value")
    s.add_argument("--wear", default=None, help="use Eq. (9) with this wear level (adds a wear column)")
    s.add_argument("--noise", default=str(NOISE_STD), help=f"noise sigma_e (default {NOISE_STD})")
    s.add_argument("--irrelevant", type=int, default=0, metavar="N",
                   help="add N columns aux_01.. of random numbers nothing depends on (default 0)")
    s.add_argument("--joint-side", action="store_true",
                   help="write speeds and torques in a joint-frame set's units (joint side rad/s, N·m; --load and "
                        "--speeds stay motor side, normalized)")
    s.add_argument("--json", action="store_true", help="print a JSON summary")
    s.set_defaults(func=cmd_synth)

    h = dsub.add_parser(
        "synth-history",
        help="write a synthetic wear history (nightly estimates of a fleet of joints) as a history CSV",
        description="Nightly wear estimates of ROBOTS x JOINTS joints over DAYS days, ending now, each joint with "
                    "its own profile in turn (linear growth, accelerating, flat, regreased once) and the joint "
                    "estimator's calibrated noise, as a CSV that `jointwear history import` reads (robot, joint, "
                    "time, wear, wear_std, cycle_id, temperature). The regrease events are printed as the "
                    "`jointwear history maintenance` commands that record them.",
    )
    h.add_argument("out", metavar="OUT.csv", help="output CSV file")
    h.add_argument("--robots", type=int, default=2, help="robots (default 2)")
    h.add_argument("--joints", type=int, default=6, help="joints per robot (default 6)")
    h.add_argument("--days", type=int, default=120, help="nights of estimates (default 120)")
    h.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    h.add_argument("--json", action="store_true",
                   help='print JSON {"out", "estimates", "joints", "maintenance": [{"robot", "joint", "time", "kind"}]}')
    h.set_defaults(func=cmd_synth_history)

    e = dsub.add_parser("effects", help="list the hidden effects synth offers")
    e.set_defaults(func=cmd_effects)

    ts = dsub.add_parser(
        "from-timeseries",
        help="a joint's recorded time series (CSV, or JointState in a bag) -> friction observations",
        description="Friction observations, Eq. (5), from a joint's recorded samples: constant-speed plateaus in "
                    "both directions paired and measured as the friction observer does (tau_f = (u+ - u-)/2 per "
                    "speed, with its batch-means standard error), or, without plateaus, steady-speed samples "
                    "(small acceleration) binned by speed. Other numeric columns are kept, averaged per "
                    "observation. Output in the data's units unless --gear-ratio/--torque-scale are given.",
    )
    ts.add_argument("files", nargs="+", metavar="FILE", help="CSV files or rosbag2 bags (sensor_msgs/JointState)")
    ts.add_argument("--time", help="CSV column of the time, s")
    ts.add_argument("--position", help="CSV column of the joint position, rad")
    ts.add_argument("--velocity", help="CSV column of the joint velocity, rad/s (default: from the position)")
    ts.add_argument("--effort", help="CSV column of the applied torque (or current times the torque constant)")
    ts.add_argument("--temperature", help="CSV column of the joint temperature, degC")
    ts.add_argument("--load", help="CSV column of the load torque (same unit as --effort); "
                                   "default |(u+ + u-)/2|")
    ts.add_argument("--joint", help="the joint: its name in a bag's JointState (needed for a bag); written into "
                                    "the table's joint column")
    ts.add_argument("--topic", help="JointState topic of a bag (default: every JointState topic)")
    ts.add_argument("--out", required=True, metavar="OBS.csv", help="output observation table (CSV)")
    ts.add_argument("--mode", default="auto", choices=("auto", "plateaus", "bins"),
                    help="plateaus, steady-speed bins, or plateaus when there are any (default auto)")
    ts.add_argument("--gear-ratio", default="1", help="output speed = |velocity| x this (default 1: as recorded)")
    ts.add_argument("--torque-scale", default="1", help="output torque = effort / this (default 1: as recorded)")
    ts.add_argument("--speed-tolerance", default="0.05",
                    help="a sample is at a speed level within this fraction of it (default 0.05)")
    ts.add_argument("--min-samples", type=int, default=20, help="samples needed per direction (default 20)")
    ts.add_argument("--bins", type=int, default=None,
                    help="speed bins without plateaus (default: picked from the data, 12 down to 6, until 5 speeds)")
    ts.add_argument("--max-accel", default=None,
                    help="steady-speed samples: |acceleration| at most this, rad/s^2 (default: the 30 %% quantile)")
    ts.add_argument("--window", default=None, metavar="HALF_WIDTH",
                    help="measure a plateau pair over the centre of its position overlap +- this, rad "
                         "(default: the whole overlap)")
    ts.add_argument("--min-friction-share", default="0.2",
                    help="drop the lowest speeds whose friction is under this share of the median (friction not "
                         "developed; default 0.2, 0 keeps all)")
    ts.add_argument("--split", default="auto", choices=("auto", "gaps", "reversals", "none"),
                    help="cut a long recording into cycles: auto (a --cycle column, or a 'cycle' column, else gaps "
                         "in time), gaps, reversals (every --split-reversals direction reversals), none")
    ts.add_argument("--split-reversals", type=int, default=4, help="reversals per cycle with --split reversals")
    ts.add_argument("--cycle", default=None, metavar="COLUMN", help="CSV column numbering the cycles")
    ts.add_argument("--json", action="store_true", help="print a JSON summary")
    ts.set_defaults(func=cmd_from_timeseries)

    pr = dsub.add_parser(
        "from-production",
        help="recorded production (/joint_states, /joint_temperature of bags) -> friction observations per shift",
        description="The production observer offline (docs/nodes-production.md): the bags' joint states fed in "
                    "stamp order to the same core and shift rule as the production_observer node: constant-speed "
                    "passes of every joint, forward and reverse pairs at matched configurations (Eq. 5), "
                    "model-based observations of unpaired passes with --arm. Prints per shift and joint the "
                    "passes, paired, model and rejected counts with their reasons, and the observations. Settings: "
                    "the node's (config/production_observer.yaml, or --params), the bag's recorded "
                    "production_observer settings over them, then the options.",
    )
    pr.add_argument("bags", nargs="+", metavar="BAG", help="rosbag2 bags, in time order")
    pr.add_argument("--arm", choices=("ur5", "panda"), default=None,
                    help="the arm's model (load check, model-based observations); default: the recorded node's, "
                         "else none")
    pr.add_argument("--payload", default=None, help="with --arm: kg of the part the program carries one way (default: "
                    "fitted per pair)")
    pr.add_argument("--shift-seconds", default=None, help="length of a shift, s (default 28800: 8 h)")
    pr.add_argument("--shift-origin", default=None, help="stamp at which shift 1 starts, s (default 0)")
    pr.add_argument("--params", default=None, metavar="YAML",
                    help="the production_observer's parameter file (default: the package's)")
    pr.add_argument("--out", default=None, metavar="OBS.csv",
                    help="write the observations as an observation table (source production, cycle = shift)")
    pr.add_argument("--json", action="store_true", help="print JSON")
    pr.set_defaults(func=cmd_from_production)

    sh = dsub.add_parser("show", help="summary of an observation table (CSV or bag)")
    sh.add_argument("data", metavar="DATA")
    sh.add_argument("--topic", default=None, help="bag topic to read")
    sh.add_argument("--json", action="store_true")
    sh.set_defaults(func=cmd_show)


def _range(text: str, what: str) -> tuple[float, float]:
    parts = text.split(":")
    if len(parts) == 1:
        v = parse_float(parts[0], what)
        return v, v
    if len(parts) != 2:
        raise UsageError(f"{what}: {text!r} must be LO:HI or a single value")
    lo, hi = parse_float(parts[0], what), parse_float(parts[1], what)
    if lo > hi:
        raise UsageError(f"{what}: {text!r} has LO above HI")
    return lo, hi


def cmd_synth(args: argparse.Namespace) -> int:
    from ..data import synth_observations
    from ..io.tables import write_table
    from ..model import load_parameter_set_info
    from ..workbench import noise_floor

    if args.cycles < 1:
        raise UsageError(f"--cycles: {args.cycles} must be at least 1")
    if args.seed < 0:
        raise UsageError(f"--seed: {args.seed} must be >= 0")
    if not 0 <= args.irrelevant <= 99:
        raise UsageError(f"--irrelevant: {args.irrelevant} must be 0 to 99")
    speeds = parse_float_list(args.speeds, "--speeds")
    if any(v < 0 for v in speeds):
        raise UsageError("--speeds: speeds must be >= 0 (the model is for |v|)")
    if args.cycles * len(speeds) > MAX_ROWS:
        raise UsageError(f"--cycles {args.cycles:,} x {len(speeds)} speeds = {args.cycles * len(speeds):,} rows; "
                         f"at most {MAX_ROWS:,}")
    temperature = _range(args.temperature, "--temperature")
    load = _range(args.load, "--load")
    position = _range(args.position, "--position")
    noise = parse_float(args.noise, "--noise")
    if not 0 <= noise <= 1:
        raise UsageError(f"--noise: {noise:g} must be within [0, 1] (normalized torque; the paper's is 0.0015)")
    info = load_parameter_set_info(args.params)
    for v in speeds:
        info.check_observation_range("speed", v)
    for v in temperature:
        info.check_observation_range("temperature", v)
    for v in load:
        info.check_observation_range("load_torque", abs(v))
    if args.joint_side and not info.units.joint_side:
        raise UsageError(f"--joint-side: parameter set {info.name!r} is in the paper's normalized units; "
                         "give a joint-frame set (units frame: joint), e.g. arm6-base")
    wear = None if args.wear is None else parse_float(args.wear, "--wear")
    if wear is not None:
        info.check_range("wear", wear)
    out = Path(args.out)
    is_csv = out.suffix.lower() == ".csv"
    if not is_csv and out.exists():
        raise UsageError(f"{out}: already exists; a bag is written to a new directory")
    if is_csv:
        check_output_file(out, "OUT")
    else:
        check_output_dir(out, "OUT")
    table = synth_observations(
        n_cycles=args.cycles, speeds=speeds, effects=args.hidden, seed=args.seed, params=args.params,
        model="paper" if wear is None else "paper+wear", temperature=temperature, load=load,
        position=position, wear=0.0 if wear is None else wear, noise=noise, irrelevant=args.irrelevant,
    )
    if args.joint_side:  # the table in the set's joint-side units (rad/s, N·m), as a real cell's log
        from ..estimation import set_frame_table

        table = set_frame_table(table, info)
    write_table(table, out)
    nf, _ = noise_floor(table)
    summary = {"out": str(out), "format": "csv" if is_csv else "rosbag2-mcap", "rows": len(table),
               "cycles": args.cycles, "hidden": args.hidden, "seed": args.seed, "noise": noise,
               "columns": table.names if is_csv else [c for c in table.names if c not in _NOT_IN_BAG
                                                      and not c.startswith("aux_")]}
    if args.json:
        print_json(summary)
    else:
        hid = ", ".join(args.hidden) or "none"
        print(f"# wrote {len(table)} observations ({args.cycles} cycles x {len(speeds)} speeds) to {out}")
        print(f"# hidden effects: {hid}; noise sigma_e = {noise:g} (noise floor {nf:.5f}); seed {args.seed}")
        if not is_csv:
            print("# note: a bag keeps only FrictionObservation fields; lube_hours, hours_running, "
                  "motor_temperature, wear and aux_* are not in it (use CSV)")
    return 0


def cmd_effects(args: argparse.Namespace) -> int:
    from ..data import EFFECT_FAMILIES

    print(format_table(["effect", "variables", "what"],
                       [[e.name, ",".join(e.variables), e.description] for e in EFFECT_FAMILIES.values()]))
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    import numpy as np

    from ..io.tables import read_table
    from ..workbench import noise_floor

    table = read_table(args.data, topic=args.topic)
    nf, src = noise_floor(table)
    stats = []
    for n in table.names:
        c = table[n]
        ok = c[np.isfinite(c)]
        stats.append({"column": n, "min": float(ok.min()) if ok.size else math.nan,
                      "max": float(ok.max()) if ok.size else math.nan,
                      "mean": float(ok.mean()) if ok.size else math.nan, "non_finite": int(c.size - ok.size)})
    cycles = int(np.unique(table["cycle"]).size) if "cycle" in table else None
    if args.json:
        print_json({"data": table.source, "rows": len(table), "cycles": cycles, "noise_floor": nf,
                    "noise_source": src, "columns": stats})
        return 0
    print(f"# {table.source}: {len(table)} observations" + (f", {cycles} cycles" if cycles else "")
          + f"; noise floor {nf:.5f} ({src})")
    print(format_table(["column", "min", "max", "mean", "non-finite"],
                       [[s["column"], s["min"], s["max"], s["mean"], s["non_finite"]] for s in stats], floatfmt=".5g"))
    return 0


def cmd_synth_history(args: argparse.Namespace) -> int:
    """A synthetic fleet's nightly estimates (``data/fleet.py``) shifted to end now, as a history CSV."""
    import time
    from datetime import UTC, datetime

    from ..data.fleet import DAY, EPOCH0, make_fleet
    from ..history import EstimateRecord
    from ..history.importers import write_csv

    for flag, v, hi in (("--robots", args.robots, 1000), ("--joints", args.joints, 64), ("--days", args.days, 3650)):
        if not 1 <= v <= hi:
            raise UsageError(f"{flag}: {v} is outside 1-{hi}")
    if args.robots * args.joints * args.days > MAX_ROWS:
        raise UsageError(f"{args.robots} robots x {args.joints} joints x {args.days} days is more than {MAX_ROWS} "
                         "estimates; ask for fewer")
    out = Path(args.out)
    check_output_file(out, "OUT")
    if out.suffix.lower() != ".csv":
        raise UsageError(f"{out}: give a .csv file name")
    fleet = make_fleet(args.robots * args.joints, args.days, seed=args.seed, joints_per_robot=args.joints)
    shift = (time.time() - 6 * 3600.0) - (EPOCH0 + args.days * DAY)  # the last night ends a few hours ago
    records, maintenance = [], []
    for j in fleet:
        for t, w, sd, temp, cid in zip(j.times, j.wear, j.wear_std, j.temperature, j.cycle_ids):
            records.append(EstimateRecord(robot=j.robot, joint=j.joint, cycle_id=int(cid), time=float(t) + shift,
                                          wear=float(w), wear_std=float(sd), temperature=float(temp), method="joint",
                                          params="ref-2011r", hardware_id=f"{j.robot}/{j.joint}",
                                          source="synthetic"))
        for t in j.maintenance_times:
            maintenance.append({"robot": j.robot, "joint": j.joint, "kind": "regrease",
                                "time": datetime.fromtimestamp(t + shift, UTC).strftime("%Y-%m-%dT%H:%M:%SZ")})
    n = write_csv(records, out)
    if args.json:
        print_json({"out": str(out), "estimates": n, "joints": len(fleet), "maintenance": maintenance})
        return 0
    print(f"{n} estimates of {len(fleet)} joints over {args.days} nights written to {out} "
          f"(profiles: linear, accelerating, flat, regreased once; seed {args.seed})")
    for m in maintenance:
        print(f"regreased: jointwear history maintenance --db DB --robot {m['robot']} --joint {m['joint']} "
              f"--kind regrease --time {m['time']}")
    return 0


def cmd_from_timeseries(args: argparse.Namespace) -> int:
    import numpy as np

    from ..errors import InputDataError
    from ..io.tables import write_csv
    from ..io.timeseries import read_timeseries
    from ..observer.timeseries import TimeseriesConfig, timeseries_observations
    from ..types import ObservationTable

    out = Path(args.out)
    if out.suffix.lower() != ".csv":
        raise UsageError(f"--out: {out} must end in .csv (an observation table)")
    check_output_file(out, "--out")
    gear = parse_float(args.gear_ratio, "--gear-ratio")
    scale = parse_float(args.torque_scale, "--torque-scale")
    tol = parse_float(args.speed_tolerance, "--speed-tolerance")
    for flag, v in (("--gear-ratio", gear), ("--torque-scale", scale)):
        if not v > 0:
            raise UsageError(f"{flag}: {v:g} must be a positive number")
    if not 0 < tol < 1:
        raise UsageError(f"--speed-tolerance: {tol:g} must be between 0 and 1 (a fraction of the speed)")
    if not 4 <= args.min_samples <= 1_000_000:
        raise UsageError(f"--min-samples: {args.min_samples} must be 4 to 1000000")
    if args.bins is not None and not 1 <= args.bins <= 1000:
        raise UsageError(f"--bins: {args.bins} must be 1 to 1000")
    max_accel = None if args.max_accel is None else parse_float(args.max_accel, "--max-accel")
    if max_accel is not None and not max_accel > 0:
        raise UsageError(f"--max-accel: {max_accel:g} must be a positive number")
    window = None if args.window is None else parse_float(args.window, "--window")
    if window is not None and not window > 0:
        raise UsageError(f"--window: {window:g} must be a positive half width, rad")
    share = parse_float(args.min_friction_share, "--min-friction-share")
    if not 0 <= share < 1:
        raise UsageError(f"--min-friction-share: {share:g} must be in [0, 1)")
    if not 2 <= args.split_reversals <= 10_000:
        raise UsageError(f"--split-reversals: {args.split_reversals} must be 2 to 10000")
    cfg = TimeseriesConfig(joint_name=args.joint or "", gear_ratio=gear, torque_scale=scale, mode=args.mode,
                           speed_tolerance=tol, min_samples=args.min_samples, n_bins=args.bins or 12,
                           max_accel=max_accel, window_half_width=window, min_friction_share=share,
                           split=args.split, split_reversals=args.split_reversals, cycle_column=args.cycle,
                           auto_bins=args.bins is None)
    series = [read_timeseries(f, time=args.time, position=args.position, effort=args.effort, velocity=args.velocity,
                              temperature=args.temperature, load=args.load, joint=args.joint, topic=args.topic)
              for f in args.files]
    rows: list[dict[str, float]] = []
    sources: list[dict[str, object]] = []
    cycle0 = 0
    for s in series:
        try:
            res = timeseries_observations(s.time, s.position, s.velocity, s.effort, s.extra, cfg,
                                          temperature=s.temperature, load=s.load)
        except InputDataError as exc:
            raise InputDataError(f"{s.source}: {exc}") from None
        for r in res.rows:
            r["cycle"] += cycle0
        cycle0 = int(max([r["cycle"] for r in res.rows], default=cycle0))
        rows.extend(res.rows)
        sources.append({"file": s.source, **res.to_dict()})
    if not rows:
        why = "; ".join(str(w) for src in sources for w in src["rejected"][:3])  # type: ignore[index]
        tried = {str(src["method"]) for src in sources}
        hint = ("--speed-tolerance, --min-samples" if tried == {"plateaus"} else
                "--max-accel (steadiness), --bins, --min-samples" if args.mode == "bins" else
                "--speed-tolerance, --min-samples (plateaus); --max-accel, --bins (bins)")
        raise InputDataError(f"{', '.join(args.files)}: no friction observation found ({why or 'no motion'}); "
                             f"the filters that rejected the samples are named above: change {hint}")
    names: list[str] = []
    for r in rows:
        names.extend(k for k in r if k not in names)
    cols = {n: np.array([r.get(n, math.nan) for r in rows], dtype=float) for n in names}
    # a column that is NaN in every row carries nothing (e.g. no temperature); the CSV rules refuse NaN cells
    cols = {n: c for n, c in cols.items() if n in ("speed", "tau_f") or np.isfinite(c).all()}
    dropped = [n for n in names if n not in cols and np.isfinite([r.get(n, math.nan) for r in rows]).any()]
    table = ObservationTable(cols, source=str(out))
    joint = args.joint or ""
    write_csv(table, out, text_columns={"joint": [joint] * len(table)} if joint else None)
    warnings = [f"{src['file']}: {w}" for src in sources for w in src["warnings"]]  # type: ignore[attr-defined]
    if dropped:
        warnings.append(f"column(s) {', '.join(dropped)} left out: not known for every observation")
    summary = {"out": str(out), "observations": len(table), "columns": table.names + (["joint"] if joint else []),
               "joint": joint or None, "sources": sources, "warnings": warnings}
    if args.json:
        print_json(summary)
        return 0
    print(f"# wrote {len(table)} friction observations to {out}")
    for src in sources:
        print(f"# {src['file']}: {src['observations']} from {src['method']} ({src['samples']} samples)")
    for w in warnings:
        print(f"# warning: {w}")
    for src in sources:
        for r in src["rejected"]:  # type: ignore[attr-defined]
            print(f"# rejected: {src['file']}: {r}")
    show = [c for c in ("cycle", "speed", "tau_f", "tau_f_std", "load_torque", "temperature", "position",
                        "samples_plus", "samples_minus", "position_spread") if c in cols]
    print(format_table(show, [[cols[c][i] for c in show] for i in range(len(table))], floatfmt=".5g"))
    return 0


def production_settings(bags: Sequence[str], names: tuple[str, ...], *, params: str | None = None,
                        arm: str | None = None, payload: str | None = None, shift_seconds: str | None = None,
                        shift_origin: str | None = None) -> tuple[dict[str, object], list[str]]:
    """The production_observer's parameter values for these bags (module docstring of the command): the node's
    file (or ``params``), the settings the node recorded in the first bag over them, then the options given
    (as their text); and where they came from."""
    from ..io.bags import recorded_settings
    from .common import node_params

    values: dict[str, object] = dict(node_params(params, "production_observer.yaml", "production_observer",
                                                 "--params"))
    settings = recorded_settings(bags[0])
    rec = settings.get("production_observer")
    used = []
    if rec:
        values.update(rec)
        used.append("the recorded production_observer's")
    for key, flag in (("payload", payload), ("shift_seconds", shift_seconds), ("shift_origin", shift_origin)):
        if flag is not None:
            values[key] = parse_float(flag, "--" + key.replace("_", "-"))
    if arm is not None:
        values["arm"] = arm
    arm = str(values.get("arm") or "")
    sim = settings.get("joint_sim", {})
    if arm:
        from ..sim.arms import arm_spec

        arm_joints = arm_spec(arm).for_names(names)
    for i, j in enumerate(names):
        for key in ("gear_ratio", "torque_scale"):
            if f"{j}.{key}" in values:
                continue
            if arm:
                values[f"{j}.{key}"] = float(getattr(arm_joints[i], key))
            elif f"{j}.{key}" in sim:
                values[f"{j}.{key}"] = float(sim[f"{j}.{key}"])  # type: ignore[arg-type]
                if "the recorded joint_sim's gear ratios and torque scales" not in used:
                    used.append("the recorded joint_sim's gear ratios and torque scales")
    return values, used


def cmd_from_production(args: argparse.Namespace) -> int:
    import numpy as np

    from ..errors import InputDataError
    from ..io.production_bag import ShiftClock, production_shifts, read_production
    from ..io.tables import PRODUCTION_COLUMN, write_csv
    from ..observer import ProductionConfig
    from ..observer.production import NO_ARM_MODEL
    from ..settings import from_mapping
    from ..sim.arm import ArmModel
    from ..types import ObservationTable

    out = None
    if args.out is not None:
        out = Path(args.out)
        if out.suffix.lower() != ".csv":
            raise UsageError(f"--out: {out} must end in .csv (an observation table)")
        check_output_file(out, "--out")
    for flag, text in (("--payload", args.payload), ("--shift-seconds", args.shift_seconds)):
        if text is not None and not parse_float(text, flag) >= (0.0 if flag == "--payload" else 1e-3):
            raise UsageError(f"{flag}: {text} must be " + ("a mass >= 0 kg" if flag == "--payload" else
                                                           "a positive number of seconds"))
    samples = read_production(args.bags)
    values, used = production_settings(args.bags, samples.names, params=args.params, arm=args.arm,
                                       payload=args.payload, shift_seconds=args.shift_seconds,
                                       shift_origin=args.shift_origin)
    configs = [from_mapping(ProductionConfig, values, joint=j) for j in samples.names]
    arm = str(values.get("arm") or "")
    payload = float(values.get("payload", 0.0))  # type: ignore[arg-type]
    clock = ShiftClock(float(values.get("shift_seconds", 8 * 3600.0)),  # type: ignore[arg-type]
                       float(values.get("shift_origin", 0.0)))  # type: ignore[arg-type]
    models = ArmModel(arm, samples.names).observer_models(
        payload_mass=payload if payload > 0 else None, model_based=bool(values.get("model_based", False))) if arm else {}
    shifts = production_shifts(samples, configs, clock=clock, models=models)
    rows = [(s.shift_id, o, k) for s in shifts for o, k in zip(s.observations, s.kinds, strict=True)]
    if out is not None:
        if not rows:
            raise InputDataError(f"{', '.join(args.bags)}: no friction observation in any shift; {out} not written "
                                 "(the counts say why: run without --out)")
        obs = [o for _, o, _ in rows]
        cols = {"cycle": np.array([float(s) for s, _, _ in rows]), "time": np.array([o.stamp for o in obs])}
        for c in ("speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position",
                  "samples_plus", "samples_minus"):
            cols[c] = np.array([float(getattr(o, c)) for o in obs])
        if not np.isfinite(cols["temperature"]).all():  # no NaN cells in a CSV: a temperature unknown somewhere
            del cols["temperature"]
        cols[PRODUCTION_COLUMN] = np.ones(len(obs))
        write_csv(ObservationTable(cols, source=str(out)), out,
                  text_columns={"joint": [o.joint_name for o in obs], "kind": [k for _, _, k in rows]})
    summary = {
        "bags": list(samples.bags), "joints": list(samples.names), "arm": arm or None, "payload": payload,
        "shift_seconds": clock.seconds, "shift_origin": clock.origin, "settings_from": used,
        "samples": int(samples.t.size), "skipped": samples.skipped, "temperature_readings": samples.temperature_readings,
        "shifts": [{
            "shift_id": s.shift_id, "t_start": s.t_start, "t_end": s.t_end, "samples": s.samples,
            "observations": len(s.observations),
            "joints": [{"joint": c.joint_name, "observations": sum(1 for o in s.observations
                                                                   if o.joint_name == c.joint_name),
                        "passes": c.passes, "paired": c.paired, "model": c.model, "rejected": c.rejected,
                        "rejected_total": c.rejected_total, "speed_levels": list(c.speed_levels),
                        "informative": c.informative, "note": c.note} for c in s.joints.values()],
        } for s in shifts],
        "observations": [{"shift_id": sid, "kind": k, **o.to_dict(), "source": "production"} for sid, o, k in rows],
        "out": None if out is None else str(out),
    }
    if args.json:
        print_json(summary)
        return 0
    skipped = ", ".join(f"{k} {v}" for k, v in samples.skipped.items())
    print(f"# {samples.t.size} samples of {', '.join(samples.names)} from {len(samples.bags)} bag(s)"
          + (f"; skipped: {skipped}" if skipped else "") + f"; arm model {arm or 'none'}"
          + ((f", a part of {payload:g} kg" if payload > 0 else ", the part's mass fitted per pair")
             + (", model-based observations" if models.get("rigid_body") else "") if arm else "")
          + f"; shifts of {clock.seconds:g} s")
    if not arm:
        print(f"# {NO_ARM_MODEL}")
    for s in shifts:
        print(f"# shift {s.shift_id}: {s.t_start:.3f}-{s.t_end:.3f} s, {s.samples} samples, "
              f"{len(s.observations)} observation(s)")
        for line in s.summary().splitlines():
            print(f"#   {line}")
    if rows:
        print(format_table(["shift", "joint", "kind", "speed", "tau_f", "tau_f_std", "load_torque", "temperature",
                            "position", "samples_plus", "samples_minus"],
                           [[sid, o.joint_name, k, o.speed, o.tau_f, o.tau_f_std, o.load_torque, o.temperature,
                             o.position, o.samples_plus, o.samples_minus] for sid, o, k in rows], floatfmt=".5g"))
    if out is not None:
        print(f"# wrote {len(rows)} friction observations to {out}")
    return 0
