"""Fast building blocks of the paper's estimator: the wear term's inverse at one speed.

With the model additive in wear (Eq. 9), ``tau_f(v, tau_m, T, w) = b(v, tau_m, T) + g_v(w)``
with ``g_v(0) = 0``. Eq. (10) for one observation and one temperature is then
``argmin_w (z - g_v(w))^2`` with ``z = tau_f - b(v, tau_m, T)``: a root of
``g_v(w) = z`` when there is one in [0, 100], else the end or turning point of
``g_v`` nearest in value. :class:`WearInverse` solves this exactly (monotone
pieces, interpolation start, Newton polish) and tabulates it once per speed on
a uniform z grid, so that each of the millions of (observation, T-sample) pairs
costs one table lookup instead of a grid scan.

For v > 0, ``g_v`` first falls (the viscous wear term Fvw*w*v < 0 dominates at
small w) and then rises, so a z slightly below 0 has two exact minimisers. The
estimator takes the **smallest** minimiser (the first, as ``argmin`` reports
ties); the grid implementation, scanning a grid, picks whichever grid point
happens to be nearer, which is why the two agree to grid resolution only where
the minimiser is unique.

At 47 rad/s (T = 40 degC, tau_m = 0.1) wear 35 adds 0.01794 to the friction
(the paper's "0.017"); the inverse gives 35 back, exactly and from the table:

>>> from jointwear_ros.model import load_parameter_set, paper_wear_model
>>> m, p = paper_wear_model(), load_parameter_set("ref-2011r")
>>> inv = WearInverse(m, p, 47.0)
>>> z = float(m.evaluate(p, speed=47.0, load_torque=0.1, temperature=40.0, wear=35.0)
...           - base_friction(m, p, 47.0, 0.1, 40.0))
>>> round(z, 5), round(float(inv.exact(z)[0]), 6), round(float(inv(z)), 3)
(0.01794, 35.0, 35.0)
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ModelError
from ..model import Model, Parameters

__all__ = ["TemperatureTable", "WearInverse", "base_friction", "shared_inverse"]

Array = npt.NDArray[np.float64]


def base_friction(model: Model, params: Parameters, speed: npt.ArrayLike, load: npt.ArrayLike,
                  temperature: npt.ArrayLike) -> Array:
    """tau_f at w = 0 (Eq. 6): the part the wear term is added to."""
    return np.asarray(model.evaluate(params, speed=speed, load_torque=load, temperature=temperature, wear=0.0))


class WearInverse:
    """``G_v(z) = smallest argmin_{w in [lo, hi]} (z - g_v(w))^2`` at one speed ``v``.

    Parameters
    ----------
    model, params
        A model additive in wear (checked) and its parameters.
    speed
        The speed v, rad/s (motor side).
    wear_range
        The search interval of w (the paper's [0, 100]).
    n_dense
        Points of the dense w grid used to split g_v into monotone pieces and
        to start the Newton polish.
    n_table
        Cells of the uniform z table used by :meth:`__call__`.
    """

    def __init__(
        self,
        model: Model,
        params: Parameters | Mapping[str, float],
        speed: float,
        wear_range: tuple[float, float] = (0.0, 100.0),
        n_dense: int = 4001,
        n_table: int = 16384,
    ) -> None:
        self.model = model
        self.params = params
        self.speed = float(speed)
        self.lo, self.hi = map(float, wear_range)
        w = np.linspace(self.lo, self.hi, n_dense)
        self._check_additive()
        self.w_dense = w
        self.g_dense = self.g(w)
        dg = self.dg(w)
        self.dg_dense = dg
        # monotone pieces: split where the slope changes sign (turning points refined by bisection)
        sgn = np.sign(dg)
        cuts = [self.lo]
        for i in np.flatnonzero(sgn[1:] * sgn[:-1] < 0):
            cuts.append(self._turning_point(float(w[i]), float(w[i + 1])))
        cuts.append(self.hi)
        self.cuts = np.asarray(cuts)
        # the z table is built on first use: a cycle with measured temperatures solves each observation
        # exactly (:meth:`exact`) and never looks it up (most of an inverse's construction)
        self.n_table = int(n_table)
        self._table: tuple[float, float, int, Array, Array, Array] | None = None

    # -- the wear term -------------------------------------------------------
    def g(self, w: npt.ArrayLike) -> Array:
        """g_v(w) = tau_f(v, ., ., w) - tau_f(v, ., ., 0)."""
        w = np.asarray(w, dtype=float)
        a = self.model.evaluate(self.params, speed=self.speed, load_torque=0.0, temperature=40.0, wear=w)
        b = self.model.evaluate(self.params, speed=self.speed, load_torque=0.0, temperature=40.0, wear=0.0)
        return np.asarray(a - b, dtype=float)

    def dg(self, w: npt.ArrayLike) -> Array:
        """d g_v / d w (analytic, from the model)."""
        w = np.asarray(w, dtype=float)
        return np.asarray(
            self.model.input_gradient("wear", self.params, speed=self.speed, load_torque=0.0, temperature=40.0, wear=w),
            dtype=float,
        )

    def _check_additive(self) -> None:
        w = np.array([0.0, 20.0, 35.0, 70.0])
        d1 = self.model.evaluate(self.params, speed=self.speed, load_torque=0.0, temperature=30.0, wear=w)
        d2 = self.model.evaluate(self.params, speed=self.speed, load_torque=0.5, temperature=50.0, wear=w)
        if not np.allclose(d1 - d1[0], d2 - d2[0], rtol=1e-9, atol=1e-12):
            raise ModelError(
                f"model {self.model.spec!r}: the wear effect depends on load or temperature, so the fast "
                "paper estimator (which needs Eq. 9, wear additive) cannot be used; use method 'paper-grid'"
            )

    def _turning_point(self, a: float, b: float) -> float:
        da = float(self.dg(a))
        for _ in range(60):
            m = 0.5 * (a + b)
            dm = float(self.dg(m))
            if np.sign(dm) == np.sign(da):
                a, da = m, dm
            else:
                b = m
        return 0.5 * (a + b)

    # -- exact solution ------------------------------------------------------
    def exact(self, z: npt.ArrayLike) -> Array:
        """The smallest minimiser for each z, solved without tabulation (vectorised)."""
        z = np.atleast_1d(np.asarray(z, dtype=float))
        cands: list[Array] = []
        for a, b in zip(self.cuts[:-1], self.cuts[1:]):
            m = (self.w_dense >= a) & (self.w_dense <= b)
            ws = np.concatenate(([a], self.w_dense[m], [b]))
            gs = self.g(ws)
            order = np.argsort(gs, kind="stable")
            gsorted, wsorted = gs[order], ws[order]
            inside = (z >= gsorted[0]) & (z <= gsorted[-1])
            root = np.interp(z, gsorted, wsorted)
            for _ in range(4):  # Newton polish, kept inside the piece
                d = self.dg(root)
                step = np.where(np.abs(d) > 1e-14, (self.g(root) - z) / np.where(d == 0, 1.0, d), 0.0)
                root = np.clip(root - step, a, b)
            cands.append(np.where(inside, root, np.nan))
        ends = np.unique(self.cuts)
        for e in ends:
            cands.append(np.full(z.shape, e))
        c = np.column_stack(cands)  # (n_z, n_cand)
        gc = self.g(np.nan_to_num(c, nan=self.lo))
        resid = np.where(np.isnan(c), np.inf, np.abs(z[:, None] - gc))
        best = resid.min(axis=1, keepdims=True)
        tol = 1e-16 + 1e-12 * np.abs(z)[:, None]
        tied = resid <= best + tol
        return np.asarray(np.where(tied, c, np.inf).min(axis=1), dtype=float)

    # -- tabulated solution --------------------------------------------------
    @property
    def z_nodes(self) -> Array:
        """The z table's nodes (built on first use)."""
        return self._built()[5]

    def _built(self) -> tuple[float, float, int, Array, Array, Array]:
        if self._table is None:
            self._table = self._build_table(self.n_table)
        return self._table

    def _build_table(self, n_table: int) -> tuple[float, float, int, Array, Array, Array]:
        gmin, gmax = float(self.g_dense.min()), float(self.g_dense.max())
        span = max(gmax - gmin, 1e-12)
        dz = span / n_table
        k0 = math.floor(gmin / dz) - 1  # z = 0 (g(0)) falls on a node: a branch switch there stays sharp
        k1 = math.ceil(gmax / dz) + 1
        nodes = np.asarray(np.arange(k0, k1 + 1) * dz, dtype=float)
        eps = 1e-3 * dz
        left = self.exact(nodes[:-1] + eps)  # right limit at the cell's start
        right = self.exact(nodes[1:] - eps)  # left limit at the cell's end
        return float(nodes[0]), 1.0 / dz, nodes.size - 1, left, right - left, nodes

    def __call__(self, z: npt.ArrayLike) -> Array:
        """Tabulated G_v(z): one lookup and a linear blend per value (any shape)."""
        z0, inv_dz, ncell, left, delta, _ = self._built()
        z = np.asarray(z, dtype=float)
        t = np.asarray((z - z0) * inv_dz, dtype=float).reshape(z.shape)  # an array also for a scalar z
        np.clip(t, 0.0, ncell - 1e-9, out=t)
        k = t.astype(np.intp)
        t -= k
        return left[k] + t * delta[k]

    def slope(self, w: npt.ArrayLike) -> Array:
        """|d g_v / d w| at w (for the noise part of an estimate's uncertainty)."""
        return np.abs(np.interp(np.asarray(w, dtype=float), self.w_dense, self.dg_dense))


#: Inverses kept by :func:`shared_inverse` (about 0.5 MB each with their tables), least recently used dropped.
_SHARED_MAX = 48
_SHARED: OrderedDict[tuple[Any, ...], WearInverse] = OrderedDict()
#: estimators may run in threads (a Dask worker of several threads): a lookup, an insertion and an eviction each
#: hold it, so one thread's eviction never falls between another's lookup and its move to the end
_SHARED_LOCK = threading.Lock()
#: Wear levels (fractions of the search interval) at which a model's wear term is part of the cache key.
_PROBES = np.array([0.0, 0.071, 0.35, 0.719, 1.0])


def shared_inverse(model: Model, params: Parameters | Mapping[str, float], speed: float, wear_range: tuple[float, float] = (0.0, 100.0),
                   n_table: int = 16384) -> WearInverse:
    """:class:`WearInverse` of ``model`` and ``params`` at ``speed``, shared by every estimator of this process.

    A monitor builds an estimator for each cycle (its own random seed) and a replay, a fleet re-analysis or a
    study estimates many cycles at the same speeds with the same set: each built the same inverses again (most
    of an estimate). The key is the model's spec, the parameter values, the speed and the interval, and the
    wear term's values at five wear levels, so that a term re-registered under the same name with another
    shape is a new key, not a stale hit.
    """
    lo, hi = map(float, wear_range)
    probe = lo + (hi - lo) * _PROBES
    g = np.asarray(model.evaluate(params, speed=float(speed), load_torque=0.0, temperature=40.0, wear=probe),
                   dtype=float)
    values: dict[str, float] = (params.valuesdict() if isinstance(params, Parameters)
                                else {str(k): float(v) for k, v in params.items()})
    key = (model.spec, tuple(values.items()), float(speed), lo, hi, int(n_table), g.tobytes())
    with _SHARED_LOCK:
        inv = _SHARED.get(key)
        if inv is not None:
            _SHARED.move_to_end(key)
            return inv
    # built outside the lock (other threads go on); a copy of the values: the inverse builds its table later, and
    # the caller's set may change meanwhile
    built = WearInverse(model, dict(values), float(speed), (lo, hi), n_table=n_table)
    with _SHARED_LOCK:
        inv = _SHARED.setdefault(key, built)  # another thread's, if it came first: one inverse per key
        _SHARED.move_to_end(key)
        while len(_SHARED) > _SHARED_MAX:
            _SHARED.popitem(last=False)
    return inv


class TemperatureTable:
    """b(v, tau_m, T) on a uniform T grid over [t_lo, t_hi], looked up by u = (T - t_lo)/(t_hi - t_lo).

    The base friction is smooth in T; 1025 nodes over 20 degC leave an
    interpolation error below 1e-9 (normalized torque).
    """

    def __init__(self, model: Model, params: Parameters, speed: float, load: float,
                 t_lo: float, t_hi: float, n: int = 1025) -> None:
        self.t_lo, self.t_hi = float(t_lo), float(t_hi)
        t = np.linspace(self.t_lo, self.t_hi, n)
        b = base_friction(model, params, speed, load, t)
        self._b = np.asarray(b, dtype=float)
        self._db = np.diff(self._b)
        self._n = n - 1

    def at_unit(self, u: Array) -> Array:
        """b at T = t_lo + u (t_hi - t_lo), u in [0, 1]."""
        t = u * self._n
        k = np.minimum(t.astype(np.intp), self._n - 1)
        return self._b[k] + (t - k) * self._db[k]
