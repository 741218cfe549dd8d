"""``jointwear bag info BAG`` and ``jointwear bag recover BAG``.

``info``: topics, types, message counts and duration of a rosbag2 bag, after
checking every MCAP file record by record (chunk CRCs, the data-section CRC,
a footer); a damaged or unfinished bag is an error (exit 2) naming the file
and byte offset. ``recover``: rebuild a readable bag (metadata.yaml v9 and an
indexed MCAP) from what a killed or disk-full recorder left, skipping and
reporting corrupt chunks; the input is never modified.
"""

from __future__ import annotations

import argparse
from typing import Any

from . import UsageError
from .common import format_table, print_json

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("bag", help="inspect and recover rosbag2 (MCAP) bags")
    bsub = p.add_subparsers(dest="bag_command", metavar="ACTION", parser_class=type(p))
    bsub.required = True
    i = bsub.add_parser("info", help="check a bag (CRCs) and show its topics, types, counts and duration")
    i.add_argument("bag", nargs="+", metavar="BAG", help="rosbag2 bag directories or globs (each bag once)")
    i.add_argument("--json", action="store_true", help="print JSON")
    i.set_defaults(func=cmd_info)
    r = bsub.add_parser(
        "recover", help="rebuild a readable bag from a killed, truncated or damaged recording",
        description="Read every intact chunk of BAG's MCAP file(s) in stream order (tolerating a truncated "
                    "tail, a missing metadata.yaml, corrupt chunks, which are skipped and reported) and write "
                    "them into a new bag: metadata.yaml v9 and an indexed MCAP. BAG is never modified.",
    )
    r.add_argument("bag", metavar="BAG", help="bag directory (or its .mcap file)")
    r.add_argument("--out", metavar="DIR", default=None,
                   help="new bag directory (must not exist; default: BAG_recovered beside BAG)")
    r.add_argument("--json", action="store_true", help="print the report as JSON")
    r.set_defaults(func=cmd_recover)


def cmd_info(args: argparse.Namespace) -> int:
    from ..io.bags import bag_info, discover_bags

    selection = discover_bags(args.bag)
    if not selection.bags:
        raise UsageError("no bag among " + "; ".join(f"{s['path']}: {s['reason']}" for s in selection.skipped[:3]))
    infos = [bag_info(b) for b in selection.bags]  # a damaged bag: exit 2 naming it, before anything is printed
    if args.json:
        print_json(infos[0].as_dict() if len(infos) == 1 else [i.as_dict() for i in infos])
        return 0
    for n, info in enumerate(infos):
        if n:
            print()
        _print_info(info)
    for s in selection.skipped:
        print(f"not a bag, skipped: {s['path']}: {s['reason']}")
    return 0


def _print_info(info: Any) -> None:
    print(f"bag: {info.path}")
    print(f"storage: {info.storage} (metadata version {info.version}), {info.message_count} messages, "
          f"{info.duration_ns * 1e-9:.3f} s from {info.start_ns * 1e-9:.3f} s")
    for c in info.check:
        crcs = ("chunk CRCs ok" if not c["chunks_without_crc"] else
                f"{c['chunks_without_crc']} of {c['chunks']} chunks without CRC (structure checked only)")
        print(f"check: {c['file']}: {c['chunks']} chunks, {crcs}, data CRC {c['data_crc']}, "
              f"summary CRC {c['summary_crc']}")
    rows = [[t, v["type"], v["count"]] for t, v in info.topics.items()]
    print(format_table(["topic", "type", "count"], rows))
    if info.messages_lost:
        print("INCOMPLETE: the recorder was told these messages were lost before it received them: "
              + ", ".join(f"{t} {n}" for t, n in info.messages_lost.items())
              + " (a publisher's history overflowed while the recorder was stalled)")
    else:
        print("messages lost while recording: none")


def cmd_recover(args: argparse.Namespace) -> int:
    from ..io.recover import recover_bag

    rep = recover_bag(args.bag, args.out)
    if args.json:
        print_json(rep.as_dict())
        return 0
    print(f"recovered {rep.messages} message(s) on {len(rep.topics)} topic(s) from {rep.source} into {rep.bag}")
    rows = [[t, v["type"], v["count"]] for t, v in rep.topics.items()]
    if rows:
        print(format_table(["topic", "type", "count"], rows))
    print(f"source: {'closed properly' if rep.source_complete else 'not closed (no footer)'}, "
          f"data CRC {rep.data_crc}, metadata.yaml {rep.source_metadata}, "
          f"truncated tail {rep.truncated_bytes} bytes")
    for c in rep.skipped_chunks:
        print(f"SKIPPED chunk at byte {c['offset']} of {c['file']} ({c['length']} bytes): {c['reason']}")
    for d in rep.damaged:
        print(f"DAMAGED {d['length']} bytes at byte {d['offset']} of {d['file']}: {d['reason']}")
    if rep.orphaned_messages:
        print(f"NOT RECOVERED: {rep.orphaned_messages} message(s) whose channel definition was in a skipped chunk")
    return 0
