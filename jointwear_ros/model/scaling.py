"""Start values, bounds and starts of a fit taken from the data, in the data's own units.

No constant here is tuned to the paper's normalized joint: every magnitude is a
multiple of the data's own scales (its friction level, its speed range, its load
range, its temperature span), so the same fit works on normalized motor-side
observations and on joint-side N·m. What a parameter's magnitude is made of
(torque, speed, load, temperature, wear) is its *dimension*, known for the
built-in terms; a term that is not built in keeps its own start and bounds.

>>> import numpy as np
>>> s = DataScales.of(speed=[0.01, 0.5], tau_f=[12.0, 20.0], load_torque=[0, 40.0], temperature=[20, 45])
>>> s.torque, s.speed, s.load, s.temperature_span
(20.0, 0.5, 40.0, 25.0)
>>> p = data_parameters(["Fc0", "vs0", "Tv0"], s)
>>> p["Fc0"].value, p["vs0"].min, p["Tv0"].max
(10.0, 0.0005, 1000.0)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .parameters import Parameter, Parameters

__all__ = ["DIMENSIONS", "DataScales", "data_parameters", "on_bound", "speed_starts"]

#: Dimension of each built-in parameter: exponents of (torque, speed, load, temperature, wear).
DIMENSIONS: dict[str, tuple[int, int, int, int, int]] = {
    "Fc0": (1, 0, 0, 0, 0),
    "Fctm": (1, 0, -1, 0, 0),
    "Fstm": (1, 0, -1, 0, 0),
    "vstm": (0, 1, 0, 0, 0),
    "Fs0": (1, 0, 0, 0, 0),
    "FsT": (1, 0, 0, -1, 0),
    "vs0": (0, 1, 0, 0, 0),
    "vsT": (0, 1, 0, -1, 0),
    "Fv0": (1, -1, 0, 0, 0),
    "FvT": (1, -1, 0, 0, 0),
    "Tv0": (0, 0, 0, 1, 0),
    "Fsw": (1, 0, 0, 0, -1),
    "vsw": (0, 1, 0, 0, -1),
    "Fvw": (1, -1, 0, 0, -1),
    "Fs": (1, 0, 0, 0, 0),
    "vs": (0, 1, 0, 0, 0),
    "Fv": (1, -1, 0, 0, 0),
}

#: Start of each built-in parameter, in units of its dimension's scale.
_START = {"Fc0": 0.5, "Fctm": 0.05, "Fstm": 0.05, "vstm": 0.05, "Fs0": 0.1, "FsT": 0.0, "vs0": 0.1, "vsT": 0.0,
          "Fv0": 0.2, "FvT": 0.2, "Tv0": 1.0, "Fsw": 0.01, "vsw": 0.01, "Fvw": 0.0, "Fs": 0.2, "vs": 0.1, "Fv": 0.3}
#: Bounds, in the same units: positive speeds and Coulomb levels, wide elsewhere.
_BOUNDS = {"Fc0": (0.0, 10.0), "Fctm": (0.0, 100.0), "Fstm": (0.0, 100.0), "vstm": (1e-3, 20.0),
           "Fs0": (-1e3, 1e3), "FsT": (-1e3, 1e3), "vs0": (1e-3, 20.0), "vsT": (-20.0, 20.0),
           "Fv0": (-1e3, 1e3), "FvT": (-1e3, 1e3), "Tv0": (-math.inf, math.inf), "Fsw": (0.0, 1e3),
           "vsw": (1e-4, 10.0), "Fvw": (-1e3, 1e3), "Fs": (-1e3, 1e3), "vs": (1e-3, 20.0), "Fv": (-1e3, 1e3)}
#: Tv0 is a temperature constant in degC whatever the torque unit: physical limits.
_TV0_BOUNDS = (1.0, 1000.0)


@dataclass(frozen=True)
class DataScales:
    """The magnitudes of one data set: friction, speed, load, temperature (and wear 100)."""

    torque: float
    speed: float
    load: float
    temperature: float
    temperature_span: float
    wear: float = 100.0

    @classmethod
    def of(cls, *, speed: npt.ArrayLike, tau_f: npt.ArrayLike, load_torque: npt.ArrayLike | None = None,
           temperature: npt.ArrayLike | None = None) -> DataScales:
        """Scales of arrays: the largest |value| of each (temperature: its mean and span)."""
        def top(a: npt.ArrayLike | None) -> float:
            if a is None:
                return math.nan
            x = np.abs(np.asarray(a, dtype=float))
            x = x[np.isfinite(x)]
            return float(x.max()) if x.size and x.max() > 0 else math.nan

        t = np.asarray([] if temperature is None else temperature, dtype=float)
        t = t[np.isfinite(t)]
        return cls(
            torque=top(tau_f) if math.isfinite(top(tau_f)) else 1.0,
            speed=top(speed) if math.isfinite(top(speed)) else 1.0,
            load=top(load_torque) if math.isfinite(top(load_torque)) else 1.0,
            temperature=float(np.mean(t)) if t.size else 40.0,
            temperature_span=max(float(np.ptp(t)), 1.0) if t.size else 20.0,
        )

    def scale(self, dims: tuple[int, int, int, int, int]) -> float:
        tq, sp, ld, tp, wr = dims
        return float(self.torque**tq * self.speed**sp * self.load**ld * self.temperature_span**tp * self.wear**wr)


def data_parameters(names: Iterable[str], scales: DataScales,
                    given: Mapping[str, Parameter] | None = None) -> Parameters:
    """Start values and bounds of the named built-in parameters from the data's scales.

    A name that is not a built-in parameter is taken from ``given`` (its own
    start and bounds) or left out.
    """
    out = Parameters()
    for n in names:
        if n in DIMENSIONS:
            s = scales.scale(DIMENSIONS[n])
            lo, hi = _TV0_BOUNDS if n == "Tv0" else (_BOUNDS[n][0] * s, _BOUNDS[n][1] * s)
            start = scales.temperature_span * 1.0 if n == "Tv0" else _START[n] * s
            if n == "Tv0":
                start = min(max(start, lo), hi)
            out.add(Parameter(n, float(start), float(lo), float(hi)))
        elif given is not None and n in given:
            g = given[n]
            out.add(Parameter(n, g.value, g.min, g.max, g.vary, g.unit, g.description))
    return out


def on_bound(params: Parameters, rtol: float = 1e-6) -> list[tuple[str, float, float]]:
    """``(name, value, bound)`` of every free parameter that ended on (within ``rtol`` of the range) a finite bound."""
    hit: list[tuple[str, float, float]] = []
    for n, p in params.items():
        if not p.vary:
            continue
        span = p.max - p.min if math.isfinite(p.max - p.min) else max(abs(p.value), 1.0)
        tol = rtol * max(span, 1e-300)
        for b in (p.min, p.max):
            if math.isfinite(b) and abs(p.value - b) <= tol:
                hit.append((n, p.value, b))
                break
    return hit


def speed_starts(names: Sequence[str], scales: DataScales, fractions: Sequence[float] = (0.03, 0.1, 0.3)
                 ) -> list[dict[str, float]]:
    """Starts of the Stribeck speeds among ``names``: each at a few fractions of the data's top speed."""
    speeds = [n for n in names if n in ("vstm", "vs0", "vs")]
    if not speeds:
        return [{}]
    out: list[dict[str, float]] = [{}]
    for n in speeds:
        out = [dict(o, **{n: f * scales.speed}) for o in out for f in fractions]
    return out

