"""Friction of the simulated joint: the full model, tabulated for fast per-step lookup.

The simulator needs ``tau_f(|v|, |tau_m|, position, time)`` once per integration
step (2 kHz and more). Evaluating :class:`jointwear_ros.model.Model` per step
(numpy on scalars) costs tens of microseconds; instead the model is evaluated
once, vectorised, on a fine speed grid, and looked up with linear
interpolation in plain Python:

``tau_f = A(|v|) + |tau_m| * B(|v|) + P(position) + k_t * time``

- ``A``, ``B``: the model (default ``paper+wear``: Eq. 9 with ``ref-2011r``) at
  the configured temperature and wear, plus the hidden effects that depend on
  speed, load or hours since lubrication (``load_viscous``, ``lubrication``).
  The model is linear in ``|tau_m|``; this is checked when the table is built.
- ``P``: hidden effects that depend on the joint position (``ripple``).
- ``k_t``: hidden effects linear in time (``time_drift``).

The hidden effects are the ones of :mod:`jointwear_ros.data.synth`, evaluated
through its definitions so that the simulator and the synthetic tables agree.
Interpolation error with the default grid (0.01 rad/s) is below 1e-6
(normalized), far under the paper's noise level 1.5e-3.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Iterable
from typing import Any

import numpy as np
import numpy.typing as npt

from ..data.synth import HIDDEN_EFFECTS, effect_value
from ..errors import ModelError, ParameterError
from ..model import Parameters, load_parameter_set_info, parse_model_spec

__all__ = ["FrictionTable"]

Array = npt.NDArray[np.float64]

#: Tables already built in this process, by everything they depend on (the model and its values, the units, the
#: temperature, wear, effects and grids), the newest last: a simulator rebuilds a joint's tables at every
#: reconfiguration and a test process builds the default ones hundreds of times. Each table holds about 80 000
#: floats (2.6 MB as lists); the tables are shared read-only between the instances.
_BUILT: OrderedDict[tuple[Any, ...], tuple[float, list[float], list[float], list[float], float, bool]] = OrderedDict()
_BUILT_MAX = 16
_BUILT_LOCK = threading.Lock()


class FrictionTable:
    """Tabulated friction magnitude of one joint at a fixed temperature and wear.

    Parameters
    ----------
    params
        Parameter set name (``ref-2011r``) or :class:`Parameters`.
    model
        Model spec (default ``paper+wear``).
    temperature
        Joint temperature, degC.
    wear
        Wear level 0-100 (used when the model has wear terms).
    hidden_effects
        Names of :data:`jointwear_ros.data.synth.HIDDEN_EFFECTS` to add.
    lube_hours
        Hours since lubrication (drives the ``lubrication`` effect).
    max_speed
        Largest tabulated speed, motor side, rad/s; faster speeds are clamped.
    speed_step
        Grid step of the speed table, rad/s.
    position_range
        Joint positions (rad) covered by the position table; clamped outside.
    gear_ratio, torque_scale
        The simulated joint's; a joint-frame parameter set (joint side, N·m) is evaluated at
        joint speed = motor speed / gear_ratio and returns N·m / torque_scale (default: the
        set's own gear ratio and torque scale).
    """

    def __init__(
        self,
        params: str | Parameters = "ref-2011r",
        model: str = "paper+wear",
        *,
        temperature: float = 40.0,
        wear: float = 0.0,
        hidden_effects: Iterable[str] = (),
        lube_hours: float = 0.0,
        max_speed: float = 400.0,
        speed_step: float = 0.01,
        position_range: tuple[float, float] = (-4.0, 4.0),
        position_step: float = 1e-3,
        gear_ratio: float | None = None,
        torque_scale: float | None = None,
    ) -> None:
        for name, val in (("temperature", temperature), ("wear", wear), ("lube_hours", lube_hours)):
            if not math.isfinite(val):
                raise ParameterError(f"{name} must be finite, got {val}")
        if not (max_speed > 0 and speed_step > 0 and position_step > 0):
            raise ParameterError("max_speed, speed_step and position_step must be > 0")
        effects = list(hidden_effects)
        unknown = [e for e in effects if e not in HIDDEN_EFFECTS]
        if unknown:
            raise ParameterError(
                f"unknown hidden effect(s) {', '.join(unknown)}; known: {', '.join(HIDDEN_EFFECTS)}"
            )
        self.model = parse_model_spec(model)
        # a joint-frame set (N·m, joint side: a commissioned set) is evaluated in its own units through its gear ratio
        # and torque scale, so the simulator's friction stays normalized motor side
        self._sf, self._tf = 1.0, 1.0
        if isinstance(params, str):
            info = load_parameter_set_info(params)
            pset = info.parameters()
            self._sf, self._tf = info.units.speed_factor, info.units.torque_factor
            if info.units.joint_side and gear_ratio is not None and torque_scale is not None:
                # the simulated joint's own gear and scale: its joint speed and N·m are what the set describes
                self._sf, self._tf = 1.0 / float(gear_ratio), float(torque_scale)
        else:
            pset = params
        self.params = self.model.make_params(pset)
        self.temperature = float(temperature)
        self.wear = float(wear)
        self.hidden_effects = tuple(effects)
        self.lube_hours = float(lube_hours)

        p0, p1 = float(position_range[0]), float(position_range[1])
        self.speed_step = float(speed_step)
        key = (self.model.spec, tuple((type(t).__module__, type(t).__qualname__) for t in self.model.terms),
               tuple(self.params.valuesdict().items()), self._sf, self._tf, self.temperature, self.wear,
               self.hidden_effects, self.lube_hours, float(max_speed), self.speed_step, p0, p1, float(position_step))
        with _BUILT_LOCK:
            built = _BUILT.get(key)
            if built is not None:
                _BUILT.move_to_end(key)
        if built is None:  # built outside the lock (tens of ms); the first one stored for a key is kept
            built = self._build(max_speed, p0, p1, position_step)
            with _BUILT_LOCK:
                built = _BUILT.setdefault(key, built)
                while len(_BUILT) > _BUILT_MAX:
                    _BUILT.popitem(last=False)
        self.max_speed, self._a, self._b, self._p, k_time, p_zero = built
        self._p0 = float(p0)
        self._pstep = float(position_step)
        self._k_time = float(k_time)
        self._inv_step = 1.0 / self.speed_step
        self._inv_pstep = 1.0 / self._pstep
        # per-call constants of __call__ (it runs once per joint and physics step): the last interpolation
        # interval of each table, and whether the position table is all +0.0 (no position effect: its
        # interpolation adds exactly +0.0, done as one addition)
        self._a_last = len(self._a) - 2
        self._p_last = len(self._p) - 1
        self._p_zero = p_zero

    def _build(self, max_speed: float, p0: float, p1: float,
               position_step: float) -> tuple[float, list[float], list[float], list[float], float, bool]:
        """The tables of :meth:`__init__`: ``(largest speed, A, B, P, k_t, P all +0.0)``, from the model and the
        hidden effects."""
        n = math.ceil(max_speed / self.speed_step) + 1
        v: Array = np.arange(n, dtype=float) * self.speed_step
        a = self._model(v, 0.0)
        b = self._model(v, 1.0) - a
        half = self._model(v, 0.5)  # linear in |tau_m|: the lookup's premise, checked at every speed of the grid
        if not np.allclose(half, a + 0.5 * b, rtol=0.0, atol=1e-12):
            raise ModelError(f"model {self.model.spec!r} is not linear in |tau_m|; the simulator's table needs that")
        npos = math.ceil((p1 - p0) / position_step) + 1
        pos: Array = p0 + np.arange(npos, dtype=float) * position_step
        ptab = np.zeros(npos)
        k_time = 0.0
        for e in self.hidden_effects:
            variables = HIDDEN_EFFECTS[e].variables
            if "position" in variables:
                ptab = ptab + effect_value(e, self._cols(np.zeros(npos), 0.0, pos, 0.0))
            elif "time" in variables:
                day = 86400.0
                e0 = float(effect_value(e, self._cols(np.zeros(1), 0.0, np.zeros(1), 0.0))[0])
                e1 = float(effect_value(e, self._cols(np.zeros(1), 0.0, np.zeros(1), day))[0])
                k_time += (e1 - e0) / day
                a = a + e0
            else:
                e_a = effect_value(e, self._cols(v, 0.0, np.zeros(n), 0.0))
                e_b = effect_value(e, self._cols(v, 1.0, np.zeros(n), 0.0)) - e_a
                a = a + e_a
                b = b + e_b
        p_zero = npos > 1 and not ptab.any() and not np.signbit(ptab).any()
        return float(v[-1]), a.tolist(), b.tolist(), ptab.tolist(), float(k_time), bool(p_zero)

    def speed_tables(self) -> tuple[list[float], list[float], float, int] | None:
        """``(A, B, 1 / speed_step, last)`` when the friction is ``A(|v|) + |tau_m| * B(|v|)`` alone (no position or
        time effect), for a caller that interpolates them itself as :meth:`__call__` does and adds ``+0.0`` (what
        the empty position and time terms add); ``last`` is the last interval's index. None otherwise."""
        if (self._p_zero or self._p_last == 0) and self._k_time == 0.0:
            return self._a, self._b, self._inv_step, self._a_last
        return None

    def _model(self, v: Array, load: float | Array) -> Array:
        inputs: dict[str, object] = {"speed": v * self._sf, "load_torque": np.asarray(load) * self._tf,
                                     "temperature": self.temperature}
        if "wear" in self.model.variables:
            inputs["wear"] = self.wear
        return np.asarray(self.model.evaluate(self.params, **inputs), dtype=float) / self._tf * np.ones_like(v)

    def _cols(self, v: Array, load: float, pos: Array, time: float) -> dict[str, Array]:
        n = v.size
        return {
            "speed": v,
            "load_torque": np.full(n, load),
            "position": pos,
            "lube_hours": np.full(n, self.lube_hours),
            "time": np.full(n, time),
        }

    def __call__(self, speed: float, load_torque: float, position: float = 0.0, time: float = 0.0) -> float:
        """Friction magnitude (normalized) at ``|speed|`` (motor rad/s), ``|load_torque|``, position, time."""
        x = abs(speed) * self._inv_step
        i = int(x)
        if i > self._a_last:
            i, f = self._a_last, 1.0
        else:
            f = x - i
        ta = self._a
        tb = self._b
        a0 = ta[i]
        b0 = tb[i]
        val = a0 + f * (ta[i + 1] - a0) + abs(load_torque) * (b0 + f * (tb[i + 1] - b0))
        if self._p_zero:
            val += 0.0  # what interpolating the all-zero position table adds
        elif self._p_last > 0:
            tp = self._p
            y = (position - self._p0) * self._inv_pstep
            if y <= 0.0:
                val += tp[0]
            elif y >= self._p_last:
                val += tp[-1]
            else:
                j = int(y)
                p0 = tp[j]
                val += p0 + (y - j) * (tp[j + 1] - p0)
        return val + self._k_time * time

    def exact(self, speed: Array, load_torque: Array | float, position: Array | float = 0.0, time: Array | float = 0.0) -> Array:
        """The same friction evaluated directly from the model and effect definitions (vectorised)."""
        v = np.abs(np.asarray(speed, dtype=float)).reshape(-1)
        n = v.size
        tm = np.broadcast_to(np.abs(np.asarray(load_torque, dtype=float)), (n,)).astype(float)
        pos = np.broadcast_to(np.asarray(position, dtype=float), (n,)).astype(float)
        tt = np.broadcast_to(np.asarray(time, dtype=float), (n,)).astype(float)
        out = self._model(v, tm) * np.ones(n)
        cols = {"speed": v, "load_torque": tm, "position": pos, "lube_hours": np.full(n, self.lube_hours), "time": tt}
        for e in self.hidden_effects:
            out = out + effect_value(e, cols)
        return out
