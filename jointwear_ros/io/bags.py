"""rosbag2 (MCAP) bags of a jointwear graph: read, summarise, convert messages.

Reading uses rosbags (``AnyReader``) with the jointwear typestore; no ROS
runtime is needed. Every problem with a bag (missing path, not a bag,
truncated file, a type that cannot be decoded) raises
:class:`~jointwear_ros.errors.InputDataError` with a one-line message naming
the bag and what to do.

The converters turn rosbags-deserialized messages (or rclpy messages: the
field names are the same) into the plain values the observer core and the
wear monitor take, keeping the ``.msg`` field names.
"""

from __future__ import annotations

import copy
import json
import os
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.typesys import get_types_from_msg
from rosbags.typesys.store import Typestore

from ..contract import Source, stamp_to_seconds
from ..errors import InputDataError
from .metadata import metadata_problem
from .typestore import jointwear_typestore

#: ``custom_data`` key of a bag's metadata.yaml where the recorder notes lost messages (JSON ``{topic: count}``)
#: ``custom_data`` key of the recorder's snapshot of every node's parameters (JSON ``{node: {name: value}}``)
NODE_PARAMS_KEY = "jointwear.node_parameters"
LOST_KEY = "jointwear.messages_lost"

__all__ = [
    "ESTIMATE_TYPE",
    "JOINT_STATE_TYPE",
    "LOST_KEY",
    "NODE_PARAMS_KEY",
    "OBSERVATION_TYPE",
    "PARAMETER_EVENT_TYPE",
    "STATUS_TYPE",
    "TEMPERATURE_TYPE",
    "BagInfo",
    "BagMessage",
    "BagPass",
    "BagSelection",
    "bag_custom_data",
    "bag_info",
    "bag_messages_lost",
    "discover_bags",
    "ensure_msgtype",
    "estimate_fields",
    "find_bags",
    "joint_sample",
    "message_fields",
    "messages_lost",
    "metadata_problem",
    "msg_search_dirs",
    "read_bag_once",
    "read_messages",
    "recorded_settings",
    "settings_memo",
    "stamp_seconds",
    "temperature_value",
]

JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
STATUS_TYPE = "jointwear_msgs/msg/TestCycleStatus"
TEMPERATURE_TYPE = "sensor_msgs/msg/Temperature"
OBSERVATION_TYPE = "jointwear_msgs/msg/FrictionObservation"
ESTIMATE_TYPE = "jointwear_msgs/msg/WearEstimate"
PARAMETER_EVENT_TYPE = "rcl_interfaces/msg/ParameterEvent"


# --------------------------------------------------------------------------- types


def msg_search_dirs() -> list[Path]:
    """``share`` directories that may hold ``<pkg>/msg/<Type>.msg`` files (ament prefixes)."""
    dirs = [Path(sys.prefix) / "share"]
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / "share")
    return dirs


def _referenced_types(obj: Any) -> Iterator[str]:
    if isinstance(obj, str):
        if obj.count("/") == 2 and "/msg/" in obj:
            yield obj
    elif isinstance(obj, (tuple, list)):
        for item in obj:
            yield from _referenced_types(item)


def ensure_msgtype(store: Typestore, msgtype: str, search_dirs: Sequence[Path] | None = None) -> bool:
    """Make ``msgtype`` known to ``store``, loading its ``.msg`` (and dependencies) if needed.

    Returns False when no definition can be found; the store is then unchanged.
    """
    if msgtype in store.fielddefs:
        return True
    dirs = list(search_dirs) if search_dirs is not None else msg_search_dirs()
    pending: dict[str, Any] = {}

    def load(name: str) -> bool:
        if name in store.fielddefs or name in pending:
            return True
        parts = name.split("/")
        if len(parts) != 3:
            return False
        pkg, kind, typ = parts
        for d in dirs:
            f = d / pkg / kind / f"{typ}.msg"
            if f.is_file():
                try:
                    types = get_types_from_msg(f.read_text(), name)
                except Exception:  # an unparsable definition is "not found"
                    return False
                pending.update(types)
                return all(load(ref) for ref in _referenced_types(types[name]))
        return False

    if not load(msgtype):
        return False
    try:
        store.register(pending)
    except Exception:
        return False
    return msgtype in store.fielddefs


# --------------------------------------------------------------------------- reading


def _bag_dir(path: Path) -> Path:
    if path.is_file() and path.suffix == ".mcap" and (path.parent / "metadata.yaml").is_file():
        return path.parent
    return path


def check_bag_path(path: Path) -> Path:
    if not path.exists():
        raise InputDataError(f"{path}: no such bag; give a rosbag2 directory (with metadata.yaml)")
    p = _bag_dir(path)
    if p.is_dir() and not (p / "metadata.yaml").is_file():
        if any(p.glob("*.mcap")):
            raise InputDataError(
                f"{p}: no metadata.yaml beside its .mcap file (recorder killed?); "
                f"`jointwear bag recover {p}` rebuilds a readable bag"
            )
        raise InputDataError(
            f"{p}: not a rosbag2 bag (no metadata.yaml); give the bag directory the recorder wrote"
        )
    if p.is_file() and p.suffix not in (".mcap", ".db3", ".bag"):
        raise InputDataError(f"{p}: not a bag (expected a rosbag2 directory or an .mcap file)")
    if p.is_dir():
        _check_metadata(p / "metadata.yaml")
    return p


def _check_metadata(meta: Path) -> None:
    """A metadata.yaml that is not the rosbag2 mapping (a scalar, a list, bad YAML) in one line, before a reader
    fails on it with "'int' object is not subscriptable"."""
    import yaml

    try:
        doc = _metadata_doc(meta.read_text(encoding="utf-8", errors="replace"))
    except (yaml.YAMLError, OSError) as exc:
        raise InputDataError(f"{meta}: not readable YAML ({str(exc).splitlines()[0]}); "
                             f"`jointwear bag recover {meta.parent}` rebuilds it from the .mcap") from None
    info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
    if not isinstance(info, dict):
        raise InputDataError(f"{meta}: not rosbag2 metadata (a {type(doc).__name__}, no "
                             f"rosbag2_bagfile_information mapping); `jointwear bag recover {meta.parent}` "
                             "rebuilds it from the .mcap")
    problem = metadata_problem(info)
    if problem:
        raise InputDataError(f"{meta}: {problem}; `jointwear bag recover {meta.parent}` rebuilds it from the .mcap")


#: parsed metadata.yaml documents by their text (a bag is checked, replayed and its settings read: one parse)
_METADATA_DOCS: dict[str, Any] = {}
_METADATA_DOCS_MAX = 64


def _metadata_doc(text: str) -> Any:
    """``yaml.safe_load(text)``, parsed once per text (the bag's readers each look at its metadata.yaml).

    Keyed by the content, so an edited file is parsed again; a copy is returned, so no caller changes another's
    document. Raises what ``yaml.safe_load`` raises (nothing is kept for a text that does not parse).
    """
    import yaml

    doc = _METADATA_DOCS.get(text)
    if doc is None and text not in _METADATA_DOCS:
        doc = yaml.safe_load(text)
        if len(_METADATA_DOCS) >= _METADATA_DOCS_MAX:
            _METADATA_DOCS.clear()
        _METADATA_DOCS[text] = doc
    return copy.deepcopy(doc)


def _metadata_info(meta: Path) -> Any:
    """The ``rosbag2_bagfile_information`` of ``meta`` (as ``(yaml.safe_load(text) or {}).get(...)``)."""
    return (_metadata_doc(meta.read_text()) or {}).get("rosbag2_bagfile_information", {})


@dataclass(frozen=True)
class BagMessage:
    """One message of a bag: topic, type, log time (ns) and the deserialized message."""

    topic: str
    msgtype: str
    log_time: int
    msg: Any


def _raw_messages(p: Path, want_topics: set[str] | None, want_types: set[str] | None,
                  store: Typestore) -> Iterator[tuple[Any, int, bytes, Callable[[bytes, str], Any]]]:
    """(connection, log time, raw CDR bytes, decode) of the wanted messages, in log-time order; every reader
    failure is an :class:`InputDataError` naming the message it was reading."""
    from rosbags.highlevel import AnyReader

    current = "opening"
    try:
        with AnyReader([p], default_typestore=store) as reader:
            conns = [
                c for c in reader.connections
                if (want_topics is None or c.topic in want_topics) and (want_types is None or c.msgtype in want_types)
            ]
            if not conns:
                return
            # the bag's own typestore (the reader empties its reference when it closes)
            ts = reader.typestore
            decode = ts.deserialize_cdr if reader.is2 else ts.deserialize_ros1
            for conn, t, raw in reader.messages(connections=conns):
                current = f"a {conn.msgtype} message on {conn.topic} at log time {t} ns"
                yield conn, int(t), raw, decode
    except InputDataError:
        raise
    except GeneratorExit:
        raise
    except Exception as exc:  # any reader failure is a bad-input message
        raise _unreadable(p, current, exc) from None


def _unreadable(p: Path, current: str, exc: Exception) -> InputDataError:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return InputDataError(
        f"{p}: cannot read the bag ({current}: {type(exc).__name__}: {text}); "
        "is it complete (closed by the recorder) and a rosbag2 MCAP/SQLite bag?"
    )


def read_messages(
    path: str | os.PathLike[str],
    topics: Iterable[str] | None = None,
    msgtypes: Iterable[str] | None = None,
    store: Typestore | None = None,
) -> Iterator[BagMessage]:
    """Yield the bag's messages in log-time order, deserialized with rosbags.

    ``topics``/``msgtypes`` restrict what is read (``None``: everything).
    Raises :class:`InputDataError` for a missing path, a directory that is not a
    bag, a truncated or corrupt file, or a message that cannot be decoded.
    """
    p = check_bag_path(Path(path))
    want_topics = None if topics is None else set(topics)
    want_types = None if msgtypes is None else set(msgtypes)
    ts = store if store is not None else jointwear_typestore()
    for conn, t, raw, decode in _raw_messages(p, want_topics, want_types, ts):
        try:
            msg = decode(raw, conn.msgtype)
        except Exception as exc:  # a message that cannot be decoded is a bad-input message
            raise _unreadable(p, f"a {conn.msgtype} message on {conn.topic} at log time {t} ns", exc) from None
        yield BagMessage(conn.topic, conn.msgtype, t, msg)


@dataclass
class BagPass:
    """A bag read in one pass (:func:`read_bag_once`): its metadata ``custom_data`` and the messages of the
    wanted types in log-time order, kept as raw CDR bytes; :meth:`message` decodes one (each is decoded
    when it is used, and once). What needs the whole bag first (the recorded settings, which joints the
    statuses name) reads the few small messages it needs; the stream is not read again."""

    path: Path
    custom_data: dict[str, Any]
    #: (topic, msgtype, log time ns, raw CDR bytes), in log-time order
    records: list[tuple[str, str, int, bytes]]
    decode: Callable[[bytes, str], Any]
    _decoded: dict[int, BagMessage] = field(default_factory=dict, repr=False)

    def message(self, i: int, keep: bool = False) -> BagMessage:
        """Record ``i`` decoded (an :class:`InputDataError` naming it when it cannot be); ``keep`` keeps the
        decoded message for the next call (for the few messages read before the stream)."""
        hit = self._decoded.get(i)
        if hit is not None:
            return hit
        topic, msgtype, t, raw = self.records[i]
        try:
            out = BagMessage(topic, msgtype, t, self.decode(raw, msgtype))
        except Exception as exc:
            raise _unreadable(self.path, f"a {msgtype} message on {topic} at log time {t} ns", exc) from None
        if keep:
            self._decoded[i] = out
        return out

    def messages(self, msgtype: str, topics: Iterable[str] | None = None, keep: bool = False) -> Iterator[BagMessage]:
        """The decoded messages of ``msgtype`` (on ``topics``, when given), in log-time order."""
        want = None if topics is None else set(topics)
        for i, rec in enumerate(self.records):
            if rec[1] == msgtype and (want is None or rec[0] in want):
                yield self.message(i, keep)

    def settings(self) -> dict[str, dict[str, Any]]:
        """Every node's recorded parameters (:func:`recorded_settings`), from this pass."""
        out = _settings(self.path, self.custom_data,
                        [m.msg for m in self.messages(PARAMETER_EVENT_TYPE, ["/parameter_events"])])
        memo = _SETTINGS_MEMO.get()
        if memo is not None:
            memo[str(self.path)] = copy.deepcopy(out)
        return out

    def messages_lost(self) -> dict[str, int]:
        """Per topic, messages the recorder was told were lost while recording (:func:`messages_lost`)."""
        return messages_lost(self.custom_data)


def read_bag_once(path: str | os.PathLike[str], msgtypes: Iterable[str], store: Typestore | None = None) -> BagPass:
    """Read the bag's messages of ``msgtypes`` (and its ``/parameter_events``) once, undecoded; see :class:`BagPass`."""
    p = check_bag_path(Path(path))
    ts = store if store is not None else jointwear_typestore()
    records: list[tuple[str, str, int, bytes]] = []
    decode: Callable[[bytes, str], Any] = ts.deserialize_cdr
    for conn, t, raw, dec in _raw_messages(p, None, {*msgtypes, PARAMETER_EVENT_TYPE}, ts):
        records.append((conn.topic, conn.msgtype, t, bytes(raw)))
        decode = dec
    return BagPass(p, bag_custom_data(p), records, decode)


@dataclass(frozen=True)
class BagInfo:
    """Summary of a bag: path, storage, per-topic type and count, start and duration."""

    path: str
    storage: str
    version: int
    start_ns: int
    duration_ns: int
    message_count: int
    topics: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: per topic, messages the recorder was told were lost before reception (metadata custom_data)
    messages_lost: dict[str, int] = field(default_factory=dict)
    #: per MCAP file, what the integrity check found (``file``, ``chunks``, ``chunks_without_crc``,
    #: ``data_crc``, ``summary_crc``: ok / absent); empty when not checked
    check: list[dict[str, Any]] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "path": self.path,
            "storage": self.storage,
            "version": self.version,
            "start_s": self.start_ns * 1e-9,
            "duration_s": self.duration_ns * 1e-9,
            "message_count": self.message_count,
            "topics": self.topics,
            "messages_lost": self.messages_lost,
            "check": self.check,
        }


def bag_info(path: str | os.PathLike[str], check: bool = True) -> BagInfo:
    """Topics (type, message count), duration and storage of a bag (from its index/metadata).

    With ``check`` every MCAP file is first walked record by record (chunk and
    data-section CRCs, a footer): a damaged or unfinished bag raises
    :class:`InputDataError` naming the file and byte offset (see
    :func:`~jointwear_ros.io.recover.check_bag`).
    """
    from rosbags.highlevel import AnyReader

    from .recover import check_bag

    p = check_bag_path(Path(path))
    checked = [
        {"file": Path(sc.path).name, "chunks": sc.chunks, "chunks_without_crc": sc.chunks_without_crc,
         "data_crc": sc.data_crc, "summary_crc": sc.summary_crc}
        for sc in (check_bag(p) if check else [])
    ]
    try:
        with AnyReader([p], default_typestore=jointwear_typestore()) as reader:
            topics: dict[str, dict[str, Any]] = {}
            for c in reader.connections:
                entry = topics.setdefault(c.topic, {"type": c.msgtype, "count": 0})
                entry["count"] += int(c.msgcount)
            storage, version, lost = "unknown", 0, {}
            meta = p / "metadata.yaml" if p.is_dir() else None
            if meta is not None and meta.is_file():
                info = _metadata_info(meta)
                storage = str(info.get("storage_identifier", "unknown"))
                version = int(info.get("version", 0))
                lost = messages_lost(info.get("custom_data"))
            return BagInfo(
                path=str(p),
                storage=storage,
                version=version,
                start_ns=int(reader.start_time) if reader.message_count else 0,
                duration_ns=int(reader.duration) if reader.message_count else 0,
                message_count=int(reader.message_count),
                topics=dict(sorted(topics.items())),
                messages_lost=lost,
                check=checked,
            )
    except InputDataError:
        raise
    except Exception as exc:
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputDataError(f"{p}: cannot read the bag ({type(exc).__name__}: {text})") from None


def bag_messages_lost(p: Path) -> dict[str, int]:
    meta = p / "metadata.yaml" if p.is_dir() else None
    if meta is None or not meta.is_file():
        return {}
    import yaml

    try:
        info = _metadata_info(meta)
    except (yaml.YAMLError, OSError, AttributeError):
        return {}  # the reader reports a broken metadata.yaml
    return messages_lost(info.get("custom_data") if isinstance(info, dict) else None)


def bag_custom_data(p: Path) -> dict[str, Any]:
    """The ``custom_data`` of a bag's metadata.yaml ({} when none or unreadable: the readers report that)."""
    meta = p / "metadata.yaml" if p.is_dir() else p.parent / "metadata.yaml"
    if not meta.is_file():
        return {}
    import yaml

    try:
        info = _metadata_info(meta)
    except (yaml.YAMLError, OSError, AttributeError):
        return {}
    custom = info.get("custom_data") if isinstance(info, dict) else None
    return dict(custom) if isinstance(custom, dict) else {}


def recorded_settings(path: str | os.PathLike[str]) -> dict[str, dict[str, Any]]:
    """Every node's parameters as the bag recorded them: node name -> flattened parameters.

    The recorder writes a snapshot of every node's parameters into each bag's metadata.yaml as it
    opens the bag (``custom_data`` key ``jointwear.node_parameters``, JSON ``{node: {name: value}}``;
    nodes found later are added), so a bag recorded per cycle, or by a recorder started after the
    nodes, carries its settings too; the bag's ``/parameter_events`` (declarations and run-time
    changes seen while recording) apply over it. A node absent from both is absent here.
    """
    p = check_bag_path(Path(path))
    memo = _SETTINGS_MEMO.get()
    if memo is not None and str(p) in memo:
        return copy.deepcopy(memo[str(p)])
    return _settings(p, bag_custom_data(p), [m.msg for m in read_messages(p, topics=["/parameter_events"])])


#: the settings one-pass reads found, by bag path, while :func:`settings_memo` is open (else None)
_SETTINGS_MEMO: ContextVar[dict[str, dict[str, dict[str, Any]]] | None] = ContextVar("settings_memo", default=None)


@contextmanager
def settings_memo() -> Iterator[None]:
    """Within it, :func:`recorded_settings` of a bag a one-pass read (:meth:`BagPass.settings`) already took
    the settings of gives those (a copy) instead of opening the bag again: for one piece of work that reads a
    bag's settings twice while the bag stays as it is (a re-analysis: the replay, then the trend node's
    identity)."""
    token = _SETTINGS_MEMO.set({})
    try:
        yield
    finally:
        _SETTINGS_MEMO.reset(token)


def _settings(p: Path, custom_data: dict[str, Any], events: list[Any]) -> dict[str, dict[str, Any]]:
    """The recorder's snapshot in ``custom_data`` with the bag's parameter events applied over it."""
    from .params import recorded_node_params

    out: dict[str, dict[str, Any]] = {}
    text = custom_data.get(NODE_PARAMS_KEY)
    if text:
        try:
            snap = json.loads(text)
        except (TypeError, ValueError):
            raise InputDataError(f"{p}: metadata.yaml custom_data {NODE_PARAMS_KEY} is not JSON") from None
        if isinstance(snap, dict):
            out = {str(n).lstrip("/"): dict(v) for n, v in snap.items() if isinstance(v, dict)}
    for node in {str(ev.node).lstrip("/") for ev in events}:
        out.setdefault(node, {}).update(recorded_node_params(events, node))
    return out


def messages_lost(custom_data: Any) -> dict[str, int]:
    """The recorder's per-topic lost-message counts from a bag's ``custom_data`` ({} when none).

    >>> messages_lost({"jointwear.messages_lost": '{"/joint_states": 2500}'})
    {'/joint_states': 2500}
    """
    if not isinstance(custom_data, dict):
        return {}
    text = custom_data.get(LOST_KEY)
    if not isinstance(text, str):
        return {}
    try:
        value = json.loads(text)
        return {str(k): int(v) for k, v in value.items() if int(v) > 0}
    except (ValueError, TypeError, AttributeError):
        return {"(unreadable count)": 1}


def find_bags(root: str | os.PathLike[str]) -> list[Path]:
    """Bag directories (holding ``metadata.yaml``) under ``root``, oldest first."""
    r = Path(root)
    if not r.is_dir():
        return []
    found = [m.parent for m in r.rglob("metadata.yaml")]
    return sorted(found, key=lambda d: (d.stat().st_mtime, str(d)))


BAG_FILE_SUFFIXES = (".mcap", ".db3")


@dataclass(frozen=True)
class BagSelection:
    """What :func:`discover_bags` found: each bag once, and every matched path it did not take, with why."""

    bags: list[Path]
    #: ``{"path", "reason"}`` for each matched path that is not a bag (and is not part of one taken)
    skipped: list[dict[str, str]]


def _bag_of(p: Path) -> Path | None:
    """The bag a path belongs to: a bag directory itself, the directory of a bag's storage file or
    ``metadata.yaml``, or a bare storage file; None when it is none of these."""
    if p.is_dir():
        if (p / "metadata.yaml").is_file() or any(f.suffix in BAG_FILE_SUFFIXES for f in p.iterdir() if f.is_file()):
            return p  # a directory of .mcap without metadata.yaml is a (broken) bag: its readers say how to recover it
        return None
    if p.is_file() and (p.name == "metadata.yaml" or p.suffix in BAG_FILE_SUFFIXES):
        if (p.parent / "metadata.yaml").is_file():
            return p.parent
        return p if p.suffix in BAG_FILE_SUFFIXES else None
    return None


def discover_bags(patterns: Iterable[str | os.PathLike[str]], *, accept: Callable[[Path], bool] | None = None,
                  ) -> BagSelection:
    """The bags named by ``patterns`` (paths or globs, ``**`` recursive), each counted once, in the order given.

    A bag's directory and the ``.mcap`` (or ``metadata.yaml``) inside it name the same bag (a glob like
    ``'bags/**/jointwear_*'`` matches both); a directory that is not a bag stands for the bags under
    it. A matched path that is not a bag is listed in ``skipped`` with the reason; ``accept(path)``
    True keeps such a path as it is (e.g. a ``.csv`` table for ``history import``). Raises
    :class:`InputDataError` when a pattern matches nothing, or a plain path does not exist.
    """
    import glob

    bags: list[Path] = []
    skipped: list[dict[str, str]] = []
    seen: set[Path] = set()

    def take(b: Path) -> None:
        key = b.resolve()
        if key not in seen:
            seen.add(key)
            bags.append(b)

    for pattern in patterns:
        pat = str(pattern)
        magic = glob.has_magic(pat)
        matches = sorted(glob.glob(pat, recursive=True)) if magic else [pat]
        if not magic and not Path(pat).exists():
            raise InputDataError(f"{pat}: no such file or bag directory")
        if not matches:
            raise InputDataError(f"{pat}: no bag matches (give rosbag2 bag directories, a glob, or a directory of bags)")
        for m in matches:
            p = Path(m)
            if accept is not None and accept(p):
                take(p)
                continue
            bag = _bag_of(p)
            if bag is not None:
                take(bag)
            elif p.is_dir():
                under = sorted({b for f in p.rglob("*") if f.is_file() and (b := _bag_of(f)) is not None},
                               key=lambda d: (d.stat().st_mtime, str(d)))
                if under:
                    for b in under:
                        take(b)
                else:
                    skipped.append({"path": str(p), "reason": "not a rosbag2 bag (no metadata.yaml) and no bag "
                                                              "under it"})
            else:
                skipped.append({"path": str(p), "reason": "not a bag (a rosbag2 bag is a directory with "
                                                          "metadata.yaml and its .mcap file)"})
    # a path skipped under one pattern but inside a bag taken under another is not worth a line
    skipped = [s for s in skipped if Path(s["path"]).resolve().parent not in seen]
    return BagSelection(bags, skipped)


# --------------------------------------------------------------------------- conversion


#: Seconds of a ``std_msgs/Header`` or ``builtin_interfaces/Time``: the contract's conversion.
stamp_seconds = stamp_to_seconds


def joint_sample(msg: Any, joint_name: str) -> tuple[float, float, float, float] | None:
    """``(stamp, position, velocity, effort)`` of ``joint_name`` in a JointState, or None.

    None, as the live friction_observer skips it, when the joint is absent, the
    message has no effort, or the position/velocity/effort arrays do not match
    ``name`` in length.
    """
    names = list(msg.name)
    try:
        i = names.index(joint_name)
    except ValueError:
        return None
    n = len(names)
    pos, vel, eff = msg.position, msg.velocity, msg.effort
    if len(eff) == 0 or len(pos) != n or len(vel) != n or len(eff) != n:
        return None
    return stamp_seconds(msg.header), float(pos[i]), float(vel[i]), float(eff[i])


def temperature_value(msg: Any) -> tuple[float, float]:
    """``(stamp, celsius)`` of a ``sensor_msgs/Temperature``."""
    return stamp_seconds(msg.header), float(msg.temperature)


def message_fields(msg: Any, names: Sequence[str]) -> dict[str, Any]:
    """The named fields of a message as plain Python values (arrays as float lists; ``source`` absent or empty:
    ``test_cycle``)."""
    out: dict[str, Any] = {}
    for n in names:
        if n == "source":  # absent in a bag recorded before the field, empty when unset: a test cycle's
            out[n] = str(getattr(msg, n, "")) or Source.TEST_CYCLE.value
            continue
        v = getattr(msg, n)
        if hasattr(v, "tolist"):
            v = [float(x) for x in v.tolist()]
        elif isinstance(v, (list, tuple)):
            v = [float(x) for x in v]
        elif isinstance(v, bool):
            v = bool(v)
        elif isinstance(v, int):
            v = int(v)
        elif isinstance(v, float):
            v = float(v)
        out[n] = v
    return out


OBSERVATION_FIELDS = (
    "joint_name", "cycle_id", "speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus",
    "load_torque", "temperature", "position", "samples_plus", "samples_minus", "source",
)
ESTIMATE_FIELDS = (
    "joint_name", "cycle_id", "method", "wear", "wear_std", "wear_low", "wear_high",
    "temperature_estimate", "speeds", "per_speed_wear", "alarm_threshold", "alarm", "source",
)


def estimate_fields(msg: Any) -> dict[str, Any]:
    """The fields of a WearEstimate message (without the header) as plain values."""
    return message_fields(msg, ESTIMATE_FIELDS)
