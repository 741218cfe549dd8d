"""A joint's condition: one level, one rule, the same on every surface; only evidence moves it.

Two separate quantities describe a joint, under the same names everywhere (``/diagnostics``,
``WearEstimate``, ``WearTrend``, ``estimate --json``, ``trend --json``, ``/api/joints``,
``/metrics``, the plant and fleet pages):

**Condition level** (``diagnostic_msgs/DiagnosticStatus`` bytes) of an estimate ``w ± s`` (``s`` the
estimate's total standard deviation: noise, temperature, wear scale), against the warning level
``warn`` (30) and the alarm ``alarm`` (35, the paper's):

- ``ERROR`` when ``w >= alarm``;
- ``WARN`` when ``w >= warn``, or when the alarm lies within the estimate's one-sided 95 % bound,
  ``w + 1.645 s >= alarm`` (the estimate cannot rule the alarm out);
- ``OK`` otherwise;
- no level when there is no finite estimate.

:func:`condition_level` is that rule; nothing else in the suite decides a level from a wear.

**Forecast** (the trend's): the time to alarm with its 90 % interval and whether the alarm is
*expected within* ``horizon_days`` (the interval's lower bound is within it and growth is detected).
It never changes the condition level; it has its own field, metric and alert.

**Only evidence moves the level.** An estimate's *evidence*:

- ``complete``: every planned step of a cycle that ended DONE (a step may repeat a speed);
- ``partial``: a cycle that ended FAILED or ABORTED, or missed planned steps, with at least the
  method's minimum number of speeds: the estimate stands, marked partial on every surface;
- ``insufficient``: fewer distinct speeds than the method needs to identify the wear (and the
  temperature when it is not measured, :func:`min_speeds`): no level from it; the joint's last level
  stands, marked stale.

And its *confirmation* against the joint's standing estimate (:func:`confirm`, the same sequential
rule in the live monitor and over a stored history): an estimate farther than ``k`` standard
deviations of the difference (and more than ``min_jump`` wear plus the growth a joint can show in
the time between, ``max_rate_per_day``) from the standing one is held ``unconfirmed``: the level
stays the standing estimate's until the next estimate agrees with it (a ``step``, reported at once)
or with the standing one (the held estimate was an ``outlier``), as Prometheus' ``for:`` holds an
alert for one more evaluation. The first estimate of a maintenance segment stands on its own.

Pure Python; no ROS, no numpy.

>>> condition_level(31.4, 0.9).name, condition_level(28.0, 5.0).name, condition_level(20.0, 2.0).name
('WARN', 'WARN', 'OK')
>>> condition_level(35.0, 0.1).name, condition_level(float("nan"), 1.0)
('ERROR', None)
>>> c = confirm([(10.0, 1.0), (10.5, 1.0), (30.5, 1.0), (11.0, 1.0)], [0.0, 1.0, 2.0, 3.0])
>>> [x.status for x in c], c[-1].standing
(['confirmed', 'confirmed', 'outlier', 'confirmed'], 3)
>>> c = confirm([(10.0, 1.0), (30.0, 1.0), (30.5, 1.0)], [0.0, 1.0, 2.0])
>>> [x.status for x in c], [x.standing for x in c]
(['confirmed', 'step', 'step'], [0, 0, 2])
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from .contract import DiagnosticLevel

__all__ = [
    "ALARM",
    "COMPLETE",
    "INSUFFICIENT",
    "PARTIAL",
    "SPEED_LEVEL_MATCH",
    "WARN",
    "Z_ONE_SIDED",
    "ConfirmConfig",
    "Confirmation",
    "Forecast",
    "Standing",
    "condition_level",
    "condition_reason",
    "confirm",
    "evidence_of",
    "forecast_of",
    "min_speeds",
    "plant_level",
    "speed_levels",
    "standing",
]

#: the paper's alarm level and the warning level below it (wear, 0-100)
ALARM = 35.0
WARN = 30.0
#: the alarm is "within reach" of an estimate when it lies below w + Z s (one-sided 95 %)
Z_ONE_SIDED = 1.645

COMPLETE, PARTIAL, INSUFFICIENT = "complete", "partial", "insufficient"


def condition_level(wear: float, wear_std: float, warn: float = WARN, alarm: float = ALARM,
                    z: float = Z_ONE_SIDED) -> DiagnosticLevel | None:
    """The condition level of an estimate ``wear ± wear_std`` (module docstring); None without a finite wear.

    >>> [condition_level(w, 1.0).name for w in (29.0, 33.0, 33.5, 34.99, 35.0)]
    ['OK', 'WARN', 'WARN', 'WARN', 'ERROR']
    """
    w = float(wear)
    if not math.isfinite(w):
        return None
    if w >= alarm:
        return DiagnosticLevel.ERROR
    s = float(wear_std)
    s = s if math.isfinite(s) and s > 0.0 else 0.0
    if w >= warn or w + z * s >= alarm:
        return DiagnosticLevel.WARN
    return DiagnosticLevel.OK


def condition_reason(wear: float, wear_std: float, warn: float = WARN, alarm: float = ALARM,
                     z: float = Z_ONE_SIDED) -> str:
    """Why :func:`condition_level` says what it says, in words (the same text on every surface)."""
    lv = condition_level(wear, wear_std, warn, alarm, z)
    if lv is None:
        return "no wear estimate"
    w, s = float(wear), float(wear_std)
    if lv == DiagnosticLevel.ERROR:
        return f"wear {w:.1f} ± {s:.1f} at or above the alarm {alarm:g}"
    if w >= warn:
        return f"wear {w:.1f} ± {s:.1f} in the warning band [{warn:g}, {alarm:g})"
    if lv == DiagnosticLevel.WARN:
        return (f"wear {w:.1f} ± {s:.1f}: the alarm {alarm:g} is within its 95 % bound "
                f"({w + z * s:.1f}); the estimate cannot rule it out")
    return f"wear {w:.1f} ± {s:.1f} below the warning level {warn:g}"


def min_speeds(temperature_known: bool) -> int:
    """Distinct speeds an estimate needs to identify the wear: 3 when the temperature is estimated with it
    (two unknowns and one speed to tell them apart: the temperature and wear effects have different speed
    shapes, Eq. 9), 1 when a measured temperature is used.

    Measured (``bench/bench_min_speeds.py --quick``, ref-2011r, the temperature unknown at 25 or 55 degC, the
    first k of the test cycle's eight speeds, 6 estimates per k): ``bayes`` read true wear 0 as WARN at k = 1 and
    left 2 of 6 estimates beyond 3 std at k = 2 (0 at k = 3, 1 at k = 4 and 5); the ``joint`` estimator's
    largest error fell from 15 (k = 1) to 8.5 (k = 3) and under 5 from k = 6. Small samples: the threshold is
    the identifiability argument above, the bench its illustration.
    The same rule for every method. It does not cure a model that does not fit the joint: issue 28's 57.8 at
    true wear 0 came from a ``cobot-j3`` joint estimated with ``ref-2011r`` (every k reads 58-100 at true 0
    there, docs/levels.md): commission the joint's own set.
    """
    return 1 if temperature_known else 3


#: Observations whose speeds lie within this fraction of a level's slowest count as one speed level
#: (:func:`speed_levels`): a production shift observes a cruise speed many times, each pass at its own
#: measured speed; a test cycle's planned speeds are far further apart.
SPEED_LEVEL_MATCH = 0.05


def speed_levels(speeds: Iterable[float], match: float = SPEED_LEVEL_MATCH) -> int:
    """How many distinct speed levels ``speeds`` make: sorted, a new level begins past ``match`` x the current
    level's slowest speed. The count :func:`min_speeds` and :func:`evidence_of` are about.

    >>> speed_levels([40.0, 10.0, 10.1, 20.0, 40.4, 10.05]), speed_levels([]), speed_levels([5.0, 5.0])
    (3, 0, 1)
    """
    first: list[float] = []
    for v in sorted(float(x) for x in speeds):
        if not first or v - first[-1] > match * abs(first[-1]):
            first.append(v)
    return len(first)


def evidence_of(speeds_observed: int, speeds_planned: int, ended_badly: bool, temperature_known: bool,
                observations: int | None = None) -> str:
    """``complete``, ``partial`` or ``insufficient`` (module docstring) for a cycle's estimate.

    ``speeds_observed`` counts the distinct speed levels observed (:func:`speed_levels`: what carries the wear
    and the temperature apart); ``speeds_planned`` the cycle's steps, ``observations`` the steps observed (default
    ``speeds_observed``). A step may repeat a speed (a line cycle stretches a joint's shorter set over its steps;
    a request may name a speed twice): the cycle is complete when every step gave its observation.

    >>> evidence_of(8, 8, False, False), evidence_of(4, 8, True, False), evidence_of(1, 8, True, False)
    ('complete', 'partial', 'insufficient')
    >>> evidence_of(4, 8, False, False, observations=8), evidence_of(4, 8, False, False, observations=7)
    ('complete', 'partial')
    """
    if speeds_observed < min_speeds(temperature_known):
        return INSUFFICIENT
    got = speeds_observed if observations is None else observations
    if ended_badly or (speeds_planned > 0 and got < speeds_planned):
        return PARTIAL
    return COMPLETE


@dataclass(frozen=True)
class ConfirmConfig:
    """When an estimate is far enough from the standing one to wait for confirmation.

    ``k``: standard deviations of the difference; ``min_jump``: wear units a change must exceed anyway;
    ``max_rate_per_day``: growth a joint may show between two estimates (wear per day) before it counts.
    """

    k: float = 3.0
    min_jump: float = 8.0
    max_rate_per_day: float = 1.0

    def far(self, a: tuple[float, float], b: tuple[float, float], dt_days: float) -> bool:
        d = abs(float(a[0]) - float(b[0]))
        allowance = max(self.min_jump, self.k * math.hypot(float(a[1]), float(b[1])))
        allowance += self.max_rate_per_day * max(float(dt_days), 0.0)
        return d > allowance


@dataclass(frozen=True)
class Confirmation:
    """One estimate's confirmation: ``status`` and the index of the estimate the level stands on after it.

    ``status``: ``confirmed`` (agrees with the standing estimate, or the first), ``unconfirmed`` (far from it,
    held), ``step`` (a held estimate confirmed by this one, or the held one when confirmed), ``outlier`` (a held
    estimate the next one did not confirm); ``standing`` is None when no estimate stands yet.
    """

    status: str
    standing: int | None


def confirm(estimates: Sequence[tuple[float, float]], times_days: Sequence[float],
            cfg: ConfirmConfig | None = None) -> list[Confirmation]:
    """The sequential confirmation of a joint's estimates ``(wear, std)`` (one maintenance segment, in time
    order): one :class:`Confirmation` per estimate, as it stands after the whole sequence (a held estimate later
    confirmed reads ``step``, one later refuted ``outlier``). Non-finite estimates are skipped (``none``)."""
    cfg = cfg or ConfirmConfig()
    n = len(estimates)
    status = ["none"] * n
    stand_after: list[int | None] = [None] * n
    standing: int | None = None
    held: int | None = None
    for i, (w, s) in enumerate(estimates):
        if not (math.isfinite(float(w)) and math.isfinite(float(s))):
            stand_after[i] = standing
            continue
        if standing is None:
            status[i], standing = "confirmed", i
        elif held is not None and not cfg.far(estimates[held], (w, s), times_days[i] - times_days[held]):
            status[held] = status[i] = "step"
            standing, held = i, None
        elif not cfg.far(estimates[standing], (w, s), times_days[i] - times_days[standing]):
            if held is not None:
                status[held] = "outlier"
                held = None
            status[i], standing = "confirmed", i
        else:
            if held is not None:
                status[held] = "outlier"
            status[i], held = "unconfirmed", i
        stand_after[i] = standing
    return [Confirmation(st, sa) for st, sa in zip(status, stand_after)]


@dataclass(frozen=True)
class Standing:
    """The estimate a joint's level stands on and the newest estimate's state (what every surface shows)."""

    level: DiagnosticLevel | None
    wear: float
    wear_std: float
    index: int | None  # of the standing estimate in the sequence given
    newest_status: str  # confirmation of the newest estimate: confirmed, unconfirmed, step, none
    newest_evidence: str
    reason: str
    #: every estimate's confirmation after the whole sequence (:func:`confirm`), ``insufficient`` for one left out
    statuses: tuple[str, ...] = ()


def standing(wear: Sequence[float], wear_std: Sequence[float], times_days: Sequence[float],
             evidence: Sequence[str] | None = None, warn: float = WARN, alarm: float = ALARM,
             cfg: ConfirmConfig | None = None) -> Standing:
    """The condition of a joint from its estimates of one segment (time order): insufficient estimates are
    left out, the rest confirmed (:func:`confirm`); the level is the standing estimate's.

    >>> s = standing([10.0, 10.4, 30.0], [1.0, 1.0, 1.0], [0.0, 1.0, 2.0])
    >>> s.level.name, s.wear, s.newest_status
    ('OK', 10.4, 'unconfirmed')
    """
    n = len(wear)
    ev = list(evidence) if evidence is not None else [COMPLETE] * n
    use = [i for i in range(n) if ev[i] != INSUFFICIENT]
    conf = confirm([(float(wear[i]), float(wear_std[i])) for i in use], [float(times_days[i]) for i in use], cfg)
    statuses = [INSUFFICIENT] * n
    for k, c in zip(use, conf):
        statuses[k] = c.status
    newest_ev = ev[-1] if n else ""
    newest_status = "none"
    if n and use and use[-1] == n - 1:
        newest_status = conf[-1].status
    at = conf[-1].standing if conf else None
    if at is None:
        why = "no usable estimate" if n == 0 else "no estimate from enough speeds yet"
        return Standing(None, math.nan, math.nan, None, newest_status, newest_ev, why, tuple(statuses))
    idx = use[at]
    w, s = float(wear[idx]), float(wear_std[idx])
    lv = condition_level(w, s, warn, alarm)
    why = condition_reason(w, s, warn, alarm)
    if newest_ev == INSUFFICIENT:
        why += "; the newest estimate came from too few speeds to carry a level (the level above stands, stale)"
    elif newest_status == "unconfirmed":
        why += (f"; the newest estimate {float(wear[-1]):.1f} ± {float(wear_std[-1]):.1f} is far from it and held "
                "unconfirmed until the next estimate")
    elif newest_status == "step":
        why += "; a step confirmed by two estimates"
    if ev[idx] == PARTIAL:
        why += " (from a partial cycle)"
    return Standing(lv, w, s, idx, newest_status, newest_ev, why, tuple(statuses))


def plant_level(level: int, last_time: float, now: float, stale_days: float) -> int:
    """The level a plant view shows (serve, ``/metrics``, ``trend --json``, the fleet page): the condition level, or
    STALE when the joint's newest estimate (``last_time``, s) is older than ``stale_days`` at ``now`` (s) and the
    level is not ERROR (an alarm is never hidden by age). A ``last_time`` that is not finite is STALE.

    >>> plant_level(0, last_time=0.0, now=8 * 86400.0, stale_days=7), plant_level(2, 0.0, 8 * 86400.0, 7)
    (3, 2)
    """
    if int(level) == DiagnosticLevel.ERROR:
        return int(DiagnosticLevel.ERROR)
    if not math.isfinite(last_time) or now - last_time > stale_days * 86400.0:
        return int(DiagnosticLevel.STALE)
    return int(level)


@dataclass(frozen=True)
class Forecast:
    """The trend's forecast: time to alarm (days from the last estimate; None: none) and whether the alarm is
    expected within ``horizon_days``."""

    expected_within_horizon: bool
    horizon_days: float
    median_days: float | None
    lo90_days: float | None
    hi90_days: float | None
    state: str  # at_alarm, within_horizon, beyond_horizon, no_growth, no_trend

    def as_dict(self) -> dict[str, object]:
        def num(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else float(x)

        return {"alarm_expected": self.expected_within_horizon, "state": self.state,
                "horizon_days": self.horizon_days, "days_to_alarm": num(self.median_days),
                "days_to_alarm_low": num(self.lo90_days), "days_to_alarm_high": num(self.hi90_days)}

    @property
    def text(self) -> str:
        if self.state == "at_alarm":
            return "at the alarm"
        if self.state == "within_horizon":
            return f"alarm expected within {self.horizon_days:g} days"
        if self.state == "beyond_horizon":
            return f"no alarm expected within {self.horizon_days:g} days"
        return "no growth detected" if self.state == "no_growth" else "too few estimates for a trend"


def forecast_of(median: float | None, lo90: float | None, hi90: float | None, growth: bool, enough: bool,
                horizon_days: float) -> Forecast:
    """The forecast from a time to alarm (None when there is none) and whether growth is detected.

    >>> forecast_of(40.0, 20.0, 90.0, True, True, 30.0).text
    'alarm expected within 30 days'
    """
    if median is not None and median == 0.0 and lo90 == 0.0:
        return Forecast(True, horizon_days, 0.0, 0.0, 0.0, "at_alarm")
    if not enough:
        return Forecast(False, horizon_days, None, None, None, "no_trend")
    if median is None or not growth:
        return Forecast(False, horizon_days, None, None, None, "no_growth")
    within = lo90 is not None and lo90 <= horizon_days
    return Forecast(within, horizon_days, median, lo90, hi90, "within_horizon" if within else "beyond_horizon")
