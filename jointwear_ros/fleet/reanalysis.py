"""Re-analysis of one recorded bag: the same cores as ``jointwear replay``, plain records out, never an exception.

:func:`reprocess_bag` runs :func:`~jointwear_ros.replay.replay_bag` (the
friction observer core and the wear monitor, offline, in log-time order) on
one bag with a given parameter set and estimator method, and returns a
:class:`BagOutcome` of plain values (picklable, cheap to ship from a Dask
worker): one record per estimated joint and cycle (robot, joint, hardware id, cycle id,
time, wear, std, temperature, method, parameter set, software version, bag,
analysis version) and the bag's fingerprint. A bag that cannot be read gives
an outcome with ``error`` set (one line naming the bag), never an exception.

**Analysis version.** :func:`analysis_version` names a re-analysis by what
decides its numbers: the parameter set's *content* (not only its name, so an
edited ``ref-2011r.yaml`` is a new version), the estimator method and the
software version; or an explicit label.

**Identity of a bag's estimates** (:func:`bag_identity`): the joint is the
``joint_name`` of the cycle (a bag of a robot cycle gives one record per
joint: the joints the observer served, see :mod:`jointwear_ros.replay`); the
robot is, in this
order, the ``robot`` parameter the cell's ``wear_trend`` node declared (as
recorded in the bag's ``/parameter_events``; the live history uses it too),
the wear_estimator's recorded ``robot`` or ``hardware_id`` parameter, or the
name of the directory holding the bag (a per-robot archive directory). The
hardware id is the joint's own ``<joint>.hardware_id`` of the wear_estimator,
else the ``hardware_id`` of ``wear_trend``, else of the wear_estimator, else
``robot/joint`` (as ``jointwear history import``).

Pure of ROS: rosbags reads the bag; no rclpy.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import one_line

__all__ = [
    "BagOutcome",
    "analysis_version",
    "bag_fingerprint",
    "bag_identity",
    "default_node_params",
    "params_digest",
    "reprocess_bag",
]

#: bytes hashed at each end of every storage file of a bag (MCAP: the header, and the summary with its statistics)
FINGERPRINT_EDGE = 64 * 1024


@dataclass
class BagOutcome:
    """What re-analysing one bag gave: its estimate records, or the error; plain values only."""

    bag: str
    fingerprint: str
    analysis_version: str
    records: list[dict[str, Any]] = field(default_factory=list)
    error: str | None = None
    seconds: float = 0.0
    #: CPU time of the re-analysis in its process (what a dedicated core would take; ``seconds`` is wall)
    cpu_seconds: float = 0.0
    observations: int = 0
    rejections: int = 0
    #: what the bag was re-analysed with: ``robot``, ``method``, ``params`` and where each came from
    #: (``method_from``/``params_from``: given, recorded, recorded estimates; ``estimator``: recorded or given)
    settings: dict[str, str] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.error is None

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def params_digest(params: str | None) -> str:
    """sha256 of a parameter set's file content (``"recorded"`` when None: each bag's own set)."""
    if params is None:
        return "recorded"
    from ..model.paramsets import load_parameter_set_info

    info = load_parameter_set_info(params)  # raises ParameterSetError (a JointwearError) for a bad set
    path = info.path
    data = Path(path).read_bytes() if path is not None else json.dumps(info.values, sort_keys=True).encode()
    return hashlib.sha256(data).hexdigest()


def analysis_version(params: str | None, method: str | None, software_version: str = __version__,
                     label: str | None = None) -> str:
    """The name of a re-analysis: ``label`` if given, else ``<params>/<method>/<hash>``.

    The hash covers the parameter set's content, the method and the software
    version, so the same name means the same numbers.

    >>> v = analysis_version("ref-2011r", "joint", "0.1.0")
    >>> v.startswith("ref-2011r/joint/") and v == analysis_version("ref-2011r", "joint", "0.1.0")
    True
    >>> v == analysis_version("ref-2011r", "joint", "0.2.0"), analysis_version(None, None, label="model-2027")
    (False, 'model-2027')
    """
    if label is not None:
        label = label.strip()
        if not label or len(label) > 200:
            from ..errors import InputDataError
            raise InputDataError(f"analysis version label {label!r} must be 1-200 characters")
        return label
    key = json.dumps({"params": params, "params_sha256": params_digest(params), "method": method,
                      "software_version": software_version}, sort_keys=True)
    short = hashlib.sha256(key.encode()).hexdigest()[:10]
    return f"{Path(params).stem if params else 'recorded'}/{method or 'recorded'}/{short}"


def bag_fingerprint(path: str | os.PathLike[str]) -> str:
    """A content fingerprint of a bag: sha256 over ``metadata.yaml`` and, per storage file, its
    name, size and first and last 64 KiB (an MCAP file's header and its summary section, whose
    statistics hold the message counts and times).

    Not the modification time: a bag copied to the archive is the same bag. Raises OSError
    when the bag cannot be read.
    """
    p = Path(path)
    h = hashlib.sha256()
    files: list[Path]
    if p.is_dir():
        meta = p / "metadata.yaml"
        if meta.is_file():
            h.update(b"metadata.yaml\0" + meta.read_bytes())
        files = sorted(f for f in p.iterdir() if f.is_file() and f.name != "metadata.yaml")
    else:
        files = [p]
    for f in files:
        size = f.stat().st_size
        h.update(f"{f.name}\0{size}\0".encode())
        with f.open("rb") as fh:
            h.update(fh.read(FINGERPRINT_EDGE))
            if size > FINGERPRINT_EDGE:
                fh.seek(max(FINGERPRINT_EDGE, size - FINGERPRINT_EDGE))
                h.update(fh.read(FINGERPRINT_EDGE))
    return "sha256:" + h.hexdigest()[:40]


def default_node_params() -> tuple[dict[str, Any], dict[str, Any]]:
    """The friction_observer and wear_estimator parameters of the config files (as ``jointwear replay``)."""
    from ..resources import node_config

    return node_config("friction_observer"), node_config("wear_estimator")


def bag_identity(monitor_params: dict[str, Any], bag: str | os.PathLike[str],
                 trend_params: dict[str, Any] | None = None) -> tuple[str, str]:
    """``(robot, hardware_id)`` of a bag's estimates (see the module docstring; ``""`` hardware id:
    ``robot/joint``).

    >>> bag_identity({"hardware_id": "cell7/robot2"}, "/bags/x")
    ('cell7/robot2', 'cell7/robot2')
    >>> bag_identity({"hardware_id": "hw"}, "/bags/x", {"robot": "r9"}), bag_identity({}, "/bags/robot_3/n1")
    (('r9', 'hw'), ('robot_3', ''))
    """
    hw = str((trend_params or {}).get("hardware_id", "") or "") or str(monitor_params.get("hardware_id", "") or "")
    robot = (str((trend_params or {}).get("robot", "") or "") or str(monitor_params.get("robot", "") or "")
             or hw or Path(bag).resolve().parent.name)
    return robot, hw


def _finite_or_nan(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v if math.isfinite(v) else math.nan


def reprocess_bag(
    bag: str | os.PathLike[str],
    *,
    params: str | None = None,
    method: str | None = None,
    version: str | None = None,
    observer_params: dict[str, Any] | None = None,
    monitor_params: dict[str, Any] | None = None,
    use_recorded_params: bool = True,
    software_version: str = __version__,
    robot: str | None = None,
) -> BagOutcome:
    """Re-run the observer and the wear monitor on ``bag`` with parameter set ``params`` and ``method``.

    ``None`` for ``params``/``method`` keeps the bag's recorded one; a bag that does not hold the
    wear_estimator's recorded settings is refused (its ``error`` says so) unless both are given: the
    config files are never taken for what the cell ran. ``robot`` names the robot of every estimate
    (default: as :func:`bag_identity`). The monitor's newest result per cycle is kept (a re-estimate after a
    late observation replaces its first estimate, as a consumer would). Never
    raises for a bad bag: the outcome's ``error`` says what went wrong.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    path = str(Path(bag).resolve())
    v = version if version is not None else analysis_version(params, method, software_version)
    out = BagOutcome(bag=path, fingerprint="", analysis_version=v)
    try:
        if not Path(path).exists():
            out.error = f"{path}: no such bag; give a rosbag2 directory (with metadata.yaml)"
            return out
        try:
            out.fingerprint = bag_fingerprint(path)
        except OSError as exc:
            out.error = f"{path}: cannot read the bag ({exc.strerror or type(exc).__name__})"
            return out
        from ..replay import replay_bag

        if observer_params is None or monitor_params is None:
            op, mp = default_node_params()
            observer_params = op if observer_params is None else observer_params
            monitor_params = mp if monitor_params is None else monitor_params
        overrides: dict[str, Any] = {}
        if params is not None:
            overrides["params"] = params
        if method is not None:
            overrides["method"] = method
        from ..io.bags import recorded_settings, settings_memo

        with settings_memo():  # the replay's one pass over the bag gives the trend node's settings too
            rep = replay_bag(path, observer_params, monitor_params, use_recorded_params=use_recorded_params,
                             overrides=overrides or None)
            trend_params = recorded_settings(path).get("wear_trend", {}) if use_recorded_params else {}
        if not rep.settings_recorded:
            missing = [f"--{k}" for k in ("params", "method") if rep.settings.get(f"{k}_from") != "given"]
            out.error = (f"{path}: the bag does not hold the wear estimator's recorded settings (recorded before "
                         f"jointwear recorded them, or by a recorder started after the nodes); give "
                         f"{' and '.join(missing)} to re-analyse it with those (nothing is guessed)")
            return out
        robot_, hw = bag_identity(rep.monitor_params, path, trend_params)
        robot_from = "given" if robot else "recorded" if (
            trend_params.get("robot") or rep.monitor_params.get("robot") or rep.monitor_params.get("hardware_id")
        ) else "folder"
        robot = robot or robot_
        out.settings = {"robot": robot, "robot_from": robot_from, **{k: str(v) for k, v in rep.settings.items()}}
        p_name = str(rep.monitor_params.get("params", params or ""))
        # the newest result per (joint, cycle): a revision replaces its cycle's first estimate, wherever
        # the other joints' results of a robot cycle came in between
        newest: dict[tuple[str, str, int], Any] = {}
        for c in rep.cycles:
            if c.result is not None:
                # a production shift and the test cycle of its id are two estimates
                newest[(str(c.joint_name), str(c.source), int(c.cycle_id))] = c
        for c in newest.values():
            r = c.result
            wear, std = _finite_or_nan(r.wear), _finite_or_nan(r.wear_std)
            if not (math.isfinite(wear) and math.isfinite(std) and std > 0):
                continue  # no usable estimate for this cycle (the monitor said why in its message)
            out.records.append({
                "robot": robot, "joint": str(c.joint_name),
                "hardware_id": (str(rep.monitor_params.get(f"{c.joint_name}.hardware_id", "") or "") or hw
                                or f"{robot}/{c.joint_name}"),
                "cycle_id": int(c.cycle_id), "time": float(c.stamp), "wear": wear, "wear_std": std,
                "temperature": _finite_or_nan(r.temperature), "method": str(r.method), "params": p_name,
                "software_version": software_version, "bag": path, "analysis_version": v, "source": "reprocess",
                "evidence": c.evidence, "cycle_source": str(c.source),
            })
        out.observations = len(rep.observations)
        out.rejections = len(rep.rejections)
    except Exception as exc:  # a broken bag (or anything else in it) is this bag's error, never the run's
        from ..errors import JointwearError

        if isinstance(exc, JointwearError):
            msg = one_line(exc)
        else:
            where = traceback.extract_tb(exc.__traceback__)[-1]
            msg = f"{path}: {type(exc).__name__}: {one_line(exc)} (at {Path(where.filename).name}:{where.lineno})"
        out.error = msg if path in msg else f"{path}: {msg}"
        out.records = []
    finally:
        out.seconds = time.perf_counter() - t0
        out.cpu_seconds = time.process_time() - c0
    return out
