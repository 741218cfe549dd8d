"""``jointwear bag info BAG``: topics, types, message counts and duration of a rosbag2 bag."""

from __future__ import annotations

import argparse

from .common import format_table, print_json

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("bag", help="inspect rosbag2 (MCAP) bags")
    bsub = p.add_subparsers(dest="bag_command", metavar="ACTION", parser_class=type(p))
    bsub.required = True
    i = bsub.add_parser("info", help="topics, types, message counts and duration of a bag")
    i.add_argument("bag", metavar="BAG", help="rosbag2 bag directory")
    i.add_argument("--json", action="store_true", help="print JSON")
    i.set_defaults(func=cmd_info)


def cmd_info(args: argparse.Namespace) -> int:
    from ..io.bags import bag_info

    info = bag_info(args.bag)
    if args.json:
        print_json(info.as_dict())
        return 0
    print(f"bag: {info.path}")
    print(f"storage: {info.storage} (metadata version {info.version}), {info.message_count} messages, "
          f"{info.duration_ns * 1e-9:.3f} s from {info.start_ns * 1e-9:.3f} s")
    rows = [[t, v["type"], v["count"]] for t, v in info.topics.items()]
    print(format_table(["topic", "type", "count"], rows))
    if info.messages_lost:
        print("INCOMPLETE: the recorder was told these messages were lost before it received them: "
              + ", ".join(f"{t} {n}" for t, n in info.messages_lost.items())
              + " (a publisher's history overflowed while the recorder was stalled)")
    return 0
