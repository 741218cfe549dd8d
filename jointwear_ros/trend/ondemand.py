"""The test cycle on demand: ask for the dedicated cycle only when the production estimate cannot decide (pure).

A joint estimated from production motion (``source: production``) needs the dedicated test cycle only when
that estimate leaves the condition level (:mod:`jointwear_ros.condition`, the one rule) undecided.
:meth:`OnDemandPolicy.decide` asks for it, per joint, for one of three reasons, in this order:

- ``straddle``: the production estimate's interval ``w ± z s`` (``z`` the level rule's one-sided 95 %,
  :data:`~jointwear_ros.condition.Z_ONE_SIDED`) straddles a level threshold (the alarm, then the warning
  level): ``w - z s < threshold <= w + z s``;
- ``crossing``: the trend's forecast (:class:`~jointwear_ros.condition.Forecast`) puts the 90 % lower bound
  of the time to alarm within ``crossing_horizon_days`` (growth detected), or the trend is at the alarm;
- ``quiet``: the joint has not moved at an informative speed for ``max_quiet_shifts`` shifts (its newest
  production estimate, if any, is that old).

Against the last dedicated cycle (its time and its estimate ``w_c ± s_c`` of the joint):

- a straddle is not asked for while the production estimate agrees with the last cycle's estimate, i.e. has not
  grown beyond it by more than the confirmation rule's ``k`` standard deviations of the difference
  (:class:`~jointwear_ros.condition.ConfirmConfig`, 3): that cycle decided the level, and one noisy shift among
  hundreds does not undo it;
- no new ask within ``min_interval_nights`` of the last cycle, unless the production estimate has grown beyond it
  and its own level is above the level that cycle gave (the level would rise: a cycle decides it now);
- nothing is asked once the last cycle gave ERROR: the alarm stands until maintenance.

A "cannot tell" production estimate (None, or a wear or std that is not finite) never asks for ``straddle`` and
never moves a level: only ``quiet`` and ``crossing`` can ask without one.

The thresholds are the level rule's (``warn``, ``alarm``: the ``warn_threshold`` and ``alarm_threshold`` the
wear_estimator and wear_trend nodes take, :data:`~jointwear_ros.condition.WARN` and
:data:`~jointwear_ros.condition.ALARM` by default); they are passed in, not declared here.

>>> p = OnDemandPolicy()
>>> d = p.decide("joint_2", (33.1, 2.4), None, quiet_shifts=0, last_cycle_time=None, now=0.0)
>>> d.ask, d.kind, d.reason
(True, 'straddle', 'joint_2: production estimate 33.1 ± 2.4 straddles the ERROR threshold 35 (29.2 to 37.0); no dedicated test cycle yet')
>>> p.decide("joint_2", (20.0, 1.0), None, quiet_shifts=0, last_cycle_time=None, now=0.0).kind
'none'
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..condition import ALARM, WARN, Z_ONE_SIDED, ConfirmConfig, Forecast, condition_level
from ..contract import DiagnosticLevel, level_name
from ..errors import InputDataError
from ..settings import check_ranges, setting
from .config import DAY

__all__ = ["ASK_KINDS", "Decision", "OnDemandConfig", "OnDemandLedger", "OnDemandPolicy"]

#: the kinds of a :class:`Decision`: the three reasons to ask, and ``none``
ASK_KINDS = ("straddle", "crossing", "quiet", "none")


@dataclass(frozen=True)
class OnDemandConfig:
    """Settings of the test cycle on demand (:class:`OnDemandPolicy`); each is a node parameter.

    Attributes
    ----------
    max_quiet_shifts : shifts without informative production motion of a joint before the cycle is asked for.
    crossing_horizon_days : ask when the trend's 90 % lower bound of the time to alarm is within this.
    min_interval_nights : no new ask within this many nights of the last dedicated cycle, unless the production
        estimate has grown beyond that cycle's and its level is above the level the cycle gave. Nights are counted as days with half a day's slack
        (a cycle at 23:00 and an ask at 07:00 seven days later are seven nights apart).
    allow_service_call : true: the request is a call to ``/test_cycle/run``; false: a status an operator acts on.
    """

    max_quiet_shifts: int = setting(9, description="shifts without informative production motion of a joint "
                                    "before the dedicated test cycle is asked for", unit="shifts",
                                    range=(1, 100_000))
    crossing_horizon_days: float = setting(14.0, description="ask for the dedicated test cycle when the trend's "
                                           "90 % lower bound of the time to alarm is within this many days",
                                           unit="days", range=(0.0, 3650.0))
    min_interval_nights: int = setting(7, description="nights after a dedicated test cycle before the next is "
                                       "asked for, unless a production estimate grown beyond that cycle's would raise the level",
                                       unit="nights", range=(0, 3650))
    allow_service_call: bool = setting(False, description="ask by calling /test_cycle/run; false: publish a "
                                       "status an operator acts on")

    def __post_init__(self) -> None:
        check_ranges(self, InputDataError, "on-demand setting")


@dataclass(frozen=True)
class Decision:
    """Whether to ask for the dedicated test cycle for one joint, and why (one line an engineer reads).

    ``kind``: ``straddle``, ``crossing``, ``quiet`` or ``none``. A reason held back by the interval since the last
    cycle has ``ask`` False, its ``kind`` and a reason that says when the next ask may come.
    """

    joint: str
    ask: bool
    kind: str
    reason: str


def _finite(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(float(x))


def _time(name: str, x: object) -> float:
    if not _finite(x):
        raise InputDataError(f"{name} = {x!r}: a finite time in seconds is needed")
    return float(x)  # type: ignore[arg-type]


class OnDemandPolicy:
    """The test cycle on demand (module docstring): pure, deterministic, per joint.

    Parameters
    ----------
    config : the policy's settings.
    warn, alarm : the level rule's thresholds (the joint's ``warn_threshold`` and ``alarm_threshold``).
    confirm : the confirmation rule's settings; its ``k`` says when a production estimate has grown beyond the
        last dedicated cycle's.
    """

    def __init__(self, config: OnDemandConfig | None = None, *, warn: float = WARN, alarm: float = ALARM,
                 confirm: ConfirmConfig | None = None) -> None:
        self.config = config if config is not None else OnDemandConfig()
        self.confirm = confirm if confirm is not None else ConfirmConfig()
        if not (_finite(warn) and _finite(alarm) and 0.0 <= float(warn) <= float(alarm) <= 100.0):
            raise InputDataError(f"warn = {warn!r}, alarm = {alarm!r}: need finite thresholds with "
                                 "0 <= warn <= alarm <= 100 (wear)")
        self.warn, self.alarm = float(warn), float(alarm)

    def decide(self, joint: str, estimate: tuple[float, float] | None, forecast: Forecast | None, *,
               quiet_shifts: int, last_cycle_time: float | None, now: float,
               last_cycle_estimate: tuple[float, float] | None = None) -> Decision:
        """Ask for the dedicated cycle for ``joint`` or not (module docstring).

        Parameters
        ----------
        estimate : the newest production estimate ``(wear, std)``; None (or a non-finite wear or std): cannot tell.
        forecast : the joint's trend forecast (None: no trend).
        quiet_shifts : shifts since the joint's last informative estimate (production motion at an informative
            speed, or a dedicated cycle), >= 0.
        last_cycle_time : time of the last dedicated cycle, s (None: never); ``now``: s.
        last_cycle_estimate : the last dedicated cycle's estimate ``(wear, std)`` of the joint (None: none).
        """
        if not isinstance(joint, str) or not joint or not joint.isprintable():
            raise InputDataError(f"joint = {joint!r}: a joint name (one printable line) is needed")
        if isinstance(quiet_shifts, bool) or not isinstance(quiet_shifts, int) or quiet_shifts < 0:
            raise InputDataError(f"{joint}: quiet_shifts = {quiet_shifts!r}: a whole number of shifts >= 0 is needed")
        t_now = _time("now", now)
        t_last = None if last_cycle_time is None else _time("last_cycle_time (None: never)", last_cycle_time)
        if forecast is not None and not isinstance(forecast, Forecast):
            raise InputDataError(f"{joint}: forecast = {forecast!r}: a condition.Forecast or None is needed")
        est = self._estimate(joint, estimate, "estimate")
        cyc = self._estimate(joint, last_cycle_estimate, "last_cycle_estimate")
        if t_last is None:
            cyc = None
        elif t_last > t_now:
            raise InputDataError(f"{joint}: last_cycle_time {t_last!r} s is after now {t_now!r} s")
        cyc_level = None if cyc is None else condition_level(cyc[0], cyc[1], self.warn, self.alarm)
        if cyc_level == DiagnosticLevel.ERROR:
            return Decision(joint, False, "none", f"{joint}: the last dedicated test cycle gave ERROR; the alarm "
                            "stands until maintenance and no test cycle decides more")
        kind, why = self._reason(joint, est, forecast, quiet_shifts)
        if kind == "none":
            return Decision(joint, False, "none", why)
        if t_last is None:
            return Decision(joint, True, kind, why + "; no dedicated test cycle yet")
        nights = (t_now - t_last) / DAY
        grown = False
        if est is not None and cyc is not None:
            grown = est[0] - cyc[0] > self.confirm.k * math.hypot(est[1], cyc[1])
            if kind == "straddle" and not grown:
                return Decision(joint, False, kind, why + f"; not asked: it agrees with the last dedicated test "
                                f"cycle's {cyc[0]:.1f} ± {cyc[1]:.1f} ({_nights(nights)} ago), which decided "
                                f"{level_name(cyc_level)}")
        if nights + 0.5 >= self.config.min_interval_nights:
            return Decision(joint, True, kind, why + f"; last dedicated test cycle {_nights(nights)} ago")
        lv = None if est is None else condition_level(est[0], est[1], self.warn, self.alarm)
        if grown and lv is not None and int(lv) > int(cyc_level if cyc_level is not None else -1):
            return Decision(joint, True, kind, why + f"; it reads {level_name(lv)}, above the "
                            f"{level_name(cyc_level)} of the last dedicated test cycle {_nights(nights)} ago")
        return Decision(joint, False, kind, why + f"; not asked: the last dedicated test cycle was {_nights(nights)} "
                        f"ago (next after {self.config.min_interval_nights} nights unless the level would rise)")

    def decide_many(self, joints: Sequence[str], estimates: Sequence[tuple[float, float] | None],
                    forecasts: Sequence[Forecast | None], *, quiet_shifts: Sequence[int],
                    last_cycle_time: float | None, now: float,
                    last_cycle_estimates: Sequence[tuple[float, float] | None] | None = None) -> list[Decision]:
        """:meth:`decide` for each joint of a robot (one dedicated cycle tests them all: one ``last_cycle_time``)."""
        n = len(joints)
        lv = list(last_cycle_estimates) if last_cycle_estimates is not None else [None] * n
        if not (len(estimates) == len(forecasts) == len(quiet_shifts) == len(lv) == n):
            raise InputDataError(f"{n} joints but {len(estimates)} estimates, {len(forecasts)} forecasts, "
                                 f"{len(quiet_shifts)} quiet counts and {len(lv)} cycle estimates: one of each per joint")
        return [self.decide(j, e, f, quiet_shifts=q, last_cycle_time=last_cycle_time, now=now, last_cycle_estimate=v)
                for j, e, f, q, v in zip(joints, estimates, forecasts, quiet_shifts, lv)]

    # ------------------------------------------------------------------------------------------------ parts

    @staticmethod
    def _estimate(joint: str, estimate: object, what: str) -> tuple[float, float] | None:
        if estimate is None:
            return None
        if not isinstance(estimate, (tuple, list)) or len(estimate) != 2:
            raise InputDataError(f"{joint}: {what} = {estimate!r}: (wear, std) or None is needed")
        w, s = estimate
        for name, x in (("wear", w), ("std", s)):
            if isinstance(x, bool) or not isinstance(x, (int, float)):
                raise InputDataError(f"{joint}: {what} {name} = {x!r}: a number is needed (NaN: cannot tell)")
        if not (math.isfinite(float(w)) and math.isfinite(float(s))):
            return None  # cannot tell
        if float(s) < 0.0:
            raise InputDataError(f"{joint}: {what} std = {s!r}: a standard deviation is >= 0")
        return float(w), float(s)

    def _reason(self, joint: str, est: tuple[float, float] | None, fc: Forecast | None,
                quiet: int) -> tuple[str, str]:
        cfg = self.config
        if est is not None:
            w, s = est
            lo, hi = w - Z_ONE_SIDED * s, w + Z_ONE_SIDED * s
            for name, thr in (("ERROR", self.alarm), ("WARN", self.warn)):
                if lo < thr <= hi:
                    return "straddle", (f"{joint}: production estimate {w:.1f} ± {s:.1f} straddles the {name} "
                                        f"threshold {thr:g} ({lo:.1f} to {hi:.1f})")
        if fc is not None and (fc.state == "at_alarm" or (
                fc.state in ("within_horizon", "beyond_horizon") and fc.lo90_days is not None
                and fc.lo90_days <= cfg.crossing_horizon_days)):
            if fc.state == "at_alarm":
                return "crossing", f"{joint}: the trend is at the alarm {self.alarm:g}"
            return "crossing", (f"{joint}: the trend says the alarm {self.alarm:g} may be crossed in "
                                f"{fc.lo90_days:.0f} days (90 % lower bound; median {_days(fc.median_days)}), within "
                                f"{cfg.crossing_horizon_days:g}")
        if quiet >= cfg.max_quiet_shifts:
            return "quiet", (f"{joint}: no informative production motion for {quiet} shifts "
                             f"(the cycle is asked for after {cfg.max_quiet_shifts})")
        if est is None:
            return "none", f"{joint}: production cannot tell this shift; {quiet} quiet shift(s) so far"
        w, s = est
        return "none", (f"{joint}: production estimate {w:.1f} ± {s:.1f} decides the level "
                        f"{level_name(condition_level(w, s, self.warn, self.alarm))}")


def _nights(days: float) -> str:
    n = max(math.floor(days + 0.5), 0)
    return f"{n} night" + ("" if n == 1 else "s")


def _days(x: float | None) -> str:
    return "unbounded" if x is None or not math.isfinite(x) else f"{x:.0f} days"



@dataclass
class _JointMemory:
    estimate: tuple[float, float] | None = None
    estimate_time: float = math.nan
    quiet: int = 0
    forecast: Forecast | None = None
    cycle_time: float | None = None
    cycle_estimate: tuple[float, float] | None = None
    asked: Decision | None = None


class OnDemandLedger:
    """What :meth:`OnDemandPolicy.decide` needs per joint, kept from the stream a cell publishes (pure).

    The ``cycle_on_demand`` node feeds it the wear estimates of both sources, the production shifts' ends and the
    trend's forecasts, and asks it after each production shift; a replay of the same stream gives the same
    decisions. Per joint it keeps the newest production estimate (a "cannot tell" one, NaN, keeps the quiet count
    going), the shifts since the joint's last informative estimate, the newest forecast and the last dedicated
    cycle's time and estimate (a dedicated cycle resets the quiet count: it informed the level).

    >>> led = OnDemandLedger(OnDemandPolicy())
    >>> led.production_estimate("joint_2", 33.1, 2.4, stamp=3600.0).ask
    True
    >>> led.test_cycle_estimate("joint_2", 31.0, 0.9, stamp=7200.0)
    >>> led.production_estimate("joint_2", 33.5, 2.4, stamp=10800.0).reason.endswith("which decided WARN")
    True
    """

    def __init__(self, policy: OnDemandPolicy) -> None:
        self.policy = policy
        self._joints: dict[str, _JointMemory] = {}

    def _joint(self, joint: str) -> _JointMemory:
        if not isinstance(joint, str) or not joint or not joint.isprintable():
            raise InputDataError(f"joint = {joint!r}: a joint name (one printable line) is needed")
        return self._joints.setdefault(joint, _JointMemory())

    @property
    def joints(self) -> tuple[str, ...]:
        return tuple(self._joints)

    def last_decision(self, joint: str) -> Decision | None:
        """The newest decision made for ``joint`` (None: none yet)."""
        m = self._joints.get(joint)
        return None if m is None else m.asked

    def forecast(self, joint: str, forecast: Forecast | None) -> None:
        """The joint's newest trend forecast (None: no trend)."""
        if forecast is not None and not isinstance(forecast, Forecast):
            raise InputDataError(f"{joint}: forecast = {forecast!r}: a condition.Forecast or None is needed")
        self._joint(joint).forecast = forecast

    def test_cycle_estimate(self, joint: str, wear: float, std: float, *, stamp: float) -> None:
        """A dedicated test cycle's estimate of ``joint`` at ``stamp`` (s): the last cycle, and the joint informed
        (an estimate that is not finite still counts as a cycle run, not as information)."""
        m = self._joint(joint)
        t = _time("stamp", stamp)
        m.cycle_time = t if m.cycle_time is None else max(m.cycle_time, t)
        est = self.policy._estimate(joint, (float(wear), float(std)), "test cycle estimate")
        if est is not None:
            m.cycle_estimate = est
            m.quiet = 0

    def production_estimate(self, joint: str, wear: float, std: float, *, stamp: float) -> Decision:
        """A production shift's estimate of ``joint`` (NaN wear or std: the shift could not tell): the decision."""
        m = self._joint(joint)
        t = _time("stamp", stamp)
        est = self.policy._estimate(joint, (float(wear), float(std)), "production estimate")
        if est is None:
            m.quiet += 1
        else:
            m.estimate, m.estimate_time, m.quiet = est, t, 0
        return self._decide(joint, m, t)

    def quiet_shift(self, joint: str, *, stamp: float) -> Decision:
        """A production shift that ended without an informative observation of ``joint``: the decision."""
        m = self._joint(joint)
        t = _time("stamp", stamp)
        m.quiet += 1
        return self._decide(joint, m, t)

    def _decide(self, joint: str, m: _JointMemory, now: float) -> Decision:
        cycle_time = None if m.cycle_time is None else min(m.cycle_time, now)
        est = m.estimate if m.quiet == 0 else None
        d = self.policy.decide(joint, est, m.forecast, quiet_shifts=m.quiet, last_cycle_time=cycle_time, now=now,
                               last_cycle_estimate=m.cycle_estimate)
        m.asked = d
        return d
