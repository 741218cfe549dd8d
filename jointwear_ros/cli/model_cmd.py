"""``jointwear model ...``: evaluate the friction model (and, later, fit and diagnose it)."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..model import load_parameter_set_info, paper_wear_model
from . import UsageError
from .common import format_table, parse_float, parse_float_list, print_json

__all__ = ["register"]

DEFAULT_SPEEDS = "0,10,25,47,80,150,280"


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("model", help="evaluate, fit and diagnose the friction model")
    msub = p.add_subparsers(dest="model_command", metavar="ACTION", parser_class=type(p))
    msub.required = True

    c = msub.add_parser(
        "curve",
        help="friction curve of the model (Eq. 9) with each term's contribution",
        description="Evaluate tau_f(v, tau_m, T, w) of Eq. (9) at given speeds, with every term's share.",
    )
    c.add_argument("--params", default="ref-2011r", help="parameter set name or YAML path (default ref-2011r)")
    c.add_argument("--load", default="0.1", help="load torque tau_m, normalized (default 0.1)")
    c.add_argument("--temperature", default="40", help="joint temperature, degC (default 40)")
    c.add_argument("--wear", default="0", help="wear level w, 0-100 (default 0)")
    c.add_argument("--speeds", default=DEFAULT_SPEEDS, help=f"comma list or START:STOP:COUNT, rad/s (default {DEFAULT_SPEEDS})")
    c.add_argument("--json", action="store_true", help="print JSON instead of a table")
    c.add_argument("--plot", metavar="FILE.png", help="draw the curve and its components to a PNG")
    c.set_defaults(func=cmd_curve)


def cmd_curve(args: argparse.Namespace) -> int:
    info = load_parameter_set_info(args.params)
    load = parse_float(args.load, "--load")
    temperature = parse_float(args.temperature, "--temperature")
    wear = parse_float(args.wear, "--wear")
    speeds = np.asarray(parse_float_list(args.speeds, "--speeds"))
    info.check_range("load_torque", abs(load))
    info.check_range("temperature", temperature)
    info.check_range("wear", wear)
    for s in speeds:
        if s < 0:
            raise UsageError(f"--speeds: {s:g} is negative; the model is for |v|, give speeds >= 0")
        info.check_range("speed", float(s))
    if args.plot and not args.plot.lower().endswith(".png"):
        raise UsageError(f"--plot: {args.plot!r} must name a .png file")

    model = paper_wear_model()
    params = model.make_params(info.parameters())
    inputs = dict(speed=speeds, load_torque=load, temperature=temperature, wear=wear)
    tau = model.evaluate(params, **inputs)
    comps = model.components(params, **inputs)

    if args.plot:
        from ..plots import plot_curve

        vv = np.linspace(0.0, float(max(speeds.max(), 1.0)), 300)
        dense = dict(inputs, speed=vv)
        plot_curve(
            Path(args.plot),
            vv,
            model.evaluate(params, **dense),
            model.components(params, **dense),
            title=f"{info.name}: tau_m={load:g}, T={temperature:g} degC, w={wear:g}",
            points=(speeds, tau),
        )

    if args.json:
        print_json(
            {
                "params": info.name,
                "load_torque": load,
                "temperature": temperature,
                "wear": wear,
                "speed": speeds,
                "tau_f": tau,
                "components": comps,
            }
        )
    else:
        print(f"# {info.name}: tau_m = {load:g}, T = {temperature:g} degC, w = {wear:g}")
        print(f"# {model.equation()}")
        headers = ["speed", "tau_f", *comps]
        rows = [[f"{s:g}", float(tau[i]), *(float(comps[k][i]) for k in comps)] for i, s in enumerate(speeds)]
        print(format_table(headers, rows))
        if args.plot:
            print(f"# plot written to {args.plot}")
    return 0
