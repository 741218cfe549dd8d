"""Named parameter sets, kept as YAML in ``config/params/``.

A parameter set file holds ``name``, ``description``, ``valid`` (input ranges in
which the set is meaningful) and ``parameters`` (name -> value). Units and
bounds come from the terms' :class:`~jointwear_ros.model.parameters.ParamSpec`.

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

import yaml

from ..errors import ParameterSetError
from ..resources import resource_dirs
from .parameters import Parameter, Parameters
from .terms import TERMS

__all__ = ["ParameterSet", "available_parameter_sets", "load_parameter_set", "load_parameter_set_info"]

#: 0 K in degC.
ABSOLUTE_ZERO = -273.15


@dataclass(frozen=True)
class ParameterSet:
    """A named parameter set with its validity ranges."""

    name: str
    description: str
    values: dict[str, float]
    valid: dict[str, tuple[float, float]] = field(default_factory=dict)
    path: Path | None = None

    def parameters(self) -> Parameters:
        """All values as :class:`Parameters`, with units and bounds from the terms."""
        specs = {s.name: s for t in TERMS.values() for s in t.params}
        out = Parameters()
        for n, v in self.values.items():
            spec = specs.get(n)
            if spec is None:
                out.add(Parameter(n, v))
            else:
                out.add(Parameter.from_spec(spec, v))
        return out

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


def load_parameter_set_info(name: str) -> ParameterSet:
    """Read a named parameter set (or a YAML path) with its description and valid ranges."""
    path = _find(name)
    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise ParameterSetError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start}); "
                                "give a parameter set YAML file") from None
    except (OSError, yaml.YAMLError) as exc:
        msg = " ".join(str(exc).split())
        raise ParameterSetError(f"{path}: cannot read parameter set: {msg}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("parameters"), dict):
        raise ParameterSetError(f"{path}: expected a mapping with a 'parameters' mapping")
    specs = {s.name: s for t in TERMS.values() for s in t.params}
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
        if spec is not None and not spec.min <= fv <= spec.max:
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
    return ParameterSet(
        name=str(doc.get("name", path.stem)),
        description=str(doc.get("description", "")).strip(),
        values=values,
        valid=valid,
        path=path,
    )


def load_parameter_set(name: str) -> Parameters:
    """The named parameter set as :class:`Parameters` (e.g. ``"ref-2011r"``)."""
    return load_parameter_set_info(name).parameters()
