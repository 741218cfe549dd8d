"""``jointwear cycle design``: choose a test cycle's speeds to minimise the bound on w.

A thin adapter over :func:`jointwear_ros.estimation.design.design_cycle`.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import Counter
from typing import Any

from ..cycle import CycleConfig, plan_cycle
from ..cycle.schedule import MAX_SCHEDULE_JOINTS, ScheduleError, rotation_schedule
from ..errors import JointwearError
from ..estimation.names import PAPER_SECONDS_PER_SPEED
from . import UsageError
from .common import check_temperature_prior, format_table, parse_float, parse_float_list, print_json

__all__ = ["register"]

DEFAULT_CANDIDATES = "5:280:56"  # every 5 rad/s; a test cycle cannot sweep at 0
#: Largest cycle the search handles in reasonable time.
MAX_SPEEDS = 64
#: Most candidate speeds the search handles in reasonable time (every 1 rad/s over 0-280).
MAX_CANDIDATES = 281


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("cycle", help="test-cycle design: which speeds to measure")
    csub = p.add_subparsers(dest="cycle_command", metavar="ACTION", parser_class=type(p))
    csub.required = True
    d = csub.add_parser(
        "design",
        help="choose the speeds that minimise the bound on the wear estimate",
        description=(
            "Choose floor(budget / seconds-per-speed) speeds (repeats allowed) from the candidates so that "
            "the Cramer-Rao bound on w of one cycle, all speeds at one unknown temperature, is smallest."
        ),
    )
    d.add_argument("--budget", default="90", help="cycle time, seconds (default 90)")
    d.add_argument("--seconds-per-speed", default=f"{PAPER_SECONDS_PER_SPEED:g}",
                   help=f"time one speed takes, seconds (default {PAPER_SECONDS_PER_SPEED:g}, the paper's)")
    d.add_argument("--params", default="ref-2011r", help="parameter set name or YAML path (default ref-2011r)")
    d.add_argument("--wear", default="35", help="wear level at which the bound is minimised (default 35, the alarm level)")
    d.add_argument("--load", default="0.1", help="load torque tau_m, normalized (default 0.1)")
    d.add_argument("--noise-std", default="0.0015", help="sigma_e of one observation (default 0.0015)")
    d.add_argument("--prior", default="uniform:25:55",
                   help="temperature distribution: uniform:LO:HI or normal:MEAN:STD (default uniform:25:55)")
    d.add_argument("--speeds-candidates", default=DEFAULT_CANDIDATES,
                   help=f"candidate speeds, comma list or START:STOP:COUNT, rad/s (default {DEFAULT_CANDIDATES})")
    d.add_argument("--no-repeats", action="store_true", help="choose each speed at most once")
    d.add_argument("--json", action="store_true", help="print JSON instead of a table")
    d.set_defaults(func=cmd_design)
    r = csub.add_parser(
        "schedule",
        help="what a robot cycle over every joint costs in cell time, and a rotation that fits a budget",
        description=(
            "Plan each joint's test cycle with test_cycle's settings (its params file: per-joint settings "
            "nested under the joint's name) and print the cell time of a robot cycle over every joint. With "
            "--budget, split the joints over the fewest nights whose robot cycles each fit the budget "
            "(each joint is then tested once every PERIOD nights)."
        ),
    )
    r.add_argument("--budget", default=None, help="cell seconds available between two shifts (default: no split)")
    r.add_argument("--params-file", default=None,
                   help="test_cycle parameter file (default: the package's config/test_cycle.yaml)")
    r.add_argument("--joints", default=None,
                   help="joints, comma list, or a count N for the first N configured (default: all configured)")
    r.add_argument("--speeds", default=None, help="speeds for every joint, motor rad/s (default: each joint's)")
    r.add_argument("--seconds-per-speed", default=None,
                   help=f"cost each speed this many seconds instead of planning the motion "
                        f"(the paper: {PAPER_SECONDS_PER_SPEED:g})")
    r.add_argument("--overhead", default="0", help="extra seconds per joint (moving to its test pose; default 0)")
    r.add_argument("--json", action="store_true", help="print JSON instead of tables")
    r.set_defaults(func=cmd_schedule)


def _progress(done: int, total: int) -> None:  # pragma: no cover - terminal only
    width = 30
    k = int(width * done / max(total, 1))
    sys.stderr.write(f"\r  searching [{'#' * k}{'.' * (width - k)}] {done}/{total}")
    if done >= total:
        sys.stderr.write("\r" + " " * (width + 40) + "\r")
    sys.stderr.flush()


def cmd_design(args: argparse.Namespace) -> int:
    from ..estimation import resolve_model
    from ..estimation.design import design_cycle
    from ..estimation.priors import parse_temperature_prior
    from ..model import load_parameter_set_info

    budget = parse_float(args.budget, "--budget")
    sps = parse_float(args.seconds_per_speed, "--seconds-per-speed")
    if budget <= 0:
        raise UsageError(f"--budget: {args.budget} must be a positive number of seconds")
    if sps <= 0:
        raise UsageError(f"--seconds-per-speed: {args.seconds_per_speed} must be a positive number of seconds")
    ratio = budget / sps
    if ratio > MAX_SPEEDS + 1:
        raise UsageError(f"--budget {budget:g} s at {sps:g} s per speed gives {ratio:.4g} speeds; "
                         f"at most {MAX_SPEEDS} are searched")
    n = math.floor(ratio + 1e-9)
    if n < 1:
        raise UsageError(f"--budget {budget:g} s is shorter than one speed ({sps:g} s); raise --budget")
    if n > MAX_SPEEDS:
        raise UsageError(f"--budget {budget:g} s at {sps:g} s per speed gives {n} speeds; at most {MAX_SPEEDS} are searched")
    info = load_parameter_set_info(args.params)
    wear = parse_float(args.wear, "--wear")
    load = parse_float(args.load, "--load")
    noise = parse_float(args.noise_std, "--noise-std")
    if not 0 < noise <= 1:
        raise UsageError(f"--noise-std: {args.noise_std} must be positive and at most 1 (normalized torque; "
                         "the paper's is 0.0015)")
    info.check_range("wear", wear)
    info.check_range("load_torque", abs(load))
    cands = parse_float_list(args.speeds_candidates, "--speeds-candidates", max_count=MAX_CANDIDATES)
    for s in cands:
        if s < 0:
            raise UsageError(f"--speeds-candidates: {s:g} is negative; give speed magnitudes >= 0 rad/s")
        info.check_range("speed", s)
    try:
        prior = parse_temperature_prior(args.prior)
    except JointwearError as exc:
        raise UsageError(f"--prior: {exc}") from None
    check_temperature_prior(prior, "--prior", info.valid.get("temperature"), info.name)
    if args.no_repeats and len(set(cands)) < n:
        raise UsageError(f"--no-repeats: {n} distinct speeds needed but --speeds-candidates gives {len(set(cands))}")

    model, set_params = resolve_model(None, info)  # the set's own model (its core terms)
    d = design_cycle(model, set_params, budget=budget, seconds_per_speed=sps,
                     candidates=cands, wear=wear, load=load, noise_std=noise, prior=prior,
                     allow_repeats=not args.no_repeats, progress=_progress if sys.stderr.isatty() else None)
    if args.json:
        print_json(dict(d.to_dict(), params=info.name))
        return 0
    print(f"cycle design: {d.n_speeds} speeds x {sps:g} s = {d.seconds:g} s of a {budget:g} s budget")
    print(f"  {info.name}, w = {wear:g}, tau_m = {load:g}, sigma_e = {noise:g}, T ~ {prior.label} (one T per cycle)")
    counts = Counter(d.speeds)
    single = dict(zip(d.speeds, d.per_speed_bound_std))
    rows = [[f"{v:g}", counts[v], single[v]] for v in sorted(counts)]
    print(format_table(["speed (rad/s)", "times", "single-speed bound std"], rows, floatfmt=".3f"))
    print(f"bound std on w of this cycle (shared T):   {d.bound_std:.3f}  (+-{100 * d.bound_rel_error:.2f} % numerical)")
    print(f"  same speeds with T known:                 {d.known_temperature_bound_std:.3f}")
    print(f"paper's best single speed {d.best_single_speed:g} rad/s: one observation {d.best_single_bound_std:.3f}, "
          f"repeated {d.n_speeds}x {d.repeated_best_bound_std:.3f}")
    print(f"design / repeated best single speed: {d.bound_std / d.repeated_best_bound_std:.3f} "
          f"({d.gain:.2f}x smaller std)")
    speeds = ",".join(f"{v:g}" for v in sorted(d.speeds))
    if all(v > 0 for v in d.speeds):
        print(f"run it: jointwear demo --speeds {speeds}   "
              f"(on a cell: RunTestCycle speeds: [{speeds.replace(',', ', ')}])")
    else:
        print("note: speed 0 cannot be swept by a test cycle; use candidates > 0 to run this design")
    return 0


def _joint_cycle_config(params: dict[str, Any], joint: str, where: str) -> CycleConfig:
    """test_cycle's settings for ``joint``: ``<joint>.<setting>`` over the node-level value over the default
    (every :class:`CycleConfig` setting, as the node reads them: :func:`jointwear_ros.settings.from_mapping`)."""
    from ..settings import from_mapping

    fixed: dict[str, Any] = {}
    rate = params.get("command_rate")
    if rate is not None:  # the node's control period, part of each speed's stopping allowance
        try:
            fixed["control_period"] = 1.0 / float(rate)
        except (TypeError, ValueError, ZeroDivisionError):
            raise UsageError(f"{where}: command_rate = {rate!r} must be a rate in Hz > 0") from None
    try:
        return from_mapping(CycleConfig, params, joint=joint, joint_name=joint, **fixed)
    except JointwearError as exc:
        raise UsageError(f"{where}: {exc}") from None


def cmd_schedule(args: argparse.Namespace) -> int:
    from ..io.params import node_params_from_yaml
    from ..resources import config_path

    where = args.params_file or str(config_path("test_cycle.yaml"))
    try:
        params = node_params_from_yaml(where, "test_cycle")
    except JointwearError as exc:
        raise UsageError(f"--params-file: {exc}") from None
    configured = [str(j) for j in params.get("joints") or []] or [str(params.get("joint_name", "joint_1"))]
    if args.joints is None:
        joints = configured
    elif args.joints.strip().isdigit():
        n = int(args.joints)
        if not 1 <= n <= len(configured):
            raise UsageError(f"--joints {n}: {where} configures {len(configured)} joints ({', '.join(configured)})")
        joints = configured[:n]
    else:
        joints = [j.strip() for j in args.joints.split(",") if j.strip()]
        unknown = [j for j in joints if j not in configured]
        if unknown or len(set(joints)) != len(joints) or not joints:
            raise UsageError(f"--joints {args.joints}: give distinct configured joints ({', '.join(configured)})")
    if len(joints) > MAX_SCHEDULE_JOINTS:
        raise UsageError(f"--joints: {len(joints)} joints; at most {MAX_SCHEDULE_JOINTS}")
    speeds = parse_float_list(args.speeds, "--speeds") if args.speeds is not None else None
    sps = parse_float(args.seconds_per_speed, "--seconds-per-speed") if args.seconds_per_speed is not None else None
    if sps is not None and not 0 < sps <= 3600:
        raise UsageError(f"--seconds-per-speed: {sps:g} must be more than 0 and at most 3600 s")
    overhead = parse_float(args.overhead, "--overhead")
    if not 0 <= overhead <= 3600:
        raise UsageError(f"--overhead: {overhead:g} must be 0-3600 s")
    budget = parse_float(args.budget, "--budget") if args.budget is not None else None
    if budget is not None and not 0 < budget <= 86400:
        raise UsageError(f"--budget: {budget:g} must be more than 0 and at most 86400 s")
    durations: dict[str, float] = {}
    counts: dict[str, int] = {}
    for j in joints:
        cfg = _joint_cycle_config(params, j, where)
        try:
            plan = plan_cycle(cfg, speeds)
        except JointwearError as exc:
            raise UsageError(f"{j}: {exc}") from None
        counts[j] = len(plan.speeds)
        durations[j] = plan.duration if sps is None else sps * len(plan.speeds)
    try:
        sched = rotation_schedule(durations, budget if budget is not None else math.inf, overhead) \
            if budget is not None else None
    except ScheduleError as exc:
        raise UsageError(f"--budget: {exc}") from None
    total = sum(durations.values()) + overhead * len(durations)
    basis = f"{sps:g} s per speed" if sps is not None else "planned motion (test_cycle's settings)"
    if args.json:
        out: dict[str, Any] = {
            "basis": basis,
            "joints": [{"joint": j, "speeds": counts[j], "seconds": durations[j] + overhead} for j in joints],
            "total_seconds": total,
            "schedule": sched.to_dict() if sched is not None else None,
        }
        print_json(out)
        return 0
    print(f"robot cycle over {len(joints)} joints, {basis}:")
    print(format_table(["joint", "speeds", "cell s"], [[j, counts[j], durations[j] + overhead] for j in joints],
                       floatfmt=".1f"))
    print(f"total: {total:.0f} s ({total / 60:.1f} min) of cell time for every joint once")
    if sched is not None:
        if sched.fits_one_night:
            print(f"fits the {budget:g} s budget: test every joint every night")
        else:
            print(f"budget {budget:g} s: {sched.period} nights per rotation, each joint tested every "
                  f"{sched.period} nights")
            print(format_table(["night", "joints", "cell s"],
                               [[k + 1, ", ".join(n), sec] for k, (n, sec) in
                                enumerate(zip(sched.nights, sched.night_seconds()))], floatfmt=".1f"))
            print("run a night: RunTestCycle joints: [" + ", ".join(sched.nights[0]) + "] (night 1)")
    return 0
