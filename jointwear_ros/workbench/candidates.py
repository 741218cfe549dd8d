"""The library of candidate effects, and the resolver that turns a term string into a term.

A candidate is a :class:`~jointwear_ros.model.Term` that can be added on top of
a model. Three kinds:

* the paper's own terms that say they are candidates
  (:attr:`~jointwear_ros.model.Term.candidate`: ``load_coulomb``,
  ``load_stribeck``, ``temp_stribeck``, ``temp_viscous``, ``wear_stribeck``,
  ``wear_viscous``) when the data has their inputs and the model does not hold
  them yet;
* the shapes of :mod:`.shapes` (one registry, :data:`~.shapes.SHAPES`):
  generic terms of ANY numeric column ``x`` of the data, named ``shape(x)``
  (``lin``, ``x_stribeck``, ``x_viscous``, ``exp_viscous``, ``ripple`` for
  angle-like columns, ``inter(x,y)`` with load and temperature), and the
  fitted shapes the diagnosis starts from the evidence;
* user terms: a small :class:`~jointwear_ros.model.Term` subclass loaded by
  dotted path ``pkg.module:ClassName`` or by name from the entry point group
  ``jointwear.terms``.

A term's workbench knowledge (the parameters it is linear in, its starting
points in the data's units, what it means) is on the term itself
(:attr:`~jointwear_ros.model.Term.linear`, :meth:`~jointwear_ros.model.Term.guess`,
:meth:`~jointwear_ros.model.Term.describe_effect`). The library only proposes
candidates; choosing among them is :mod:`jointwear_ros.workbench.diagnose`'s job.

>>> t = resolve_term("x_stribeck(lube_hours)")
>>> t.name, t.param_names, t.linear
('x_stribeck(lube_hours)', ('x_stribeck_lube_hours_a', 'x_stribeck_lube_hours_vs'), ('x_stribeck_lube_hours_a',))
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable, Sequence
from importlib import metadata
from typing import Any

import numpy as np

from ..errors import ModelError
from ..model import MODEL_SPECS, TERMS, Model, Term, parse_model_spec
from ..types import ObservationTable
from .shapes import IDENT, SHAPES, Interaction, shape_class

__all__ = [
    "ENTRY_POINT_GROUP",
    "NON_CANDIDATE_COLUMNS",
    "candidate_library",
    "candidate_variables",
    "parse_spec",
    "resolve_term",
]

#: Entry point group for user terms (``name = pkg.module:ClassName``).
ENTRY_POINT_GROUP = "jointwear.terms"

#: Columns never used as a candidate's variable: the response, its parts and ids.
NON_CANDIDATE_COLUMNS = frozenset({"speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "cycle"})

_CALL = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\((.*)\)$")


# generic candidates that would only repeat a paper term (load_torque >= 0)
_DUPLICATES = {"lin(load_torque)": "load_coulomb", "x_stribeck(load_torque)": "load_stribeck"}


# -- resolving term strings ---------------------------------------------------
def _load_class(target: str, what: str) -> Term:
    mod_name, _, cls_name = target.partition(":")
    try:
        mod = importlib.import_module(mod_name)
    except Exception as exc:
        raise ModelError(f"user term {what!r}: cannot import module {mod_name!r} ({exc})") from None
    obj: Any = mod
    for part in cls_name.split("."):
        obj = getattr(obj, part, None)
        if obj is None:
            raise ModelError(f"user term {what!r}: module {mod_name!r} has no {cls_name!r}")
    if not (isinstance(obj, type) and issubclass(obj, Term)):
        raise ModelError(f"user term {what!r}: {cls_name!r} is not a jointwear_ros.model.Term subclass")
    try:
        term = obj()
    except Exception as exc:
        raise ModelError(f"user term {what!r}: {cls_name}() failed: {exc}") from None
    # the spec string must round-trip: name the term by where it came from
    if getattr(term, "name", "") != what:
        term.name = what  # type: ignore[misc]
    return term


def _entry_point(name: str) -> str | None:
    try:
        eps = metadata.entry_points(group=ENTRY_POINT_GROUP)
    except Exception:
        return None
    for ep in eps:
        if ep.name == name:
            return str(ep.value)
    return None


def resolve_term(name: str) -> Term | None:
    """Resolve a term string that is not a built-in term name.

    ``shape(col)`` / ``shape(col1,col2)`` gives a generic candidate term,
    ``pkg.module:ClassName`` imports a user term, a name registered in the
    entry point group ``jointwear.terms`` loads that class. Returns ``None``
    for anything else (built-in names are left to the model core).
    """
    text = name.strip()
    m = _CALL.match(text)
    if m:
        shape, (args, options) = m.group(1), _call_arguments(m.group(2), text)
        cls = shape_class(shape)
        if cls is None:
            raise ModelError(
                f"unknown term shape {shape!r} in {text!r}; shapes: {', '.join(f'{s}(x)' for s in SHAPES)}"
            )
        from_call = getattr(cls, "from_call", None)
        if from_call is not None:
            return from_call(args, options)  # type: ignore[no-any-return]
        if options:
            raise ModelError(f"term shape {shape}(...) takes no options, got {', '.join(options)} in {text!r}")
        return cls(*args)
    if ":" in text:
        return _load_class(text, text)
    if text not in TERMS:
        target = _entry_point(text)
        if target is not None:
            return _load_class(target, text)
        raise ModelError(
            f"unknown term {text!r}; built-in terms: {', '.join(TERMS)}; named models: "
            f"{', '.join(MODEL_SPECS)}; generic shapes: {', '.join(f'{s}(x)' for s in SHAPES)}; "
            "user terms: pkg.module:ClassName"
        )
    return None


def _call_arguments(inner: str, text: str) -> tuple[list[str], dict[str, float]]:
    """``a, b, key=1.5`` -> (['a', 'b'], {'key': 1.5}); positional arguments come first."""
    args: list[str] = []
    options: dict[str, float] = {}
    for raw in inner.split(","):
        item = raw.strip()
        key, eq, val = item.partition("=")
        if eq:
            key, val = key.strip(), val.strip()
            if not IDENT.match(key):
                raise ModelError(f"{text!r}: option name {key!r} is not an identifier")
            try:
                num = float(val)
            except ValueError:
                raise ModelError(f"{text!r}: option {key}={val!r} is not a number") from None
            if key in options:
                raise ModelError(f"{text!r}: option {key} given twice")
            options[key] = num
        else:
            if options:
                raise ModelError(f"{text!r}: column {item!r} after an option; give columns first")
            args.append(item)
    return args, options


def parse_spec(spec: str) -> Model:
    """:func:`~jointwear_ros.model.parse_model_spec` with the candidate and user-term resolver."""
    return parse_model_spec(spec, resolver=resolve_term)


# -- the library --------------------------------------------------------------
def candidate_variables(table: ObservationTable) -> list[str]:
    """Columns usable as a candidate's variable: numeric, finite, not constant, not the response."""
    out = []
    for name, col in table.columns.items():
        if name in NON_CANDIDATE_COLUMNS or not IDENT.match(name):
            continue
        if col.size == 0 or not np.all(np.isfinite(col)) or float(np.ptp(col)) == 0.0:
            continue
        out.append(name)
    return out


def candidate_library(
    table: ObservationTable,
    model: Model,
    *,
    extra: Sequence[Term] = (),
    variables: Sequence[str] | None = None,
    shapes: Callable[[str], Sequence[str]] | None = None,
    generic: Sequence[str] | None = None,
) -> list[Term]:
    """Candidate terms to try on top of ``model`` for this data.

    Paper terms whose inputs the data has, the library's shapes
    (:meth:`~.shapes.CandidateTerm.offered_for`) of every usable column (the
    ripple only for angle-like columns), interactions with load and
    temperature, and ``extra`` (user terms). Terms already in the model, and
    generic terms that would repeat a paper term, are left out. ``generic``
    (default: every usable column) limits the generic shapes and
    interactions to those columns; the paper terms are offered whenever the
    data has their inputs.
    """
    have = set(model.term_names)
    all_vars = list(variables) if variables is not None else candidate_variables(table)
    usable = set(all_vars) | {"speed"}
    vars_ = [v for v in all_vars if generic is None or v in generic]
    out: list[Term] = []
    for name, cls in TERMS.items():
        term = cls()
        if term.candidate and name not in have and set(term.variables) <= usable:
            out.append(term)
    for v in vars_:
        names = shapes(v) if shapes is not None else [s for s, c in SHAPES.items() if c.offered_for(v)]
        for s in names:
            term = SHAPES[s](v)
            dup = _DUPLICATES.get(term.name)
            if term.name in have or (dup is not None and dup in {t.name for t in out} | have):
                continue
            out.append(term)
    partners: list[str] = [v for v in ("load_torque", "temperature") if v in vars_]
    pairs: list[tuple[str, str]] = []
    for partner in partners:
        for v in vars_:
            if v != partner and (partner, v) not in pairs and (v, partner) not in pairs:
                pairs.append((v, partner))
    for v, y in pairs:
        term = Interaction(v, y)
        if term.name not in have:
            out.append(term)
    seen = {t.name for t in out}
    out.extend(t for t in extra if t.name not in have and t.name not in seen)
    return out
