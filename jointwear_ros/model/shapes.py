"""Shapes: generic candidate terms of the data's columns, and the one registry of them.

A shape is a :class:`CandidateTerm` written in a model spec as
``shape(column, ..., option=value, ...)``: positional arguments are column
names (``scale`` takes a built-in term name first), the options are numbers
that fix the shape's structure or its starting point, so that a spec string
reproduces the fit (``--model "paper + ripple(position, w0=17.2)"``). Every
shape is in :data:`SHAPES`, by its spec name; :func:`register_shape` adds one
(a decorator), and an installed package can offer shapes in the entry point
group ``jointwear.shapes`` (``name = pkg.module:Class``).

The fixed library (``v = |speed|``, ``S(v; vs) = exp(-|v/vs|^1.3)``), offered
for every column the diagnosis finds (:attr:`CandidateTerm.library`; the ripple
only for angle-like columns):

============================  =======================================  ==========================
spec                          equation                                 physical reading
============================  =======================================  ==========================
``lin(x)``                    ``a*x``                                  Coulomb level shifts with x
``x_stribeck(x)``             ``a*x*S(v; vs)``                         low-speed friction with x
``x_viscous(x)``              ``a*x*v``                                viscous slope changes with x
``exp_viscous(x)``            ``a*exp(-x/c)*v``                        viscosity, exponential in x
``ripple(x)``                 ``a*sin(w*x) + b*cos(w*x)``              periodic in joint angle x
``inter(x,y)``                ``a*x*y``                                interaction of x and y
============================  =======================================  ==========================

The fitted shapes, which the diagnosis starts from what the model-free ranking
found (the periodogram's peak, the changepoint, the column's range, the
model's own terms):

=========================================  =================================================  ===========================
spec                                       equation                                           fitted parameters
=========================================  =================================================  ===========================
``ripple(x, w0=W, k=K)``                   ``sum_j a_j*sin(j*w*x) + b_j*cos(j*w*x)``, j=1..K   a, b, (a2, b2, ...), w
``step(x, at=C, width=S)``                 ``a / (1 + exp(-(x - c)/s))``                      a, c, s
``spline(x, lo=L, hi=H, n=N)``             ``sum_{j=2..N} c_j*B_j(x)``, cubic B-splines on     c2..cN
                                           N uniform basis functions over [L, H]
``scale(term, x[, y])``                    ``x*[y*]term(v, ...; own copy of term's params)``  the term's parameters
=========================================  =================================================  ===========================

``w0``, ``at``, ``width`` are starting values (the fit moves them); ``k``,
``lo``, ``hi``, ``n`` fix the structure. A new shape: docs/extending.md,
"A workbench shape".

>>> from jointwear_ros.model import parse_spec
>>> m = parse_spec("paper + ripple(position, w0=17.2, k=2) + step(time, at=1.5e6, width=3e4)")
>>> m.term_names[-2:]
['ripple(position, w0=17.2, k=2)', 'step(time, at=1500000, width=30000)']
>>> list(SHAPES)[:9]  # the built-in ones, in the order the fixed library tries them
['lin', 'x_stribeck', 'x_viscous', 'exp_viscous', 'inter', 'ripple', 'step', 'spline', 'scale']
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import ClassVar, TypeVar

import numpy as np

from ..errors import ModelError
from .model import Array, Inputs, Term, Values
from .parameters import ParamSpec
from .terms import STRIBECK_EXPONENT, TERMS, stribeck_shape

__all__ = [
    "SHAPES",
    "SHAPE_ENTRY_POINT_GROUP",
    "CandidateTerm",
    "ExpViscous",
    "HarmonicRipple",
    "Interaction",
    "Lin",
    "LinearShape",
    "Scale",
    "Spline",
    "Step",
    "XStribeck",
    "XViscous",
    "format_option",
    "is_angle",
    "register_shape",
    "shape_class",
]


#: Entry point group of shapes from installed packages (``name = pkg.module:Class``).
SHAPE_ENTRY_POINT_GROUP = "jointwear.shapes"

IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def is_angle(name: str) -> bool:
    """Columns a periodic shape (the ripple, the periodogram) is tried on: joint angles."""
    return name == "position" or "angle" in name or name.startswith("position")


def broadcast_shape(x: Inputs) -> tuple[int, ...]:
    shape = getattr(x, "shape", None)  # inputs prepared once (Model.prepare) carry their broadcast shape
    if shape is not None:
        return shape  # type: ignore[no-any-return]
    return np.broadcast(*[np.asarray(a) for a in x.values()]).shape


def column_values(x: Inputs, name: str) -> Array:
    return np.asarray(x[name], dtype=float)


class CandidateTerm(Term):
    """A generic term parametrised by column name(s): ``shape(x)`` or ``shape(x,y)``.

    Subclasses set ``shape`` (the spec name), ``arity``, ``param_suffixes``
    (suffix, unit, default, min, max), ``linear_suffixes`` (the parameters the
    term is linear in), ``formula`` and ``meaning`` (with ``{x}``/``{y}`` and
    ``{p_<suffix>}`` placeholders) and ``library`` (offered by the fixed
    library for a column, :meth:`offered_for`), implement :meth:`value` and
    :meth:`param_gradient`, and may override :meth:`start_points` (starts of
    the nonlinear parameters) and ``from_call`` (a shape with options). The
    term's workbench hints (:attr:`~jointwear_ros.model.Term.linear`,
    :meth:`~jointwear_ros.model.Term.guess`, ``meaning``) follow from these.
    Register the class with :func:`register_shape`.
    """

    shape: ClassVar[str] = ""
    arity: ClassVar[int] = 1
    param_suffixes: ClassVar[tuple[tuple[str, str, float, float, float], ...]] = ()
    linear_suffixes: ClassVar[tuple[str, ...]] = ()
    formula: ClassVar[str] = ""
    #: Offered by the fixed library for a column the diagnosis finds (see :meth:`offered_for`).
    library: ClassVar[bool] = False

    def __init__(self, *columns: str) -> None:
        if len(columns) != self.arity:
            raise ModelError(f"term {self.shape}(...) takes {self.arity} column name(s), got {len(columns)}")
        for c in columns:
            if not IDENT.match(c):
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
        self.meaning = self.meaning.format(x=columns[0], y=columns[-1])  # type: ignore[misc]
        self.linear = tuple(self.pn(s) for s in self.linear_suffixes)  # type: ignore[misc]

    @classmethod
    def offered_for(cls, column: str) -> bool:
        """Does the fixed library try this shape on ``column``? (:attr:`library`, one column.)"""
        return cls.library and cls.arity == 1

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(repr(c) for c in self.columns)})"

    def p(self, p: Values, suffix: str) -> float:
        return float(p[f"{self.prefix}_{suffix}"])

    def pn(self, suffix: str) -> str:
        return f"{self.prefix}_{suffix}"

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var not in self.variables:
            return np.zeros(broadcast_shape(x))
        return super().input_gradient(x, p, var)


#: Every shape by its spec name, in the order the fixed library tries them: the built-in ones and those
#: added with :func:`register_shape` (or found in the entry point group :data:`SHAPE_ENTRY_POINT_GROUP`).
SHAPES: dict[str, type[CandidateTerm]] = {}

_S = TypeVar("_S", bound=type[CandidateTerm])


def register_shape(cls: _S) -> _S:
    """Add a :class:`CandidateTerm` subclass to :data:`SHAPES` under its ``shape`` name (a class decorator).

    The spec grammar then knows it (``parse_spec("paper + NAME(column, ...)")``); with
    ``library = True`` the fixed library of the diagnosis tries it on every column it finds.
    A name taken by another class is an error (the same class registered again is not).
    """
    name = getattr(cls, "shape", "")
    if not (isinstance(cls, type) and issubclass(cls, CandidateTerm)):
        raise ModelError(f"register_shape: {cls!r} is not a CandidateTerm subclass")
    if not IDENT.match(name):
        raise ModelError(f"register_shape: {cls.__qualname__}.shape = {name!r} is not an identifier")
    old = SHAPES.get(name)
    if old is not None and (old.__module__, old.__qualname__) != (cls.__module__, cls.__qualname__):
        raise ModelError(f"register_shape: shape {name!r} is taken by {old.__module__}.{old.__qualname__}")
    SHAPES[name] = cls
    return cls


def shape_class(name: str) -> type[CandidateTerm] | None:
    """The shape registered as ``name``, else the one an installed package offers under that name (None: none)."""
    if name in SHAPES:
        return SHAPES[name]
    from importlib import metadata  # on use: it costs every node importing the model 0.1-0.2 s

    try:
        eps = [ep for ep in metadata.entry_points(group=SHAPE_ENTRY_POINT_GROUP) if ep.name == name]
    except Exception:
        return None
    for ep in eps:
        try:
            cls = ep.load()
        except Exception as exc:
            raise ModelError(f"shape {name!r} (entry point {ep.value}): cannot load it ({exc})") from None
        register_shape(cls)
        return SHAPES.get(name)
    return None


# -- the fixed library ----------------------------------------------------------
class LinearShape(CandidateTerm):
    """A shape ``a * feature(x)`` with one amplitude ``a``: subclasses give :meth:`feature`."""

    linear_suffixes = ("a",)

    def feature(self, x: Inputs) -> Array:  # pragma: no cover - abstract
        raise NotImplementedError

    def value(self, x: Inputs, p: Values) -> Array:
        return np.broadcast_to(self.p(p, "a") * self.feature(x), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        return {self.pn("a"): np.broadcast_to(self.feature(x), broadcast_shape(x)).copy()}


@register_shape
class Lin(LinearShape):
    """``a*x``: the Coulomb level shifts linearly with column x (dimensionless a per unit x)."""

    shape = "lin"
    library = True
    param_suffixes = (("a", "-/x", 0.0, -np.inf, np.inf),)
    formula = "{p_a}*{x}"
    meaning = "friction level (all speeds) changes with {x}"

    def feature(self, x: Inputs) -> Array:
        return column_values(x, self.columns[0])


@register_shape
class XStribeck(CandidateTerm):
    """``a*x*exp(-|v/vs|^1.3)``: low-speed (Stribeck) friction scaled by column x; vs in rad/s."""

    shape = "x_stribeck"
    library = True
    param_suffixes = (("a", "-/x", 0.0, -np.inf, np.inf), ("vs", "rad/s", 20.0, 0.3, 1000.0))
    linear_suffixes = ("a",)
    formula = "{p_a}*{x}*exp(-|v/{p_vs}|^1.3)"
    meaning = "low-speed (Stribeck) friction changes with {x}"

    def start_points(self, x: Inputs) -> list[dict[str, float]]:
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


@register_shape
class XViscous(LinearShape):
    """``a*x*v``: the viscous slope changes linearly with column x; a in s/rad per unit x."""

    shape = "x_viscous"
    library = True
    param_suffixes = (("a", "s/rad/x", 0.0, -np.inf, np.inf),)
    formula = "{p_a}*{x}*v"
    meaning = "viscous slope (high speed) changes with {x}"

    def feature(self, x: Inputs) -> Array:
        return column_values(x, self.columns[0]) * np.abs(column_values(x, "speed"))  # type: ignore[no-any-return]


@register_shape
class ExpViscous(CandidateTerm):
    """``a*exp(-x/c)*v``: viscosity falling exponentially with column x (c in units of x)."""

    shape = "exp_viscous"
    library = True
    param_suffixes = (("a", "s/rad", 0.0, -np.inf, np.inf), ("c", "x", 25.0, 1e-6, 1e12))
    linear_suffixes = ("a",)
    formula = "{p_a}*exp(-{x}/{p_c})*v"
    meaning = "viscous slope (high speed) changes exponentially with {x}"

    def start_points(self, x: Inputs) -> list[dict[str, float]]:
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


@register_shape
class Interaction(LinearShape):
    """``a*x*y``: the friction level changes with the product of columns x and y."""

    shape = "inter"
    arity = 2
    param_suffixes = (("a", "-/(x*y)", 0.0, -np.inf, np.inf),)
    formula = "{p_a}*{x}*{y}"
    meaning = "friction level changes with {x} times {y}"

    def feature(self, x: Inputs) -> Array:
        return column_values(x, self.columns[0]) * column_values(x, self.columns[1])

# -- fitted shapes ---------------------------------------------------------------
def format_option(value: float) -> str:
    """A number as a spec option: 6 significant digits, no trailing zeros (``17.2``, ``1500000``)."""
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    return f"{value:.6g}"


def _option(options: Mapping[str, float], key: str, default: float | None, what: str) -> float:
    if key in options:
        return float(options[key])
    if default is None:
        raise ModelError(f"{what} needs the option {key}=VALUE")
    return default


def _check_options(name: str, options: Mapping[str, float], allowed: tuple[str, ...]) -> None:
    bad = [k for k in options if k not in allowed]
    if bad:
        raise ModelError(f"{name}: unknown option(s) {', '.join(bad)}; allowed: {', '.join(allowed) or 'none'}")
    for k, v in options.items():
        if not math.isfinite(v):
            raise ModelError(f"{name}: option {k}={v} is not a finite number")


@register_shape
class HarmonicRipple(CandidateTerm):
    """Friction periodic in column x at any frequency, with harmonics.

    ``tau = sum_{j=1..k} a_j*sin(j*w*x) + b_j*cos(j*w*x)`` (a_1, b_1 are named
    ``a``, ``b``); w in 1/(unit of x), started at ``w0`` (the periodogram's
    peak when the diagnosis writes the spec). The amplitudes are linear, w is
    fitted. A gear's tooth-mesh or bearing ripple in joint angle.

    >>> import numpy as np
    >>> t = HarmonicRipple.from_call(["position"], {"w0": 17.0, "k": 2})
    >>> t.name, t.param_names
    ('ripple(position, w0=17, k=2)', ('ripple_position_a', 'ripple_position_b', 'ripple_position_w', 'ripple_position_a2', 'ripple_position_b2'))
    >>> p = {"ripple_position_a": 0.003, "ripple_position_b": 0.0, "ripple_position_w": 17.0,
    ...      "ripple_position_a2": 0.0, "ripple_position_b2": 0.001}
    >>> round(float(t.value({"speed": np.array([10.0]), "position": np.array([0.1])}, p)[0]), 6)
    0.002008
    """

    shape = "ripple"
    library = True
    formula = "{p_a}*sin({p_w}*{x}) + {p_b}*cos({p_w}*{x})"
    meaning = "friction periodic in {x}"
    #: Largest angular frequency, 1/(unit of x).
    W_MAX: ClassVar[float] = 500.0

    def __init__(self, column: str, w0: float | None = None, k: int = 1) -> None:
        if not 1 <= k <= 6:
            raise ModelError(f"ripple({column}): k={k} harmonics; give 1 to 6")
        if w0 is not None and not (0 < w0 <= self.W_MAX):
            raise ModelError(f"ripple({column}): w0={w0} must be in (0, {self.W_MAX:g}]")
        self.k = int(k)
        self.w0 = w0
        suffixes: list[tuple[str, str, float, float, float]] = [
            ("a", "-", 0.0, -np.inf, np.inf), ("b", "-", 0.0, -np.inf, np.inf),
            ("w", "1/x", 1.0 if w0 is None else float(w0), 1e-3, self.W_MAX),
        ]
        for j in range(2, self.k + 1):
            suffixes += [(f"a{j}", "-", 0.0, -np.inf, np.inf), (f"b{j}", "-", 0.0, -np.inf, np.inf)]
        self.param_suffixes = tuple(suffixes)  # type: ignore[misc]
        self.linear_suffixes = tuple(s[0] for s in suffixes if s[0] != "w")  # type: ignore[misc]
        super().__init__(column)
        opts = [] if w0 is None else [f"w0={format_option(w0)}"]
        if self.k > 1:
            opts.append(f"k={self.k}")
        if opts:
            self.name = f"ripple({column}, {', '.join(opts)})"  # type: ignore[misc]
        eq = [self.equation]
        w = self.pn("w")
        for j in range(2, self.k + 1):
            eq.append(f"{self.pn(f'a{j}')}*sin({j}*{w}*{column}) + {self.pn(f'b{j}')}*cos({j}*{w}*{column})")
        self.equation = " + ".join(eq)  # type: ignore[misc]

    @classmethod
    def from_call(cls, args: list[str], options: Mapping[str, float]) -> HarmonicRipple:
        if len(args) != 1:
            raise ModelError(f"ripple(...) takes one column name, got {len(args)}")
        _check_options("ripple", options, ("w0", "k"))
        k = options.get("k", 1.0)
        if not float(k).is_integer():
            raise ModelError(f"ripple({args[0]}): k={k} must be a whole number")
        return cls(args[0], options.get("w0"), int(k))

    def __repr__(self) -> str:
        return f"HarmonicRipple({self.columns[0]!r}, w0={self.w0!r}, k={self.k})"

    @classmethod
    def offered_for(cls, column: str) -> bool:
        """Only angle-like columns (:func:`is_angle`)."""
        return is_angle(column)

    #: Angular frequencies tried as starts without ``w0`` (harmonics up to 12 per unit of x).
    W_GRID: ClassVar[tuple[float, ...]] = tuple(float(w) for w in np.arange(0.25, 12.01, 0.25))

    def start_points(self, x: Inputs) -> list[dict[str, float]]:
        if self.w0 is not None:
            return [{self.pn("w"): self.w0}]
        return [{self.pn("w"): w} for w in self.W_GRID]

    def _amps(self, p: Values) -> list[tuple[float, float]]:
        out = [(self.p(p, "a"), self.p(p, "b"))]
        out += [(self.p(p, f"a{j}"), self.p(p, f"b{j}")) for j in range(2, self.k + 1)]
        return out

    def value(self, x: Inputs, p: Values) -> Array:
        col = column_values(x, self.columns[0])
        w = self.p(p, "w")
        tot = np.zeros_like(col)
        for j, (a, b) in enumerate(self._amps(p), start=1):
            tot = tot + a * np.sin(j * w * col) + b * np.cos(j * w * col)
        return np.broadcast_to(tot, broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        col = column_values(x, self.columns[0])
        w = self.p(p, "w")
        sh = broadcast_shape(x)
        out: dict[str, Array] = {}
        dw = np.zeros_like(col)
        for j, (a, b) in enumerate(self._amps(p), start=1):
            s, c = np.sin(j * w * col), np.cos(j * w * col)
            na, nb = (self.pn("a"), self.pn("b")) if j == 1 else (self.pn(f"a{j}"), self.pn(f"b{j}"))
            out[na] = np.broadcast_to(s, sh).copy()
            out[nb] = np.broadcast_to(c, sh).copy()
            dw = dw + (a * c - b * s) * j * col
        out[self.pn("w")] = np.broadcast_to(dw, sh).copy()
        return {n: out[n] for n in self.param_names}


@register_shape
class Step(CandidateTerm):
    """A smooth step in column x: a maintenance event (regreasing) in time, a threshold in any column.

    ``tau = a / (1 + exp(-(x - c)/s))``: the friction level changes by ``a``
    around ``x = c`` over a width ``s`` (units of x). ``a`` is linear; ``c``
    and ``s`` are fitted, started at ``at`` and ``width``; ``s`` is at most
    ``width`` (a gradual change is a spline's job). When the data has a gap
    around the change (no cycle between two days), any ``c`` in the gap fits
    equally well; the fit reports that as a large standard error. The bound
    keeps the step sharp in the gap: a step free to widen leans its tails
    into the cycles next to the change, and with one of those cycles held
    out (cross-validation) the refit moves the change over it.

    >>> import numpy as np
    >>> t = Step.from_call(["time"], {"at": 100.0, "width": 1.0})
    >>> t.name, t.equation
    ('step(time, at=100, width=1)', 'step_time_a/(1 + exp(-(time - step_time_c)/step_time_s))')
    >>> p = {"step_time_a": -0.005, "step_time_c": 100.0, "step_time_s": 1.0}
    >>> np.round(t.value({"speed": np.zeros(3), "time": np.array([90.0, 100.0, 110.0])}, p), 6).tolist()
    [-0.0, -0.0025, -0.005]
    """

    shape = "step"
    #: The centre stays within this many widths of ``at`` (the diagnosis puts ``at`` mid-gap between two groups
    #: of a per-cycle column and the width at a sixteenth of the gap: the centre stays in its middle half).
    #: There the fit is flat in the centre, and a free centre drifted to wherever the optimizer's last bits
    #: took it: a cross-validated cycle next to the step fell on either side, by the CPU
    CENTRE_WITHIN = 4.0
    formula = "{p_a}/(1 + exp(-({x} - {p_c})/{p_s}))"
    meaning = "friction level steps once in {x} (a maintenance event or a threshold)"

    def __init__(self, column: str, at: float, width: float) -> None:
        if not width > 0:
            raise ModelError(f"step({column}): width={width} must be > 0")
        self.at, self.width = float(at), float(width)
        self.param_suffixes = (  # type: ignore[misc]
            ("a", "-", 0.0, -np.inf, np.inf),
            ("c", "x", self.at, self.at - self.CENTRE_WITHIN * self.width, self.at + self.CENTRE_WITHIN * self.width),
            ("s", "x", self.width, self.width * 1e-6, self.width),
        )
        self.linear_suffixes = ("a",)  # type: ignore[misc]
        super().__init__(column)
        self.name = f"step({column}, at={format_option(self.at)}, width={format_option(self.width)})"  # type: ignore[misc]

    @classmethod
    def from_call(cls, args: list[str], options: Mapping[str, float]) -> Step:
        if len(args) != 1:
            raise ModelError(f"step(...) takes one column name, got {len(args)}")
        _check_options("step", options, ("at", "width"))
        return cls(args[0], _option(options, "at", None, f"step({args[0]})"),
                   _option(options, "width", None, f"step({args[0]})"))

    def __repr__(self) -> str:
        return f"Step({self.columns[0]!r}, at={self.at!r}, width={self.width!r})"

    def _sig(self, x: Inputs, p: Values) -> Array:
        z = (column_values(x, self.columns[0]) - self.p(p, "c")) / self.p(p, "s")
        with np.errstate(over="ignore"):
            return 1.0 / (1.0 + np.exp(-np.clip(z, -700.0, 700.0)))  # type: ignore[no-any-return]

    def value(self, x: Inputs, p: Values) -> Array:
        return np.broadcast_to(self.p(p, "a") * self._sig(x, p), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        a, c, s = self.p(p, "a"), self.p(p, "c"), self.p(p, "s")
        sig = self._sig(x, p)
        d = a * sig * (1.0 - sig)
        col = column_values(x, self.columns[0])
        sh = broadcast_shape(x)
        return {
            self.pn("a"): np.broadcast_to(sig, sh).copy(),
            self.pn("c"): np.broadcast_to(-d / s, sh).copy(),
            self.pn("s"): np.broadcast_to(-d * (col - c) / s**2, sh).copy(),
        }


@register_shape
class Spline(CandidateTerm):
    """A smooth function of column x: cubic B-splines (:class:`scipy.interpolate.BSpline`).

    ``tau = sum_{j=2..n} c_j * B_j(x)`` with ``n`` cubic B-spline basis
    functions on uniform clamped knots over ``[lo, hi]`` (x is clipped to that
    range). The first basis function is left out: the B-splines sum to 1, so
    with it the term would repeat the model's Coulomb level. Linear in every
    c_j. Saturating, monotone or any smooth effect of a column; the diagnosis
    chooses ``n`` by cross-validation.

    >>> import numpy as np
    >>> t = Spline.from_call(["hours_running"], {"lo": 0.0, "hi": 8.0, "n": 5})
    >>> t.param_names
    ('spline_hours_running_c2', 'spline_hours_running_c3', 'spline_hours_running_c4', 'spline_hours_running_c5')
    >>> p = dict.fromkeys(t.param_names, 0.002)
    >>> np.round(t.value({"speed": np.zeros(2), "hours_running": np.array([0.0, 8.0])}, p), 6).tolist()
    [0.0, 0.002]
    """

    shape = "spline"
    meaning = "friction level is a smooth function of {x}"

    def __init__(self, column: str, lo: float, hi: float, n: int = 5) -> None:
        if not hi > lo:
            raise ModelError(f"spline({column}): lo={lo} must be below hi={hi}")
        if not 4 <= n <= 20:
            raise ModelError(f"spline({column}): n={n} basis functions; give 4 to 20")
        self.lo, self.hi, self.n = float(lo), float(hi), int(n)
        inner = np.linspace(self.lo, self.hi, self.n - 2)
        self.knots = np.concatenate([[self.lo] * 3, inner, [self.hi] * 3])
        self.param_suffixes = tuple((f"c{j}", "-", 0.0, -np.inf, np.inf) for j in range(2, self.n + 1))  # type: ignore[misc]
        self.linear_suffixes = tuple(s[0] for s in self.param_suffixes)  # type: ignore[misc]
        super().__init__(column)
        self.name = (f"spline({column}, lo={format_option(self.lo)}, hi={format_option(self.hi)}, "  # type: ignore[misc]
                     f"n={self.n})")
        self.equation = (f"sum_j {self.prefix}_c<j>*B_j({column}), cubic B-splines j=2..{self.n} "  # type: ignore[misc]
                         f"on [{format_option(self.lo)}, {format_option(self.hi)}]")

    @classmethod
    def from_call(cls, args: list[str], options: Mapping[str, float]) -> Spline:
        if len(args) != 1:
            raise ModelError(f"spline(...) takes one column name, got {len(args)}")
        _check_options("spline", options, ("lo", "hi", "n"))
        n = options.get("n", 5.0)
        if not float(n).is_integer():
            raise ModelError(f"spline({args[0]}): n={n} must be a whole number")
        what = f"spline({args[0]})"
        return cls(args[0], _option(options, "lo", None, what), _option(options, "hi", None, what), int(n))

    def __repr__(self) -> str:
        return f"Spline({self.columns[0]!r}, lo={self.lo!r}, hi={self.hi!r}, n={self.n})"

    def basis(self, col: Array) -> Array:
        """The basis functions 2..n at ``col`` (clipped into [lo, hi]), shape (len(col), n - 1)."""
        c = np.clip(np.ravel(np.asarray(col, dtype=float)), self.lo, self.hi)
        from scipy.interpolate import BSpline  # scipy on use: importing the model stays quick

        dm = BSpline.design_matrix(c, self.knots, 3).toarray()
        return dm[:, 1:]  # type: ignore[no-any-return]

    def _basis_of(self, x: Inputs, col: Array) -> Array:
        """:meth:`basis` at the column of ``x``; once for inputs prepared once (``Model.prepare``: they keep it)."""
        memo = getattr(x, "memo", None)
        if memo is None:
            return self.basis(col)
        key = ("spline basis", self.columns[0], self.lo, self.hi, self.n)
        b = memo.get(key)
        if b is None:
            b = memo[key] = self.basis(col)
            b.setflags(write=False)
        return b  # type: ignore[no-any-return]

    def value(self, x: Inputs, p: Values) -> Array:
        col = column_values(x, self.columns[0])
        coef = np.array([self.p(p, s[0]) for s in self.param_suffixes])
        return np.broadcast_to((self._basis_of(x, col) @ coef).reshape(np.shape(col)), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        col = column_values(x, self.columns[0])
        b = self._basis_of(x, col)
        sh = broadcast_shape(x)
        return {self.pn(s[0]): np.broadcast_to(b[:, j].reshape(np.shape(col)), sh).copy()
                for j, s in enumerate(self.param_suffixes)}


@register_shape
class Scale(CandidateTerm):
    """An existing term of the model, scaled by a column (or a product of two): an interaction.

    ``tau = x * term(v, ...; theta')`` (or ``x*y*term``) where ``term`` is a
    built-in term (``stribeck``, ``load_stribeck``, ``temp_viscous``, ...) with
    its own copy ``theta'`` of the term's parameters (prefixed
    ``scale_<term>_<x>_``). Added to a model that holds ``term``, it reshapes
    it: ``Fs*S(v; vs) + x*Fs'*S(v; vs')`` is the Stribeck amplitude times
    ``(1 + a*x)`` when ``vs' = vs``. The amplitudes are linear and free in
    sign; the shape parameters keep the term's bounds and start at the
    model's current values.

    >>> import numpy as np
    >>> t = Scale.from_call(["load_stribeck", "temperature"], {})
    >>> t.name, t.param_names
    ('scale(load_stribeck, temperature)', ('scale_load_stribeck_temperature_Fstm', 'scale_load_stribeck_temperature_vstm'))
    >>> t.equation
    'temperature*(scale_load_stribeck_temperature_Fstm*|tau_m|*exp(-|v/scale_load_stribeck_temperature_vstm|^1.3))'
    >>> p = {"scale_load_stribeck_temperature_Fstm": 1e-3, "scale_load_stribeck_temperature_vstm": 12.0}
    >>> x = {"speed": np.array([0.0]), "load_torque": np.array([0.5]), "temperature": np.array([40.0])}
    >>> round(float(t.value(x, p)[0]), 6)
    0.02
    """

    shape = "scale"

    def __init__(self, term: str, *columns: str) -> None:
        if term not in TERMS:
            raise ModelError(f"scale({term}, ...): {term!r} is not a built-in term; terms: {', '.join(TERMS)}")
        if not 1 <= len(columns) <= 2:
            raise ModelError(f"scale({term}, ...) takes one or two column names, got {len(columns)}")
        self.inner: Term = TERMS[term]()
        self.term_name = term
        self.arity = len(columns)  # type: ignore[misc]
        lin = self.inner.linear
        self._rename = {}
        suffixes = []
        for ps in self.inner.params:
            lo, hi = (-np.inf, np.inf) if ps.name in lin else (ps.min, ps.max)
            default = 0.0 if ps.name in lin else ps.default
            suffixes.append((ps.name, ps.unit, default, lo, hi))
        self.param_suffixes = tuple(suffixes)  # type: ignore[misc]
        self.linear_suffixes = lin  # type: ignore[misc]
        super().__init__(*columns)
        tag = f"scale_{term}_{'_'.join(columns)}"
        self.prefix = tag
        self.params = tuple(  # type: ignore[misc]
            ParamSpec(f"{tag}_{s}", unit, d, lo, hi, f"{s} of {term} scaled by {'*'.join(columns)}")
            for s, unit, d, lo, hi in suffixes
        )
        self._rename = {ps.name: f"{tag}_{ps.name}" for ps in self.inner.params}
        self.linear = tuple(self._rename[n] for n in lin)  # type: ignore[misc]
        self.name = f"scale({term}, {', '.join(columns)})"  # type: ignore[misc]
        self.meaning = f"the {term} term changes with {'*'.join(columns)}"  # type: ignore[misc]
        self.variables = tuple(dict.fromkeys(("speed", *self.inner.variables, *columns)))  # type: ignore[misc]
        eq = self.inner.equation
        for old, new in self._rename.items():
            eq = re.sub(rf"\b{re.escape(old)}\b", new, eq)
        self.equation = f"{'*'.join(columns)}*({eq})"  # type: ignore[misc]

    @classmethod
    def from_call(cls, args: list[str], options: Mapping[str, float]) -> Scale:
        if len(args) < 2:
            raise ModelError("scale(...) takes a term name and one or two column names, e.g. scale(stribeck, temperature)")
        _check_options("scale", options, ())
        return cls(args[0], *args[1:])

    def __repr__(self) -> str:
        return f"Scale({self.term_name!r}, {', '.join(repr(c) for c in self.columns)})"

    def _factor(self, x: Inputs) -> Array:
        f = column_values(x, self.columns[0])
        for c in self.columns[1:]:
            f = f * column_values(x, c)
        return f

    def _inner_p(self, p: Values) -> dict[str, float]:
        return {old: float(p[new]) for old, new in self._rename.items()}

    def inner_names(self) -> dict[str, str]:
        """The wrapped term's parameter name -> this term's name for it."""
        return dict(self._rename)

    def value(self, x: Inputs, p: Values) -> Array:
        return np.broadcast_to(self._factor(x) * self.inner.value(x, self._inner_p(p)), broadcast_shape(x))

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        g = self.inner.param_gradient(x, self._inner_p(p))
        f = self._factor(x)
        sh = broadcast_shape(x)
        return {new: np.broadcast_to(f * g[old], sh).copy() for old, new in self._rename.items()}

    def start_points(self, x: Inputs) -> list[dict[str, float]]:
        """The wrapped term's own starting points, under this term's names."""
        return [{self._rename[k]: v for k, v in g.items() if k in self._rename} for g in self.inner.start_points(x)]
