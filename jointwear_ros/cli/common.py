"""Argument checks shared by the sub-commands.

Every check here runs before a command starts any work or writes anything, and
raises :class:`~jointwear_ros.cli.UsageError` (one line on stderr, exit code 2)
naming the option, the value and what to do.
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..resources import config_path
from . import UsageError

__all__ = [
    "ABSOLUTE_ZERO",
    "MAX_LIST",
    "check_input_file",
    "check_method",
    "check_output_dir",
    "check_output_file",
    "check_temperature_prior",
    "check_text_file",
    "format_table",
    "node_params",
    "open_history",
    "parse_float",
    "parse_float_list",
    "parse_int",
    "print_json",
]

#: Most values a comma list or START:STOP:COUNT range may give (speeds, candidates).
MAX_LIST = 10_000
#: 0 K in degC: no temperature distribution may reach below it.
ABSOLUTE_ZERO = -273.15


def parse_float(text: str, what: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise UsageError(f"{what}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise UsageError(f"{what}: {text!r} is not finite")
    return value


def parse_int(text: str | int, what: str, lo: int, hi: int | None = None, *, handler: str = "this command") -> int:
    """An integer in ``[lo, hi]`` (``hi`` None: no upper bound), else :class:`UsageError` (above ``hi``: the
    most ``handler`` handles)."""
    try:
        n = int(str(text).strip())
    except (TypeError, ValueError):
        raise UsageError(f"{what}: {text!r} is not an integer") from None
    if n < lo:
        raise UsageError(f"{what}: {n} must be at least {lo}")
    if hi is not None and n > hi:
        raise UsageError(f"{what}: {n:,} is more than the {hi:,} {handler} handles")
    return n


def parse_float_list(text: str, what: str, max_count: int = MAX_LIST) -> list[float]:
    """``"0,10,25"`` -> [0, 10, 25]; ``"0:280:56"`` -> 56 values from 0 to 280 inclusive.

    At most ``max_count`` values.

    >>> parse_float_list("0:280:5", "--speeds")
    [0.0, 70.0, 140.0, 210.0, 280.0]
    >>> parse_float_list("0:280:1000000000", "--speeds")
    Traceback (most recent call last):
    ...
    jointwear_ros.cli.UsageError: --speeds: count 1000000000 in '0:280:1000000000' is more than the 10,000 values allowed
    """
    text = text.strip()
    if not text:
        raise UsageError(f"{what}: empty list")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UsageError(f"{what}: range {text!r} must be START:STOP:COUNT")
        lo, hi = parse_float(parts[0], what), parse_float(parts[1], what)
        try:
            n = int(parts[2])
        except ValueError:
            raise UsageError(f"{what}: count {parts[2]!r} in {text!r} is not an integer") from None
        if n < 1:
            raise UsageError(f"{what}: count in {text!r} must be at least 1")
        if n > max_count:
            raise UsageError(f"{what}: count {n} in {text!r} is more than the {max_count:,} values allowed")
        import numpy as np

        return [float(x) for x in np.linspace(lo, hi, n)]
    items = text.split(",")
    if len(items) > max_count:
        raise UsageError(f"{what}: {len(items)} values are more than the {max_count:,} allowed")
    return [parse_float(t, what) for t in items]


# -- files ----------------------------------------------------------------------------
def _existing_ancestor(p: Path) -> Path:
    q = p.absolute()
    while not q.exists() and q != q.parent:
        q = q.parent
    return q


def _probe_dir(d: Path, flag: str, value: str) -> None:
    """``d`` is an existing directory we can create a file in (tried for real: root passes os.access)."""
    if not os.access(d, os.W_OK | os.X_OK):
        raise UsageError(f"{flag}: {value!r}: directory {str(d)!r} is not writable")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".jointwear-probe-", dir=d)
    except OSError as exc:
        raise UsageError(f"{flag}: {value!r}: cannot create files in {str(d)!r} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(tmp)


def check_output_dir(value: str | os.PathLike[str] | None, flag: str) -> Path | None:
    """An output directory that exists (and is writable) or can be created; nothing is created.

    >>> check_output_dir(__file__, "--plot")
    Traceback (most recent call last):
    ...
    jointwear_ros.cli.UsageError: --plot: '...common.py' exists and is not a directory
    """
    if value is None or str(value) == "":
        return None if value is None else _empty(flag)
    p = Path(value)
    text = str(value)
    if p.exists() and not p.is_dir():
        raise UsageError(f"{flag}: {text!r} exists and is not a directory")
    anc = _existing_ancestor(p)
    if not anc.is_dir():
        raise UsageError(f"{flag}: {text!r}: {str(anc)!r} is a file, not a directory; give another path")
    _probe_dir(anc, flag, text)
    return p


def check_output_file(value: str | os.PathLike[str] | None, flag: str, suffix: str | None = None) -> Path | None:
    """An output file whose directory exists (and is writable) or can be created; nothing is created."""
    if value is None or str(value) == "":
        return None if value is None else _empty(flag)
    p = Path(value)
    text = str(value)
    if suffix is not None and not text.lower().endswith(suffix):
        raise UsageError(f"{flag}: {text!r} must name a {suffix} file")
    if p.is_dir():
        raise UsageError(f"{flag}: {text!r} is a directory; give a file name")
    if p.exists() and not os.access(p, os.W_OK):
        raise UsageError(f"{flag}: {text!r} exists and is not writable")
    anc = _existing_ancestor(p.parent)
    if not anc.is_dir():
        raise UsageError(f"{flag}: {text!r}: {str(anc)!r} is a file, not a directory; give another path")
    _probe_dir(anc, flag, text)
    return p


def check_input_file(value: str | os.PathLike[str], flag: str) -> Path:
    """A regular file that exists and can be read."""
    text = str(value)
    if text == "":
        _empty(flag)
    p = Path(value)
    if not p.exists():
        raise UsageError(f"{flag}: {text!r}: no such file")
    if p.is_dir():
        raise UsageError(f"{flag}: {text!r} is a directory; give a file")
    if not os.access(p, os.R_OK):
        raise UsageError(f"{flag}: {text!r} is not readable")
    return p


def _empty(flag: str) -> Any:
    raise UsageError(f"{flag}: empty path")


# -- temperature distributions ---------------------------------------------------------
def check_temperature_prior(prior: Any, flag: str, valid: tuple[float, float] | None, set_name: str = "") -> None:
    """Refuse a temperature distribution that is non-physical or outside a parameter set's range.

    Its central 95 % must lie within ``valid`` (the set's temperature range,
    where the model means something), and none of it below absolute zero.
    """
    lo, hi = (float(x) for x in prior.support(0.95))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise UsageError(f"{flag}: {prior.label} is not a finite temperature range")
    if float(prior.support(1.0 - 1e-9)[0]) < ABSOLUTE_ZERO:
        raise UsageError(f"{flag}: {prior.label} reaches below absolute zero ({ABSOLUTE_ZERO} degC)")
    if valid is not None and (lo < valid[0] or hi > valid[1]):
        of = f" of parameter set {set_name!r}" if set_name else ""
        raise UsageError(
            f"{flag}: {prior.label} puts more than 5 % of its mass (central 95 %: {lo:.3g} .. {hi:.3g} degC) "
            f"outside the valid temperature range [{valid[0]:g}, {valid[1]:g}] degC{of}"
        )


def format_table(headers: Sequence[str], rows: Sequence[Sequence[Any]], floatfmt: str = ".5f") -> str:
    """:func:`jointwear_ros.fmt.format_table` (imported on use: it brings numpy)."""
    from ..fmt import format_table as table

    return table(headers, rows, floatfmt)


def _clean(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    np = sys.modules.get("numpy")  # no numpy value can exist before numpy is imported
    if np is None:
        return None if isinstance(obj, float) and not math.isfinite(obj) else obj
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def print_json(obj: Any) -> None:
    """Print ``obj`` as JSON (numpy arrays and scalars converted; NaN/inf -> null)."""
    json.dump(_clean(obj), sys.stdout, indent=2)
    sys.stdout.write("\n")


def node_params(path: str | None, default_name: str, node: str, flag: str = "") -> dict[str, Any]:
    """A node's ROS parameters from ``path`` (checked), else from the package's ``config/<default_name>``."""
    from ..io.params import node_params_from_yaml

    if path is not None:
        check_text_file(path, flag or "params file")
        return node_params_from_yaml(path, node)
    f = config_path(default_name)
    return node_params_from_yaml(f, node) if f.is_file() else {}


def check_text_file(path: str, flag: str) -> None:
    """A readable UTF-8 text file (a params file), else :class:`UsageError`."""
    p = check_input_file(path, flag)
    try:
        p.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise UsageError(f"{flag}: {path!r} is not a UTF-8 text file ({exc.reason} at byte {exc.start}); "
                         "give a ROS 2 parameter YAML file") from None
    except OSError as exc:
        raise UsageError(f"{flag}: {path!r}: cannot read ({exc.strerror})") from None


def check_method(method: str | None, flag: str) -> None:
    """An estimator method name the estimators know (None: the configured one)."""
    from ..estimation import ESTIMATORS

    if method is not None and str(method).strip().lower() not in ESTIMATORS:
        raise UsageError(f"{flag}: unknown wear estimation method {method!r}; choose one of {', '.join(ESTIMATORS)}")


def open_history(url: str, *, must_exist: bool) -> Any:
    """The history store at ``url`` (a URL or an SQLite path); ``must_exist``: a store file that is not
    there is a one-line error (nothing created)."""
    from ..history import HistoryStore, backend_for

    backend = backend_for(url)
    if must_exist and not backend.exists():
        raise UsageError(f"--db {url}: no such history file")
    return HistoryStore(backend.url)


def add_unit_flags(parser: Any, *, frame_flags: bool = True) -> None:
    """The flags that say what units a table is in (a table's own ``# units:`` line takes precedence).

    ``--joint-side`` (with ``--gear-ratio``/``--torque-scale`` where the set does not give them),
    ``--speed-unit``, ``--torque-unit``, ``--temperature-unit``.
    """
    from ..units import SPEED_UNITS, TEMPERATURE_UNITS, TORQUE_UNITS

    if frame_flags:
        parser.add_argument("--joint-side", action="store_true",
                            help="tables are joint side (rad/s, N·m); default: the suite's units (motor side, "
                                 "normalized). A table's own '# units:' line takes precedence")
        parser.add_argument("--gear-ratio", type=float, default=None,
                            help="joint-side tables: motor speed = joint speed x this (default: the set's)")
        parser.add_argument("--torque-scale", type=float, default=None,
                            help="joint-side tables: N·m per normalized torque unit (default: the set's)")
    parser.add_argument("--speed-unit", default="rad/s", choices=list(SPEED_UNITS),
                        help="unit of the tables' speed column (default rad/s)")
    parser.add_argument("--torque-unit", default=None, choices=list(TORQUE_UNITS),
                        help="unit of joint-side torque columns (default N·m)")
    parser.add_argument("--temperature-unit", default="degC", choices=list(TEMPERATURE_UNITS),
                        help="unit of the tables' temperature column (default degC)")


def units_from_args(args: Any, *, joint_side: bool | None = None) -> tuple[Any, bool]:
    """``(TableUnits, explicit)``: the units the flags assume for tables, and whether any flag said so."""
    from ..errors import JointwearError
    from ..units import TableUnits

    side = bool(getattr(args, "joint_side", False)) if joint_side is None else joint_side
    gear, scale = getattr(args, "gear_ratio", None), getattr(args, "torque_scale", None)
    for flag, v in (("--gear-ratio", gear), ("--torque-scale", scale)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise UsageError(f"{flag} {v!r}: must be a positive number")
    torque = getattr(args, "torque_unit", None)
    if torque is not None and not side:
        raise UsageError(f"--torque-unit {torque}: torque units are for joint-side tables (add --joint-side, or "
                         "--gear-ratio and --torque-scale); motor-side tables are normalized")
    try:
        units = TableUnits("joint" if side else "motor_normalized", gear, scale,
                           speed_unit=getattr(args, "speed_unit", "rad/s"),
                           torque_unit=torque or ("N·m" if side else "normalized"),
                           temperature_unit=getattr(args, "temperature_unit", "degC"))
    except JointwearError as exc:
        raise UsageError(str(exc)) from None
    explicit = (side or gear is not None or torque is not None or units.speed_unit != "rad/s"
                or units.temperature_unit != "degC")
    return units, explicit


def trend_command(db: str, robot: str, analysis_version: str) -> str:
    """The exact ``jointwear trend`` command that shows a robot's estimates of one analysis version (what every
    command that stores estimates prints)."""
    import shlex

    return shlex.join(["jointwear", "trend", "--db", db, "--robot", robot, "--analysis-version", analysis_version])
