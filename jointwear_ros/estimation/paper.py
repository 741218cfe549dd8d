"""The paper's wear estimator, Eq. (10)-(11), in a fast and a grid-search implementation.

For each observation: draw ``T_i ~ U(T_lo, T_hi)``, i = 1..N, solve
``w_i = argmin_{w in [0,100]} (tau_f - tau_f_hat(v, tau_m, T_i, w))^2`` (Eq. 11a) and
take ``w_hat = mean(w_i)`` (Eq. 11b). With a measured temperature (finite
``temperature`` column) Eq. (10) is solved once at that T instead.

:class:`PaperEstimator` solves (11a) through the tabulated inverse of the
wear term (:class:`~jointwear_ros.estimation.inverse.WearInverse`), vectorised
over observations and samples. :class:`PaperGridEstimator` scans a w grid for
every sample, exactly as the paper describes; it is kept for cross-checks. With
the same seed both draw the same temperature samples.

>>> from jointwear_ros.types import ObservationTable
>>> from jointwear_ros.model import paper_wear_model, load_parameter_set
>>> m, p = paper_wear_model(), load_parameter_set("ref-2011r")
>>> tau = m.evaluate(p, speed=40.0, load_torque=0.1, temperature=40.0, wear=35.0)
>>> obs = ObservationTable.from_arrays(speed=[40.0], tau_f=[tau], load_torque=[0.1], temperature=[40.0])
>>> round(PaperEstimator(seed=1).estimate(obs).wear, 6)
35.0
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from ..model import Model, Parameters, ParameterSet
from ..types import ObservationTable, WearResult
from ._common import WEAR_RANGE, Capabilities, Rows, SetModelBase, combine_rows, make_rng, prepare_rows, with_set_info
from .inverse import TemperatureTable, WearInverse, base_friction, shared_inverse
from .priors import parse_temperature_prior

__all__ = ["PAPER_N_SAMPLES", "PAPER_TEMPERATURE_RANGE", "PaperEstimator", "PaperGridEstimator"]

Array = npt.NDArray[np.float64]

#: [T_lo, T_hi] of Section 5.1, degC.
PAPER_TEMPERATURE_RANGE = (30.0, 50.0)
#: N of Section 5.1.
PAPER_N_SAMPLES = 200

_CHUNK_ELEMENTS = 1 << 18


class _PaperBase(SetModelBase):
    """What both implementations share: options, sampling, combination."""

    name = "paper"

    def __init__(
        self,
        model: Model | None = None,
        params: Parameters | Mapping[str, float] | str | ParameterSet | None = None,
        *,
        n_samples: int = PAPER_N_SAMPLES,
        temperature_range: tuple[float, float] | None = None,
        wear_range: tuple[float, float] = WEAR_RANGE,
        noise_std: float | None = None,
        default_load: float | None = None,
        use_temperature: bool = True,
        seed: int | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        noise_std = self.attach_set_model(model, params, noise_std)
        if temperature_range is None:
            temperature_range = PAPER_TEMPERATURE_RANGE
            if self.param_set is not None and self.param_set.temperature_prior:
                temperature_range = parse_temperature_prior(self.param_set.temperature_prior).support(1.0)
        if int(n_samples) < 1:
            raise InputDataError(f"n_samples = {n_samples!r}: the paper's estimator needs at least one temperature sample")
        self.n_samples = int(n_samples)
        lo, hi = map(float, temperature_range)
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise InputDataError(f"temperature_range = {temperature_range!r}: needs finite T_lo < T_hi (degC)")
        self.temperature_range = (lo, hi)
        self.wear_range = (float(wear_range[0]), float(wear_range[1]))
        self.noise_std = float(noise_std)
        self.default_load = default_load
        self.use_temperature = use_temperature
        self.rng = make_rng(rng, seed)

    # -- per-row solution (implemented by each variant) -----------------------
    def _solve_known(self, speed: Array, load: Array, tau: Array, temp: Array) -> Array:
        raise NotImplementedError

    def _solve_sampled(self, speed: float, load: float, tau: Array, u: Array) -> Array:
        """Per-sample argmins, shape (len(tau), N), for T = T_lo + u (T_hi - T_lo)."""
        raise NotImplementedError

    def _slope(self, speed: float, w: Array) -> Array:
        return np.abs(
            self.model.input_gradient("wear", self.params, speed=speed, load_torque=0.0, temperature=40.0, wear=w)
        )

    # -- vectorised API ----------------------------------------------------------
    def estimate_rows(
        self,
        speed: npt.ArrayLike,
        load: npt.ArrayLike,
        tau_f: npt.ArrayLike,
        temperature: npt.ArrayLike | None = None,
        *,
        rng: np.random.Generator | None = None,
    ) -> tuple[Array, Array]:
        """Single-observation estimates of many rows at once.

        Returns ``(w_hat, sample_std)``: Eq. (11b) per row and the standard
        deviation of its N per-sample argmins (0 for a measured temperature).
        The N uniforms of every row with unknown T are drawn from ``rng`` (or
        the estimator's own generator) in row order, one (rows, N) block.
        """
        speed = np.atleast_1d(np.asarray(speed, dtype=float))
        tau = np.broadcast_to(np.asarray(tau_f, dtype=float), speed.shape)
        load = np.broadcast_to(np.asarray(load, dtype=float), speed.shape)
        temp = (np.full(speed.shape, math.nan) if temperature is None
                else np.broadcast_to(np.asarray(temperature, dtype=float), speed.shape))
        gen = rng if rng is not None else self.rng
        out = np.empty(speed.shape)
        spread = np.zeros(speed.shape)
        known = np.isfinite(temp)
        if known.any():
            out[known] = self._solve_known(speed[known], load[known], tau[known], temp[known])
        unk = np.flatnonzero(~known)
        if unk.size:
            u_all = gen.random((unk.size, self.n_samples))
            keys = np.stack([speed[unk], load[unk]], axis=1)
            uniq, inv = np.unique(keys, axis=0, return_inverse=True)
            inv = np.asarray(inv).reshape(-1)
            for g, (v, tm) in enumerate(uniq):
                idx = np.flatnonzero(inv == g)
                step = max(1, _CHUNK_ELEMENTS // self.n_samples)
                for s in range(0, idx.size, step):
                    sel = idx[s:s + step]
                    wi = self._solve_sampled(float(v), float(tm), tau[unk[sel]], u_all[sel])
                    out[unk[sel]] = wi.mean(axis=1)
                    if self.n_samples > 1:
                        spread[unk[sel]] = wi.std(axis=1, ddof=1)
        return out, spread

    def estimate(self, observations: ObservationTable) -> WearResult:
        """Eq. (11) per observation (speed); the cycle estimate combines them (see ``combine_rows``)."""
        rows = prepare_rows(observations, noise_std=self.noise_std, default_load=self.default_load,
                            use_temperature=self.use_temperature, pset=self.param_set, extra=self.extra,
                            params=self.params)
        w, spread = self.estimate_rows(rows.speed, rows.load, rows.tau_f, rows.temperature)
        std = self._row_std(rows, w, spread)
        lo, hi = self.temperature_range
        return with_set_info(combine_rows(
            rows, w, std, method=self.name,
            info={
                "n_samples": self.n_samples,
                "temperature_range": [lo, hi],
                "known_temperature": [bool(k) for k in rows.known_temperature],
                "per_speed_sample_std": [float(s) for s in spread],
            },
        ), self.param_set)

    def _row_std(self, rows: Rows, w: Array, spread: Array) -> Array:
        """Uncertainty of a row: the spread over T samples and the noise through the wear slope."""
        std = np.empty(len(rows))
        span = self.wear_range[1] - self.wear_range[0]
        for i in range(len(rows)):
            slope = float(self._slope(float(rows.speed[i]), np.array([w[i]]))[0])
            noise = rows.noise_std[i] / slope if slope > 0 else math.inf
            std[i] = min(math.hypot(spread[i], noise), span / math.sqrt(12.0))
        return std


class PaperEstimator(_PaperBase):
    """Eq. (11) through the tabulated inverse of the wear term: fast, no grid scan.

    Parameters
    ----------
    model, params
        Friction model (default Eq. 9) and parameters (default ``ref-2011r``).
    n_samples
        N, temperature samples per observation (paper: 200).
    temperature_range
        [T_lo, T_hi] of the uniform temperature assumption, degC (paper: 30, 50).
    wear_range
        Search interval of w (paper: [0, 100]).
    noise_std
        sigma_e for rows without ``tau_f_std`` (only enters the reported uncertainty).
    default_load
        tau_m for tables without a ``load_torque`` column (else that is an error).
    use_temperature
        Use measured temperatures (finite ``temperature``) instead of sampling.
    seed, rng
        Source of the temperature samples (a Generator passed in, or a seed).
    n_table
        Cells of the inverse table per speed.
    """

    name = "paper"
    capabilities = Capabilities(
        summary="the paper's Eq. (11): per observation, T sampled from a uniform range, a tabulated inverse",
        temperature_assumption="range", needs_seed=True, temperature_samples=True, search="table")

    def __init__(self, model: Model | None = None, params: Parameters | Mapping[str, float] | str | ParameterSet | None = None,
                 *, n_table: int = 16384, **options: object) -> None:
        super().__init__(model, params, **options)  # type: ignore[arg-type]
        self.n_table = int(n_table)
        self._inverse: dict[float, WearInverse] = {}
        self._ttables: dict[tuple[float, float], TemperatureTable] = {}

    def inverse(self, speed: float) -> WearInverse:
        """The (cached) inverse of the wear term at ``speed``."""
        key = float(speed)
        inv = self._inverse.get(key)
        if inv is None:
            inv = shared_inverse(self.model, self.params, key, self.wear_range, n_table=self.n_table)
            self._inverse[key] = inv
        return inv

    def temperature_table(self, speed: float, load: float) -> TemperatureTable:
        key = (float(speed), float(load))
        tt = self._ttables.get(key)
        if tt is None:
            tt = TemperatureTable(self.model, self.params, key[0], key[1], *self.temperature_range)
            self._ttables[key] = tt
        return tt

    def _solve_known(self, speed: Array, load: Array, tau: Array, temp: Array) -> Array:
        z = tau - base_friction(self.model, self.params, speed, load, temp)
        return np.array([float(self.inverse(float(v)).exact(zz)[0]) for v, zz in zip(speed, z)])

    def _solve_sampled(self, speed: float, load: float, tau: Array, u: Array) -> Array:
        b = self.temperature_table(speed, load).at_unit(u)
        np.subtract(tau[:, None], b, out=b)
        return self.inverse(speed)(b)

    def _slope(self, speed: float, w: Array) -> Array:
        return self.inverse(speed).slope(w)


class PaperGridEstimator(_PaperBase):
    """Eq. (11) exactly as written: a grid search over w for every temperature sample.

    Same options as :class:`PaperEstimator` plus ``grid_step`` (default 0.1).
    Evaluates the full model for every (sample, grid point); slow, kept to
    cross-check the fast implementation. Among grid points of equal error the
    first (smallest w) wins, as ``numpy.argmin`` does.
    """

    name = "paper-grid"
    capabilities = Capabilities(
        summary="Eq. (11) exactly as written: a grid scan of w per temperature sample (slow; a cross-check)",
        temperature_assumption="range", needs_seed=True, temperature_samples=True, search="grid")

    def __init__(self, model: Model | None = None, params: Parameters | Mapping[str, float] | str | ParameterSet | None = None,
                 *, grid_step: float = 0.1, **options: object) -> None:
        super().__init__(model, params, **options)  # type: ignore[arg-type]
        if not (grid_step > 0 and math.isfinite(grid_step)):
            raise InputDataError(f"grid_step = {grid_step!r} must be a positive number")
        lo, hi = self.wear_range
        n = round((hi - lo) / grid_step) + 1
        self.grid = np.linspace(lo, hi, n)
        self.grid_step = (hi - lo) / (n - 1)

    def _argmin(self, speed: float, load: float, tau: Array, temps: Array) -> Array:
        """argmin over the grid for each (row, T) in ``temps`` of shape (rows, k)."""
        pred = self.model.evaluate(self.params, speed=speed, load_torque=load,
                                   temperature=temps[..., None], wear=self.grid)
        err = (tau[:, None, None] - pred) ** 2
        return self.grid[np.argmin(err, axis=-1)]

    def _solve_known(self, speed: Array, load: Array, tau: Array, temp: Array) -> Array:
        return np.array([float(self._argmin(float(v), float(tm), np.array([y]), np.array([[t]]))[0, 0])
                         for v, tm, y, t in zip(speed, load, tau, temp)])

    def _solve_sampled(self, speed: float, load: float, tau: Array, u: Array) -> Array:
        lo, hi = self.temperature_range
        temps = lo + (hi - lo) * u
        out = np.empty(u.shape)
        step = max(1, (1 << 16) // (u.shape[1] * self.grid.size) + 1)
        for s in range(0, tau.size, step):
            out[s:s + step] = self._argmin(speed, load, tau[s:s + step], temps[s:s + step])
        return out
