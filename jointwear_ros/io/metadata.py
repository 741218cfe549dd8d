"""A rosbag2 ``metadata.yaml`` checked key by key before a reader opens the bag.

:func:`metadata_problem` names what is wrong with a ``rosbag2_bagfile_information`` mapping (a key a reader
needs missing, a value of the wrong type); the bag reader (:mod:`.bags`) refuses such a bag in one line and
``bag recover`` (:mod:`.recover`) rebuilds its metadata from the MCAP. Pure Python, no bag IO.
"""

from __future__ import annotations

from typing import Any

__all__ = ["metadata_problem"]

_TIME = {"nanoseconds_since_epoch": int}
_DURATION = {"nanoseconds": int}
#: The keys of ``rosbag2_bagfile_information`` a reader uses, and what each must hold: a type, ``[x]`` a list
#: of x, a mapping of key -> what; a tuple: any of these. rosbag2's metadata, versions 1-9.
_METADATA: dict[str, Any] = {
    "version": int, "storage_identifier": str, "relative_file_paths": [str], "duration": _DURATION,
    "starting_time": _TIME, "message_count": int, "compression_format": (str, type(None)),
    "compression_mode": (str, type(None)), "ros_distro": (str, type(None)), "custom_data": (dict, type(None)),
    "topics_with_message_count": [{"message_count": int, "topic_metadata": {
        "name": str, "type": str, "serialization_format": str, "offered_qos_profiles": (str, [dict]),
        "type_description_hash": (str, type(None))}}],
    "files": [{"path": str, "starting_time": _TIME, "duration": _DURATION, "message_count": int}],
}
#: Keys without which no reader can open the bag (the others are optional, or newer than version 1).
_REQUIRED = {
    "": ("version", "storage_identifier", "relative_file_paths", "duration", "starting_time", "message_count",
         "topics_with_message_count"),
    "topics_with_message_count[]": ("message_count", "topic_metadata"),
    "topic_metadata": ("name", "type", "serialization_format"),
    "duration": ("nanoseconds",), "starting_time": ("nanoseconds_since_epoch",),
}
_WHAT = {int: "an integer", str: "a string", list: "a list", dict: "a mapping", type(None): "empty (null)"}


def _what_is(value: Any) -> str:
    if isinstance(value, bool):
        return "true/false"
    if isinstance(value, (int, float)):
        return "a number"
    return _WHAT.get(type(value), f"a {type(value).__name__}")


def _expected(spec: Any) -> str:
    if isinstance(spec, tuple):
        return " or ".join(_expected(s) for s in spec)
    if isinstance(spec, list):
        return "a list"
    if isinstance(spec, dict):
        return "a mapping"
    return _WHAT[spec]


def _matches(value: Any, spec: Any) -> bool:
    if isinstance(spec, tuple):
        return any(_matches(value, s) for s in spec)
    if isinstance(spec, list):
        return isinstance(value, list)
    if isinstance(spec, dict):
        return isinstance(value, dict)
    if spec is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, spec)


def _problem_in(value: Any, spec: Any, key: str, kind: str) -> str:
    if not _matches(value, spec):
        return f"key {key!r} is {_what_is(value)} where {_expected(spec)} belongs"
    specs = spec if isinstance(spec, tuple) else (spec,)
    for sp in specs:
        if isinstance(sp, list) and isinstance(value, list):
            for i, item in enumerate(value):
                found = _problem_in(item, sp[0], f"{key}[{i}]", f"{kind}[]")
                if found:
                    return found
        elif isinstance(sp, dict) and isinstance(value, dict):
            for k in _REQUIRED.get(kind, ()):
                if k not in value:
                    return f"key {key + '.' + k!r} is missing"
            for k, sub in sp.items():
                if k in value:
                    found = _problem_in(value[k], sub, f"{key}.{k}", k)
                    if found:
                        return found
    return ""


def metadata_problem(info: dict[str, Any]) -> str:
    """What is wrong with a bag's ``rosbag2_bagfile_information`` mapping, naming the key ('' when nothing):
    a key a reader needs missing, or a value of the wrong type (a number where a list belongs).

    >>> metadata_problem({"version": 9, "storage_identifier": "mcap", "relative_file_paths": 5,
    ...                   "duration": {"nanoseconds": 0}, "starting_time": {"nanoseconds_since_epoch": 0},
    ...                   "message_count": 0, "topics_with_message_count": []})
    "key 'relative_file_paths' is a number where a list belongs"
    """
    for k in _REQUIRED[""]:
        if k not in info:
            return f"key {k!r} is missing"
    for k, spec in _METADATA.items():
        if k in info:
            found = _problem_in(info[k], spec, k, k)
            if found:
                return found
    return ""
