"""Joint estimation of wear and temperature from all speeds of one test cycle.

The paper estimates w one speed at a time, each time integrating over an
unknown T. In a test cycle every speed is measured within minutes, at the same
joint temperature, so the K observations share ONE unknown T:

    y_k = f(v_k, tau_m,k, T, w) + e_k,   e_k ~ N(0, sigma_k^2),   T ~ p(T),   w ~ U(0, 100)

:class:`JointEstimator` computes the posterior ``p(w, T | y)`` on a grid: T on
the prior's quadrature nodes (Gauss-Legendre in probability space; as many as
:func:`~jointwear_ros.estimation.crb.temperature_nodes` needs to resolve the
likelihood's width in T: two nodes per sigma of the friction's spread over the
prior), w on a uniform grid over [0, 100]. A coarse pass (w
step 0.5) finds every region of w holding posterior mass (the wear effect is
not monotone in w for v > 0, so the posterior can have two modes); a fine pass
(step 1/32) over those regions only gives the posterior moments. Reported:

- ``wear``: the posterior mean of w (``point="mean"``, default) or the joint
  MAP of (w, T), polished by bounded L-BFGS-B (``point="map"``);
- ``wear_std``, ``wear_low``/``wear_high``: posterior std and the central 95 %
  credible interval of the marginal posterior of w;
- ``temperature``, ``temperature_std``: posterior mean and std of T;
- ``per_speed_wear``: each row's own least-squares w at the estimated T;
- ``wear_std_model``: what the set's own parameter uncertainty (a commissioned set's
  ``covariance``) adds to ``wear_std`` (:meth:`JointEstimator.model_std`, the delta method; 0 for a
  set without one); ``info`` names the parts (``wear_std_posterior``, ``wear_std_model``, and
  ``wear_std_temperature``: the unknown temperature's part of the posterior std).

With the temperature unknown, the posterior mean of a weak wear reads low (about -0.5 std at
wear 10 with ``ref-2011r``); the median, the MAP, a profile over T and a Jeffreys prior were
measured and none removes it without more estimates beyond 3 std elsewhere (docs/estimation-joint.md).

Rows with a measured temperature (finite ``temperature`` column) fix T: with a
measurement on every row each row uses its own; when only some rows have one,
the cycle's T is the mean of the measured values. The posterior is then over
w alone.

The friction model's values on the (row, T node, w) grid do not depend on the
data and are cached per set of (speed, load) rows, so repeated cycles at the
same speeds (a simulation study) cost a few array operations each.

>>> from jointwear_ros.types import ObservationTable
>>> from jointwear_ros.model import paper_wear_model, load_parameter_set
>>> m, p = paper_wear_model(), load_parameter_set("ref-2011r")
>>> v = [0.0, 20.0, 40.0, 60.0, 100.0, 150.0]
>>> tau = m.evaluate(p, speed=v, load_torque=0.1, temperature=37.0, wear=35.0)
>>> r = JointEstimator().estimate(ObservationTable.from_arrays(speed=v, tau_f=tau, load_torque=0.1))
>>> abs(r.wear - 35.0) < 0.5 and abs(r.temperature - 37.0) < 1.0
True
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.special import chdtrc  # chdtrc(dof, x): scipy.stats.chi2.sf(x, dof)

from ..errors import InputDataError
from ..model import Model, Parameters, ParameterSet
from ..types import ObservationTable, WearResult
from ._common import (
    WEAR_RANGE,
    Capabilities,
    Rows,
    SetModelBase,
    check_noise_std,
    check_wear_range,
    log_sum_exp,
    prepare_rows,
    set_temperature_prior,
    with_set_info,
)
from .crb import DEFAULT_CRB_PRIOR, temperature_nodes
from .priors import TemperaturePrior, parse_temperature_prior

__all__ = ["JointEstimator", "JointPosterior", "parameter_covariance", "widen_interval"]

Array = npt.NDArray[np.float64]
Index = npt.NDArray[np.intp]

#: Below this chi-square tail probability of the fit at the estimate, the cycle is called unexplained and
#: the std is widened by the Birge ratio (see :meth:`JointEstimator._fit_check`).
MISFIT_P = 1e-3
#: A temperature estimated at the edge of its prior is named when the fit is also poor (p below this).
EDGE_P = 0.05
#: Fine w steps per coarse step.
_REFINE = 16
#: Coarse cells whose marginal log posterior is within this of the maximum are refined.
_KEEP_LOG = 25.0
#: Largest cached model grid (floats); beyond it the fine pass evaluates the model on demand.
_MAX_CACHE = 12_000_000
#: Grid cells below this share of the largest one's posterior mass are left out of the model part's gradient.
_MASS_FLOOR = 1e-9
#: Two-sided 95 % of a normal: the interval's half-width of the model part.
_Z95 = 1.959963984540054


@dataclass(frozen=True)
class JointPosterior:
    """Summary of p(w, T | y) for one cycle."""

    wear_mean: float
    wear_std: float
    wear_low: float
    wear_high: float
    wear_map: float
    temperature_mean: float
    temperature_std: float
    temperature_map: float
    n_modes: int
    #: the part of ``wear_std`` the unknown temperature adds (law of total variance: the std over T of the mean of
    #: w given T); 0 with the temperature measured
    wear_std_temperature: float = 0.0


class _Grid:
    """Model values on (rows, T nodes, fine w grid) for one set of rows."""

    def __init__(self, model: Model, params: Parameters, speed: Array, load: Array, temps: Array,
                 wgrid: Array) -> None:
        self.model, self.params = model, params
        self.speed, self.load, self.temps, self.w = speed, load, temps, wgrid
        self.coarse_idx = np.arange(0, wgrid.size, _REFINE)
        if self.coarse_idx[-1] != wgrid.size - 1:
            self.coarse_idx = np.append(self.coarse_idx, wgrid.size - 1)
        size = speed.size * temps.size * wgrid.size
        self.full: Array | None = self._eval(wgrid) if size <= _MAX_CACHE else None
        self.coarse = self.full[:, :, self.coarse_idx] if self.full is not None else self._eval(wgrid[self.coarse_idx])

    def _eval(self, w: Array) -> Array:
        f = self.model.evaluate(self.params, speed=self.speed[:, None, None], load_torque=self.load[:, None, None],
                                temperature=self.temps[None, :, None], wear=w[None, None, :])
        return np.asarray(np.broadcast_to(f, (self.speed.size, self.temps.size, w.size)), dtype=float)

    def fine(self, idx: Index) -> Array:
        """The model on the fine columns ``idx`` (ascending); a view of the cache when they are one run (one mode:
        the usual case), not a copy."""
        if self.full is not None:
            if idx.size and int(idx[-1]) - int(idx[0]) + 1 == idx.size:
                return self.full[:, :, int(idx[0]):int(idx[-1]) + 1]
            return self.full[:, :, idx]
        return self._eval(self.w[idx])


class JointEstimator(SetModelBase):
    """Wear and temperature together from all speeds of one cycle (one shared unknown T).

    Parameters
    ----------
    model, params
        Friction model (default Eq. 9) and parameters (default ``ref-2011r``).
    prior
        Temperature prior (a :class:`TemperaturePrior` or a spec such as
        ``"uniform:25:55"``); default the set's ``temperature_prior`` (a commissioned
        set's covered range), else U(25, 55) degC.
    noise_std
        sigma_e for rows without ``tau_f_std`` (the set's torque unit); default the
        set's ``noise_std``, else the paper's 0.0015.
    wear_range
        Support of the flat prior on w (default [0, 100]).
    wear_step
        Step of the fine w grid (default 1/32).
    point
        ``"mean"`` (posterior mean, default) or ``"map"`` (joint MAP of w and T).
    n_temperature
        Quadrature nodes over T (default: enough to resolve the likelihood).
    default_load
        tau_m for tables without a ``load_torque`` column.
    use_temperature
        Use measured temperatures when rows have them.
    model_uncertainty
        Carry the set's parameter covariance (a commissioned set's ``covariance``) into the std
        (default True; see :meth:`model_std`): ``wear_std`` is then ``hypot(posterior std, wear_std_model)``
        and the interval widens by +-1.96 ``wear_std_model``. A set without a covariance is unaffected.
    seed, rng
        Accepted for the common estimator interface; the estimator is deterministic.
    """

    name = "joint"
    capabilities = Capabilities(
        summary="all speeds of a cycle at once: the joint posterior of w and the cycle's one unknown T",
        cycle=True, temperature_assumption="prior", gives_posterior=True, search="posterior grid",
        points=(("mean", "mean"), ("map", "map"), ("mode", "map")))

    def __init__(
        self,
        model: Model | None = None,
        params: Parameters | Mapping[str, float] | str | ParameterSet | None = None,
        *,
        prior: TemperaturePrior | str | None = None,
        noise_std: float | None = None,
        wear_range: tuple[float, float] = WEAR_RANGE,
        wear_step: float = 1.0 / 32.0,
        point: str = "mean",
        n_temperature: int | None = None,
        default_load: float | None = None,
        use_temperature: bool = True,
        model_uncertainty: bool = True,
        seed: int | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        noise_std = self.attach_set_model(model, params, noise_std)
        self.prior = parse_temperature_prior(prior if prior is not None
                                             else set_temperature_prior(self.param_set, DEFAULT_CRB_PRIOR))
        self.noise_std = check_noise_std(noise_std)
        self.wear_range = lo, hi = check_wear_range(wear_range)
        if not (math.isfinite(wear_step) and 0 < wear_step <= (hi - lo) / (4 * _REFINE)):
            raise InputDataError(f"wear_step = {wear_step!r} must be positive and at most {(hi - lo) / (4 * _REFINE):g}")
        n = math.ceil((hi - lo) / wear_step / _REFINE) * _REFINE
        self.w_grid = np.linspace(lo, hi, n + 1)
        key = str(point).strip().lower()
        if key not in ("mean", "map"):
            raise InputDataError(f"point = {point!r}: choose 'mean' (posterior mean) or 'map'")
        self.point = key
        if n_temperature is not None and int(n_temperature) < 2:
            raise InputDataError(f"n_temperature = {n_temperature!r} must be at least 2")
        self.n_temperature = None if n_temperature is None else int(n_temperature)
        self.default_load = default_load
        self.use_temperature = use_temperature
        self.model_uncertainty = bool(model_uncertainty)
        self.model_covariance = (parameter_covariance(self.param_set, self.params, self.model.param_names)
                                 if self.model_uncertainty else None)
        self._covariance_note = ""
        if self.model_uncertainty and self.model_covariance is None and self.param_set is not None \
                and self.param_set.covariance is not None:
            self._covariance_note = ("the set's covariance has no finite entries for the model's parameters: "
                                     "its uncertainty is not in the std")
        self._cache: OrderedDict[tuple[object, ...], _Grid] = OrderedDict()

    # -- grids ---------------------------------------------------------------
    def _grid(self, speed: Array, load: Array, temps: Array | None) -> _Grid:
        key = (speed.tobytes(), load.tobytes(), None if temps is None else temps.tobytes())
        g = self._cache.get(key)
        if g is not None:
            self._cache.move_to_end(key)
            return g
        if temps is None:
            n = self.n_temperature or temperature_nodes(self.model, self.params, speed, 35.0,
                                                        load=float(np.mean(load)), noise_std=self.noise_std,
                                                        prior=self.prior, density=2.0)
            temps, _ = self.prior.quadrature(n)
        g = _Grid(self.model, self.params, speed, load, temps, self.w_grid)
        self._cache[key] = g
        if len(self._cache) > 8:
            self._cache.popitem(last=False)
        return g

    # -- the posterior ---------------------------------------------------------
    def posterior(self, speed: npt.ArrayLike, load: npt.ArrayLike, tau_f: npt.ArrayLike,
                  noise_std: npt.ArrayLike | None = None, temperature: npt.ArrayLike | None = None
                  ) -> JointPosterior:
        """The posterior summary for one cycle given as arrays (rows share T).

        ``temperature``: None or all-NaN for unknown T; otherwise measured
        values (NaN rows take the mean of the measured ones).
        """
        v = np.atleast_1d(np.asarray(speed, dtype=float))
        tm = np.abs(np.broadcast_to(np.asarray(load, dtype=float), v.shape)).copy()
        y = np.broadcast_to(np.asarray(tau_f, dtype=float), v.shape)
        sig = np.broadcast_to(np.asarray(self.noise_std if noise_std is None else noise_std, dtype=float), v.shape)
        temp = None if temperature is None else np.broadcast_to(np.asarray(temperature, dtype=float), v.shape)
        if temp is not None and np.isfinite(temp).any():
            return self._posterior_known(v, tm, y, sig, np.where(np.isfinite(temp), temp, np.nanmean(temp)))
        return self._posterior_unknown(v, tm, y, sig)

    def _posterior_unknown(self, v: Array, tm: Array, y: Array, sig: Array) -> JointPosterior:
        g = self._grid(v, tm, None)
        p, chi, idx, keep, _ = self._fine_pass(g, y, sig)
        w = g.w[idx]
        pw = p.sum(axis=0)
        pt = p.sum(axis=1)
        wm = float(pw @ w)
        ws = math.sqrt(max(float(pw @ (w - wm) ** 2), 0.0))
        tmn = float(pt @ g.temps)
        ts = math.sqrt(max(float(pt @ (g.temps - tmn) ** 2), 0.0))
        lo, hi = self._interval(w, pw)
        # the unknown T's part of the std: var(w) = E_T[var(w | T)] + var_T(E[w | T])
        on = pt > 0
        mt = (p[on] @ w) / pt[on]
        wst = math.sqrt(max(float(pt[on] @ (mt - wm) ** 2), 0.0))
        # joint MAP: the prior density (not the quadrature weight) at each node
        lmap = np.asarray(self.prior.logpdf(g.temps), dtype=float)[:, None] - chi
        it, iw = np.unravel_index(int(np.argmax(lmap)), lmap.shape)
        w_map, t_map = float(w[iw]), float(g.temps[it])
        if self.point == "map":
            w_map, t_map = self._polish(v, tm, y, sig, w_map, t_map)
        return JointPosterior(wm, ws, lo, hi, w_map, tmn, ts, t_map, _count_modes(keep), min(wst, ws))

    def _fine_pass(self, g: _Grid, y: Array, sig: Array) -> tuple[Array, Array, Index, Index, Array]:
        """p(T, w | y) on the fine w columns that hold posterior mass: ``(p, chi, idx, keep, f)``, ``chi`` half
        the squared normalized residuals, ``idx`` the fine columns, ``keep`` the coarse cells kept, ``f`` the
        model on (rows, T nodes, idx)."""
        _, wq = self.prior.quadrature(g.temps.size)
        with np.errstate(divide="ignore"):
            logw = np.log(wq)
        inv = 0.5 / sig**2
        # coarse pass: marginal over T on the coarse w grid
        rc = y[:, None, None] - g.coarse
        llc = logw[:, None] - np.einsum("k,ktw->tw", inv, rc * rc)
        marg = log_sum_exp(llc, axis=0, overwrite=True)  # finite: the quadrature weights sum to 1
        keep = np.flatnonzero(marg >= marg.max() - _KEEP_LOG)
        idx = self._fine_columns(g, keep)
        # fine pass
        f = g.fine(idx)
        rf = y[:, None, None] - f
        chi = np.einsum("k,ktw->tw", inv, rf * rf)
        ll = logw[:, None] - chi
        ll -= ll.max()
        p = np.exp(ll)
        p /= p.sum()
        return p, chi, idx, keep, f

    def _posterior_known(self, v: Array, tm: Array, y: Array, sig: Array, temp: Array) -> JointPosterior:
        f = self.model.evaluate(self.params, speed=v[:, None], load_torque=tm[:, None], temperature=temp[:, None],
                                wear=self.w_grid[None, :])
        chi = np.sum(((y[:, None] - f) / sig[:, None]) ** 2, axis=0) * 0.5
        ll = -(chi - chi.min())
        p = np.exp(ll)
        p /= p.sum()
        w = self.w_grid
        wm = float(p @ w)
        ws = math.sqrt(max(float(p @ (w - wm) ** 2), 0.0))
        lo, hi = self._interval(w, p)
        w_map = float(w[int(np.argmin(chi))])
        t = float(np.mean(temp))
        if self.point == "map":
            w_map = self._polish_known(v, tm, y, sig, temp, w_map)
        modes = _count_modes(np.flatnonzero(ll[::_REFINE] >= -_KEEP_LOG))
        return JointPosterior(wm, ws, lo, hi, w_map, t, 0.0, t, modes)

    def _fine_columns(self, g: _Grid, keep: Index) -> Index:
        """Fine w indices covering the coarse cells on either side of each kept coarse point."""
        ci = g.coarse_idx
        mask = np.zeros(g.w.size, dtype=bool)
        for c in keep:
            a = ci[max(c - 1, 0)]
            b = ci[min(c + 1, ci.size - 1)]
            mask[a:b + 1] = True
        return np.flatnonzero(mask)

    @staticmethod
    def _interval(w: Array, pw: Array, level: float = 0.95) -> tuple[float, float]:
        c = np.cumsum(pw)
        a = (1.0 - level) / 2.0
        lo = float(w[min(int(np.searchsorted(c, a)), w.size - 1)])
        hi = float(w[min(int(np.searchsorted(c, 1.0 - a)), w.size - 1)])
        return lo, hi

    def _polish(self, v: Array, tm: Array, y: Array, sig: Array, w0: float, t0: float) -> tuple[float, float]:
        from scipy.optimize import minimize  # on use: it costs a node's start-up 0.2 s

        t_lo, t_hi = self.prior.support(1.0 - 1e-9)

        def cost(x: Array) -> float:
            f = self.model.evaluate(self.params, speed=v, load_torque=tm, temperature=x[1], wear=x[0])
            return float(0.5 * np.sum(((y - f) / sig) ** 2) - self.prior.logpdf(x[1]))

        res = minimize(cost, np.array([w0, t0]), method="L-BFGS-B",
                       bounds=[self.wear_range, (t_lo, t_hi)])
        if res.success and res.fun <= cost(np.array([w0, t0])):
            return float(res.x[0]), float(res.x[1])
        return w0, t0

    def _polish_known(self, v: Array, tm: Array, y: Array, sig: Array, temp: Array, w0: float) -> float:
        from scipy.optimize import minimize

        def cost(x: Array) -> float:
            f = self.model.evaluate(self.params, speed=v, load_torque=tm, temperature=temp, wear=x[0])
            return float(0.5 * np.sum(((y - f) / sig) ** 2))

        res = minimize(cost, np.array([w0]), method="L-BFGS-B", bounds=[self.wear_range])
        return float(res.x[0]) if res.success and res.fun <= cost(np.array([w0])) else w0

    # -- many cycles at once -----------------------------------------------------
    def estimate_arrays(self, speed: npt.ArrayLike, load: npt.ArrayLike, tau_f: npt.ArrayLike,
                        temperature: npt.ArrayLike | None = None) -> dict[str, Array]:
        """Estimates of many cycles at the same speeds: ``tau_f`` of shape (runs, K).

        Returns arrays (runs,) ``wear`` (the chosen point), ``wear_mean``,
        ``wear_map``, ``wear_std``, ``temperature``, ``temperature_std``.
        ``temperature``: None (unknown) or per-run values of shape (runs,) or (runs, K).
        """
        v = np.atleast_1d(np.asarray(speed, dtype=float))
        tau = np.atleast_2d(np.asarray(tau_f, dtype=float))
        if tau.shape[1] != v.size:
            raise InputDataError(f"tau_f has {tau.shape[1]} columns for {v.size} speeds")
        temp = None if temperature is None else np.asarray(temperature, dtype=float)
        keys = ("wear", "wear_mean", "wear_map", "wear_std", "temperature", "temperature_std")
        out = {k: np.empty(tau.shape[0]) for k in keys}
        for i in range(tau.shape[0]):
            ti = None
            if temp is not None:
                ti = np.broadcast_to(temp[i] if temp.ndim else temp, v.shape)
            post = self.posterior(v, load, tau[i], None, ti)
            out["wear_mean"][i] = post.wear_mean
            out["wear_map"][i] = post.wear_map
            out["wear"][i] = post.wear_map if self.point == "map" else post.wear_mean
            out["wear_std"][i] = post.wear_std
            out["temperature"][i] = post.temperature_map if self.point == "map" else post.temperature_mean
            out["temperature_std"][i] = post.temperature_std
        return out

    # -- the common interface --------------------------------------------------------
    def estimate(self, observations: ObservationTable) -> WearResult:
        """w and T from all rows of one cycle; see the module docstring."""
        rows = prepare_rows(observations, noise_std=self.noise_std, default_load=self.default_load,
                            use_temperature=self.use_temperature, pset=self.param_set, extra=self.extra,
                            params=self.params)
        known = rows.known_temperature
        temp = rows.temperature if known.any() else None
        post = self.posterior(rows.speed, rows.load, rows.tau_f, rows.noise_std, temp)
        est = post.wear_map if self.point == "map" else post.wear_mean
        t_est = post.temperature_map if self.point == "map" else post.temperature_mean
        t_rows = (np.where(known, rows.temperature, np.nanmean(rows.temperature)) if known.any()
                  else np.full(len(rows), t_est))
        per_row = self._per_row(rows, t_rows)
        # a posterior on one grid point has std 0 on the grid; the grid cannot resolve better than
        # its step (uniform quantization, step / sqrt(12)): never report a certainty it does not have
        resolution = float(self.w_grid[1] - self.w_grid[0]) / math.sqrt(12.0) if self.w_grid.size > 1 else 0.0
        fit = self._fit_check(rows, est, t_rows, unknown_temperature=not known.any())
        scale = fit.pop("std_scale")
        wear_std = max(post.wear_std, resolution) * scale
        low, high = post.wear_low, post.wear_high
        low, high = widen_interval(est, low, high, scale, self.wear_range)
        extra: dict = {"model_uncertainty": self._covariance_note} if self._covariance_note else {}
        std_model = 0.0
        if self.model_covariance is not None:
            std_model = self.model_std(rows.speed, rows.load, rows.tau_f, rows.noise_std, temp)
            extra = {"wear_std_posterior": wear_std, "wear_std_model": std_model,
                     "model_uncertainty": f"the set's parameter covariance ({len(self.model_covariance[0])} parameters)"}
            if std_model > 0:
                low = max(self.wear_range[0], est - math.hypot(max(est - low, 0.0), _Z95 * std_model))
                high = min(self.wear_range[1], est + math.hypot(max(high - est, 0.0), _Z95 * std_model))
                wear_std = math.hypot(wear_std, std_model)
        return with_set_info(WearResult(
            wear=est,
            wear_std=wear_std,
            wear_low=low,
            wear_high=high,
            method=self.name,
            temperature=t_est,
            temperature_std=post.temperature_std,
            speeds=tuple(float(s) for s in rows.speed),
            per_speed_wear=tuple(float(w) for w in per_row),
            wear_std_model=std_model,
            info={
                "point": self.point,
                "wear_std_temperature": post.wear_std_temperature * scale,
                **extra,
                "prior": self.prior.label if not known.any() else "measured",
                "wear_mean": post.wear_mean,
                "wear_map": post.wear_map,
                "temperature_map": post.temperature_map,
                "posterior_modes": post.n_modes,
                "interval": "central 95% credible interval of the marginal posterior of w",
                "known_temperature": [bool(k) for k in known],
                "per_speed_wear": "each row's least-squares w at the estimated temperature",
                **fit,
            },
        ), self.param_set)

    def model_std(self, speed: Array, load: Array, tau_f: Array, noise_std: Array,
                  temperature: Array | None = None) -> float:
        """The std the set's parameter uncertainty adds to the estimate (the delta method).

        ``sqrt(g^T Sigma g)``, ``Sigma`` the set's covariance over the model's parameters
        (:func:`parameter_covariance`) and ``g`` the gradient of the posterior mean over them, exact on the
        grid: ``d E[w] / d theta_n = Cov(w, sum_k r_k / sigma_k^2 * d f_k / d theta_n)`` under the posterior
        (``r_k`` the residuals), from the model's parameter gradients on the posterior's own grid. With
        ``point="map"`` the same gradient (the MAP's and the mean's agree where the posterior is near normal;
        the grid's MAP is a step function of the parameters). The gradients are evaluated on the posterior's
        cells that hold mass: with the temperature unknown about 25-70 ms more per 6-speed cycle with 11
        parameters (the estimate itself 5-15 ms; a loaded machine), with it measured about 1 ms.
        ``temperature``: the rows' measured values, or None when unknown.
        """
        if self.model_covariance is None:
            return 0.0
        temps = None if temperature is None else np.where(np.isfinite(temperature), temperature,
                                                           np.nanmean(temperature))
        names, sigma = self.model_covariance
        g = self._mean_gradient(speed, np.abs(load), tau_f, noise_std, temps, names)
        return math.sqrt(max(float(g @ sigma @ g), 0.0))

    def _mean_gradient(self, v: Array, tm: Array, y: Array, sig: Array, temps: Array | None,
                       names: Sequence[str]) -> Array:
        """d (posterior mean of w) / d theta for each of ``names``: ``Cov(w, score)`` under the posterior, over
        the grid cells holding mass (at least :data:`_MASS_FLOOR` of the largest cell's)."""
        if temps is None:
            grid = self._grid(v, tm, None)
            p, _, idx, _, f = self._fine_pass(grid, y, sig)
            it, iw = np.nonzero(p >= _MASS_FLOOR * p.max())
            t_cells, w_cells, f_cells = grid.temps[it][None, :], grid.w[idx][iw], f[:, it, iw]
        else:
            w_all = self.w_grid
            f_all = np.asarray(self.model.evaluate(self.params, speed=v[:, None], load_torque=tm[:, None],
                                                   temperature=temps[:, None], wear=w_all[None, :]), dtype=float)
            chi = np.sum(((y[:, None] - f_all) / sig[:, None]) ** 2, axis=0) * 0.5
            p = np.exp(-(chi - chi.min()))[None, :]
            iw = np.flatnonzero(p[0] >= _MASS_FLOOR)
            it = np.zeros_like(iw)
            t_cells, w_cells, f_cells = temps[:, None], w_all[iw], f_all[:, iw]
        mass = p[it, iw]
        mass = mass / mass.sum()
        dev = mass * (w_cells - float(mass @ w_cells))
        rd = (y[:, None] - f_cells) / (sig**2)[:, None] * dev[None, :]
        grads = self.model.param_gradient(self.params, names, speed=v[:, None], load_torque=tm[:, None],
                                          temperature=t_cells, wear=w_cells[None, :])
        return np.array([float(np.vdot(np.broadcast_to(grads[n], rd.shape), rd)) for n in names])

    def _fit_check(self, rows: Rows, wear: float, temps: Array, unknown_temperature: bool) -> dict:
        """How well the model at the estimate explains the rows, and what the estimate may not assume.

        ``fit_chi2`` is the sum of squared normalized residuals at (wear, T) on ``fit_dof`` = rows minus
        the fitted unknowns (w, and T when it was not measured), ``fit_p`` its chi-square tail
        probability. Below :data:`MISFIT_P` the model does not explain the cycle within its stated
        noise (a temperature outside the prior, an effect the model lacks, a noise std set too low):
        the std and the interval are scaled by the Birge ratio sqrt(chi2 / dof), the usual inflation
        when residuals exceed the stated errors, and ``misfit`` says so in words. An unmeasured
        temperature estimated at the edge of its prior's support while the fit is poor (p below :data:`EDGE_P`) is
        named too (``temperature_at_prior_edge``):
        the joint may be colder or hotter than the prior allows, and the wear then absorbs the difference.
        """
        f = self.model.evaluate(self.params, speed=rows.speed, load_torque=rows.load, temperature=temps, wear=wear)
        r = (rows.tau_f - np.asarray(f, dtype=float)) / rows.noise_std
        chi2 = float(np.sum(r * r))
        dof = len(rows) - (2 if unknown_temperature else 1)
        out: dict = {"fit_chi2": chi2, "fit_dof": int(dof), "std_scale": 1.0}
        notes = []
        p = float(chdtrc(dof, chi2)) if dof >= 1 and math.isfinite(chi2) else math.nan
        if unknown_temperature and p < EDGE_P:
            t_lo, t_hi = self.prior.support(1.0 - 1e-9)
            t = float(temps[0])
            edge = 0.02 * (t_hi - t_lo)
            if (math.isfinite(t_lo) and t - t_lo <= edge) or (math.isfinite(t_hi) and t_hi - t <= edge):
                out["temperature_at_prior_edge"] = True
                notes.append(f"the temperature estimate {t:.1f} degC is at the edge of its prior {self.prior.label}: "
                             "the joint may be outside it (measure the temperature or widen temperature_prior)")
        if math.isfinite(p):
            out["fit_p"] = p
            if p < MISFIT_P:
                out["std_scale"] = math.sqrt(chi2 / dof)
                notes.insert(0, f"the model leaves the cycle unexplained (chi2 {chi2:.1f} on {dof} dof, p {p:.1e}): "
                                f"std and interval widened x{out['std_scale']:.1f}")
        if notes:
            out["misfit"] = "; ".join(notes)
        return out

    def _per_row(self, rows: Rows, temps: Array) -> Array:
        f = self.model.evaluate(self.params, speed=rows.speed[:, None], load_torque=rows.load[:, None],
                                temperature=temps[:, None], wear=self.w_grid[None, :])
        return np.asarray(self.w_grid[np.argmin((rows.tau_f[:, None] - f) ** 2, axis=1)], dtype=float)


def parameter_covariance(pset: ParameterSet | None, params: Parameters, names: Sequence[str] | None = None
                         ) -> tuple[tuple[str, ...], Array] | None:
    """A set's parameter covariance (symmetrized) over the parameters ``params`` has (and ``names``, the model's,
    when given): ``(names, matrix)``, or None for a set without one (or with a non-finite entry among them).

    A term of inputs other than speed, load, temperature and wear (a ripple of position) is a known offset to
    the estimators, so its parameters are left out with ``names`` the core model's."""
    if pset is None or pset.covariance is None:
        return None
    all_names, mat = pset.covariance
    keep = [i for i, n in enumerate(all_names) if n in params and (names is None or n in names)]
    if not keep:
        return None
    sigma = np.asarray(mat, dtype=float)[np.ix_(keep, keep)]
    if not np.all(np.isfinite(sigma)):
        return None
    return tuple(all_names[i] for i in keep), 0.5 * (sigma + sigma.T)


def widen_interval(est: float, low: float, high: float, scale: float,
                   bounds: tuple[float, float]) -> tuple[float, float]:
    """``[low, high]`` widened ``scale`` times about ``est`` (the Birge ratio of an unexplained cycle), within
    ``bounds``; never narrower than it was, whichever side of the interval ``est`` lies on.

    >>> widen_interval(30.0, 29.0, 32.0, 2.0, (0.0, 100.0))
    (28.0, 34.0)
    >>> widen_interval(99.9, 99.95, 100.0, 3.0, (0.0, 100.0))  # est below its interval: it reaches down to est
    (99.9, 100.0)
    """
    if not scale > 1.0:
        return low, high
    lo = max(bounds[0], min(low, est - max(est - low, 0.0) * scale))
    hi = min(bounds[1], max(high, est + max(high - est, 0.0) * scale))
    return lo, hi


def _count_modes(keep: Index) -> int:
    """Separate regions of w (runs of kept coarse cells) that hold posterior mass."""
    if keep.size == 0:
        return 0
    runs = np.split(keep, np.flatnonzero(np.diff(keep) > 1) + 1)
    return len(runs)
