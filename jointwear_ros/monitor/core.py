"""The wear monitor: friction observations of a test cycle → wear estimate → diagnostic level.

:class:`WearMonitor` gathers observations per ``cycle_id``. It estimates a
cycle when it holds ``speeds_total`` observations of it (known from the status
stream), or ``done_timeout`` seconds after the cycle's DONE (or ABORTED/FAILED)
status, or -- when no status of the cycle was seen -- ``idle_timeout`` seconds
after its last observation. The estimate uses the configured method through
:func:`~jointwear_ros.estimation.make_estimator`; its random seed derives from
the configured seed and the cycle id, so a replay gives the same estimate.
An observation that arrives after its cycle was estimated (a speed the estimate
lacked: the observer was slow, or ``done_timeout`` too short) is not lost: the
cycle is re-estimated with it and a *revision* of the result is returned (same
``cycle_id``, ``revision`` 1, 2, ...; the message says which speed came late).
Consumers keep the newest result per cycle. A repeated observation (same speed
and stamp) or one beyond the cycle's ``speeds_total`` is ignored with a reason in
:attr:`WearMonitor.ignored`. Finished cycles are remembered up to
``max_finished_cycles``. A RUNNING status of an already estimated cycle id is a
new cycle that reuses the id (the test_cycle node was restarted and counts
from 1 again): the old record is dropped and the new cycle starts afresh.
:attr:`WearMonitor.last` is the newest result of the most recently *started*
estimate, so a revision of an older cycle does not replace a newer cycle's
status.
**Sources.** Observations come from the dedicated test cycle (``source`` ``test_cycle``) or from production
(``production``: the robot's own program, ``cycle_id`` the shift id); :class:`~jointwear_ros.contract.Source`
names them. Cycles are keyed by (source, cycle id): production shift 3 and test cycle 3 never mix, each
result estimates one source's observations only and says which (``CycleResult.source``, the ``source``
diagnostic value). A production shift is a unit like a test cycle: its status (``on_status(...,
source=Source.PRODUCTION)``, the production observer's RUNNING then DONE with ``speeds_total`` = the shift's
observations of the joint) completes it, or its timeouts do. The joint's level stands on its recent estimates
of both sources (the confirmation compares an estimate with the standing one whatever its source). An
observation whose source is outside the vocabulary is dropped with the reason.
Measured temperatures are used when present and ``use_measured_temperature``
is true; otherwise the temperature column is dropped and the estimator treats
T as unknown (Eq. 11).

Every observation is screened first (:func:`~jointwear_ros.monitor.validation.screen_observation`):
a non-physical speed, friction, std or load drops it, an impossible or
out-of-range temperature makes its temperature unknown. Either way the reason
is appended to :attr:`WearMonitor.ignored`, counted in the cycle's result
(``CycleResult.rejected``, key ``observations_rejected`` /
``temperatures_unknown``) and named in its message; the rest of the cycle is
estimated. A dropped observation still counts towards the cycle's
``speeds_total`` (the cycle is estimated as soon as every speed was heard of).

The level is the joint's *condition level* (:mod:`jointwear_ros.condition`, the one rule of the
suite): ERROR at ``w_hat >= alarm_threshold``, WARN at ``w_hat >= warn_threshold`` or when the
alarm lies within the estimate's one-sided 95 % bound, else OK. Only evidence moves it:

- an estimate from fewer distinct speeds than the method needs (:func:`~jointwear_ros.condition.min_speeds`:
  3 with the temperature unknown, 1 with it measured) gives no level; nor does a cycle with no usable
  observation or a failed estimation. The joint's last level stands, ``stale`` (STALE when it has none), and the
  message says why, with the test cycle's own reason when the cycle FAILED or was ABORTED;
- an estimate of a FAILED/ABORTED cycle, or one that missed planned speeds, stands but is ``partial``;
- an estimate far from the joint's standing estimate is held ``unconfirmed`` (the level stays) until the
  next estimate confirms it (a step, reported at once) or not (an outlier)
  (:func:`~jointwear_ros.condition.confirm`, over the last :data:`CONFIRM_MEMORY` estimates).

Pure numpy; no ROS import.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..condition import INSUFFICIENT, Standing, condition_level, evidence_of, min_speeds, speed_levels, standing
from ..contract import ENDED_STATES, CycleState, CycleStatus, DiagnosticLevel, Source, level_name
from ..errors import InputDataError, JointwearError, ParameterError
from ..estimation import ESTIMATORS, make_estimator
from ..model.paramsets import load_parameter_set_info
from ..observer.types import FrictionObservationData
from ..settings import check_ranges, setting
from ..types import ObservationTable, WearEstimator, WearResult
from .validation import screen_observation

__all__ = ["CycleKey", "CycleResult", "EstimatorFactory", "MonitorConfig", "WearMonitor",
           "cycle_label", "cycle_seed", "diagnostic_level", "observations_table", "parse_estimator_options"]

def parse_estimator_options(value: Any) -> dict[str, Any]:
    """The ``estimator_options`` setting as the estimator takes it: a mapping as it is, a JSON object string
    (the node's parameter; ``""``: none) parsed; anything else a one-line
    :class:`~jointwear_ros.errors.ParameterError`.

    >>> parse_estimator_options('{"n_samples": 200}'), parse_estimator_options("")
    ({'n_samples': 200}, {})
    >>> parse_estimator_options({"n_samples": 50})
    {'n_samples': 50}
    """
    if isinstance(value, Mapping):
        return dict(value)
    if not isinstance(value, str):
        raise ParameterError(f"estimator_options is a JSON object string, not {value!r}")
    if not value.strip():
        return {}
    try:
        parsed = json.loads(value)
    except ValueError as exc:
        raise ParameterError(f"estimator_options = {value!r} is not a JSON object: {exc}") from None
    if not isinstance(parsed, dict):
        raise ParameterError(f"estimator_options = {value!r} is not a JSON object")
    return parsed


#: estimates of a joint the confirmation looks back over (the standing one and the one held are what count)
CONFIRM_MEMORY = 8



@dataclass(frozen=True)
class MonitorConfig:
    """Settings of :class:`WearMonitor`.

    A field declared with :func:`~jointwear_ros.settings.setting` is also a parameter of the
    ``wear_estimator`` node, each joint's own (``<joint>.<setting>``) and live: its description, unit
    and range are in the field metadata, from which ``settings.declarations`` builds the node's
    declarations and ``settings.from_mapping`` the config from parameter values (node, params YAML,
    ``--set``, a bag's recorded settings, fleet re-analysis). ``joint_name`` is not a parameter.

    Attributes
    ----------
    joint_name : the joint; observations of other joints are ignored.
    method : estimator name for :func:`~jointwear_ros.estimation.make_estimator`.
    params : friction-model parameter set name.
    seed : base seed; each cycle's estimator gets a seed derived from it and the cycle id.
    warn_threshold, alarm_threshold : wear levels of WARN and ERROR.
    use_measured_temperature : use the observations' temperature when finite.
    done_timeout : s after DONE/ABORTED/FAILED before a cycle with missing observations is estimated.
    idle_timeout : s after the last observation of a cycle whose status was never seen.
    min_observations : observations needed for an estimate.
    observation_noise_std : sweep-to-sweep scatter of tau_f (normalized; the paper's sigma_e = 0.0015).
        An observation's ``tau_f_std`` is the standard error from its window samples; it cannot see
        what stays constant over one sweep (lubricant film, position-dependent friction), so the
        estimator is given ``sqrt(tau_f_std^2 + observation_noise_std^2)``.
    estimator_options : extra keyword arguments for the estimator (``n_samples``, ``temperature_range``, ...).
    """

    joint_name: str = "joint_1"
    method: str = setting("paper", description=f"estimator: {', '.join(ESTIMATORS)}", per_joint=True)
    params: str = setting("ref-2011r", description="friction-model parameter set: a name or a YAML path "
                          "(a commissioned set)", per_joint=True)
    seed: int = setting(0, description="base seed; each cycle's seed derives from it and the cycle id", per_joint=True)
    warn_threshold: float = setting(30.0, description="wear at which the level becomes WARN", unit="%",
                                    range=(0.0, 100.0), per_joint=True)
    alarm_threshold: float = setting(35.0, description="wear at which the level becomes ERROR (alarm)", unit="%",
                                     range=(0.0, 100.0), per_joint=True)
    use_measured_temperature: bool = setting(True, description="use the observations' temperature when present; "
                                             "else T is unknown (Eq. 11)", per_joint=True)
    done_timeout: float = setting(2.0, description="s after DONE before a cycle with missing speeds is estimated",
                                  unit="s", range=(0.0, 600.0), per_joint=True)
    idle_timeout: float = setting(30.0, description="s after the last observation of a cycle without status",
                                  unit="s", range=(0.0, 3600.0), per_joint=True)
    min_observations: int = setting(1, description="observations needed for an estimate", range=(1, 100_000),
                                    per_joint=True)
    observation_noise_std: float = setting(0.0015, description="sweep-to-sweep scatter of tau_f added to each "
                                           "observation's window standard error", range=(0.0, 1.0), per_joint=True)
    #: a JSON object string as a parameter (``""``: none), a mapping here
    estimator_options: Mapping[str, Any] = setting(
        default_factory=dict, description="JSON object of extra estimator options, e.g. {\"n_samples\": 200}",
        per_joint=True, parse=parse_estimator_options, param_default="")

    def __post_init__(self) -> None:
        check_ranges(self, InputDataError)
        if not float(self.warn_threshold) <= float(self.alarm_threshold):
            raise InputDataError(
                f"warn_threshold = {self.warn_threshold!r}, alarm_threshold = {self.alarm_threshold!r}: "
                "need finite thresholds with warn_threshold <= alarm_threshold (wear 0-100)"
            )


@dataclass(frozen=True)
class CycleResult:
    """The outcome of one cycle: the estimate (None when there is none) and its diagnostic status."""

    cycle_id: int
    joint_name: str
    stamp: float
    result: WearResult | None
    level: int
    message: str
    values: tuple[tuple[str, str], ...]
    observations: tuple[FrictionObservationData, ...] = ()
    alarm_threshold: float = 35.0
    #: 0 for the first result of a cycle; n for its n-th re-estimate after a late observation
    revision: int = 0
    #: reasons of the observations of this cycle that were dropped before estimation (the first 5;
    #: the count is the ``observations_rejected`` value)
    rejected: tuple[str, ...] = ()
    #: reasons of the observations whose temperature was made unknown (the first 5)
    temperature_unknown: tuple[str, ...] = ()
    #: ``complete``, ``partial`` or ``insufficient`` (:mod:`jointwear_ros.condition`); ``none``: no estimate
    evidence: str = "complete"
    #: this estimate against the joint's standing one: ``confirmed``, ``unconfirmed`` (held), ``step``; ``none``
    confirmation: str = "confirmed"
    #: the level is the joint's earlier one (this cycle gave none, or its estimate is held)
    stale: bool = False
    #: the estimate the level stands on (NaN: none)
    standing_wear: float = math.nan
    standing_wear_std: float = math.nan
    #: where the estimate's observations come from: ``test_cycle`` or ``production`` (``cycle_id`` the shift id)
    source: str = Source.TEST_CYCLE.value

    @property
    def level_name(self) -> str:
        return level_name(self.level)

    @property
    def calibrated(self) -> bool | None:
        """Whether the estimate's wear scale is calibrated (``info['calibrated']``); None without an estimate."""
        if self.result is None or "calibrated" not in self.result.info:
            return None
        return bool(self.result.info["calibrated"])

    @property
    def alarm(self) -> bool:
        """The joint's condition level is ERROR (whether or not this cycle's own estimate made it so)."""
        return self.level == DiagnosticLevel.ERROR


def diagnostic_level(wear: float, wear_std: float, warn_threshold: float, alarm_threshold: float) -> DiagnosticLevel:
    """The condition level of one estimate (:func:`jointwear_ros.condition.condition_level`); no estimate: STALE.

    >>> [diagnostic_level(w, 1.0, 30.0, 35.0).name for w in (29.99, 30.0, 34.99, 35.0, float("nan"))]
    ['OK', 'WARN', 'WARN', 'ERROR', 'STALE']
    >>> diagnostic_level(20.0, 1.0, 30.0, 35.0).name
    'OK'
    """
    lv = condition_level(wear, wear_std, warn_threshold, alarm_threshold)
    return DiagnosticLevel.STALE if lv is None else lv


def cycle_seed(seed: int, cycle_id: int, source: str = Source.TEST_CYCLE) -> int:
    """A per-cycle seed from the configured seed, the cycle id and the source (stable across runs; a test
    cycle's is the seed it always had, a production shift's differs from the test cycle of the same id)."""
    entropy = [int(seed) & 0xFFFFFFFF, int(cycle_id) & 0xFFFFFFFF]
    if Source.parse(source) is Source.PRODUCTION:
        entropy.append(1)
    return int(np.random.SeedSequence(entropy).generate_state(1)[0])


#: a cycle's key in the monitor: (source, cycle id)
CycleKey = tuple[str, int]


def cycle_label(key: CycleKey) -> str:
    """How messages name a cycle: ``cycle 3`` (a test cycle) or ``production shift 3``.

    >>> cycle_label(("test_cycle", 3)), cycle_label(("production", 3))
    ('cycle 3', 'production shift 3')
    """
    source, cid = key
    return f"production shift {cid}" if source == Source.PRODUCTION else f"cycle {cid}"


def observations_table(observations: list[FrictionObservationData] | tuple[FrictionObservationData, ...],
                       *, use_temperature: bool = True, noise_std: float = 0.0, source: str = "") -> ObservationTable:
    """The estimator input (standard observation columns) of a list of observations.

    ``tau_f_std`` becomes ``sqrt(tau_f_std^2 + noise_std^2)`` (a non-finite one becomes ``noise_std``).
    """
    obs = list(observations)
    temp = [o.temperature if use_temperature else math.nan for o in obs]
    std = [math.hypot(o.tau_f_std, noise_std) if math.isfinite(o.tau_f_std) else noise_std for o in obs]
    return ObservationTable.from_arrays(
        source=source,
        speed=[o.speed for o in obs], tau_f=[o.tau_f for o in obs], tau_f_std=std,
        load_torque=[o.load_torque for o in obs], temperature=temp, position=[o.position for o in obs],
        time=[o.stamp for o in obs], cycle=[float(o.cycle_id) for o in obs],
        tau_plus=[o.tau_plus for o in obs], tau_minus=[o.tau_minus for o in obs],
    )


@dataclass
class _Cycle:
    observations: list[FrictionObservationData] = field(default_factory=list)
    speeds_total: int = 0
    ended_at: float = math.nan
    end_state: int = -1
    end_message: str = ""  # the test cycle's reason when it ended ABORTED/FAILED
    last_obs: float = math.nan
    revision: int = 0
    late: list[float] = field(default_factory=list)
    order: int = 0  # when the cycle was first estimated (1, 2, ...)
    rejected: list[str] = field(default_factory=list)  # the first _MAX_REASONS reasons
    temperature_unknown: list[str] = field(default_factory=list)
    n_rejected: int = 0
    n_temperature_unknown: int = 0

    def reject(self, why: str) -> None:
        self.n_rejected += 1
        if len(self.rejected) < _MAX_REASONS:
            self.rejected.append(why)

    def unknown_temperature(self, why: str) -> None:
        self.n_temperature_unknown += 1
        if len(self.temperature_unknown) < _MAX_REASONS:
            self.temperature_unknown.append(why)

    @property
    def heard(self) -> int:
        """Observations received for this cycle, dropped ones included."""
        return len(self.observations) + self.n_rejected


EstimatorFactory = Callable[[str, int], WearEstimator]

#: reasons kept per cycle and kind (the counts are exact; a flood of bad messages stays small)
_MAX_REASONS = 5


def _reasons(kept: list[str], total: int) -> str:
    more = f"; and {total - len(kept)} more" if total > len(kept) else ""
    return "; ".join(kept) + more


class WearMonitor:
    """Observations per cycle → :class:`CycleResult`; see the module docstring.

    ``estimator_factory(method, seed)`` builds the estimator of one cycle
    (default: :func:`make_estimator` with the configured parameter set and
    options).
    """

    def __init__(self, config: MonitorConfig | None = None, estimator_factory: EstimatorFactory | None = None) -> None:
        self.config = config if config is not None else MonitorConfig()
        self._factory = estimator_factory or self._default_factory
        #: open cycles by (source, cycle id)
        self._cycles: dict[CycleKey, _Cycle] = {}
        #: estimated cycles by (source, cycle id), kept so that a late observation can revise their estimate
        self._finished: dict[CycleKey, _Cycle] = {}
        self.max_finished_cycles = 1000
        self._order = 0
        self._last_order = 0
        self.last: CycleResult | None = None
        #: the joint's recent estimates that carry a level ((source, cycle id) -> order, stamp, wear, std,
        #: evidence), of both sources, the confirmation's memory (:data:`CONFIRM_MEMORY`)
        self._recent: dict[CycleKey, tuple[int, float, float, float, str]] = {}
        #: notes on ignored or corrected inputs, newest last (the last ``max_notes`` are kept)
        self.ignored: list[str] = []
        #: notes made in all (``ignored`` is bounded: a flood of bad messages must not grow memory)
        self.notes_total = 0
        self.max_notes = 1000
        #: observations dropped by the screening, in all
        self.rejected_count = 0
        try:
            self.valid_ranges: dict[str, tuple[float, float]] = load_parameter_set_info(self.config.params).observation_valid()
        except JointwearError:  # an unknown set fails at estimation, with its reason in the result
            self.valid_ranges = {}

    def _note(self, text: str) -> None:
        self.ignored.append(text)
        self.notes_total += 1
        if len(self.ignored) > self.max_notes:
            del self.ignored[: len(self.ignored) - self.max_notes]

    def notes_since(self, total: int) -> list[str]:
        """The notes made after :attr:`notes_total` was ``total`` (newest last)."""
        k = self.notes_total - int(total)
        return list(self.ignored[-k:]) if k > 0 else []

    def reconfigure(self, config: MonitorConfig) -> None:
        """Use ``config`` from the next estimate on (a live parameter change).

        Raises :class:`~jointwear_ros.errors.JointwearError` (nothing changed)
        when the joint differs, or the method, parameter set or estimator
        options cannot build an estimator.
        """
        if config.joint_name != self.config.joint_name:
            raise InputDataError(f"joint_name cannot change ({self.config.joint_name!r} -> {config.joint_name!r})")
        make_estimator(config.method, params=config.params, seed=0, **dict(config.estimator_options))
        valid = load_parameter_set_info(config.params).observation_valid()
        self.config = config
        self.valid_ranges = valid

    def _default_factory(self, method: str, seed: int) -> WearEstimator:
        return make_estimator(method, params=self.config.params, seed=seed, **dict(self.config.estimator_options))

    # -- inputs -----------------------------------------------------------------------
    def add(self, observation: FrictionObservationData, now: float | None = None) -> list[CycleResult]:
        """One observation; returns the cycle's result when this completes it.

        ``now`` is the time of receipt on the clock :meth:`poll` is given
        (default: the observation's stamp); the idle timeout counts from it.
        An observation of an already estimated cycle returns its revised result.
        """
        o = observation
        t_rx = o.stamp if now is None else float(now)
        if o.joint_name and o.joint_name != self.config.joint_name:
            return []
        cid = int(o.cycle_id)
        try:
            key: CycleKey = (Source.parse(o.source).value, cid)
        except JointwearError as exc:
            self.rejected_count += 1
            self._note(f"observation of cycle {cid}: {exc}; dropped")
            return []
        kept, why = screen_observation(o, self.valid_ranges, use_temperature=self.config.use_measured_temperature)
        if why:
            self._note(f"observation of {cycle_label(key)}: {why}")
        done = self._finished.get(key)
        if kept is None:
            self.rejected_count += 1
            if done is None:
                cyc = self._cycles.setdefault(key, _Cycle())
                cyc.reject(why)
                cyc.last_obs = t_rx if not math.isfinite(cyc.last_obs) else max(cyc.last_obs, t_rx)
                if cyc.speeds_total > 0 and cyc.heard >= cyc.speeds_total:
                    return [self._finish(key, t_rx)]
            return []
        if done is not None:
            return self._revise(key, done, kept, t_rx, why)
        cyc = self._cycles.setdefault(key, _Cycle())
        cyc.observations.append(kept)
        if why:
            cyc.unknown_temperature(why)
        cyc.last_obs = t_rx if not math.isfinite(cyc.last_obs) else max(cyc.last_obs, t_rx)
        if cyc.speeds_total > 0 and cyc.heard >= cyc.speeds_total:
            return [self._finish(key, t_rx)]
        return []

    def on_status(self, status: CycleStatus, now: float, source: str = Source.TEST_CYCLE) -> list[CycleResult]:
        """A ``TestCycleStatus`` heard at ``now``: learns ``speeds_total``, starts the timeout on DONE/ABORTED/FAILED.

        ``now`` is on the clock :meth:`poll` is given (the node passes its clock at receipt, a replay the log
        time; the status's own ``stamp`` is not used). A status of another joint (a non-empty ``joint_name``) is
        ignored. ``source`` is the stream's: ``test_cycle`` (``/test_cycle/status``) or ``production``
        (``/production/status``: its ``cycle_id`` is the shift's, ``speeds_total`` the shift's observations of
        the joint).
        """
        if status.joint_name and status.joint_name != self.config.joint_name:
            return []
        cid, state, speeds_total, stamp = int(status.cycle_id), int(status.state), int(status.speeds_total), float(now)
        key: CycleKey = (Source.parse(source).value, cid)
        message = status.message
        if key in self._finished and state == CycleState.RUNNING:
            del self._finished[key]  # the id is reused by a new cycle (test_cycle restarted)
            self._note(f"{cycle_label(key)} RUNNING again: a new cycle reuses the id of an estimated one "
                       f"({'the production observer' if key[0] == Source.PRODUCTION else 'test_cycle'} restarted?); "
                       "the new cycle is estimated on its own")
        if cid == 0 or key in self._finished:
            return []
        cyc = self._cycles.setdefault(key, _Cycle())
        if speeds_total > 0:
            cyc.speeds_total = int(speeds_total)
        if state in ENDED_STATES and not math.isfinite(cyc.ended_at):
            cyc.ended_at = stamp
            cyc.end_state = state
            cyc.end_message = str(message)
        if cyc.speeds_total > 0 and cyc.heard >= cyc.speeds_total:
            return [self._finish(key, stamp)]
        return self.poll(stamp)

    def poll(self, now: float) -> list[CycleResult]:
        """Estimate the cycles whose timeout has passed at ``now`` (same clock as the stamps)."""
        cfg = self.config
        due: list[CycleKey] = []
        for key, cyc in self._cycles.items():
            if math.isfinite(cyc.ended_at):
                if now >= cyc.ended_at + cfg.done_timeout:
                    due.append(key)
            elif math.isfinite(cyc.last_obs) and now >= cyc.last_obs + cfg.idle_timeout:
                due.append(key)
        # by cycle id, a test cycle before the production shift of the same id
        return [self._finish(key, now) for key in sorted(due, key=lambda k: (k[1], k[0] != Source.TEST_CYCLE))]

    # -- estimation ---------------------------------------------------------------------
    def _finish(self, key: CycleKey, stamp: float) -> CycleResult:
        cyc = self._cycles.pop(key)
        self._order += 1
        cyc.order = self._order
        self._finished[key] = cyc
        if len(self._finished) > self.max_finished_cycles:  # bounded memory: forget the oldest (by cycle id)
            by_id = sorted(self._finished, key=lambda k: (k[1], k[0]))
            for old in by_id[: max(len(self._finished) - self.max_finished_cycles // 2, 1)]:
                del self._finished[old]
        return self._estimate(key, cyc, stamp)

    def _revise(self, key: CycleKey, cyc: _Cycle, o: FrictionObservationData, stamp: float,
                why: str = "") -> list[CycleResult]:
        if any(p.speed == o.speed and p.stamp == o.stamp for p in cyc.observations):
            self._note(f"observation of {cycle_label(key)} at {o.speed:g} rad/s received twice; the repeat is ignored")
            return []
        if cyc.speeds_total > 0 and cyc.heard >= cyc.speeds_total:
            self._note(
                f"observation of {cycle_label(key)} at {o.speed:g} rad/s came after its estimate, which already has "
                f"all {cyc.speeds_total} speeds; ignored"
            )
            return []
        cyc.observations.append(o)
        if why:
            cyc.unknown_temperature(why)
        cyc.revision += 1
        cyc.late.append(float(o.speed))
        return [self._estimate(key, cyc, stamp)]


    def _estimate(self, key: CycleKey, cyc: _Cycle, stamp: float) -> CycleResult:
        cfg = self.config
        src, cid = key
        label = cycle_label(key)
        # in stamp order, however they arrived: a revision with a late observation equals the estimate
        # made with every observation on time (replay = live whatever the timing)
        obs = tuple(sorted(cyc.observations, key=lambda o: (o.stamp, o.speed)))
        partial = ""
        if cyc.speeds_total > 0 and len(obs) < cyc.speeds_total:
            partial = f"; {len(obs)} of {cyc.speeds_total} speeds observed"
        failed = cyc.end_state in (CycleState.ABORTED, CycleState.FAILED)
        ended = f" ({'shift' if src == Source.PRODUCTION else 'cycle'} {CycleState(cyc.end_state).name})" if failed else ""
        if cyc.revision:
            partial += (f"; revision {cyc.revision}: re-estimated with late observation(s) at "
                        + ", ".join(f"{v:g}" for v in cyc.late) + " rad/s")
        rev = [("revision", str(cyc.revision))] if cyc.revision else []
        if cyc.n_rejected:
            rev.append(("observations_rejected", str(cyc.n_rejected)))
            partial += f"; {cyc.n_rejected} observation(s) rejected: " + _reasons(cyc.rejected, cyc.n_rejected)
        if cyc.n_temperature_unknown:
            rev.append(("temperatures_unknown", str(cyc.n_temperature_unknown)))
            partial += (f"; {cyc.n_temperature_unknown} temperature(s) used as unknown: "
                        + _reasons(cyc.temperature_unknown, cyc.n_temperature_unknown))
        extra = {"rejected": tuple(cyc.rejected), "temperature_unknown": tuple(cyc.temperature_unknown)}
        base: list[tuple[str, str]] = [("cycle_id", str(cid)), ("source", src), ("n_observations", str(len(obs))),
                                       ("method", cfg.method), ("warn_threshold", f"{cfg.warn_threshold:g}"),
                                       ("alarm_threshold", f"{cfg.alarm_threshold:g}")]
        why_cycle = ""
        if failed:
            who = "production" if src == Source.PRODUCTION else "test_cycle"
            why_cycle = f"; {who}: {cyc.end_message}" if cyc.end_message else f"; {who} gave no reason"
        # order by speed so the estimate does not depend on the arrival order of observations
        obs_s = tuple(sorted(obs, key=lambda o: (o.speed, o.stamp)))
        table = observations_table(obs_s, use_temperature=cfg.use_measured_temperature,
                                   noise_std=cfg.observation_noise_std, source=f"{label}")
        # distinct speed levels (a shift observes a cruise speed pass after pass, each at its measured speed)
        speeds = speed_levels(o.speed for o in obs)
        t_known = bool(len(obs)) and bool(np.all(np.isfinite(table.get("temperature"))))
        need = max(min_speeds(t_known), int(cfg.min_observations))
        # a test cycle plans its speeds; a production shift plans none (its speeds_total counts observations)
        planned = 0 if src == Source.PRODUCTION else cyc.speeds_total
        evidence = evidence_of(speeds, planned, failed, t_known, observations=len(obs))
        if speeds < need:
            if not obs:
                what = (f"no usable friction observation{why_cycle}" if failed else
                        "no usable friction observation (see the friction_observer log for rejected windows)")
            else:
                what = (f"{speeds} speed{' level' if src == Source.PRODUCTION else ''}(s) observed; a wear level needs {need} "
                        f"({'temperature measured' if t_known else 'temperature unknown: the wear and the temperature together'})"
                        f"{why_cycle}")
            return self._no_level(key, cyc, stamp, f"{label}{ended}: no wear level from this cycle, {what}{partial}",
                                  tuple(base + rev), obs, "none" if not obs else INSUFFICIENT, extra)
        try:
            est = self._factory(cfg.method, cycle_seed(cfg.seed, cid, src))
            res = est.estimate(table)
        except JointwearError as exc:
            return self._no_level(key, cyc, stamp, f"{label}{ended}: wear estimation failed: {exc}{partial}",
                                  tuple(base + rev), obs, "none", extra)
        self._recent[key] = (cyc.order, float(stamp), float(res.wear), float(res.wear_std), evidence)
        for old in sorted(self._recent, key=lambda c: self._recent[c][0])[:-CONFIRM_MEMORY]:
            del self._recent[old]
        st, own = self._standing(key)
        level = DiagnosticLevel.STALE if st.level is None else st.level
        tag = f"{label}{ended}{partial}"
        if evidence == "partial":
            total = max(cyc.speeds_total, len(obs))
            tag += (f"; partial: {speeds} of {total} speeds{why_cycle}" if len(obs) == speeds else
                    f"; partial: {len(obs)} of {total} steps ({speeds} speeds){why_cycle}")
        msg = f"{st.reason} ({tag})" if own == "confirmed" else f"{st.reason}; this cycle: {res.wear:.1f} ± {res.wear_std:.1f} ({tag})"
        values = [("wear", f"{res.wear:.3f}"), ("wear_std", f"{res.wear_std:.3f}"),
                  ("wear_low", f"{res.wear_low:.3f}"), ("wear_high", f"{res.wear_high:.3f}"),
                  ("method", res.method), ("cycle_id", str(cid)), ("source", src),
                  ("temperature_estimate", f"{res.temperature:.2f}"), ("n_observations", str(len(obs))),
                  ("speeds", ", ".join(f"{s:g}" for s in res.speeds)),
                  ("warn_threshold", f"{cfg.warn_threshold:g}"), ("alarm_threshold", f"{cfg.alarm_threshold:g}"),
                  ("evidence", evidence), ("confirmation", own),
                  ("level_wear", f"{st.wear:.3f}"), ("level_wear_std", f"{st.wear_std:.3f}")]
        values += [(k, str(res.info[k])) for k in ("parameter_set", "wear_calibration") if k in res.info]
        # what the std is made of (the joint estimator): the set's parameter covariance, the unknown temperature
        values += [(k, f"{float(res.info[k]):.3f}") for k in ("wear_std_model", "wear_std_temperature")
                   if k in res.info]
        if "calibrated" in res.info:  # a prior wear scale (no wear data on the joint): its std is in wear_std
            values += [("calibrated", "true" if res.info["calibrated"] else "false"),
                       ("wear_std_noise", f"{float(res.info.get('wear_std_noise', res.wear_std)):.3f}"),
                       ("wear_scale_std", f"{float(res.info.get('wear_scale_std', 0.0)):.3f}")]
            if not res.info["calibrated"]:
                msg += f"; wear scale not calibrated ({res.info.get('wear_calibration', 'prior')}: a prior)"
        if "fit_p" in res.info:  # how much of the cycle the model leaves unexplained (joint estimator)
            values.append(("fit_p", f"{float(res.info['fit_p']):.3g}"))
        if res.info.get("misfit"):
            msg += f"; {res.info['misfit']}"
            values.append(("misfit", str(res.info["misfit"])))
        return self._store(CycleResult(cid, cfg.joint_name, stamp, res, int(level), msg, tuple(values + rev), obs,
                                       cfg.alarm_threshold, cyc.revision, **extra, evidence=evidence,
                                       confirmation=own, stale=own == "unconfirmed",
                                       standing_wear=st.wear, standing_wear_std=st.wear_std, source=src), cyc.order)

    def _standing(self, key: CycleKey | None = None) -> tuple[Standing, str]:
        """The joint's condition over its recent estimates (both sources), and the confirmation of cycle ``key``'s."""
        cfg = self.config
        ids = sorted(self._recent, key=lambda c: self._recent[c][0])
        rows = [self._recent[c] for c in ids]
        st = standing([r[2] for r in rows], [r[3] for r in rows], [r[1] / 86400.0 for r in rows],
                      [r[4] for r in rows], cfg.warn_threshold, cfg.alarm_threshold)
        own = st.statuses[ids.index(key)] if key is not None and key in self._recent else "none"
        return st, own

    def _no_level(self, key: CycleKey, cyc: _Cycle, stamp: float, what: str, values: tuple[tuple[str, str], ...],
                  obs: tuple[FrictionObservationData, ...], evidence: str, extra: dict[str, Any]) -> CycleResult:
        """A cycle that gives no level: the joint's last level stands, marked stale (STALE when there is none)."""
        cfg = self.config
        src, cid = key
        st, _ = self._standing()
        if st.level is None:
            level, msg = DiagnosticLevel.STALE, f"{what}; the joint has no wear level yet"
        else:
            level, msg = st.level, f"{what}; the joint's level stands (stale): {st.reason}"
        vals = (*values, ("evidence", evidence), ("confirmation", "none"), ("stale", "true"))
        return self._store(CycleResult(cid, cfg.joint_name, stamp, None, int(level), msg, vals, obs,
                                       cfg.alarm_threshold, cyc.revision, **extra, evidence=evidence,
                                       confirmation="none", stale=True, standing_wear=st.wear,
                                       standing_wear_std=st.wear_std, source=src), cyc.order)

    def _store(self, result: CycleResult, order: int) -> CycleResult:
        if order >= self._last_order:  # a revision of an older cycle does not replace a newer one
            self.last, self._last_order = result, order
        return result

    @property
    def open_cycles(self) -> tuple[CycleKey, ...]:
        """The (source, cycle id) of the cycles not estimated yet."""
        return tuple(sorted(self._cycles))
