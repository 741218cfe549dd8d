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

import json
import math
import os
import sys
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.typesys import get_types_from_msg
from rosbags.typesys.store import Typestore

from ..errors import InputDataError
from .typestore import jointwear_typestore

#: ``custom_data`` key of a bag's metadata.yaml where the recorder notes lost messages (JSON ``{topic: count}``)
LOST_KEY = "jointwear.messages_lost"

__all__ = [
    "ESTIMATE_TYPE",
    "JOINT_STATE_TYPE",
    "LOST_KEY",
    "OBSERVATION_TYPE",
    "STATUS_TYPE",
    "TEMPERATURE_TYPE",
    "BagInfo",
    "BagMessage",
    "ReplayResult",
    "bag_info",
    "ensure_msgtype",
    "estimate_fields",
    "find_bags",
    "joint_sample",
    "message_fields",
    "messages_lost",
    "msg_search_dirs",
    "node_params_from_yaml",
    "parameter_value",
    "read_messages",
    "recorded_node_params",
    "replay_bag",
    "stamp_seconds",
    "status_fields",
    "temperature_value",
]

JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
STATUS_TYPE = "jointwear_msgs/msg/TestCycleStatus"
TEMPERATURE_TYPE = "sensor_msgs/msg/Temperature"
OBSERVATION_TYPE = "jointwear_msgs/msg/FrictionObservation"
ESTIMATE_TYPE = "jointwear_msgs/msg/WearEstimate"


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
    return p


@dataclass(frozen=True)
class BagMessage:
    """One message of a bag: topic, type, log time (ns) and the deserialized message."""

    topic: str
    msgtype: str
    log_time: int
    msg: Any


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
    from rosbags.highlevel import AnyReader

    p = check_bag_path(Path(path))
    want_topics = None if topics is None else set(topics)
    want_types = None if msgtypes is None else set(msgtypes)
    ts = store if store is not None else jointwear_typestore()
    current = "opening"
    try:
        with AnyReader([p], default_typestore=ts) as reader:
            conns = [
                c for c in reader.connections
                if (want_topics is None or c.topic in want_topics) and (want_types is None or c.msgtype in want_types)
            ]
            if not conns:
                return
            for conn, t, raw in reader.messages(connections=conns):
                current = f"a {conn.msgtype} message on {conn.topic} at log time {t} ns"
                yield BagMessage(conn.topic, conn.msgtype, int(t), reader.deserialize(raw, conn.msgtype))
    except InputDataError:
        raise
    except GeneratorExit:
        raise
    except Exception as exc:  # any reader failure is a bad-input message
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputDataError(
            f"{p}: cannot read the bag ({current}: {type(exc).__name__}: {text}); "
            "is it complete (closed by the recorder) and a rosbag2 MCAP/SQLite bag?"
        ) from None


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
                import yaml

                info = (yaml.safe_load(meta.read_text()) or {}).get("rosbag2_bagfile_information", {})
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


def _bag_messages_lost(p: Path) -> dict[str, int]:
    meta = p / "metadata.yaml" if p.is_dir() else None
    if meta is None or not meta.is_file():
        return {}
    import yaml

    try:
        info = (yaml.safe_load(meta.read_text()) or {}).get("rosbag2_bagfile_information", {})
    except (yaml.YAMLError, OSError, AttributeError):
        return {}  # the reader reports a broken metadata.yaml
    return messages_lost(info.get("custom_data") if isinstance(info, dict) else None)


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


# --------------------------------------------------------------------------- conversion


def stamp_seconds(header_or_stamp: Any) -> float:
    """Seconds of a ``std_msgs/Header`` or ``builtin_interfaces/Time``."""
    st = getattr(header_or_stamp, "stamp", header_or_stamp)
    return float(st.sec) + 1e-9 * float(st.nanosec)


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


def status_fields(msg: Any) -> dict[str, Any]:
    """Keyword arguments of ``FrictionObserverCore.on_status`` / ``WearMonitor.on_status``."""
    return {
        "stamp": stamp_seconds(msg.header),
        "cycle_id": int(msg.cycle_id),
        "state": int(msg.state),
        "phase": int(msg.phase),
        "current_speed_motor": float(msg.current_speed),
        "speeds_done": int(msg.speeds_done),
        "speeds_total": int(msg.speeds_total),
        "window_center": float(msg.window_center),
        "window_half_width": float(msg.window_half_width),
        "joint_name": str(msg.joint_name),
    }


def temperature_value(msg: Any) -> tuple[float, float]:
    """``(stamp, celsius)`` of a ``sensor_msgs/Temperature``."""
    return stamp_seconds(msg.header), float(msg.temperature)


def message_fields(msg: Any, names: Sequence[str]) -> dict[str, Any]:
    """The named fields of a message as plain Python values (arrays as float lists)."""
    out: dict[str, Any] = {}
    for n in names:
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
    "load_torque", "temperature", "position", "samples_plus", "samples_minus",
)
ESTIMATE_FIELDS = (
    "joint_name", "cycle_id", "method", "wear", "wear_std", "wear_low", "wear_high",
    "temperature_estimate", "speeds", "per_speed_wear", "alarm_threshold", "alarm",
)


def estimate_fields(msg: Any) -> dict[str, Any]:
    """The fields of a WearEstimate message (without the header) as plain values."""
    return message_fields(msg, ESTIMATE_FIELDS)



# --------------------------------------------------------------------------- node parameters


def _nest(flat: dict[str, Any]) -> dict[str, Any]:
    """``{"a.b": 1}`` -> ``{"a": {"b": 1}}`` (ROS dotted parameter names to nested mappings)."""
    out: dict[str, Any] = {}
    for key, value in flat.items():
        parts = key.split(".")
        d = out
        for part in parts[:-1]:
            nxt = d.get(part)
            if not isinstance(nxt, dict):
                nxt = {}
                d[part] = nxt
            d = nxt
        d[parts[-1]] = value
    return out


def _flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_flatten(value, name + "."))
        else:
            out[name] = value
    return out


def node_params_from_yaml(path: str | os.PathLike[str], node_name: str) -> dict[str, Any]:
    """The ``ros__parameters`` of ``node_name`` in a ROS 2 params file, flattened to dotted names.

    Accepts ``node_name``, ``/node_name`` and the ``/**`` wildcard section.
    """
    import yaml

    p = Path(path)
    try:
        doc = yaml.safe_load(p.read_text())
    except FileNotFoundError:
        raise InputDataError(f"{p}: no such parameter file") from None
    except yaml.YAMLError as exc:
        raise InputDataError(f"{p}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        raise InputDataError(f"{p}: not a ROS 2 parameter file (expected '<node>: ros__parameters: ...')")
    out: dict[str, Any] = {}
    for key in ("/**", node_name, f"/{node_name}"):
        section = doc.get(key)
        if isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict):
            out.update(_flatten(section["ros__parameters"]))
    return out


_PARAM_VALUE_FIELDS = {
    1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value", 5: "byte_array_value",
    6: "bool_array_value", 7: "integer_array_value", 8: "double_array_value", 9: "string_array_value",
}


def parameter_value(value: Any) -> Any:
    """The Python value of an ``rcl_interfaces/ParameterValue`` (None when NOT_SET)."""
    name = _PARAM_VALUE_FIELDS.get(int(value.type))
    if name is None:
        return None
    v = getattr(value, name)
    if hasattr(v, "tolist"):
        return v.tolist()
    return list(v) if isinstance(v, (list, tuple)) else v


def recorded_node_params(events: Iterable[Any], node_name: str) -> dict[str, Any]:
    """Parameters of ``node_name`` as its ``ParameterEvent`` messages declared or changed them."""
    out: dict[str, Any] = {}
    for ev in events:
        if str(ev.node).lstrip("/") != node_name.lstrip("/"):
            continue
        for param in (*ev.new_parameters, *ev.changed_parameters):
            value = parameter_value(param.value)
            if value is not None:
                out[str(param.name)] = value
        for param in ev.deleted_parameters:
            out.pop(str(param.name), None)
    return out


# --------------------------------------------------------------------------- offline replay


@dataclass
class ReplayResult:
    """What :func:`replay_bag` found: replayed and recorded observations/estimates, and their differences."""

    bag: str
    observations: list[Any]
    rejections: list[Any]
    cycles: list[Any]
    recorded_observations: list[dict[str, Any]]
    recorded_estimates: list[dict[str, Any]]
    samples: int
    statuses: int
    observer_params: dict[str, Any]
    monitor_params: dict[str, Any]
    #: per topic, messages the recorder was told were lost while recording (the bag is incomplete)
    messages_lost: dict[str, int] = field(default_factory=dict)

    def comparison(self) -> dict[str, Any]:
        """Replayed vs recorded: observations matched by (cycle_id, speed), estimates by cycle_id.

        A cycle re-estimated after a late observation has several results on
        each side; the newest of each is compared (what a consumer keeps).
        """
        numeric = ("tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position",
                   "samples_plus", "samples_minus")
        rec = {(int(o["cycle_id"]), round(float(o["speed"]), 9)): o for o in self.recorded_observations}
        matched, max_diff, missing = 0, 0.0, []
        for o in self.observations:
            r = rec.get((int(o.cycle_id), round(float(o.speed), 9)))
            if r is None:
                missing.append(f"cycle {o.cycle_id} speed {o.speed:g}")
                continue
            matched += 1
            for f in numeric:
                a, b = float(getattr(o, f)), float(r[f])
                if math.isnan(a) and math.isnan(b):
                    continue
                max_diff = max(max_diff, abs(a - b)) if math.isfinite(a - b) else math.inf
        est = {int(e["cycle_id"]): e for e in self.recorded_estimates}  # the newest per cycle
        newest = {int(c.cycle_id): c for c in self.cycles if c.result is not None}
        e_matched, e_diff = 0, 0.0
        for cid, c in newest.items():
            e = est.get(cid)
            if e is None:
                continue
            e_matched += 1
            for a, b in ((c.result.wear, e["wear"]), (c.result.wear_std, e["wear_std"]),
                         (c.result.wear_low, e["wear_low"]), (c.result.wear_high, e["wear_high"])):
                d = abs(float(a) - float(b))
                e_diff = max(e_diff, d) if math.isfinite(d) else (e_diff if math.isnan(a) and math.isnan(b) else math.inf)
        return {
            "observations": {
                "recorded": len(self.recorded_observations), "replayed": len(self.observations),
                "matched": matched, "max_abs_diff": max_diff if matched else None,
                "not_recorded": missing,
            },
            "estimates": {
                "recorded": len(self.recorded_estimates), "replayed": sum(c.result is not None for c in self.cycles),
                "revisions": sum(getattr(c, "revision", 0) > 0 for c in self.cycles),
                "matched": e_matched, "max_abs_diff": e_diff if e_matched else None,
            },
        }


def replay_bag(
    path: str | os.PathLike[str],
    observer_params: dict[str, Any],
    monitor_params: dict[str, Any],
    *,
    use_recorded_params: bool = True,
    joint_states_topic: str = "",
    status_topic: str = "",
    temperature_topic: str | None = None,
    observations_topic: str = "",
    estimate_topic: str = "",
    observer_node: str = "friction_observer",
    monitor_node: str = "wear_estimator",
    overrides: dict[str, Any] | None = None,
) -> ReplayResult:
    """Re-run the friction observer core and the wear monitor on a bag, offline, in log-time order.

    ``observer_params``/``monitor_params`` are flattened ROS parameters (e.g.
    from the nodes' config files); with ``use_recorded_params`` the values
    the live nodes declared (``/parameter_events`` in the bag) take precedence.
    ``overrides`` (e.g. ``{"method": "bayes"}``) apply to the monitor last.
    Topics default to the nodes' parameters (the temperature is used only when
    the observer had a ``temperature_topic``, as live). Header stamps of 0 and
    the monitor's clock are replaced by the log time, as the live nodes use
    their clock at receipt.
    """
    import json

    from ..monitor import MonitorConfig, WearMonitor
    from ..observer import FrictionObservationData, FrictionObserverCore, ObserverConfig
    from .recover import check_bag

    p = check_bag_path(Path(path))
    check_bag(p)  # a damaged bag is refused with its offset, never replayed as if whole
    obs_params = dict(observer_params)
    mon_params = dict(monitor_params)
    if use_recorded_params:
        events = [m.msg for m in read_messages(p, topics=["/parameter_events"])]
        obs_params.update(recorded_node_params(events, observer_node))
        mon_params.update(recorded_node_params(events, monitor_node))
    if overrides:
        mon_params.update(overrides)
    mon_tree = _nest(mon_params)
    opts = mon_tree.get("estimator_options", {})
    if isinstance(opts, str):  # the wear_estimator node takes a JSON object string
        try:
            mon_tree["estimator_options"] = dict(json.loads(opts)) if opts.strip() else {}
        except (ValueError, TypeError) as exc:
            raise InputDataError(f"estimator_options = {opts!r} is not a JSON object: {exc}") from None
    try:
        ocfg = ObserverConfig.from_mapping(_nest(obs_params))
        mcfg = MonitorConfig.from_mapping(mon_tree)
    except (TypeError, ValueError) as exc:
        raise InputDataError(f"{p}: observer/estimator parameters are malformed ({exc})") from None
    # the topics the live nodes used (their parameters), unless given
    joint_states_topic = joint_states_topic or str(obs_params.get("joint_states_topic", "/joint_states"))
    status_topic = status_topic or str(obs_params.get("status_topic", "/test_cycle/status"))
    if temperature_topic is None:
        temperature_topic = str(obs_params.get("temperature_topic", ""))
    observations_topic = observations_topic or str(obs_params.get("observations_topic",
                                                                  "/jointwear/friction_observations"))
    estimate_topic = estimate_topic or str(mon_params.get("estimate_topic", "/jointwear/wear_estimate"))
    core = FrictionObserverCore(ocfg)
    monitor = WearMonitor(mcfg)
    joint = ocfg.joint_name
    observations: list[FrictionObservationData] = []
    rejections: list[Any] = []
    cycles: list[Any] = []
    recorded_obs: list[dict[str, Any]] = []
    recorded_est: list[dict[str, Any]] = []
    samples = statuses = 0
    now = -math.inf

    def take(out: Any) -> None:
        observations.extend(out.observations)
        rejections.extend(out.rejections)
        for o in out.observations:
            cycles.extend(monitor.add(o, now=now))

    def stamp_or_now(t: float) -> float:  # the live observer stamps header-less messages on receipt
        return t if t > 0 else now

    topics = [joint_states_topic, status_topic, observations_topic, estimate_topic]
    if temperature_topic:
        topics.append(temperature_topic)
    seen_js = False
    for m in read_messages(p, topics=topics):
        now = max(now, m.log_time * 1e-9)
        if m.topic == joint_states_topic and m.msgtype == JOINT_STATE_TYPE:
            seen_js = True
            s = joint_sample(m.msg, joint)
            if s is not None:
                samples += 1
                take(core.on_joint_state(stamp_or_now(s[0]), *s[1:]))
        elif m.topic == status_topic and m.msgtype == STATUS_TYPE:
            statuses += 1
            f = status_fields(m.msg)
            f["stamp"] = stamp_or_now(f["stamp"])
            take(core.on_status(**f))
            cycles.extend(monitor.on_status(now, f["cycle_id"], f["state"], f["speeds_done"],
                                            f["speeds_total"], f["joint_name"]))
        elif m.topic == temperature_topic and m.msgtype == TEMPERATURE_TYPE:
            t, c = temperature_value(m.msg)
            take(core.on_temperature(stamp_or_now(t), c))
        elif m.topic == observations_topic and m.msgtype == OBSERVATION_TYPE:
            d = message_fields(m.msg, OBSERVATION_FIELDS)
            d["stamp"] = stamp_seconds(m.msg.header)
            recorded_obs.append(d)
        elif m.topic == estimate_topic and m.msgtype == ESTIMATE_TYPE:
            d = estimate_fields(m.msg)
            d["stamp"] = stamp_seconds(m.msg.header)
            recorded_est.append(d)
        if now > -math.inf and m.topic != joint_states_topic:
            cycles.extend(monitor.poll(now))
    if not seen_js:
        raise InputDataError(
            f"{p}: no {JOINT_STATE_TYPE} messages on {joint_states_topic}; "
            "record /joint_states (and /test_cycle/status) to replay the observer"
        )
    take(core.flush())
    if math.isfinite(now):
        cycles.extend(monitor.poll(now + mcfg.done_timeout + mcfg.idle_timeout + 1.0))
    return ReplayResult(
        bag=str(p), observations=observations, rejections=rejections, cycles=cycles,
        recorded_observations=recorded_obs, recorded_estimates=recorded_est, samples=samples,
        statuses=statuses, observer_params=obs_params, monitor_params=mon_params,
        messages_lost=_bag_messages_lost(p),
    )
