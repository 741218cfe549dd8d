"""The library of candidate effects, and the resolver that turns a term string into a term.

A candidate is a :class:`~jointwear_ros.model.Term` that can be added on top of
a model. Three kinds:

* the paper's own terms (``load_coulomb``, ``load_stribeck``, ``temp_stribeck``,
  ``temp_viscous``, ``wear_stribeck``, ``wear_viscous``) when the data has their
  inputs and the model does not hold them yet;
* physically shaped generic terms of ANY numeric column ``x`` of the data,
  named ``shape(x)`` (or ``shape(x,y)`` for interactions), with ``v = |speed|``
  and ``S(v; vs) = exp(-|v/vs|^1.3)``:

  ============================  =======================================  ==========================
  term string                   equation                                 physical reading
  ============================  =======================================  ==========================
  ``lin(x)``                    ``a*x``                                  Coulomb level shifts with x
  ``x_stribeck(x)``             ``a*x*S(v; vs)``                         low-speed friction with x
  ``x_viscous(x)``              ``a*x*v``                                viscous slope changes with x
  ``exp_viscous(x)``            ``a*exp(-x/c)*v``                        viscosity, exponential in x
  ``ripple(x)``                 ``a*sin(w*x) + b*cos(w*x)``              periodic in joint angle x
  ``inter(x,y)``                ``a*x*y``                                interaction of x and y
  ============================  =======================================  ==========================

* user terms: a small :class:`~jointwear_ros.model.Term` subclass loaded by
  dotted path ``pkg.module:ClassName`` or by name from the entry point group
  ``jointwear.terms``.

The library only proposes candidates; choosing among them is
:mod:`jointwear_ros.workbench.diagnose`'s job.

>>> t = resolve_term("x_stribeck(lube_hours)")
>>> t.name, t.param_names
('x_stribeck(lube_hours)', ('x_stribeck_lube_hours_a', 'x_stribeck_lube_hours_vs'))
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable, Mapping, Sequence
from importlib import metadata
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from ..errors import ModelError
from ..model import MODEL_SPECS, STRIBECK_EXPONENT, TERMS, Model, ParamSpec, Term, parse_model_spec, stribeck_shape
from ..model.scaling import DataScales, scale_grid
from ..types import ObservationTable

__all__ = [
    "ENTRY_POINT_GROUP",
    "NON_CANDIDATE_COLUMNS",
    "PAPER_CANDIDATES",
    "SHAPES",
    "CandidateTerm",
    "ExpViscous",
    "Interaction",
    "Lin",
    "Ripple",
    "XStribeck",
    "XViscous",
    "all_shapes",
    "candidate_library",
    "candidate_variables",
    "describe_term",
    "linear_params",
    "parse_spec",
    "resolve_term",
    "start_grid",
]

Array = npt.NDArray[np.float64]
Inputs = Mapping[str, Array]
Values = Mapping[str, float]

#: Entry point group for user terms (``name = pkg.module:ClassName``).
ENTRY_POINT_GROUP = "jointwear.terms"

#: Columns never used as a candidate's variable: the response, its parts and ids.
NON_CANDIDATE_COLUMNS = frozenset({"speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "cycle"})

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_CALL = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\((.*)\)$")


def broadcast_shape(x: Inputs) -> tuple[int, ...]:
    return np.broadcast(*[np.asarray(a) for a in x.values()]).shape


def column_values(x: Inputs, name: str) -> Array:
    return np.asarray(x[name], dtype=float)


class CandidateTerm(Term):
    """A generic term parametrised by column name(s): ``shape(x)`` or ``shape(x,y)``.

    Subclasses set ``shape``, ``arity``, ``param_suffixes`` (with unit, default,
    bounds), ``linear`` (suffixes of the parameters the term is linear in) and
    ``formula`` (with ``{x}``/``{y}`` and ``{p_<suffix>}`` placeholders), and
    implement :meth:`value` and :meth:`param_gradient`.
    """

    shape: ClassVar[str] = ""
    arity: ClassVar[int] = 1
    param_suffixes: ClassVar[tuple[tuple[str, str, float, float, float], ...]] = ()
    linear_suffixes: ClassVar[tuple[str, ...]] = ()
    formula: ClassVar[str] = ""
    meaning: ClassVar[str] = ""

    def __init__(self, *columns: str) -> None:
        if len(columns) != self.arity:
            raise ModelError(f"term {self.shape}(...) takes {self.arity} column name(s), got {len(columns)}")
        for c in columns:
            if not _IDENT.match(c):
                raise ModelError(f"term {self.shape}({','.join(columns)}): {c!r} is not a column name")
            if c in ("tau_f", "tau_plus", "tau_minus", "tau_f_std"):
                raise ModelError(f"term {self.shape}({c}): {c!r} is the measured friction, not an input")
        self.columns = tuple(columns)
        tag = f"{self.shape}_{'_'.join(columns)}"
        self.prefix = tag
        self.name = f"{self.shape}({','.join(columns)})"  # type: ignore[misc]
        self.variables = tuple(dict.fromkeys(("speed", *columns)))  # type: ignore[misc]
        self.params = tuple(  # type: ignore[misc]
            ParamSpec(f"{tag}_{s}", unit, default, lo, hi, f"{s} of {self.name}")
            for s, unit, default, lo, hi in self.param_suffixes
        )
        fmt = {"x": columns[0], "y": columns[-1], **{f"p_{s[0]}": f"{tag}_{s[0]}" for s in self.param_suffixes}}
        self.equation = self.formula.format(**fmt)  # type: ignore[misc]

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(repr(c) for c in self.columns)})"

    def p(self, p: Values, suffix: str) -> float:
        return float(p[f"{self.prefix}_{suffix}"])

    def pn(self, suffix: str) -> str:
        return f"{self.prefix}_{suffix}"

    @property
    def linear(self) -> tuple[str, ...]:
        return tuple(self.pn(s) for s in self.linear_suffixes)

    def grid(self, x: Inputs) -> list[dict[str, float]]:
        """Starting values of the nonlinear parameters to try (the linear ones are solved for)."""
        return [{}]

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var not in self.variables:
            return np.zeros(broadcast_shape(x))
        return super().input_gradient(x, p, var)


class Lin(CandidateTerm):
    """``a*x``: the Coulomb level shifts linearly with column x (dimensionless a per unit x)."""

    shape = "lin"
    param_suffixes = (("a", "-/x", 0.0, -np.inf, np.inf),)
    linear_suffixes = ("a",)
    formula = "{p_a}*{x}"
    meaning = "friction level (all speeds) changes with {x}"

    def value(self, x: Inputs, p: Values) -> Array:
        return np.broadcast_to(self.p(p, "a") * column_values(x, self.columns[0]), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        return {self.pn("a"): np.broadcast_to(column_values(x, self.columns[0]), broadcast_shape(x)).copy()}


class XStribeck(CandidateTerm):
    """``a*x*exp(-|v/vs|^1.3)``: low-speed (Stribeck) friction scaled by column x; vs in rad/s."""

    shape = "x_stribeck"
    param_suffixes = (("a", "-/x", 0.0, -np.inf, np.inf), ("vs", "rad/s", 20.0, 0.3, 1000.0))
    linear_suffixes = ("a",)
    formula = "{p_a}*{x}*exp(-|v/{p_vs}|^1.3)"
    meaning = "low-speed (Stribeck) friction changes with {x}"

    def grid(self, x: Inputs) -> list[dict[str, float]]:
        return [{self.pn("vs"): vs} for vs in (3.0, 8.0, 20.0, 50.0, 120.0)]

    def value(self, x: Inputs, p: Values) -> Array:
        s, _ = stribeck_shape(np.abs(column_values(x, "speed")), self.p(p, "vs"))
        return np.broadcast_to(self.p(p, "a") * column_values(x, self.columns[0]) * s, broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        vs = self.p(p, "vs")
        s, ra = stribeck_shape(np.abs(column_values(x, "speed")), vs)
        xs = column_values(x, self.columns[0]) * s
        sh = broadcast_shape(x)
        return {
            self.pn("a"): np.broadcast_to(xs, sh).copy(),
            self.pn("vs"): np.broadcast_to(self.p(p, "a") * xs * STRIBECK_EXPONENT * ra / vs, sh).copy(),
        }


class XViscous(CandidateTerm):
    """``a*x*v``: the viscous slope changes linearly with column x; a in s/rad per unit x."""

    shape = "x_viscous"
    param_suffixes = (("a", "s/rad/x", 0.0, -np.inf, np.inf),)
    linear_suffixes = ("a",)
    formula = "{p_a}*{x}*v"
    meaning = "viscous slope (high speed) changes with {x}"

    def value(self, x: Inputs, p: Values) -> Array:
        return np.broadcast_to(self.p(p, "a") * column_values(x, self.columns[0]) * np.abs(column_values(x, "speed")), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        g = column_values(x, self.columns[0]) * np.abs(column_values(x, "speed"))
        return {self.pn("a"): np.broadcast_to(g, broadcast_shape(x)).copy()}


class ExpViscous(CandidateTerm):
    """``a*exp(-x/c)*v``: viscosity falling exponentially with column x (c in units of x)."""

    shape = "exp_viscous"
    param_suffixes = (("a", "s/rad", 0.0, -np.inf, np.inf), ("c", "x", 25.0, 1e-6, 1e12))
    linear_suffixes = ("a",)
    formula = "{p_a}*exp(-{x}/{p_c})*v"
    meaning = "viscous slope (high speed) changes exponentially with {x}"

    def grid(self, x: Inputs) -> list[dict[str, float]]:
        col = column_values(x, self.columns[0])
        span = float(np.ptp(col)) if col.size else 1.0
        scale = max(span, float(np.max(np.abs(col))) if col.size else 1.0, 1e-6)
        return [{self.pn("c"): f * scale} for f in (0.1, 0.3, 1.0, 3.0)]

    def _e(self, x: Inputs, p: Values) -> Array:
        with np.errstate(over="ignore", under="ignore"):
            return np.exp(np.clip(-column_values(x, self.columns[0]) / self.p(p, "c"), -700.0, 700.0))

    def value(self, x: Inputs, p: Values) -> Array:
        return np.broadcast_to(self.p(p, "a") * self._e(x, p) * np.abs(column_values(x, "speed")), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        c = self.p(p, "c")
        ev = self._e(x, p) * np.abs(column_values(x, "speed"))
        sh = broadcast_shape(x)
        return {
            self.pn("a"): np.broadcast_to(ev, sh).copy(),
            self.pn("c"): np.broadcast_to(self.p(p, "a") * ev * column_values(x, self.columns[0]) / c**2, sh).copy(),
        }


class Ripple(CandidateTerm):
    """``a*sin(w*x) + b*cos(w*x)``: friction periodic in column x (a joint angle, rad); w in 1/rad."""

    shape = "ripple"
    param_suffixes = (
        ("a", "-", 0.0, -np.inf, np.inf),
        ("b", "-", 0.0, -np.inf, np.inf),
        ("w", "1/x", 1.0, 1e-3, 200.0),
    )
    linear_suffixes = ("a", "b")
    formula = "{p_a}*sin({p_w}*{x}) + {p_b}*cos({p_w}*{x})"
    meaning = "friction periodic in {x}"

    #: Angular frequencies tried as starts, 1/rad (harmonics up to 12 per radian).
    W_GRID: ClassVar[tuple[float, ...]] = tuple(float(w) for w in np.arange(0.25, 12.01, 0.25))

    def grid(self, x: Inputs) -> list[dict[str, float]]:
        return [{self.pn("w"): w} for w in self.W_GRID]

    def value(self, x: Inputs, p: Values) -> Array:
        wx = self.p(p, "w") * column_values(x, self.columns[0])
        return np.broadcast_to(self.p(p, "a") * np.sin(wx) + self.p(p, "b") * np.cos(wx), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        col = column_values(x, self.columns[0])
        wx = self.p(p, "w") * col
        s, c = np.sin(wx), np.cos(wx)
        sh = broadcast_shape(x)
        return {
            self.pn("a"): np.broadcast_to(s, sh).copy(),
            self.pn("b"): np.broadcast_to(c, sh).copy(),
            self.pn("w"): np.broadcast_to((self.p(p, "a") * c - self.p(p, "b") * s) * col, sh).copy(),
        }


class Interaction(CandidateTerm):
    """``a*x*y``: the friction level changes with the product of columns x and y."""

    shape = "inter"
    arity = 2
    param_suffixes = (("a", "-/(x*y)", 0.0, -np.inf, np.inf),)
    linear_suffixes = ("a",)
    formula = "{p_a}*{x}*{y}"
    meaning = "friction level changes with {x} times {y}"

    def value(self, x: Inputs, p: Values) -> Array:
        g = column_values(x, self.columns[0]) * column_values(x, self.columns[1])
        return np.broadcast_to(self.p(p, "a") * g, broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        g = column_values(x, self.columns[0]) * column_values(x, self.columns[1])
        return {self.pn("a"): np.broadcast_to(g, broadcast_shape(x)).copy()}


#: Generic shapes by name.
SHAPES: dict[str, type[CandidateTerm]] = {
    c.shape: c for c in (Lin, XStribeck, XViscous, ExpViscous, Ripple, Interaction)
}

#: The paper's terms as candidates: (linear parameters, starting values of the nonlinear ones, meaning).
PAPER_CANDIDATES: dict[str, tuple[tuple[str, ...], list[dict[str, float]], str]] = {
    "load_coulomb": (("Fctm",), [{}], "Coulomb friction grows with load torque (Eq. 6a)"),
    "load_stribeck": (
        ("Fstm",), [{"vstm": v} for v in (4.0, 12.0, 30.0, 80.0)],
        "low-speed friction hump grows with load torque (Eq. 6a)",
    ),
    "temp_stribeck": (
        ("Fs0", "FsT"), [{"vs0": v, "vsT": 0.0} for v in (10.0, 30.0, 60.0, 120.0)],
        "low-speed friction changes with temperature (Eq. 6b)",
    ),
    "temp_viscous": (
        ("Fv0", "FvT"), [{"Tv0": t} for t in (10.0, 25.0, 60.0)],
        "viscous slope falls with temperature (Eq. 6c)",
    ),
    "wear_stribeck": (
        ("Fsw",), [{"vsw": v} for v in (0.5, 2.2, 8.0)], "low-speed friction grows with wear (Eq. 7)",
    ),
    "wear_viscous": (("Fvw",), [{}], "viscous slope changes with wear (Eq. 7)"),
}

# generic candidates that would only repeat a paper term (load_torque >= 0)
_DUPLICATES = {"lin(load_torque)": "load_coulomb", "x_stribeck(load_torque)": "load_stribeck"}


def linear_params(term: Term) -> tuple[str, ...]:
    """Names of the parameters ``term`` is linear in (empty when unknown, e.g. user terms)."""
    if isinstance(term, CandidateTerm):
        return term.linear
    if term.name in PAPER_CANDIDATES and type(term) is TERMS.get(term.name):
        return PAPER_CANDIDATES[term.name][0]
    return ()


def start_grid(term: Term, x: Inputs) -> list[dict[str, float]]:
    """Starting values of ``term``'s nonlinear parameters to try, scaled to the data's speeds.

    The grids are written for the paper's joint (motor side, up to ~280 rad/s);
    a speed-like parameter (``rad/s``) is scaled by the data's speed scale
    (:class:`~jointwear_ros.model.scaling.DataScales`), so joint-side data
    at a few rad/s get Stribeck speeds inside their own range.
    """
    if isinstance(term, CandidateTerm):
        grid = term.grid(x)
    elif term.name in PAPER_CANDIDATES and type(term) is TERMS.get(term.name):
        grid = [dict(g) for g in PAPER_CANDIDATES[term.name][1]]
    else:
        return [{}]
    sc = DataScales.of(speed=x.get("speed"))
    return grid if sc.speed == 1.0 else scale_grid(term, grid, sc)


def describe_term(term: Term) -> str:
    """What the term means physically, in a few words."""
    if isinstance(term, CandidateTerm):
        return term.meaning.format(x=term.columns[0], y=term.columns[-1])
    if term.name in PAPER_CANDIDATES:
        return PAPER_CANDIDATES[term.name][2]
    doc = (type(term).__doc__ or "").strip().splitlines()
    return doc[0] if doc else term.name


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
        shapes = all_shapes()
        cls = shapes.get(shape)
        if cls is None:
            raise ModelError(
                f"unknown term shape {shape!r} in {text!r}; shapes: {', '.join(f'{s}(x)' for s in shapes)}"
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
            if not _IDENT.match(key):
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


def all_shapes() -> dict[str, Any]:
    """Every generic shape by spec name: the fixed library's and the fitted ones of :mod:`.shapes`."""
    from .shapes import NEW_SHAPES

    return {**SHAPES, **NEW_SHAPES}


def parse_spec(spec: str) -> Model:
    """:func:`~jointwear_ros.model.parse_model_spec` with the candidate and user-term resolver."""
    return parse_model_spec(spec, resolver=resolve_term)


# -- the library --------------------------------------------------------------
def candidate_variables(table: ObservationTable) -> list[str]:
    """Columns usable as a candidate's variable: numeric, finite, not constant, not the response."""
    out = []
    for name, col in table.columns.items():
        if name in NON_CANDIDATE_COLUMNS or not _IDENT.match(name):
            continue
        if col.size == 0 or not np.all(np.isfinite(col)) or float(np.ptp(col)) == 0.0:
            continue
        out.append(name)
    return out


def _is_angle(name: str) -> bool:
    return name == "position" or "angle" in name or name.startswith("position")


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

    Paper terms whose inputs the data has, generic shapes of every usable
    column (ripple only for angle-like columns), interactions with load and
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
    for name in PAPER_CANDIDATES:
        term = TERMS[name]()
        if name not in have and set(term.variables) <= usable:
            out.append(term)
    for v in vars_:
        names = shapes(v) if shapes is not None else (
            ["lin", "x_stribeck", "x_viscous", "exp_viscous"] + (["ripple"] if _is_angle(v) else [])
        )
        shape_classes = all_shapes()
        for s in names:
            term = shape_classes[s](v)
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
