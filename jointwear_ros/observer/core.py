"""The friction observer core: status stream + joint-state samples → one observation per speed.

:class:`FrictionObserverCore` is fed plain values (no ROS types) by the live
node and by the offline replay alike. The status stream delimits each speed of
a test cycle by stamps: a speed starts at the stamp of the first RUNNING status
with that ``(cycle_id, speeds_done)`` and ends at the stamp of the status where
``speeds_done`` advances, the cycle id changes, or the state leaves RUNNING.
Samples are selected by stamp, position and velocity (never by arrival order),
and a finished speed is processed only once a message stamped
``reorder_margin`` later than its end has been seen (or :meth:`poll`/
:meth:`flush` says so). So however status, temperature and joint-state
messages interleave within ``reorder_margin``, the observations are the same:
the live run and a replay in bag log order agree exactly.

The temperature sensor is a topic of its own, and DDS orders messages per
topic only: after a stall, or in a burst, the joint states of several seconds
may arrive before the temperature readings stamped among them. So once a
joint's sensor has been heard, a finished speed also waits until a
temperature stamped at or after its end has arrived (each topic arrives in
stamp order, so then every reading of the window is in), for at most
``temperature_wait`` seconds of joint-state stamps; a speed measured without
no reading at all (the sensor stopped) is counted in :attr:`FrictionObserverCore.temperatures_missing`.
However late the sensor's topic comes within that bound, the observation is
the same.

After a speed is processed, samples older than its end are dropped; newer
samples are kept (the next speed may already have started).

Pure numpy; no ROS import.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from ..contract import CycleState, CycleStatus
from ..errors import InputDataError
from .segmentation import measure_segment
from .types import (
    PLAUSIBLE_TEMPERATURE,
    FrictionObservationData,
    ObserverConfig,
    ObserverOutput,
    Rejection,
    SpeedSegment,
)

__all__ = ["FrictionObserverCore", "SampleBuffer", "receipt_stamp"]

Array = npt.NDArray[np.float64]



def receipt_stamp(stamp: float, now: float) -> float:
    """A message's header stamp, or ``now`` (the receiver's clock) when the header has none (0)."""
    return stamp if stamp > 0 else now

class SampleBuffer:
    """Growable column store of (stamp, position, velocity, effort) samples.

    Appending one sample writes into preallocated arrays (amortised O(1));
    appending a batch is one slice copy.
    """

    def __init__(self, capacity: int = 4096) -> None:
        self._data = np.empty((4, max(16, int(capacity))))
        self.size = 0

    def __len__(self) -> int:
        return self.size

    def _reserve(self, extra: int) -> None:
        need = self.size + extra
        cap = self._data.shape[1]
        if need > cap:
            new = np.empty((4, max(need, 2 * cap)))
            new[:, : self.size] = self._data[:, : self.size]
            self._data = new

    def append(self, stamp: float, position: float, velocity: float, effort: float) -> None:
        if self.size >= self._data.shape[1]:
            self._reserve(1)
        d = self._data
        i = self.size
        d[0, i] = stamp
        d[1, i] = position
        d[2, i] = velocity
        d[3, i] = effort
        self.size = i + 1

    def extend(self, stamps: Array, position: Array, velocity: Array, effort: Array) -> None:
        n = int(stamps.size)
        if n == 0:
            return
        self._reserve(n)
        s = slice(self.size, self.size + n)
        self._data[0, s] = stamps
        self._data[1, s] = position
        self._data[2, s] = velocity
        self._data[3, s] = effort
        self.size += n

    def columns(self) -> tuple[Array, Array, Array, Array]:
        d = self._data[:, : self.size]
        return d[0], d[1], d[2], d[3]

    def drop_before(self, stamp: float) -> None:
        """Drop every sample stamped before ``stamp`` (keeps arrival order of the rest)."""
        if self.size == 0:
            return
        t = self._data[0, : self.size]
        keep = t >= stamp
        if keep.all():
            return
        kept = self._data[:, : self.size][:, keep]
        self.size = kept.shape[1]
        self._data[:, : self.size] = kept

    def min_stamp(self) -> float:
        return float(self._data[0, : self.size].min()) if self.size else math.inf


class FrictionObserverCore:
    """Segments test-cycle speeds and applies Eq. (5); see the module docstring.

    Every ``on_*`` call returns an :class:`ObserverOutput` ``(observations,
    rejections)`` of the speeds it finished (usually empty).

    >>> core = FrictionObserverCore(ObserverConfig())
    >>> core.on_joint_state(0.0, 0.0, 0.0, 0.0)
    ObserverOutput(observations=[], rejections=[])
    """

    def __init__(self, config: ObserverConfig | None = None) -> None:
        self.config = config if config is not None else ObserverConfig()
        self._samples = SampleBuffer()
        self._temp_t: list[float] = []
        self._temp_v: list[float] = []
        self._active: SpeedSegment | None = None
        self._pending: list[SpeedSegment] = []
        self._max_stamp = -math.inf
        self._due = math.inf  # earliest t_end + reorder_margin of the pending speeds
        self._trim_at = 0  # buffer size at which the next idle trim runs
        self.samples_seen = 0
        self.samples_skipped = 0
        self.temperatures_skipped = 0
        #: observations without a temperature although the joint's sensor was heard before (it stopped,
        #: or its topic came later than ``temperature_wait``)
        self.temperatures_missing = 0
        self._temp_max = -math.inf  # newest temperature stamp seen (-inf: no sensor heard yet)

    def reconfigure(self, config: ObserverConfig) -> None:
        """Use ``config`` from now on; only between speeds (nothing active or pending), same joint.

        Raises :class:`~jointwear_ros.errors.InputDataError` with the reason
        otherwise: a speed being observed must be measured with the settings
        it started with, or live and replayed observations would differ.
        """
        if config.joint_name != self.config.joint_name:
            raise InputDataError(f"joint_name cannot change ({self.config.joint_name!r} -> {config.joint_name!r})")
        busy = ([self._active] if self._active is not None else []) + self._pending
        if busy:
            seg = busy[0]
            raise InputDataError(
                f"cycle {seg.cycle_id} speed #{seg.speed_index + 1} is being observed; change the observer "
                "settings between cycles"
            )
        self.config = config

    # -- inputs ------------------------------------------------------------------
    def on_status(self, status: CycleStatus, now: float = 0.0) -> ObserverOutput:
        """A ``TestCycleStatus``: opens and closes speeds, at its stamp (``now`` when it has none, 0).
        ``phase`` is not used for selection; a status of another joint (a non-empty ``joint_name``) is ignored."""
        stamp = receipt_stamp(float(status.stamp), float(now))
        if status.joint_name and status.joint_name != self.config.joint_name:
            return ObserverOutput([], [])
        cycle_id, state, speeds_done, speeds_total = (int(status.cycle_id), int(status.state), int(status.speeds_done),
                                                      int(status.speeds_total))
        act = self._active
        if state == CycleState.RUNNING:
            if act is not None and act.cycle_id == cycle_id and act.speed_index == speeds_done:
                return self._advance(stamp)
            if act is not None:
                self._close(stamp, completed=act.cycle_id == cycle_id and speeds_done > act.speed_index,
                            end_state=CycleState.RUNNING)
            if 0 < speeds_total <= speeds_done:  # every speed done; DONE follows
                return self._advance(stamp)
            self._active = SpeedSegment(
                cycle_id=cycle_id, speed_index=speeds_done, speed=float(status.current_speed),
                window_center=float(status.window_center), window_half_width=float(status.window_half_width),
                t_start=stamp, speeds_total=speeds_total,
            )
        elif act is not None:
            completed = act.cycle_id == cycle_id and (state == CycleState.DONE or speeds_done > act.speed_index)
            self._close(stamp, completed=completed, end_state=state)
        return self._advance(stamp)

    def on_joint_state(self, stamp: float, position: float, velocity: float, effort: float) -> ObserverOutput:
        """One joint-state sample of the observed joint (joint side: rad, rad/s, N·m)."""
        if not (math.isfinite(stamp) and math.isfinite(position) and math.isfinite(velocity) and math.isfinite(effort)):
            self.samples_skipped += 1
            return ObserverOutput([], [])
        self._samples.append(stamp, position, velocity, effort)
        self.samples_seen += 1
        if self._samples.size >= self._trim_at:
            self._trim()
        if stamp > self._max_stamp:
            self._max_stamp = stamp
            if stamp > self._due:
                return self._process_due()
        return ObserverOutput([], [])

    def on_joint_states(
        self, stamps: npt.ArrayLike, position: npt.ArrayLike, velocity: npt.ArrayLike, effort: npt.ArrayLike
    ) -> ObserverOutput:
        """A batch of samples (same result as feeding them one by one; rows with NaN are skipped)."""
        t = np.asarray(stamps, dtype=float).reshape(-1)
        p = np.asarray(position, dtype=float).reshape(-1)
        v = np.asarray(velocity, dtype=float).reshape(-1)
        e = np.asarray(effort, dtype=float).reshape(-1)
        if not (t.size == p.size == v.size == e.size):
            raise ValueError(f"on_joint_states: arrays of {t.size}, {p.size}, {v.size}, {e.size} samples; need equal lengths")
        ok = np.isfinite(t) & np.isfinite(p) & np.isfinite(v) & np.isfinite(e)
        if not ok.all():
            self.samples_skipped += int(t.size - np.count_nonzero(ok))
            t, p, v, e = t[ok], p[ok], v[ok], e[ok]
        if t.size == 0:
            return ObserverOutput([], [])
        self._samples.extend(t, p, v, e)
        self.samples_seen += int(t.size)
        if self._samples.size >= self._trim_at:
            self._trim()
        return self._advance(float(t.max()))

    def on_temperature(self, stamp: float, celsius: float) -> ObserverOutput:
        """A joint temperature sample (degC); non-finite and physically impossible values are skipped.

        A reading outside :data:`~jointwear_ros.observer.types.PLAUSIBLE_TEMPERATURE`
        (-300 degC, 1000 degC) is a sensor fault: averaged with the good readings
        of a speed it would give a plausible-looking wrong temperature, so it is
        left out and counted in :attr:`temperatures_skipped`.
        """
        lo, hi = PLAUSIBLE_TEMPERATURE
        if not (math.isfinite(celsius) and lo <= celsius <= hi):
            self.temperatures_skipped += 1
            return ObserverOutput([], [])
        if math.isfinite(stamp):
            stamp = float(stamp)
            self._temp_t.append(stamp)
            self._temp_v.append(float(celsius))
            if stamp > self._temp_max:
                self._temp_max = stamp
                if self._pending:  # a speed may have been waiting for this reading
                    self._due = min(self._seg_due(seg) for seg in self._pending)
                    if self._max_stamp > self._due_margin():
                        out = self._process_due()
                        more = self._advance(stamp)
                        return ObserverOutput(out.observations + more.observations,
                                              out.rejections + more.rejections)
            return self._advance(stamp)
        return ObserverOutput([], [])

    def poll(self, now: float) -> ObserverOutput:
        """Process finished speeds whose end is ``reorder_margin + poll_grace`` before ``now``.

        For a live node whose inputs fall silent after the last speed; it
        does not change which samples an observation uses.
        """
        cfg = self.config
        if self._pending and now > self._due + cfg.poll_grace:
            return self._process(lambda seg: seg.t_end + cfg.reorder_margin + cfg.poll_grace < now)
        return ObserverOutput([], [])

    def process_pending(self) -> ObserverOutput:
        """Process every finished speed now (the inputs fell silent; nothing more will arrive)."""
        if not self._pending:
            return ObserverOutput([], [])
        return self._process(lambda seg: True)

    def flush(self) -> ObserverOutput:
        """End of input: process every finished speed; a speed still running is rejected."""
        out = self._process(lambda seg: True)
        act = self._active
        if act is not None:
            self._active = None
            out.rejections.append(Rejection(
                stamp=self._max_stamp if math.isfinite(self._max_stamp) else act.t_start,
                joint_name=self.config.joint_name, cycle_id=act.cycle_id, speed_index=act.speed_index,
                speed=act.speed, reason="input ended before this speed finished",
            ))
        return out

    # -- state ---------------------------------------------------------------------
    @property
    def active_segment(self) -> SpeedSegment | None:
        return self._active

    @property
    def pending_segments(self) -> tuple[SpeedSegment, ...]:
        return tuple(self._pending)

    @property
    def buffered_samples(self) -> int:
        return self._samples.size

    # -- internals -------------------------------------------------------------------
    def _close(self, stamp: float, *, completed: bool, end_state: int) -> None:
        act = self._active
        assert act is not None
        self._active = None
        seg = SpeedSegment(
            cycle_id=act.cycle_id, speed_index=act.speed_index, speed=act.speed, window_center=act.window_center,
            window_half_width=act.window_half_width, t_start=act.t_start, t_end=max(stamp, act.t_start),
            speeds_total=act.speeds_total, completed=completed, end_state=end_state,
        )
        self._pending.append(seg)
        self._due = min(self._due, self._seg_due(seg))

    def _advance(self, stamp: float) -> ObserverOutput:
        if stamp > self._max_stamp:
            self._max_stamp = stamp
        if self._max_stamp > self._due:
            return self._process_due()
        return ObserverOutput([], [])

    def _waits_for_temperature(self, seg: SpeedSegment) -> bool:
        """The joint has a temperature sensor and no reading stamped at or after ``seg``'s end came yet."""
        return math.isfinite(self._temp_max) and self._temp_max < seg.t_end

    def _seg_due(self, seg: SpeedSegment) -> float:
        """The joint-state stamp past which ``seg`` is processed whatever else arrives."""
        cfg = self.config
        if self._waits_for_temperature(seg):
            return seg.t_end + max(cfg.reorder_margin, cfg.temperature_wait)
        return seg.t_end + cfg.reorder_margin

    def _due_margin(self) -> float:
        """The earliest end + ``reorder_margin`` of the pending speeds (ready then but for the temperature)."""
        return min((s.t_end for s in self._pending), default=math.inf) + self.config.reorder_margin

    def _process_due(self) -> ObserverOutput:
        margin = self.config.reorder_margin
        horizon = self._max_stamp
        return self._process(lambda seg: seg.t_end + margin < horizon and (
            not self._waits_for_temperature(seg) or horizon > self._seg_due(seg)))

    def _process(self, ready: object) -> ObserverOutput:
        obs: list[FrictionObservationData] = []
        rej: list[Rejection] = []
        keep: list[SpeedSegment] = []
        done_until = -math.inf
        t, p, v, e = self._samples.columns()
        tt = np.asarray(self._temp_t)
        tv = np.asarray(self._temp_v)
        for seg in self._pending:
            if not ready(seg):  # type: ignore[operator]
                keep.append(seg)
                continue
            if not seg.completed:
                how = CycleState.name_of(seg.end_state)
                reason = (f"cycle {how} before this speed finished" if seg.end_state != CycleState.RUNNING
                          else "a new cycle started before this speed finished")
                rej.append(Rejection(stamp=seg.t_end, joint_name=self.config.joint_name, cycle_id=seg.cycle_id,
                                     speed_index=seg.speed_index, speed=seg.speed, reason=reason))
            else:
                r = measure_segment(t, p, v, e, seg, self.config, tt, tv)
                if (isinstance(r, FrictionObservationData) and math.isnan(r.temperature)
                        and math.isfinite(self._temp_max)):
                    self.temperatures_missing += 1  # the sensor was heard, but not in this window
                (obs if isinstance(r, FrictionObservationData) else rej).append(r)  # type: ignore[arg-type]
            done_until = max(done_until, seg.t_end)
        self._pending = keep
        self._due = min((self._seg_due(s) for s in keep), default=math.inf)
        if math.isfinite(done_until):
            self._drop_before(done_until)
        return ObserverOutput(obs, rej)

    def _oldest_needed(self) -> float:
        starts = [s.t_start for s in self._pending]
        if self._active is not None:
            starts.append(self._active.t_start)
        return min(starts, default=math.inf)

    def _drop_before(self, stamp: float) -> None:
        stamp = min(stamp, self._oldest_needed())
        self._samples.drop_before(stamp)
        if self._temp_t and self._temp_t[0] < stamp:
            keep = [i for i, ts in enumerate(self._temp_t) if ts >= stamp]
            self._temp_t = [self._temp_t[i] for i in keep]
            self._temp_v = [self._temp_v[i] for i in keep]

    def _trim(self) -> None:
        """Bound memory: idle history beyond ``idle_keep_seconds``, any beyond ``max_buffer_seconds``."""
        cfg = self.config
        latest = self._max_stamp
        if math.isfinite(latest):
            cut = latest - cfg.max_buffer_seconds
            needed = self._oldest_needed()
            if not math.isfinite(needed):
                cut = max(cut, latest - cfg.idle_keep_seconds)
            self._samples.drop_before(cut)
            if self._temp_t and self._temp_t[0] < cut:
                keep = [i for i, ts in enumerate(self._temp_t) if ts >= cut]
                self._temp_t = [self._temp_t[i] for i in keep]
                self._temp_v = [self._temp_v[i] for i in keep]
        # next trim after the buffer has grown by a chunk (keeps per-sample cost tiny)
        self._trim_at = self._samples.size + 4096


def observe_arrays(
    config: ObserverConfig,
    stamps: npt.ArrayLike,
    position: npt.ArrayLike,
    velocity: npt.ArrayLike,
    effort: npt.ArrayLike,
    statuses: Sequence[CycleStatus] = (),
    temperatures: Sequence[tuple[float, float]] = (),
    *,
    flush: bool = True,
) -> ObserverOutput:
    """Run the observer offline on whole arrays (the replay path), vectorised.

    ``statuses`` are :class:`~jointwear_ros.contract.CycleStatus` (each at its ``stamp``);
    ``temperatures`` are ``(stamp, celsius)``.
    Inputs are fed in stamp order, the samples in chunks between status
    stamps, so the result equals the live core's for any interleaving within
    ``reorder_margin``.
    """
    core = FrictionObserverCore(config)
    t = np.asarray(stamps, dtype=float).reshape(-1)
    p = np.asarray(position, dtype=float).reshape(-1)
    v = np.asarray(velocity, dtype=float).reshape(-1)
    e = np.asarray(effort, dtype=float).reshape(-1)
    if not (t.size == p.size == v.size == e.size):
        raise ValueError(f"observe_arrays: arrays of {t.size}, {p.size}, {v.size}, {e.size} samples; need equal lengths")
    order = np.argsort(t, kind="stable")
    if not np.all(order[1:] > order[:-1]):
        t, p, v, e = t[order], p[order], v[order], e[order]
    events: list[tuple[float, int, int, CycleStatus | tuple[float, float]]] = []
    for i, st in enumerate(statuses):
        events.append((float(st.stamp), 0, i, st))
    for i, tm in enumerate(temperatures):
        events.append((float(tm[0]), 1, i, (float(tm[0]), float(tm[1]))))
    events.sort(key=lambda ev: (ev[0], ev[1], ev[2]))
    obs: list[FrictionObservationData] = []
    rej: list[Rejection] = []

    def take(out: ObserverOutput) -> None:
        obs.extend(out.observations)
        rej.extend(out.rejections)

    start = 0
    for stamp, _, _, ev in events:
        stop = int(np.searchsorted(t, stamp, side="left"))
        if stop > start:
            take(core.on_joint_states(t[start:stop], p[start:stop], v[start:stop], e[start:stop]))
            start = stop
        if isinstance(ev, CycleStatus):
            take(core.on_status(ev))
        else:
            take(core.on_temperature(*ev))
    if start < t.size:
        take(core.on_joint_states(t[start:], p[start:], v[start:], e[start:]))
    if flush:
        take(core.flush())
    return ObserverOutput(obs, rej)
