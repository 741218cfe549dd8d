"""Model specifications: named models, spec strings, and the resolver that turns a term string into a term.

A spec is a named model (:data:`MODEL_SPECS`: ``standard``, ``paper``, ``paper+wear``) or a sum
``A + B + ...`` of named models and term strings. A term string is a built-in term's name
(:data:`~.terms.TERMS`), a shape of the data's columns (``ripple(position, w0=17.2)``, the registry
:data:`~.shapes.SHAPES`), or a user term: a :class:`~.model.Term` subclass loaded by dotted path
``pkg.module:ClassName`` or by name from the entry point group ``jointwear.terms``.
:func:`parse_model_spec` knows the built-in names; :func:`parse_spec` adds the shapes and user terms
(:func:`resolve_term`), so a parameter set's ``model`` spec and the workbench's ``--model`` read alike.

>>> t = resolve_term("x_stribeck(lube_hours)")
>>> t.name, t.param_names, t.linear
('x_stribeck(lube_hours)', ('x_stribeck_lube_hours_a', 'x_stribeck_lube_hours_vs'), ('x_stribeck_lube_hours_a',))
>>> parse_spec("paper + ripple(position, w0=3)").term_names[-1]
'ripple(position, w0=3)'
"""

from __future__ import annotations

import importlib
import re
from typing import Any

from ..errors import ModelError
from .model import Model, Term
from .shapes import IDENT, SHAPES, shape_class
from .terms import TERMS, term_by_name

__all__ = [
    "ENTRY_POINT_GROUP",
    "MODEL_SPECS",
    "paper_model",
    "paper_wear_model",
    "parse_model_spec",
    "parse_spec",
    "resolve_term",
    "split_model_spec",
    "standard_model",
]

#: Entry point group for user terms (``name = pkg.module:ClassName``).
ENTRY_POINT_GROUP = "jointwear.terms"

#: Named model specifications.
MODEL_SPECS: dict[str, tuple[str, ...]] = {
    "standard": ("coulomb", "stribeck", "viscous"),
    "paper": ("coulomb", "load_coulomb", "load_stribeck", "temp_stribeck", "temp_viscous"),
    "paper+wear": (
        "coulomb",
        "load_coulomb",
        "load_stribeck",
        "temp_stribeck",
        "temp_viscous",
        "wear_stribeck",
        "wear_viscous",
    ),
}

_CALL = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\((.*)\)$")


def parse_model_spec(spec: str, resolver: Any = None) -> Model:
    """Build a model from a spec string.

    ``spec`` is a named spec (``standard``, ``paper``, ``paper+wear``) or a sum
    ``A + B + ...`` of named specs and term names. ``resolver`` (optional) is a
    callable ``name -> Term | None`` consulted for names that are not built-in
    (candidate effects, user terms by dotted path); the first one to return a
    term wins.
    """
    text = spec.strip()
    if not text:
        raise ModelError("empty model spec; use e.g. 'paper', 'standard' or 'coulomb + viscous'")
    if text in MODEL_SPECS:
        return Model(term_by_name(n) for n in MODEL_SPECS[text])
    parts = _split_top_level(text)
    terms: list[Term] = []
    for part in parts:
        if part in MODEL_SPECS:
            terms.extend(term_by_name(n) for n in MODEL_SPECS[part])
            continue
        term = resolver(part) if resolver is not None else None
        if term is None:
            term = term_by_name(part)
        terms.append(term)
    return Model(terms)


def split_model_spec(text: str) -> list[str]:
    """The parts of a spec: split on '+' outside parentheses; the named spec 'paper+wear' stays one name.

    >>> split_model_spec("paper+wear + ripple(position, w0=3)")
    ['paper+wear', 'ripple(position, w0=3)']
    """
    return _split_top_level(text)


def _split_top_level(text: str) -> list[str]:
    """Split on '+' outside parentheses; the named spec 'paper+wear' stays one name."""
    raw: list[str] = []
    depth = 0
    cur = ""
    for c in text:
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
        if c == "+" and depth == 0:
            raw.append(cur.strip())
            cur = ""
        else:
            cur += c
    raw.append(cur.strip())
    if depth != 0 or any(not p for p in raw):
        raise ModelError(f"malformed model spec {text!r}: unbalanced parentheses or an empty term")
    out: list[str] = []
    for part in raw:
        if part == "wear" and out and out[-1] == "paper":
            out[-1] = "paper+wear"
        else:
            out.append(part)
    return out


def standard_model() -> Model:
    """Coulomb + Stribeck + viscous: the standard static model, no load or temperature."""
    return parse_model_spec("standard")


def paper_model() -> Model:
    """Eq. (6): load and temperature effects, no wear."""
    return parse_model_spec("paper")


def paper_wear_model() -> Model:
    """Eq. (9): Eq. (6) plus the wear terms of Eq. (7)."""
    return parse_model_spec("paper+wear")


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
    from importlib import metadata  # on use: it costs every node importing the model 0.1-0.2 s

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
    """:func:`parse_model_spec` with the shapes and user terms (:func:`resolve_term`)."""
    return parse_model_spec(spec, resolver=resolve_term)
