"""Units of friction observations and parameter sets: the frame, one conversion, and the check for slips.

Every observation table and parameter set is in one of two **frames**:

``motor_normalized`` (the paper's, and the suite's own: what the observer publishes)
    speed motor side in rad/s, torques (``tau_f``, ``load_torque``, ...) normalized.
``joint``
    speed joint side in rad/s, torques in N·m, with ``gear_ratio`` (motor speed =
    joint speed x gear_ratio) and ``torque_scale`` (N·m per normalized unit) saying
    how it maps to the suite's frame.

A table may also be in other **units** within its frame (speeds in rpm or deg/s, torques in
mN·m, temperatures in K or degF): :class:`TableUnits` says which, and :func:`to_suite` converts
it to the suite's frame (degC, rad/s motor side, normalized). Conversion lives here and
nowhere else; a consumer converts the suite's observations into a set's frame with
:func:`to_set_frame`.

A table's units are either **declared** (a CSV written by the suite carries a comment line
``# units: frame=joint gear_ratio=80 torque_scale=4 speed=rad/s torque=N·m temperature=degC``,
:meth:`TableUnits.header`) or **assumed** (a hand-made table: the command's flags, else the
suite's units). Assumed units are checked against the parameter set's ``valid`` ranges and
the physical ranges of each column (:func:`check_for_set`, :func:`check_plausible`); what does
not fit is refused in one line that names the column, its range, the set's range, the likely
slip and the flag that fixes it (:class:`UnitError`).

>>> u = TableUnits.parse_header("# units: frame=joint gear_ratio=80 torque_scale=4 temperature=K")
>>> u.frame, u.gear_ratio, u.temperature_unit, u.declared
('joint', 80.0, 'K', True)
>>> TableUnits.parse_header(u.header()) == u
True
>>> convert_temperature(np.array([300.15]), "K")
array([27.])
>>> likely_temperature_slip(np.array([295.0, 325.0]), (18.0, 52.0))
('kelvin', '--temperature-unit K')
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from .errors import InputDataError

__all__ = [
    "FRAMES",
    "PLAUSIBLE_OPERATING_TEMPERATURE",
    "SPEED_UNITS",
    "SUITE_UNITS",
    "TEMPERATURE_UNITS",
    "TORQUE_COLUMNS",
    "TORQUE_UNITS",
    "SetUnits",
    "TableUnits",
    "UnitError",
    "check_for_set",
    "check_plausible",
    "check_temperature",
    "convert_temperature",
    "effective_units",
    "in_base_units",
    "likely_temperature_slip",
    "prepare_baseline",
    "prepare_for_set",
    "to_set_frame",
    "to_suite",
]

Array = npt.NDArray[np.float64]

#: Frames a set's parameters and a table's columns can be in.
FRAMES = ("motor_normalized", "joint")
#: Speed units a table may be in (factor to rad/s).
SPEED_UNITS: dict[str, float] = {"rad/s": 1.0, "rpm": 2.0 * math.pi / 60.0, "deg/s": math.pi / 180.0}
#: Torque units of a joint-side table (factor to N·m); a motor-side table is normalized.
TORQUE_UNITS: dict[str, float] = {"N·m": 1.0, "mN·m": 1.0e-3}
#: Temperature units a table may be in.
TEMPERATURE_UNITS = ("degC", "K", "degF")
#: Columns that hold torques (converted with the torque factor).
TORQUE_COLUMNS = ("tau_f", "tau_f_std", "load_torque", "tau_plus", "tau_minus")
#: Temperatures a robot joint reaches in operation (degC): outside, a unit slip is likelier than the reading.
PLAUSIBLE_OPERATING_TEMPERATURE = (-30.0, 100.0)
#: How far (degC) beyond a set's temperature range a reading is taken as a warmer or colder joint, not a unit slip.
PLAUSIBLE_EXCURSION = 15.0
#: Largest plausible normalized friction torque (a motor's friction above its rated torque is not a reading).
MAX_NORMALIZED_FRICTION = 1.0
#: Largest plausible motor speed, rad/s (about 10 000 rpm).
MAX_MOTOR_SPEED = 1100.0
#: Largest plausible joint speed of a robot, rad/s.
MAX_JOINT_SPEED = 20.0
#: Below this largest speed a "motor side" test cycle is implausibly slow (rad/s): likely joint side.
MIN_MOTOR_CYCLE_SPEED = 5.0


class UnitError(InputDataError):
    """Data whose values do not fit the units they are read in (a unit slip, named with its fix)."""


def _aliases(text: str) -> str:
    t = text.strip().replace("Nm", "N·m").replace("N.m", "N·m").replace("N*m", "N·m")
    return {"C": "degC", "°C": "degC", "celsius": "degC", "kelvin": "K", "F": "degF", "°F": "degF",
            "fahrenheit": "degF", "rad/s": "rad/s", "RPM": "rpm", "deg/s": "deg/s", "°/s": "deg/s",
            "mNm": "mN·m", "normalised": "normalized"}.get(t, t)


@dataclass(frozen=True)
class SetUnits:
    """The frame a parameter set's parameters (and its ``valid`` ranges) are in.

    ``motor_normalized`` (the paper's): speed motor side rad/s, torques normalized;
    ``joint``: speed joint side rad/s, torques N·m. ``gear_ratio`` (motor speed =
    joint speed x gear_ratio) and ``torque_scale`` (N·m per normalized unit) map the
    suite's observations (motor side, normalized) into a joint-frame set.

    >>> u = SetUnits("joint", 120.0, 50.0)
    >>> u.speed_factor, u.torque_factor, u.torque_unit
    (0.008333333333333333, 50.0, 'N·m')
    """

    frame: str = "motor_normalized"
    gear_ratio: float | None = None
    torque_scale: float | None = None

    @property
    def joint_side(self) -> bool:
        return self.frame == "joint"

    @property
    def speed_factor(self) -> float:
        """Set-frame speed per suite (motor side) speed."""
        return 1.0 / float(self.gear_ratio or 1.0) if self.joint_side else 1.0

    @property
    def torque_factor(self) -> float:
        """Set-frame torque per suite (normalized) torque."""
        return float(self.torque_scale or 1.0) if self.joint_side else 1.0

    @property
    def torque_unit(self) -> str:
        return "N·m" if self.joint_side else "normalized"

    @property
    def speed_unit(self) -> str:
        return "rad/s joint side" if self.joint_side else "rad/s motor side"

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"frame": self.frame, "speed": self.speed_unit, "torque": self.torque_unit,
                               "temperature": "degC"}
        if self.gear_ratio is not None:
            out["gear_ratio"] = float(self.gear_ratio)
        if self.torque_scale is not None:
            out["torque_scale"] = float(self.torque_scale)
        return out


@dataclass(frozen=True)
class TableUnits:
    """The units a table's columns are in, declared by the table or assumed from the command's flags.

    ``frame`` as :class:`SetUnits`; ``gear_ratio``/``torque_scale`` of a joint-side table when
    known (else a joint-frame set's are used); ``speed_unit`` one of :data:`SPEED_UNITS`,
    ``torque_unit`` one of :data:`TORQUE_UNITS` (joint side) or ``normalized``,
    ``temperature_unit`` one of :data:`TEMPERATURE_UNITS`. ``declared``: read from the table itself.
    """

    frame: str = "motor_normalized"
    gear_ratio: float | None = None
    torque_scale: float | None = None
    speed_unit: str = "rad/s"
    torque_unit: str = "normalized"
    temperature_unit: str = "degC"
    declared: bool = False

    def __post_init__(self) -> None:
        if self.frame not in FRAMES:
            raise InputDataError(f"units frame {self.frame!r} unknown; use one of {', '.join(FRAMES)}")
        if self.speed_unit not in SPEED_UNITS:
            raise InputDataError(f"speed unit {self.speed_unit!r} unknown; use one of {', '.join(SPEED_UNITS)}")
        allowed = ("normalized",) if self.frame == "motor_normalized" else tuple(TORQUE_UNITS)
        if self.frame == "joint" and self.torque_unit == "normalized":
            object.__setattr__(self, "torque_unit", "N·m")
        if self.torque_unit not in allowed:
            raise InputDataError(f"torque unit {self.torque_unit!r} does not go with frame {self.frame} "
                                 f"(use {', '.join(allowed)})")
        if self.temperature_unit not in TEMPERATURE_UNITS:
            raise InputDataError(f"temperature unit {self.temperature_unit!r} unknown; use one of "
                                 f"{', '.join(TEMPERATURE_UNITS)}")
        for key in ("gear_ratio", "torque_scale"):
            v = getattr(self, key)
            if v is not None and not (math.isfinite(float(v)) and float(v) > 0):
                raise InputDataError(f"units {key} = {v!r} must be a positive number")

    @classmethod
    def of_set(cls, units: SetUnits, *, declared: bool = True) -> TableUnits:
        """A table in a set's own units."""
        return cls(units.frame, units.gear_ratio, units.torque_scale,
                   torque_unit="N·m" if units.joint_side else "normalized", declared=declared)

    @property
    def joint_side(self) -> bool:
        return self.frame == "joint"

    @property
    def is_suite(self) -> bool:
        """In the suite's own units (nothing to convert)."""
        return (self.frame == "motor_normalized" and self.speed_unit == "rad/s"
                and self.temperature_unit == "degC")

    def describe(self) -> str:
        side = "joint side" if self.joint_side else "motor side"
        parts = [f"speed {self.speed_unit} {side}", f"torque {self.torque_unit}", f"temperature {self.temperature_unit}"]
        if self.gear_ratio is not None:
            parts.append(f"gear ratio {self.gear_ratio:g}")
        if self.torque_scale is not None:
            parts.append(f"torque scale {self.torque_scale:g} N·m per normalized unit")
        return ", ".join(parts)

    def header(self) -> str:
        """The comment line a CSV carries to declare these units (:meth:`parse_header` reads it)."""
        parts = [f"frame={self.frame}"]
        if self.gear_ratio is not None:
            parts.append(f"gear_ratio={self.gear_ratio:g}")
        if self.torque_scale is not None:
            parts.append(f"torque_scale={self.torque_scale:g}")
        parts += [f"speed={self.speed_unit}", f"torque={self.torque_unit}", f"temperature={self.temperature_unit}"]
        return "# units: " + " ".join(parts)

    @classmethod
    def parse_header(cls, line: str) -> TableUnits | None:
        """The units a ``# units: key=value ...`` comment line declares (None if the line is not one)."""
        text = line.strip().lstrip("#").strip()
        if not text.lower().startswith("units:"):
            return None
        fields: dict[str, str] = {}
        for item in text.split(":", 1)[1].split():
            if "=" not in item:
                raise InputDataError(f"units line {line.strip()!r}: expected key=value items, got {item!r}")
            k, v = item.split("=", 1)
            fields[k.strip()] = _aliases(v)
        known = {"frame", "gear_ratio", "torque_scale", "speed", "torque", "temperature"}
        unknown = sorted(set(fields) - known)
        if unknown:
            raise InputDataError(f"units line {line.strip()!r}: unknown key(s) {', '.join(unknown)}; known: "
                                 f"{', '.join(sorted(known))}")

        def num(key: str) -> float | None:
            if key not in fields:
                return None
            try:
                return float(fields[key])
            except ValueError:
                raise InputDataError(f"units line {line.strip()!r}: {key} {fields[key]!r} is not a number") from None

        frame = fields.get("frame", "motor_normalized")
        return cls(frame, num("gear_ratio"), num("torque_scale"), speed_unit=fields.get("speed", "rad/s"),
                   torque_unit=fields.get("torque", "N·m" if frame == "joint" else "normalized"),
                   temperature_unit=fields.get("temperature", "degC"), declared=True)


#: The suite's own units (what the observer publishes, what bags hold).
SUITE_UNITS = TableUnits(declared=True)


def convert_temperature(values: Array, unit: str) -> Array:
    """Temperatures in ``unit`` to degC."""
    v = np.asarray(values, dtype=float)
    if unit == "K":
        return v - 273.15
    if unit == "degF":
        return (v - 32.0) * 5.0 / 9.0
    return v


def _with_columns(table: Any, cols: Mapping[str, Array], units: TableUnits) -> Any:
    from .types import ObservationTable

    return ObservationTable(dict(cols), source=table.source, units=units)


def to_suite(table: Any, units: TableUnits, set_units: SetUnits | None = None, *, where: str = "") -> Any:
    """``table`` (in ``units``) in the suite's units: degC, rad/s motor side, normalized torques.

    A joint-side table needs its gear ratio and torque scale: its own, else the set's
    (``set_units``); without either it is refused, naming the flags.
    """
    cols = {k: np.asarray(v, dtype=float).copy() for k, v in table.columns.items()}
    if "temperature" in cols:
        cols["temperature"] = convert_temperature(cols["temperature"], units.temperature_unit)
    sf = SPEED_UNITS[units.speed_unit]
    tf = 1.0 if units.frame == "motor_normalized" else TORQUE_UNITS[units.torque_unit]
    if units.joint_side:
        gear = units.gear_ratio or (set_units.gear_ratio if set_units is not None and set_units.joint_side else None)
        scale = units.torque_scale or (set_units.torque_scale if set_units is not None and set_units.joint_side
                                       else None)
        if gear is None or scale is None:
            raise UnitError(f"{where or table.source or 'observations'}: the table is joint side (rad/s, N·m) but "
                            "neither it nor the parameter set gives the gear ratio and torque scale that map it to "
                            "the motor side, normalized: add --gear-ratio G --torque-scale S")
        sf *= float(gear)
        tf /= float(scale)
    if "speed" in cols:
        cols["speed"] = cols["speed"] * sf
    for name in TORQUE_COLUMNS:
        if name in cols:
            cols[name] = cols[name] * tf
    return _with_columns(table, cols, SUITE_UNITS)


def to_set_frame(table: Any, set_units: SetUnits) -> Any:
    """The suite's observations (motor side, normalized) in a set's frame (identity for the paper's frame)."""
    if not set_units.joint_side:
        if getattr(table, "units", None) is None:  # the suite's observations: say so
            return _with_columns(table, table.columns, SUITE_UNITS)
        return table
    sf, tf = set_units.speed_factor, set_units.torque_factor
    cols = {k: np.asarray(v, dtype=float) for k, v in table.columns.items()}
    if "speed" in cols:
        cols["speed"] = cols["speed"] * sf
    for name in TORQUE_COLUMNS:
        if name in cols:
            cols[name] = cols[name] * tf
    return _with_columns(table, cols, TableUnits.of_set(set_units))


# -- the check ------------------------------------------------------------------------------------
def _span(col: Array) -> tuple[float, float] | None:
    c = np.abs(np.asarray(col, dtype=float))
    c = c[np.isfinite(c)]
    if c.size == 0:
        return None
    return float(c.min()), float(c.max())


def _fits(span: tuple[float, float], rng: tuple[float, float], tol: float) -> bool:
    lo, hi = rng
    return span[0] >= lo - tol and span[1] <= hi + tol


def likely_temperature_slip(col: Array, rng: tuple[float, float], tol: float = 0.0) -> tuple[str, str] | None:
    """``(what, flag)`` when the temperatures fit ``rng`` (degC) read as kelvin or degF, else None."""
    raw = np.asarray(col, dtype=float)
    raw = raw[np.isfinite(raw)]
    if raw.size == 0:
        return None
    span = (float(raw.min()), float(raw.max()))
    for unit, what in (("K", "kelvin"), ("degF", "degF")):
        conv = convert_temperature(np.asarray(span), unit)
        if _fits((float(conv[0]), float(conv[1])), rng, tol):
            return what, f"--temperature-unit {unit}"
    return None


def _tol(rng: tuple[float, float], rel: float) -> float:
    return rel * max(abs(rng[1] - rng[0]), abs(rng[1]), 1e-12)


def _fmt_range(span: tuple[float, float]) -> str:
    return f"{span[0]:.4g} to {span[1]:.4g}"


def check_for_set(table: Any, pset: Any, units: TableUnits, *, where: str = "", tolerance: float = 0.05,
                  tau_range: tuple[float, float] | None = None) -> None:
    """Refuse a table (in the suite's units, converted from ``units``) that does not fit ``pset``.

    Checks, in the set's own frame, ``speed``, ``load_torque`` and ``temperature`` against the
    set's ``valid`` ranges (``tolerance`` x the range's width beyond either end is accepted: a
    test cycle at the baseline's speeds and windows), and ``tau_f`` against ``tau_range`` (the
    friction the set's model gives over its valid ranges and wear 0-100, when given) within a
    factor of 5. A column outside is a :class:`UnitError` naming the column, its range, the
    set's range, the likely slip and the flag that fixes it.
    """
    src = where or table.source or "observations"
    su = pset.units
    in_set = to_set_frame(table, su)
    side = "joint side" if su.joint_side else "motor side"
    read_as = units.describe()
    for var in ("temperature", "speed", "load_torque"):
        rng = pset.valid.get(var)
        if rng is None or var not in in_set:
            continue
        col = np.asarray(in_set[var], dtype=float)
        span = _span(col) if var != "temperature" else (
            (float(np.nanmin(col)), float(np.nanmax(col))) if np.isfinite(col).any() else None)
        if span is None:
            continue
        tol = _tol(rng, tolerance)
        if _fits(span, rng, tol):
            continue
        unit = {"temperature": "degC", "speed": f"rad/s {side}", "load_torque": su.torque_unit}[var]
        slip = _likely_slip(var, table, in_set, pset, units, rng, tol)
        msg = (f"{src}: column {var} runs {_fmt_range(span)} {unit} (read as {read_as}), outside the valid range "
               f"[{rng[0]:.4g}, {rng[1]:.4g}] of parameter set {pset.name!r}")
        if slip:
            msg += f"; {slip}"
        elif var == "temperature":
            hotter = span[1] > rng[1]
            msg += (f"; the joint is {'hotter' if hotter else 'colder'} than in the data the set was made from, and "
                    "the model would extrapolate: commission the joint over this temperature range (baseline cycles "
                    "as warm or as cold as this)")
        else:
            msg += "; give data inside the set's range, or commission the joint over this range"
        raise UnitError(msg)
    if tau_range is not None and "tau_f" in in_set:
        tau = np.asarray(in_set["tau_f"], dtype=float)
        tau = tau[np.isfinite(tau)]
        if tau.size:
            med = float(np.median(np.abs(tau)))
            lo, hi = tau_range
            if med > 5.0 * hi or (lo > 0 and med < lo / 5.0):
                slip = _likely_slip("tau_f", table, in_set, pset, units, (lo / 5.0, 5.0 * hi), 0.0)
                msg = (f"{src}: column tau_f has a median of {med:.4g} {su.torque_unit} (read as {read_as}); the "
                       f"parameter set {pset.name!r} gives friction of {lo:.4g} to {hi:.4g} {su.torque_unit} over its "
                       "valid ranges and wear 0-100")
                raise UnitError(msg + (f"; {slip}" if slip else "; is the table in another torque unit?"))


def _likely_slip(var: str, table: Any, in_set: Any, pset: Any, units: TableUnits, rng: tuple[float, float],
                 tol: float) -> str:
    """The slip that would make ``var`` fit ``rng`` (set frame), as 'what? flag', or ''."""
    su = pset.units
    if var == "temperature":
        raw = np.asarray(in_set["temperature"], dtype=float)
        # the set's check ran on degC values: undo the table's own conversion to test other units
        if units.temperature_unit == "K":
            raw = raw + 273.15
        elif units.temperature_unit == "degF":
            raw = raw * 9.0 / 5.0 + 32.0
        degc = np.asarray(in_set["temperature"], dtype=float)
        degc = degc[np.isfinite(degc)]
        if degc.size and degc.min() >= rng[0] - PLAUSIBLE_EXCURSION and degc.max() <= rng[1] + PLAUSIBLE_EXCURSION:
            return ""  # a joint warmer or colder than at commissioning is likelier than a unit slip
        s = likely_temperature_slip(raw, rng, tol)
        if s is not None:
            return f"in {s[0]}? add {s[1]}"
        return ""
    col = np.asarray(in_set[var], dtype=float)
    span = _span(col)
    if span is None:
        return ""
    candidates: list[tuple[float, str]] = []
    # the other frame: a joint-side table read as motor side, or the reverse
    gear = su.gear_ratio if su.joint_side else units.gear_ratio
    scale = su.torque_scale if su.joint_side else units.torque_scale
    speed_like = var == "speed"
    if units.joint_side and gear:
        f = (1.0 / gear) if speed_like else (scale or 1.0)
        flag = "drop --joint-side" if su.joint_side else "drop --joint-side (or its gear ratio and torque scale)"
        candidates.append((f, f"motor side, normalized? {flag}"))
    elif not units.joint_side:
        if su.joint_side and gear:
            f = gear if speed_like else 1.0 / (scale or 1.0)
            candidates.append((f, "joint side (rad/s, N·m)? add --joint-side"))
    if speed_like:
        for unit, factor in SPEED_UNITS.items():
            if unit != units.speed_unit:
                candidates.append((factor / SPEED_UNITS[units.speed_unit], f"in {unit}? add --speed-unit {unit}"))
    elif units.joint_side or su.joint_side:
        for unit, factor in TORQUE_UNITS.items():
            if unit != units.torque_unit:
                candidates.append((factor / TORQUE_UNITS.get(units.torque_unit, 1.0), f"in {unit}? add --torque-unit {unit}"))
    for f, text in candidates:
        if _fits((span[0] * f, span[1] * f), rng, tol):
            return text
    if not units.joint_side and not su.joint_side and speed_like and span[1] < rng[0]:
        return ("joint side? this set is motor side, normalized: convert with the joint's gear ratio and torque "
                "scale, or commission the joint in its own units (--gear-ratio G --torque-scale S)")
    return ""


def check_plausible(table: Any, units: TableUnits, *, where: str = "", fix_frame: str = "",
                    valid_speed: tuple[float, float] | None = None) -> None:
    """Refuse a table (already in the suite's units, converted from ``units``) that no joint can have.

    For data without a parameter set to compare with (commissioning): temperatures within
    :data:`PLAUSIBLE_OPERATING_TEMPERATURE` (else kelvin or degF is named), normalized friction
    at most :data:`MAX_NORMALIZED_FRICTION` (else N·m, mN·m or a missing torque scale is named),
    motor speeds below :data:`MAX_MOTOR_SPEED` and a largest speed of a cycle above
    :data:`MIN_MOTOR_CYCLE_SPEED` rad/s motor side (else joint side, rpm or deg/s is named).
    ``fix_frame``: the flags that declare a joint-side table for this command; ``valid_speed``: a set's
    valid speed range (suite frame), which decides between the speed slips that would fit.
    """
    src = where or table.source or "observations"
    read_as = units.describe()
    frame_flags = fix_frame or "--gear-ratio G --torque-scale S"
    check_temperature(table, units, where=src)
    tau = np.asarray(table["tau_f"], dtype=float)
    tau = np.abs(tau[np.isfinite(tau)])
    if tau.size:
        med = float(np.median(tau))
        limit = MAX_NORMALIZED_FRICTION if not units.joint_side else 10.0 * MAX_NORMALIZED_FRICTION
        if med > limit:
            if units.joint_side and units.torque_unit == "N·m" and med / 1000.0 <= limit:
                hint = "in mN·m? add --torque-unit mN·m (or check --torque-scale)"
            elif units.joint_side:
                hint = "check --torque-scale (N·m per normalized unit) and the torque unit"
            else:
                hint = f"joint side in N·m? add {frame_flags} (1 and 1 keep the data's own units)"
            raise UnitError(f"{src}: column tau_f has a median of {med:.4g} normalized (read as {read_as}); a joint's "
                            f"friction is at most {limit:g} of its normalized torque; {hint}")
    sp = np.abs(np.asarray(table.speed, dtype=float))
    sp = sp[np.isfinite(sp)]
    if sp.size:
        top = float(sp.max())
        too_fast = top > MAX_MOTOR_SPEED
        too_slow = top < MIN_MOTOR_CYCLE_SPEED and not units.joint_side
        if too_fast or too_slow:
            hints = _speed_slips(float(sp.min()), top, units, valid_speed, frame_flags)
            if too_fast:
                what = (f"reaches {top:.4g} rad/s motor side (read as {read_as}), more than a motor turns "
                        f"({MAX_MOTOR_SPEED:g} rad/s, about 10 000 rpm)")
            else:
                what = (f"reaches only {top:.4g} rad/s motor side (read as {read_as}); a test cycle's motor turns "
                        "faster")
            raise UnitError(f"{src}: column speed {what}; {hints or 'check the speed unit and the gear ratio'}")


def _speed_slips(bottom: float, top: float, units: TableUnits, valid_speed: tuple[float, float] | None,
                 frame_flags: str) -> str:
    """The slips that would bring motor speeds ``bottom``-``top`` into range, as 'what? flag' texts."""
    cands: list[tuple[float, str]] = []
    if units.joint_side and units.gear_ratio:
        cands.append((1.0 / units.gear_ratio, "motor side already? drop --joint-side (and its gear ratio)"))
    if not units.joint_side:
        extra = " (1 and 1 keep the data's own units)" if frame_flags == "--gear-ratio G --torque-scale S" else ""
        cands.append((math.nan, f"joint side? add {frame_flags}{extra}"))
    base = SPEED_UNITS[units.speed_unit]
    for unit, factor in SPEED_UNITS.items():
        if unit != units.speed_unit:
            cands.append((factor / base, f"in {unit}? add --speed-unit {unit}"))
    lo, hi = valid_speed if valid_speed is not None else (0.0, MAX_MOTOR_SPEED)
    hi = min(hi, MAX_MOTOR_SPEED) * 1.05
    lo = lo / 1.05
    out = []
    for f, text in cands:
        if math.isnan(f):
            if top < MIN_MOTOR_CYCLE_SPEED:
                out.append(text)
            continue
        if MIN_MOTOR_CYCLE_SPEED <= top * f <= hi and bottom * f >= lo:
            out.append(text)
    return "; or ".join(out)


def in_base_units(table: Any, units: TableUnits) -> Any:
    """``table`` with temperatures in degC, speeds in rad/s and joint-side torques in N·m, its frame kept.

    What the workbench needs: it fits in the data's own frame (joint side N·m or the paper's), but
    a temperature term is in degC and a speed term in rad/s.
    """
    cols = {k: np.asarray(v, dtype=float).copy() for k, v in table.columns.items()}
    if "temperature" in cols:
        cols["temperature"] = convert_temperature(cols["temperature"], units.temperature_unit)
    if "speed" in cols:
        cols["speed"] = cols["speed"] * SPEED_UNITS[units.speed_unit]
    tf = TORQUE_UNITS.get(units.torque_unit, 1.0) if units.joint_side else 1.0
    for name in TORQUE_COLUMNS:
        if name in cols:
            cols[name] = cols[name] * tf
    base = replace(units, speed_unit="rad/s", temperature_unit="degC",
                   torque_unit="N·m" if units.joint_side else "normalized")
    return _with_columns(table, cols, base)


def check_temperature(table: Any, units: TableUnits, *, where: str = "") -> None:
    """Refuse temperatures (degC, converted from ``units``) no robot joint reaches in operation, naming kelvin or
    degF when the values fit those (:data:`PLAUSIBLE_OPERATING_TEMPERATURE`)."""
    if "temperature" not in table:
        return
    col = np.asarray(table["temperature"], dtype=float)
    col = col[np.isfinite(col)]
    if not col.size:
        return
    lo, hi = PLAUSIBLE_OPERATING_TEMPERATURE
    span = (float(col.min()), float(col.max()))
    if _fits(span, (lo, hi), 0.0):
        return
    raw = col
    if units.temperature_unit == "K":
        raw = col + 273.15
    elif units.temperature_unit == "degF":
        raw = col * 9.0 / 5.0 + 32.0
    s = likely_temperature_slip(raw, (lo, hi))
    hint = f"in {s[0]}? add {s[1]}" if s else "check the sensor and its unit"
    raise UnitError(f"{where or table.source or 'observations'}: column temperature runs {_fmt_range(span)} degC "
                    f"(read as {units.describe()}), outside what a robot joint reaches in operation ({lo:g} to "
                    f"{hi:g} degC); {hint}")


def effective_units(table: Any, assumed: TableUnits, *, explicit: bool = False, where: str = "") -> TableUnits:
    """The units to read ``table`` in: what it declares, else ``assumed`` (the command's flags or the suite's).

    ``explicit``: the command's flags said something; a table that declares other units is then
    refused (one of the two is wrong, and silently picking one loses the other).
    """
    declared = getattr(table, "units", None)
    if declared is None or not declared.declared:
        return assumed
    if explicit:
        fields = ("frame", "speed_unit", "torque_unit", "temperature_unit")
        differ = [f for f in fields if getattr(declared, f) != getattr(assumed, f)]
        for f in ("gear_ratio", "torque_scale"):
            a, d = getattr(assumed, f), getattr(declared, f)
            if a is not None and d is not None and not math.isclose(a, d, rel_tol=1e-9):
                differ.append(f)
        if differ:
            raise UnitError(f"{where or table.source or 'observations'}: the table declares its units "
                            f"({declared.describe()}) and the flags say otherwise ({', '.join(differ)}): drop the "
                            "flags (the table's own declaration is used) or fix its '# units:' line")
    if declared.joint_side and (declared.gear_ratio is None or declared.torque_scale is None):
        return replace(declared, gear_ratio=declared.gear_ratio or assumed.gear_ratio,
                       torque_scale=declared.torque_scale or assumed.torque_scale)
    return declared


def prepare_for_set(table: Any, pset: Any, assumed: TableUnits, *, explicit: bool = False,
                    where: str = "", tau_range: tuple[float, float] | None = None) -> Any:
    """``table`` in the suite's units, checked against ``pset`` (see :func:`check_for_set`).

    Declared units are converted; assumed units are first checked for plausibility
    (:func:`check_plausible`), so a joint-side table read as motor side, kelvin, rpm or deg/s
    is named even where the set's ranges are wide. Raises :class:`UnitError`.
    """
    units = effective_units(table, assumed, explicit=explicit, where=where)
    if units.joint_side and pset.units.joint_side and (units.gear_ratio is None or units.torque_scale is None):
        units = replace(units, gear_ratio=units.gear_ratio or pset.units.gear_ratio,
                        torque_scale=units.torque_scale or pset.units.torque_scale)
    suite = to_suite(table, units, pset.units, where=where)
    if not units.declared:
        fix = "--joint-side" if pset.units.joint_side else "--joint-side --gear-ratio G --torque-scale S"
        check_plausible(suite, units, where=where or table.source, fix_frame=fix,
                        valid_speed=pset.observation_valid().get("speed"))
    check_for_set(suite, pset, units, where=where or table.source, tau_range=tau_range)
    return suite


def prepare_baseline(table: Any, assumed: TableUnits, *, explicit: bool = False, where: str = "",
                     fix_frame: str = "--gear-ratio G --torque-scale S") -> Any:
    """A baseline table (no set to compare with yet) in the suite's units, checked for plausibility."""
    units = effective_units(table, assumed, explicit=explicit, where=where)
    suite = to_suite(table, units, None, where=where)
    check_plausible(suite, units, where=where or table.source, fix_frame=fix_frame)
    return suite
