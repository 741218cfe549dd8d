"""Wear per joint from a shift of production observations, through the live wear monitor.

:func:`estimate_shift` turns a :class:`~jointwear_ros.observer.production.ProductionShift` into one estimate
per joint (:class:`ShiftEstimate`) by the path the live ``wear_estimator`` takes: one :class:`~.core.WearMonitor`
per joint is fed the shift's observations of that joint (:meth:`~.core.WearMonitor.add`, in the shift's order)
and then a DONE :class:`~jointwear_ros.contract.CycleStatus` of cycle ``shift_id`` with ``speeds_total`` = that
joint's number of observations (:meth:`~.core.WearMonitor.on_status`): the status completes the cycle, as the
test cycle's DONE does, so an offline estimate and a live one cannot differ (tested bit for bit).

A joint gets an explicit *cannot tell* instead of a number (``wear`` NaN, ``reason`` set) when it never moved
at an informative speed in the shift (the observer's note), when none of its passes gave an observation
(the reasons the observer counted), or when the monitor gives no level (too few speeds for the estimator:
:func:`~jointwear_ros.condition.min_speeds`, 3 with the temperature unknown, 1 with it measured; a failed
estimation). Pure; no ROS import.

>>> from jointwear_ros.observer.production import JointShiftCounts, ProductionShift
>>> shift = ProductionShift(1, 0.0, 60.0, 100, (), (), {"joint_6": JointShiftCounts(
...     "joint_6", note="joint_6: never moved at a constant speed >= 10 rad/s motor in this shift")})
>>> est = estimate_shift(shift)
>>> est["joint_6"].told, est["joint_6"].reason
(False, 'joint_6: never moved at a constant speed >= 10 rad/s motor in this shift')
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

from ..contract import CycleState, CycleStatus, Source
from ..observer.production import JointShiftCounts, ProductionShift
from .core import CycleResult, EstimatorFactory, MonitorConfig, WearMonitor

__all__ = ["ShiftEstimate", "estimate_shift"]


@dataclass(frozen=True)
class ShiftEstimate:
    """One joint's production estimate of a shift: ``wear`` and ``wear_std`` (NaN when it cannot tell, and
    ``reason`` says why), the monitor's :class:`~.core.CycleResult` (None when no observation reached it),
    the observations used and the observer's pass counts (paired, model, rejected)."""

    joint_name: str
    shift_id: int
    wear: float
    wear_std: float
    reason: str
    result: CycleResult | None
    n_observations: int
    paired: int
    model: int
    rejected: int

    @property
    def told(self) -> bool:
        """The shift gave this joint a wear estimate (else :attr:`reason` says why not)."""
        return math.isfinite(self.wear)


def _estimate(name: str, sid: int, wear: float, std: float, reason: str, result: CycleResult | None, n: int,
              counts: JointShiftCounts) -> ShiftEstimate:
    return ShiftEstimate(name, sid, wear, std, reason, result, n, counts.paired, counts.model, counts.rejected_total)


def estimate_shift(shift: ProductionShift, config: MonitorConfig | Mapping[str, MonitorConfig] | None = None, *,
                   pooled: bool = False,
                   estimator_factory: EstimatorFactory | None = None,
                   monitors: Mapping[str, WearMonitor] | None = None) -> dict[str, ShiftEstimate]:
    """Each joint's wear from ``shift`` (module docstring), keyed by joint name in the shift's order.

    ``config``: one :class:`~.core.MonitorConfig` for every joint (its ``joint_name`` replaced by each
    joint's), or one per joint; default ``MonitorConfig(method="joint")``, the estimator the dedicated
    cycle on the arm uses (:func:`jointwear_ros.simcell.run_cycle`); ``use_measured_temperature`` decides
    whether a temperature sensor's readings are used. ``monitors``: the joints' running monitors (a live
    wear_estimator's), fed in place, so their confirmation memory carries over from shift to shift;
    default a fresh monitor per joint.

    The shift's ``observations`` are fed, each pair's own (what the production_observer node publishes): the
    monitor adds its sweep-to-sweep scatter (``observation_noise_std``) to each, as to each sweep of a test
    cycle, so N pairs of a level weigh as N sweeps. ``pooled``: feed ``shift.levels`` instead, one per speed
    level (each weighs as one sweep: a std about twice as large on the simulated UR5, docs/production.md). The pairs of one level have
    nearly the same speed: the monitor counts speed levels (:func:`~jointwear_ros.condition.speed_levels`), not
    observations, against the estimator's need of distinct speeds (3 with the temperature unknown, 1 with it
    measured), live as here."""
    out: dict[str, ShiftEstimate] = {}
    sid = int(shift.shift_id)
    for name, counts in shift.joints.items():
        obs = [o for o in (shift.levels if pooled else shift.observations) if o.joint_name == name]

        if not counts.informative or not obs:
            why = counts.note or (f"{name}: no friction observation from its {counts.passes} passes in this shift"
                                  + (" (" + ", ".join(f"{k} {v}" for k, v in sorted(counts.rejected.items())) + ")"
                                     if counts.rejected else ""))
            out[name] = _estimate(name, sid, math.nan, math.nan, why, None, len(obs), counts)
            continue
        if monitors is not None and name in monitors:
            mon = monitors[name]
        else:
            cfg = config.get(name) if isinstance(config, Mapping) else config
            cfg = replace(cfg or MonitorConfig(method="joint"), joint_name=name)
            mon = WearMonitor(cfg, estimator_factory)
        results: list[CycleResult] = []
        for o in obs:
            results += mon.add(o, o.stamp)
        status = CycleStatus(cycle_id=sid, state=CycleState.DONE, speeds_total=len(obs), joint_name=name,
                             stamp=shift.t_end)
        results += mon.on_status(status, shift.t_end, source=Source.PRODUCTION)
        mine = [r for r in results if r.cycle_id == sid]
        res = mine[-1] if mine else None
        if res is None or res.result is None:
            why = f"{name}: " + (res.message if res is not None else "the monitor gave no result for the shift")
            out[name] = _estimate(name, sid, math.nan, math.nan, why, res, len(obs), counts)
        else:
            out[name] = _estimate(name, sid, float(res.result.wear), float(res.result.wear_std), "", res, len(obs),
                                  counts)
    return out
