"""Named parameter sets, kept as YAML in ``config/params/``.

A parameter set file holds ``name``, ``description``, ``valid`` (input ranges in
which the set is meaningful) and ``parameters`` (name -> value). Units and
bounds come from the terms' :class:`~jointwear_ros.model.parameters.ParamSpec`.

A set may also carry its own model (commissioning, docs/commissioning.md): ``model`` (a spec string, default
``paper+wear``, Eq. 9; candidate terms such as ``ripple(position)`` resolve
through the workbench's library), ``units`` (``frame: motor_normalized``, the
paper's motor side and normalized torque, the default; or ``frame: joint``,
joint side rad/s and N·m, with ``gear_ratio`` and ``torque_scale`` mapping the
suite's observations into it), ``covariance`` (``names`` and ``matrix`` of the
fitted parameters), ``noise_std`` (a friction observation's noise in the set's
torque unit), ``wear`` (``calibration``: where the wear parameters came from)
and ``provenance`` (robot, joint, data, date, software). Sets without these
keys (``ref-2011r``) read as before. See docs/commissioning.md.

Sets are looked up, in order, in ``$JOINTWEAR_PARAMS_PATH`` (``:``-separated
directories), then ``config/params`` of every place
:func:`jointwear_ros.resources.resource_dirs` names (the source tree of a
development checkout, the ament index, the ament prefixes and the running
prefix). A path to a ``.yaml`` file is accepted too.

A loaded set holds finite values within the terms' physical bounds, and valid
ranges with low <= high (temperatures above absolute zero); anything else, a
binary file included, is a :class:`~jointwear_ros.errors.ParameterSetError`.

>>> info = load_parameter_set_info("ref-2011r")
>>> info.name, info.values["Fsw"], info.valid["temperature"]
('ref-2011r', 0.00091, (20.0, 60.0))
>>> info.check_range("temperature", 75.0)
Traceback (most recent call last):
...
jointwear_ros.errors.ParameterSetError: temperature = 75 is outside the valid range [20, 60] of parameter set 'ref-2011r'
>>> load_parameter_set("paper-printed")["Fsw"].value  # the printed Eq. (8) value, 10x ref-2011r's
0.0091
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from ..errors import ParameterSetError
from ..resources import resource_dirs
from ..units import FRAMES, SetUnits
from .parameters import Parameter, Parameters
from .specs import parse_model_spec, parse_spec
from .terms import TERMS

if TYPE_CHECKING:
    from .model import Model

__all__ = ["FORMAT", "FRAMES", "KEYS", "ParameterSet", "SetUnits", "available_parameter_sets", "load_parameter_set",
           "load_parameter_set_info", "parameter_set_document"]

#: 0 K in degC.
ABSOLUTE_ZERO = -273.15
#: The model a set without a ``model`` key has: Eq. (9).
DEFAULT_SPEC = "paper+wear"
#: The set file format this version reads and writes (a newer one is refused, never half-read).
FORMAT = 1
#: The keys a set file may have (any other key is refused: a typo, or a newer format).
KEYS = ("format", "name", "description", "model", "units", "valid", "noise_std", "temperature_prior",
        "parameters", "covariance", "wear", "provenance")


@dataclass(frozen=True)
class ParameterSet:
    """A named parameter set with its validity ranges."""

    name: str
    description: str
    values: dict[str, float]
    valid: dict[str, tuple[float, float]] = field(default_factory=dict)
    path: Path | None = None
    spec: str = DEFAULT_SPEC
    units: SetUnits = field(default_factory=SetUnits)
    stderr: dict[str, float] = field(default_factory=dict)
    covariance: tuple[tuple[str, ...], tuple[tuple[float, ...], ...]] | None = None
    noise_std: float | None = None
    temperature_prior: str | None = None
    wear: dict[str, Any] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)

    def parameters(self) -> Parameters:
        """All values as :class:`Parameters`, with units and bounds from the terms.

        The terms' bounds are the paper's normalized units; a joint-frame set's
        parameters get unbounded :class:`Parameter` entries with the same unit label.
        """
        specs = {s.name: s for t in TERMS.values() for s in t.params}
        out = Parameters()
        for n, v in self.values.items():
            spec = specs.get(n)
            if spec is None:
                out.add(Parameter(n, v))
            elif self.units.joint_side:
                out.add(Parameter(n, v, unit=spec.unit, description=spec.description))
            else:
                out.add(Parameter.from_spec(spec, v))
            if n in self.stderr:
                out[n].stderr = self.stderr[n]
        return out

    def model(self) -> Model:
        """The set's model (its ``model`` spec; Eq. 9 when the file names none)."""
        if self.spec == DEFAULT_SPEC:
            return parse_model_spec(self.spec)
        return parse_spec(self.spec)  # candidate terms too (ripple(position), ...)

    @property
    def wear_calibration(self) -> str:
        """Where the wear parameters came from (``paper`` for a set that does not say)."""
        return str(self.wear.get("calibration", "paper"))

    def check_observation_range(self, var: str, value: float) -> None:
        """:meth:`check_range` for a value in the suite's observation units (motor side, normalized)."""
        rng = self.observation_valid().get(var)
        if rng is not None and not rng[0] <= value <= rng[1]:
            unit = {"speed": " (rad/s motor side)", "load_torque": " (normalized)"}.get(var, "")
            raise ParameterSetError(f"{var} = {value:g}{unit} is outside the valid range [{rng[0]:g}, {rng[1]:g}] "
                                    f"of parameter set {self.name!r}")

    def observation_valid(self) -> dict[str, tuple[float, float]]:
        """``valid`` in the suite's observation frame (motor side speed, normalized torques)."""
        out = dict(self.valid)
        sf, tf = self.units.speed_factor, self.units.torque_factor
        if "speed" in out:
            out["speed"] = (out["speed"][0] / sf, out["speed"][1] / sf)
        if "load_torque" in out:
            out["load_torque"] = (out["load_torque"][0] / tf, out["load_torque"][1] / tf)
        return out

    def friction_range(self) -> tuple[float, float] | None:
        """The friction (set units) the set's model gives over its valid ranges and wear 0-100, or None.

        What a friction observation of this joint can read: a table far outside it is in other
        units (:func:`jointwear_ros.units.check_for_set`).
        """
        import numpy as np

        try:
            m = self.model()
            s_lo, s_hi = self.valid.get("speed", (0.0, 0.0))
            speeds = np.linspace(max(s_lo, 0.01 * s_hi), s_hi, 12) if s_hi > 0 else np.array([0.0])
            axes = {"speed": speeds, "load_torque": np.array(self.valid.get("load_torque", (0.0, 0.0))),
                    "temperature": np.array(self.valid.get("temperature", (40.0, 40.0))),
                    "wear": np.array([0.0, min(100.0, self.valid.get("wear", (0.0, 100.0))[1])])}
            names = [v for v in m.variables]
            grids = np.meshgrid(*[axes.get(v, np.array([0.0])) for v in names], indexing="ij")
            vals = np.asarray(m.evaluate(self.values, **{v: g.ravel() for v, g in zip(names, grids)}), dtype=float)
        except Exception:  # a model this check cannot evaluate: no friction range to check against
            return None
        vals = np.abs(vals[np.isfinite(vals)])
        if vals.size == 0 or float(vals.max()) <= 0:
            return None
        return float(vals.min()), float(vals.max())

    def check_range(self, var: str, value: float) -> None:
        """Raise :class:`ParameterSetError` if ``value`` is outside the set's valid range of ``var``."""
        if var in self.valid:
            lo, hi = self.valid[var]
            if not lo <= value <= hi:
                raise ParameterSetError(
                    f"{var} = {value:g} is outside the valid range [{lo:g}, {hi:g}] of parameter set {self.name!r}"
                )


def _search_dirs() -> list[Path]:
    dirs: list[Path] = []
    env = os.environ.get("JOINTWEAR_PARAMS_PATH")
    if env:
        dirs.extend(Path(d) for d in env.split(os.pathsep) if d)
    dirs.extend(d / "config" / "params" for d in resource_dirs("jointwear_ros"))
    return dirs


def available_parameter_sets() -> list[str]:
    names: set[str] = set()
    for d in _search_dirs():
        if d.is_dir():
            names.update(p.stem for p in d.glob("*.yaml"))
    return sorted(names)


def _find(name: str) -> Path:
    as_path = Path(name)
    if as_path.suffix in (".yaml", ".yml") and as_path.is_file():
        return as_path
    for d in _search_dirs():
        cand = d / f"{name}.yaml"
        if cand.is_file():
            return cand
    known = ", ".join(available_parameter_sets()) or "(none found)"
    raise ParameterSetError(f"unknown parameter set {name!r}; available: {known}")


#: libyaml's safe loader where PyYAML has it (the same documents, about 10x faster: a set loads at every
#: estimator's and every simulated joint's construction), else PyYAML's own
_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def load_parameter_set_info(name: str) -> ParameterSet:
    """Read a named parameter set (or a YAML path) with its description and valid ranges."""
    path = _find(name)
    try:
        doc = yaml.load(path.read_text(encoding="utf-8"), Loader=_YAML_LOADER)
    except UnicodeDecodeError as exc:
        raise ParameterSetError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start}); "
                                "give a parameter set YAML file") from None
    except (OSError, yaml.YAMLError) as exc:
        msg = " ".join(str(exc).split())
        raise ParameterSetError(f"{path}: cannot read parameter set: {msg}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("parameters"), dict):
        raise ParameterSetError(f"{path}: expected a mapping with a 'parameters' mapping")
    fmt = doc.get("format", FORMAT)
    if isinstance(fmt, bool) or not isinstance(fmt, int) or fmt < 1:
        raise ParameterSetError(f"{path}: format {fmt!r} is not a set format number (this jointwear reads "
                                f"format {FORMAT})")
    if fmt > FORMAT:
        raise ParameterSetError(f"{path}: set format {fmt} was written by a newer jointwear (this one reads format "
                                f"{FORMAT}); update jointwear to read it")
    unknown = [str(k) for k in doc if k not in KEYS]
    if unknown:
        raise ParameterSetError(f"{path}: unknown key(s) {', '.join(repr(k) for k in unknown)} (a typo, or a newer "
                                f"set format); a set has {', '.join(KEYS)}")
    specs = {s.name: s for t in TERMS.values() for s in t.params}
    units = _read_units(path, doc.get("units"))
    values: dict[str, float] = {}
    for k, v in doc["parameters"].items():
        if isinstance(v, bool):
            raise ParameterSetError(f"{path}: parameter {k!r} = {v!r} is not a number")
        try:
            fv = float(v)
        except (TypeError, ValueError, OverflowError):
            raise ParameterSetError(f"{path}: parameter {k!r} = {v!r} is not a number") from None
        if not math.isfinite(fv):
            raise ParameterSetError(f"{path}: parameter {k!r} = {v!r} is not finite")
        spec = specs.get(str(k))
        if spec is not None and not units.joint_side and not spec.min <= fv <= spec.max:
            raise ParameterSetError(
                f"{path}: parameter {k!r} = {fv:g} is outside its physical bounds [{spec.min:g}, {spec.max:g}] "
                f"({spec.unit})"
            )
        values[str(k)] = fv
    valid_doc = doc.get("valid") or {}
    if not isinstance(valid_doc, dict):
        raise ParameterSetError(f"{path}: 'valid' must be a mapping of input name -> [low, high]")
    valid: dict[str, tuple[float, float]] = {}
    for k, rng in valid_doc.items():
        try:
            if isinstance(rng, (str, bytes)) or len(rng) != 2:
                raise TypeError
            lo, hi = (float(rng[0]), float(rng[1]))
        except (TypeError, ValueError, IndexError, OverflowError):
            raise ParameterSetError(f"{path}: valid range of {k!r} must be [low, high], got {rng!r}") from None
        if math.isnan(lo) or math.isnan(hi) or lo > hi:
            raise ParameterSetError(f"{path}: valid range of {k!r} = [{lo!r}, {hi!r}] must have low <= high")
        if str(k) == "temperature" and lo < ABSOLUTE_ZERO:
            raise ParameterSetError(f"{path}: valid temperature range starts at {lo:g} degC, below absolute zero")
        valid[str(k)] = (lo, hi)
    model_spec = str(doc.get("model") or DEFAULT_SPEC).strip()
    stderr, covariance = _read_covariance(path, doc.get("covariance"), values)
    noise = doc.get("noise_std")
    if noise is not None:
        try:
            noise = float(noise)
        except (TypeError, ValueError):
            noise = math.nan
        if not (math.isfinite(noise) and noise > 0):
            raise ParameterSetError(f"{path}: noise_std = {doc.get('noise_std')!r} must be a positive number "
                                    f"({units.torque_unit})")
    wear = doc.get("wear") or {}
    prov = doc.get("provenance") or {}
    if not isinstance(wear, dict) or not isinstance(prov, dict):
        raise ParameterSetError(f"{path}: 'wear' and 'provenance' must be mappings")
    pset = ParameterSet(
        name=str(doc.get("name", path.stem)),
        description=str(doc.get("description", "")).strip(),
        values=values,
        valid=valid,
        path=path,
        spec=model_spec,
        units=units,
        stderr=stderr,
        covariance=covariance,
        noise_std=noise,
        temperature_prior=(str(doc["temperature_prior"]) if doc.get("temperature_prior") else None),
        wear=dict(wear),
        provenance=dict(prov),
    )
    _check_parameters_match_model(path, pset)
    return pset


def _check_parameters_match_model(path: Path, pset: ParameterSet) -> None:
    """Every parameter the set's model needs is given, and every given one is the model's (never a default)."""
    try:
        names = pset.model().param_names
    except ParameterSetError:
        raise
    except Exception as exc:  # an unknown term or a malformed spec: the model error's own text
        raise ParameterSetError(f"{path}: model {pset.spec!r}: {' '.join(str(exc).split())}") from None
    missing = [n for n in names if n not in pset.values]
    if missing:
        raise ParameterSetError(f"{path}: parameter(s) {', '.join(missing)} of model {pset.spec!r} missing; a set "
                                "gives every parameter of its model (none is taken from a default)")
    extra = [n for n in pset.values if n not in names]
    if extra:
        raise ParameterSetError(f"{path}: parameter(s) {', '.join(extra)} are not parameters of model "
                                f"{pset.spec!r}; remove them or name the model that has them")


def _read_units(path: Path, doc: Any) -> SetUnits:
    if doc is None:
        return SetUnits()
    if not isinstance(doc, dict):
        raise ParameterSetError(f"{path}: 'units' must be a mapping (frame, gear_ratio, torque_scale)")
    unknown = [str(k) for k in doc if k not in ("frame", "gear_ratio", "torque_scale", "speed", "torque",
                                                  "temperature")]
    if unknown:
        raise ParameterSetError(f"{path}: units key(s) {', '.join(unknown)} unknown (a set's units are frame, "
                                "gear_ratio, torque_scale; speed, torque and temperature are labels)")
    if str(doc.get("temperature", "degC")) != "degC":
        raise ParameterSetError(f"{path}: units temperature {doc.get('temperature')!r}: a set is in degC")
    frame = str(doc.get("frame", "motor_normalized"))
    if frame not in FRAMES:
        raise ParameterSetError(f"{path}: units frame {frame!r} unknown; use one of {', '.join(FRAMES)}")
    out: dict[str, float | None] = {}
    for key in ("gear_ratio", "torque_scale"):
        v = doc.get(key)
        if v is None:
            out[key] = None
            continue
        try:
            fv = float(v)
        except (TypeError, ValueError):
            fv = math.nan
        if not (math.isfinite(fv) and fv > 0) or isinstance(v, bool):
            raise ParameterSetError(f"{path}: units {key} = {v!r} must be a positive number")
        out[key] = fv
    if frame == "joint" and (out["gear_ratio"] is None or out["torque_scale"] is None):
        raise ParameterSetError(f"{path}: a joint-frame set needs units gear_ratio and torque_scale "
                                "(how the suite's motor-side, normalized observations map into it)")
    return SetUnits(frame, out["gear_ratio"], out["torque_scale"])


def _read_covariance(path: Path, doc: Any, values: dict[str, float]
                     ) -> tuple[dict[str, float], tuple[tuple[str, ...], tuple[tuple[float, ...], ...]] | None]:
    if doc is None:
        return {}, None
    try:
        names = tuple(str(n) for n in doc["names"])
        mat = tuple(tuple(float(x) for x in row) for row in doc["matrix"])
    except (TypeError, KeyError, ValueError):
        raise ParameterSetError(f"{path}: 'covariance' must hold 'names' and a square 'matrix'") from None
    if len(mat) != len(names) or any(len(r) != len(names) for r in mat):
        raise ParameterSetError(f"{path}: covariance matrix is not {len(names)}x{len(names)} (one row per name)")
    unknown = [n for n in names if n not in values]
    if unknown:
        raise ParameterSetError(f"{path}: covariance names {', '.join(unknown)} that are not parameters of the set")
    stderr = {}
    for i, n in enumerate(names):
        d = mat[i][i]
        if not (math.isfinite(d) and d >= 0):
            raise ParameterSetError(f"{path}: covariance of {n!r} = {d!r} is not a variance (finite, >= 0)")
        stderr[n] = math.sqrt(d)
    return stderr, (names, mat)


def parameter_set_document(pset: ParameterSet) -> dict[str, Any]:
    """The YAML document of a set (what :func:`load_parameter_set_info` reads back)."""
    doc: dict[str, Any] = {"format": FORMAT, "name": pset.name, "description": pset.description, "model": pset.spec,
                           "units": pset.units.to_dict()}
    doc["valid"] = {k: [float(lo), float(hi)] for k, (lo, hi) in pset.valid.items()}
    if pset.noise_std is not None:
        doc["noise_std"] = float(pset.noise_std)
    if pset.temperature_prior:
        doc["temperature_prior"] = pset.temperature_prior
    doc["parameters"] = {k: float(v) for k, v in pset.values.items()}
    if pset.covariance is not None:
        names, mat = pset.covariance
        doc["covariance"] = {"names": list(names), "matrix": [[float(x) for x in row] for row in mat]}
    if pset.wear:
        doc["wear"] = dict(pset.wear)
    if pset.provenance:
        doc["provenance"] = dict(pset.provenance)
    return doc


def load_parameter_set(name: str) -> Parameters:
    """The named parameter set as :class:`Parameters` (e.g. ``"ref-2011r"``)."""
    return load_parameter_set_info(name).parameters()
