"""Physical effects of the static friction model as composable terms.

Each term is one effect of Eq. (6), (7), (9) of Bittencourt et al. (2011)
(or of the "standard" static friction model the paper improves on). A term is
a pure numpy function of named input variables and named parameters, plus
its analytic derivatives. Terms compose with ``+`` into a
:class:`~jointwear_ros.model.model.Model`.

Input variables (arrays, broadcast against each other):

``speed``
    joint speed on the motor side, rad/s; the model is for ``|speed|``.
``load_torque``
    manipulated load torque tau_m, normalized (dimensionless).
``temperature``
    joint temperature T, degrees C.
``wear``
    wear level w, 0-100 (% of a failure state); 35 is the alarm level.

Torques (the terms' values) are normalized to the maximum manipulation
torque at low speed (dimensionless).

Each parameter has a *dimension* (:class:`Dimension`): what its magnitude is made
of, as exponents of the data's torque, speed, load torque, temperature and wear
scales. A fit in any units takes its start values and bounds from it
(:mod:`jointwear_ros.model.scaling`). The unit a parameter is written in implies
it (:data:`UNIT_DIMENSIONS`: ``s/rad`` is torque per speed); a term declares the
dimension of a parameter whose unit does not say it (:attr:`Term.dimensions`:
``Fctm``, written ``-``, is a torque per load torque).

>>> LoadCoulomb().dimension("Fctm"), TempViscous().dimension("Fv0")
(Dimension(torque=1, speed=0, load=-1, temperature=0, wear=0), Dimension(torque=1, speed=-1, load=0, temperature=0, wear=0))

A term also carries what the workbench needs to fit it, as an lmfit model carries its
parameter hints and ``guess()``: the parameters it is linear in (:attr:`Term.linear`),
starting points of the others (:attr:`Term.starts`, moved to the data's units by
:meth:`Term.guess`), what it means (:attr:`Term.meaning`) and whether the diagnosis offers it
as a candidate effect (:attr:`Term.candidate`).

>>> TempStribeck.linear, [g["vs0"] for g in TempStribeck().guess({"speed": np.array([0.5, 2.8])})]
(('Fs0', 'FsT'), [0.1, 0.3, 0.6, 1.2])

The wear Stribeck term of Eq. (7) at 47 rad/s and w = 35 (Eq. 8 values):

>>> t = term_by_name("wear_stribeck")
>>> t.param_names, t.variables
(('Fsw', 'vsw'), ('speed', 'wear'))
>>> x = {"speed": np.array([47.0]), "wear": np.array([35.0])}
>>> [round(float(v), 5) for v in t.value(x, {"Fsw": 9.10e-4, "vsw": 2.20})]
[0.01882]
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import ClassVar

import numpy as np

from ..errors import ModelError
from .dimensions import UNIT_DIMENSIONS, Dimension, Relative, unit_dimension
from .model import Array, Inputs, Term, Values
from .parameters import ParamSpec

__all__ = [
    "STRIBECK_EXPONENT",
    "TERMS",
    "UNIT_DIMENSIONS",
    "Coulomb",
    "Dimension",
    "LoadCoulomb",
    "LoadStribeck",
    "Relative",
    "Stribeck",
    "TempStribeck",
    "TempViscous",
    "Term",
    "Viscous",
    "WearStribeck",
    "WearViscous",
    "param_dimension",
    "stribeck_shape",
]


#: The Stribeck shape exponent the paper fixes for every exponential term.
STRIBECK_EXPONENT = 1.3


def stribeck_shape(v: Array, vs: Array | float, alpha: float = STRIBECK_EXPONENT) -> tuple[Array, Array]:
    """Stribeck shape ``S = exp(-|v / vs|**alpha)`` and ``r**alpha`` with ``r = |v/vs|``.

    ``vs = 0`` is the limit ``vs -> 0+``: ``S = 1`` at ``v = 0``, else 0.
    Returns ``(S, r**alpha)``; where ``S == 0`` the second array is set to 0 so
    that products ``S * r**alpha`` (which appear in every derivative) are 0,
    their limit, and never ``0 * inf``.
    """
    v = np.abs(np.asarray(v, dtype=float))
    vs = np.asarray(vs, dtype=float)
    if vs.ndim == 0 and vs != 0.0 and not np.isnan(vs):
        # one speed, neither 0 nor nan: v / |vs| is 0 where v is and nothing divides by 0 (the same numbers
        # as below, without the error state's cost: a fit evaluates this thousands of times)
        ra = (v / abs(float(vs))) ** alpha
        s = np.exp(-ra)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(v == 0.0, 0.0, v / np.abs(vs))
            ra = r**alpha
            s = np.exp(-ra)
    ra = np.where(s > 0.0, ra, 0.0)
    return s, ra


def _v(x: Inputs) -> Array:
    return np.abs(np.asarray(x["speed"], dtype=float))


#: Stribeck shapes an input set prepared once keeps (a fit's Jacobian comes at the point it just evaluated).
_SHAPES_KEPT = 8


def _speed_shape(x: Inputs, vs: float, key: tuple[str | float, ...] | None = None,
                 vs_of: Callable[[], Array] | None = None) -> tuple[Array, Array]:
    """``stribeck_shape(|speed|, vs)``; inputs prepared once (``Model.prepare``) keep the last few by ``key``
    (default: the speed ``vs``; ``vs_of`` computes an array of speeds that ``key`` names), the same arrays
    as computing them again."""
    memo = getattr(x, "memo", None)
    if memo is None:
        return stribeck_shape(_v(x), vs if vs_of is None else vs_of())
    kept = memo.setdefault("stribeck", {})
    k = (float(vs),) if key is None else key
    hit = kept.get(k)
    if hit is None:
        if len(kept) >= _SHAPES_KEPT:
            kept.clear()
        s, ra = stribeck_shape(_v(x), vs if vs_of is None else vs_of())
        s.setflags(write=False)
        ra.setflags(write=False)
        hit = kept[k] = (s, ra)
    return hit  # type: ignore[no-any-return]


def _zeros_like_inputs(x: Inputs) -> Array:
    shape = getattr(x, "shape", None)  # inputs prepared once (Model.prepare) carry their broadcast shape
    if shape is None:
        shape = np.broadcast(*[np.asarray(a) for a in x.values()]).shape
    return np.zeros(shape)


class Coulomb(Term):
    """Coulomb friction, the constant part of Eq. (6a).

    ``tau = Fc0``

    Fc0: normalized torque (dimensionless). Paper: Eq. (6a), first term.
    """

    name = "coulomb"
    variables = ("speed",)
    params = (ParamSpec("Fc0", "-", 0.04, 0.0, 1.0, "Coulomb friction level"),)
    equation = "Fc0"
    paper_ref = "Eq. (6a)"
    relative: ClassVar[Mapping[str, Relative]] = {"Fc0": Relative(0.5, 0.0, 10.0)}
    linear = ("Fc0",)

    def value(self, x: Inputs, p: Values) -> Array:
        return p["Fc0"] + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        return {"Fc0": np.ones_like(self.value(x, p))}

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        return _zeros_like_inputs(x)


class LoadCoulomb(Term):
    """Load-dependent Coulomb friction, Eq. (6a).

    ``tau = Fctm * |tau_m|``

    Fctm: dimensionless (normalized torque per normalized load torque).
    tau_m: manipulated load torque, normalized. Paper: Eq. (6a).
    """

    name = "load_coulomb"
    variables = ("load_torque",)
    params = (ParamSpec("Fctm", "-", 0.06, 0.0, 10.0, "Coulomb friction per unit load torque"),)
    dimensions: ClassVar[Mapping[str, Dimension]] = {"Fctm": Dimension(torque=1, load=-1)}
    equation = "Fctm*|tau_m|"
    paper_ref = "Eq. (6a)"
    relative: ClassVar[Mapping[str, Relative]] = {"Fctm": Relative(0.05, 0.0, 100.0)}
    linear = ("Fctm",)
    meaning = "Coulomb friction grows with load torque (Eq. 6a)"
    candidate = True

    def value(self, x: Inputs, p: Values) -> Array:
        return p["Fctm"] * np.abs(np.asarray(x["load_torque"], dtype=float)) + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        return {"Fctm": np.abs(np.asarray(x["load_torque"], dtype=float)) + _zeros_like_inputs(x)}

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var == "load_torque":
            return p["Fctm"] * np.sign(np.asarray(x["load_torque"], dtype=float)) + _zeros_like_inputs(x)
        return _zeros_like_inputs(x)


class LoadStribeck(Term):
    """Load-dependent Stribeck friction, Eq. (6a).

    ``tau = Fstm * |tau_m| * exp(-|v / vstm|^1.3)``

    Fstm: dimensionless; vstm: rad/s (motor side). The hump that load adds
    below ~25 rad/s. Paper: Eq. (6a).
    """

    name = "load_stribeck"
    variables = ("speed", "load_torque")
    params = (
        ParamSpec("Fstm", "-", 0.08, 0.0, 10.0, "Stribeck amplitude per unit load torque"),
        ParamSpec("vstm", "rad/s", 12.0, 0.1, 500.0, "Stribeck speed of the load term"),
    )
    dimensions: ClassVar[Mapping[str, Dimension]] = {"Fstm": Dimension(torque=1, load=-1)}
    equation = "Fstm*|tau_m|*exp(-|v/vstm|^1.3)"
    paper_ref = "Eq. (6a)"
    relative: ClassVar[Mapping[str, Relative]] = {"Fstm": Relative(0.05, 0.0, 100.0), "vstm": Relative(0.05, 1e-3, 20.0)}
    linear = ("Fstm",)
    starts = tuple({"vstm": v} for v in (4.0, 12.0, 30.0, 80.0))
    meaning = "low-speed friction hump grows with load torque (Eq. 6a)"
    candidate = True

    def value(self, x: Inputs, p: Values) -> Array:
        s, _ = _speed_shape(x, p["vstm"])
        return p["Fstm"] * np.abs(np.asarray(x["load_torque"], dtype=float)) * s + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        s, ra = _speed_shape(x, p["vstm"])
        tm = np.abs(np.asarray(x["load_torque"], dtype=float))
        z = _zeros_like_inputs(x)
        return {
            "Fstm": tm * s + z,
            "vstm": p["Fstm"] * tm * s * STRIBECK_EXPONENT * ra / p["vstm"] + z,
        }

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var == "load_torque":
            s, _ = _speed_shape(x, p["vstm"])
            return p["Fstm"] * np.sign(np.asarray(x["load_torque"], dtype=float)) * s + _zeros_like_inputs(x)
        return _zeros_like_inputs(x)


class TempStribeck(Term):
    """Temperature-dependent Stribeck friction, Eq. (6b).

    ``tau = (Fs0 + FsT*T) * exp(-|v / (vs0 + vsT*T)|^1.3)``

    Fs0: dimensionless; FsT: per degree C; vs0: rad/s; vsT: rad/s per degree C;
    T: degrees C. Higher temperature raises low-speed friction. The amplitude
    ``Fs0 + FsT*T`` must stay positive over the valid temperature range.
    Paper: Eq. (6b).
    """

    name = "temp_stribeck"
    variables = ("speed", "temperature")
    params = (
        ParamSpec("Fs0", "-", -0.015, -1.0, 1.0, "Stribeck amplitude at 0 degC"),
        ParamSpec("FsT", "1/degC", 1.0e-3, -0.1, 0.1, "Stribeck amplitude per degC"),
        ParamSpec("vs0", "rad/s", 30.0, 0.1, 500.0, "Stribeck speed at 0 degC"),
        ParamSpec("vsT", "rad/s/degC", 0.25, -5.0, 5.0, "Stribeck speed per degC"),
    )
    equation = "(Fs0 + FsT*T)*exp(-|v/(vs0 + vsT*T)|^1.3)"
    paper_ref = "Eq. (6b)"
    relative: ClassVar[Mapping[str, Relative]] = {"Fs0": Relative(0.1, -1e3, 1e3), "FsT": Relative(0.0, -1e3, 1e3),
                                                  "vs0": Relative(0.1, 1e-3, 20.0), "vsT": Relative(0.0, -20.0, 20.0)}
    linear = ("Fs0", "FsT")
    starts = tuple({"vs0": v, "vsT": 0.0} for v in (10.0, 30.0, 60.0, 120.0))
    meaning = "low-speed friction changes with temperature (Eq. 6b)"
    candidate = True

    def _parts(self, x: Inputs, p: Values) -> tuple[Array, Array, Array, Array, Array]:
        T = np.asarray(x["temperature"], dtype=float)
        amp = p["Fs0"] + p["FsT"] * T
        vs = p["vs0"] + p["vsT"] * T
        s, ra = _speed_shape(x, 0.0, ("temp", float(p["vs0"]), float(p["vsT"])), lambda: vs)
        return T, amp, vs, s, ra

    def value(self, x: Inputs, p: Values) -> Array:
        _, amp, _, s, _ = self._parts(x, p)
        return amp * s + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        T, amp, vs, s, ra = self._parts(x, p)
        z = _zeros_like_inputs(x)
        ds_dvs = s * STRIBECK_EXPONENT * ra / vs
        return {
            "Fs0": s + z,
            "FsT": T * s + z,
            "vs0": amp * ds_dvs + z,
            "vsT": amp * ds_dvs * T + z,
        }

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var == "temperature":
            _, amp, vs, s, ra = self._parts(x, p)
            ds_dvs = s * STRIBECK_EXPONENT * ra / vs
            return p["FsT"] * s + amp * ds_dvs * p["vsT"] + _zeros_like_inputs(x)
        return _zeros_like_inputs(x)


class TempViscous(Term):
    """Temperature-dependent viscous friction, Eq. (6c).

    ``tau = (Fv0 + FvT * exp(-T / Tv0)) * |v|``

    Fv0, FvT: s/rad (normalized torque per rad/s); Tv0: degrees C. Viscosity
    falls exponentially with temperature, lowering the slope at high speed.
    (The seed text prints ``exp(-1/Tv0)``; the ``T`` was lost in extraction.)
    Paper: Eq. (6c).
    """

    name = "temp_viscous"
    variables = ("speed", "temperature")
    params = (
        ParamSpec("Fv0", "s/rad", 2.0e-4, -0.01, 0.01, "viscous coefficient at high temperature"),
        ParamSpec("FvT", "s/rad", 1.061e-3, -0.1, 0.1, "temperature-dependent viscous coefficient"),
        ParamSpec("Tv0", "degC", 25.0, 1.0, 500.0, "viscosity temperature constant"),
    )
    equation = "(Fv0 + FvT*exp(-T/Tv0))*v"
    paper_ref = "Eq. (6c)"
    relative: ClassVar[Mapping[str, Relative]] = {"Fv0": Relative(0.2, -1e3, 1e3), "FvT": Relative(0.2, -1e3, 1e3),
                                                  # a temperature constant in degC whatever the torque unit
                                                  "Tv0": Relative(1.0, 1.0, 1000.0, absolute=True)}
    linear = ("Fv0", "FvT")
    starts = tuple({"Tv0": t} for t in (10.0, 25.0, 60.0))
    meaning = "viscous slope falls with temperature (Eq. 6c)"
    candidate = True

    def value(self, x: Inputs, p: Values) -> Array:
        T = np.asarray(x["temperature"], dtype=float)
        return (p["Fv0"] + p["FvT"] * np.exp(-T / p["Tv0"])) * _v(x) + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        T = np.asarray(x["temperature"], dtype=float)
        v = _v(x)
        e = np.exp(-T / p["Tv0"])
        z = _zeros_like_inputs(x)
        return {
            "Fv0": v + z,
            "FvT": e * v + z,
            "Tv0": p["FvT"] * e * T / p["Tv0"] ** 2 * v + z,
        }

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var == "temperature":
            T = np.asarray(x["temperature"], dtype=float)
            return -p["FvT"] / p["Tv0"] * np.exp(-T / p["Tv0"]) * _v(x) + _zeros_like_inputs(x)
        return _zeros_like_inputs(x)


class WearStribeck(Term):
    """Wear-dependent Stribeck friction, Eq. (7).

    ``tau = Fsw * w * exp(-|v / (vsw * w)|^1.3)``

    Fsw: per unit wear (normalized torque); vsw: rad/s per unit wear; w: wear,
    0-100. Wear raises the exponential-like part of the curve up to
    ~150 rad/s. At ``w = 0`` the term is 0. Paper: Eq. (7), values Eq. (8).
    """

    name = "wear_stribeck"
    variables = ("speed", "wear")
    params = (
        ParamSpec("Fsw", "1/w", 9.10e-4, 0.0, 1.0, "Stribeck amplitude per unit wear"),
        ParamSpec("vsw", "rad/s/w", 2.20, 0.01, 100.0, "Stribeck speed per unit wear"),
    )
    equation = "Fsw*w*exp(-|v/(vsw*w)|^1.3)"
    paper_ref = "Eq. (7)"
    relative: ClassVar[Mapping[str, Relative]] = {"Fsw": Relative(0.01, 0.0, 1e3), "vsw": Relative(0.01, 1e-4, 10.0)}
    linear = ("Fsw",)
    starts = tuple({"vsw": v} for v in (0.5, 2.2, 8.0))
    meaning = "low-speed friction grows with wear (Eq. 7)"
    candidate = True

    def _parts(self, x: Inputs, p: Values) -> tuple[Array, Array, Array]:
        w = np.asarray(x["wear"], dtype=float)
        s, ra = stribeck_shape(_v(x), p["vsw"] * w)
        return w, s, ra

    def value(self, x: Inputs, p: Values) -> Array:
        w, s, _ = self._parts(x, p)
        return p["Fsw"] * w * s + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        w, s, ra = self._parts(x, p)
        z = _zeros_like_inputs(x)
        return {
            "Fsw": w * s + z,
            "vsw": p["Fsw"] * w * s * STRIBECK_EXPONENT * ra / p["vsw"] + z,
        }

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var == "wear":
            _, s, ra = self._parts(x, p)
            return p["Fsw"] * s * (1.0 + STRIBECK_EXPONENT * ra) + _zeros_like_inputs(x)
        return _zeros_like_inputs(x)


class WearViscous(Term):
    """Wear-dependent viscous friction, Eq. (7).

    ``tau = Fvw * w * |v|``

    Fvw: s/rad per unit wear (negative: wear slightly lowers the slope at high
    speed). Paper: Eq. (7), value Eq. (8).
    """

    name = "wear_viscous"
    variables = ("speed", "wear")
    params = (ParamSpec("Fvw", "s/rad/w", -5.3e-7, -1e-3, 1e-3, "viscous coefficient per unit wear"),)
    equation = "Fvw*w*v"
    paper_ref = "Eq. (7)"
    relative: ClassVar[Mapping[str, Relative]] = {"Fvw": Relative(0.0, -1e3, 1e3)}
    linear = ("Fvw",)
    meaning = "viscous slope changes with wear (Eq. 7)"
    candidate = True

    def value(self, x: Inputs, p: Values) -> Array:
        return p["Fvw"] * np.asarray(x["wear"], dtype=float) * _v(x) + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        return {"Fvw": np.asarray(x["wear"], dtype=float) * _v(x) + _zeros_like_inputs(x)}

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        if var == "wear":
            return p["Fvw"] * _v(x) + _zeros_like_inputs(x)
        return _zeros_like_inputs(x)


class Stribeck(Term):
    """Plain Stribeck friction of the standard static model (no load, no temperature).

    ``tau = Fs * exp(-|v / vs|^1.3)``

    Fs: dimensionless; vs: rad/s. The standard model the paper improves on is
    Coulomb + Stribeck + viscous.
    """

    name = "stribeck"
    variables = ("speed",)
    params = (
        ParamSpec("Fs", "-", 0.03, -1.0, 1.0, "Stribeck amplitude"),
        ParamSpec("vs", "rad/s", 20.0, 0.1, 500.0, "Stribeck speed"),
    )
    equation = "Fs*exp(-|v/vs|^1.3)"
    paper_ref = "standard model"
    relative: ClassVar[Mapping[str, Relative]] = {"Fs": Relative(0.2, -1e3, 1e3), "vs": Relative(0.1, 1e-3, 20.0)}
    linear = ("Fs",)
    starts = tuple({"vs": v} for v in (4.0, 12.0, 30.0, 80.0))

    def value(self, x: Inputs, p: Values) -> Array:
        s, _ = _speed_shape(x, p["vs"])
        return p["Fs"] * s + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        s, ra = _speed_shape(x, p["vs"])
        z = _zeros_like_inputs(x)
        return {"Fs": s + z, "vs": p["Fs"] * s * STRIBECK_EXPONENT * ra / p["vs"] + z}

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        return _zeros_like_inputs(x)


class Viscous(Term):
    """Plain viscous friction of the standard static model.

    ``tau = Fv * |v|``

    Fv: s/rad (normalized torque per rad/s).
    """

    name = "viscous"
    variables = ("speed",)
    params = (ParamSpec("Fv", "s/rad", 4.0e-4, -0.01, 0.01, "viscous coefficient"),)
    equation = "Fv*v"
    paper_ref = "standard model"
    relative: ClassVar[Mapping[str, Relative]] = {"Fv": Relative(0.3, -1e3, 1e3)}
    linear = ("Fv",)

    def value(self, x: Inputs, p: Values) -> Array:
        return p["Fv"] * _v(x) + _zeros_like_inputs(x)

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        return {"Fv": _v(x) + _zeros_like_inputs(x)}

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        return _zeros_like_inputs(x)


#: Built-in terms by name.
TERMS: dict[str, type[Term]] = {
    t.name: t
    for t in (
        Coulomb,
        LoadCoulomb,
        LoadStribeck,
        TempStribeck,
        TempViscous,
        WearStribeck,
        WearViscous,
        Stribeck,
        Viscous,
    )
}


def param_dimension(name: str, unit: str = "") -> Dimension:
    """The dimension of a parameter by name: a built-in term's (as the term declares it), else its unit's.

    >>> param_dimension("Fstm"), param_dimension("a", "s/rad").speed, param_dimension("b", "1/x")
    (Dimension(torque=1, speed=0, load=-1, temperature=0, wear=0), -1, Dimension(torque=0, speed=0, load=0, temperature=0, wear=0))
    """
    for cls in TERMS.values():
        if name in cls().param_names:
            return cls().dimension(name)
    return unit_dimension(unit)


def term_by_name(name: str) -> Term:
    """Instantiate a built-in term by name (``coulomb``, ``temp_stribeck``, ...)."""
    try:
        return TERMS[name]()
    except KeyError:
        raise ModelError(f"unknown term {name!r}; built-in terms: {', '.join(TERMS)}") from None
