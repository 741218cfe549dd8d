"""Plain data types of the friction observer: configuration, observation, rejection, segment.

Pure Python; no ROS import. :class:`FrictionObservationData` lives next to the message contract
(:mod:`jointwear_ros.observation`) and is re-exported here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from ..contract import CycleState
from ..errors import InputDataError
from ..observation import FrictionObservationData
from ..settings import check_ranges, setting

__all__ = [
    "PLAUSIBLE_TEMPERATURE",
    "FrictionObservationData",
    "ObserverConfig",
    "ObserverOutput",
    "Rejection",
    "SpeedSegment",
]

#: Temperatures a robot joint can have, degC; a reading outside is a sensor fault (not used).
PLAUSIBLE_TEMPERATURE = (-50.0, 200.0)


@dataclass(frozen=True)
class ObserverConfig:
    """Settings of :class:`~jointwear_ros.observer.FrictionObserverCore`.

    A field declared with :func:`~jointwear_ros.settings.setting` is also a parameter of the
    ``friction_observer`` node, each joint's own (``<joint>.<setting>``) and live: its description, unit
    and range are in the field metadata, from which ``settings.declarations`` builds the node's
    declarations and ``settings.from_mapping`` the config from parameter values (node, params YAML,
    a bag's recorded settings). ``joint_name`` (the node's joint) and ``idle_keep_seconds`` are not
    parameters.

    Speeds and tolerances are motor side (rad/s), positions joint side (rad),
    times in seconds of the message stamps.

    Attributes
    ----------
    joint_name : the joint observed; statuses naming another joint are ignored.
    gear_ratio : motor speed = joint speed x gear_ratio.
    torque_scale : N·m (joint side) per normalized torque unit: u = effort / torque_scale.
    speed_tolerance : a sample is "at speed" when ``|v - (±v_cmd)| <= max(speed_tolerance * v_cmd,
        speed_tolerance_min)``.
    speed_tolerance_min : floor of that tolerance, rad/s motor side.
    max_speed_std : the at-speed samples of a direction must have a speed standard deviation of at
        most ``max(max_speed_std * v_cmd, max_speed_std_min)``, else "speed not constant".
    max_speed_std_min : floor of that limit, rad/s motor side.
    min_constant_fraction : at least this fraction of the window samples moving in a direction must
        be at speed, else "speed not constant".
    min_samples : at-speed samples needed in each direction's window.
    edge_trim : fraction of the half width trimmed off each window edge (0 = use the whole window).
    pass_gap : s without a sample moving in a direction inside the window that separates two passes.
    n_batches : batches for the batch-means standard error of u+ and u-.
    reorder_margin : how far (s) status, temperature and joint-state messages may be out of stamp
        order on arrival; a finished speed is processed once a message stamped this much later
        than its end has been seen.
    poll_grace : extra wait (s) before :meth:`poll` processes a finished speed on the clock alone.
    temperature_wait : once a joint's temperature sensor has been heard, a finished speed waits for a
        temperature stamped at or after its end (so every reading of the window is in, however late the
        sensor's topic is delivered) until joint states stamped this much (s) later than its end have
        been seen; then it is measured with the readings that came (none: temperature unknown, counted
        in ``temperatures_missing``: a sensor that stopped, or delivers later than this).
    max_buffer_seconds : joint-state history kept at most (s) while a speed runs.
    idle_keep_seconds : joint-state history kept (s) while no speed runs. It is also how late a status
        may arrive and still find its speed's samples: a process starved of CPU receives the statuses of
        seconds in one burst (a recorder under load logged them 7.6 s after their stamps, while its joint
        states came on time), and a replay takes them at the recorder's log time. 15 s of 500 Hz joint
        states is 7,500 samples per joint.
    """

    joint_name: str = "joint_1"
    gear_ratio: float = setting(100.0, description="motor speed = joint speed x gear_ratio", range=(1e-6, 1e6),
                                per_joint=True)
    torque_scale: float = setting(200.0, description="N·m (joint side) per normalized torque unit", unit="N·m",
                                  range=(1e-9, 1e9), per_joint=True)
    speed_tolerance: float = setting(0.1, description="at speed: |v - v_cmd| <= this x v_cmd", range=(1e-6, 10.0),
                                     per_joint=True)
    speed_tolerance_min: float = setting(1.0, description="floor of that tolerance, rad/s motor", unit="rad/s",
                                         range=(0.0, 1e6), per_joint=True)
    max_speed_std: float = setting(0.05, description="speed std limit over the at-speed samples, x v_cmd",
                                   range=(1e-6, 10.0), per_joint=True)
    max_speed_std_min: float = setting(0.5, description="floor of that limit, rad/s motor", unit="rad/s",
                                       range=(0.0, 1e6), per_joint=True)
    min_constant_fraction: float = setting(0.8, description="fraction of the moving window samples that must be "
                                           "at speed", range=(0.0, 1.0), per_joint=True)
    min_samples: int = setting(20, description="at-speed samples needed per direction", range=(2, 1_000_000),
                               per_joint=True)
    edge_trim: float = setting(0.0, description="fraction of the half width trimmed off each window edge",
                               range=(0.0, 0.99), per_joint=True)
    pass_gap: float = setting(0.05, description="s without samples that separates two passes through the window",
                              unit="s", range=(1e-4, 10.0), per_joint=True)
    n_batches: int = setting(10, description="batches of the batch-means standard error", range=(2, 10_000),
                             per_joint=True)
    reorder_margin: float = setting(0.5, description="s the inputs may be out of stamp order", unit="s",
                                    range=(0.0, 60.0), per_joint=True)
    poll_grace: float = setting(1.0, description="s of silence on every input after which finished speeds are "
                                "processed", unit="s", range=(0.0, 60.0), per_joint=True)
    temperature_wait: float = setting(5.0, description="s of joint-state stamps a finished speed waits for its "
                                      "joint's temperature readings (once the sensor was heard)", unit="s",
                                      range=(0.0, 600.0), per_joint=True)
    max_buffer_seconds: float = setting(120.0, description="s of joint states kept at most", unit="s",
                                        range=(1.0, 3600.0), per_joint=True)
    idle_keep_seconds: float = 15.0  # not a parameter

    def __post_init__(self) -> None:
        check_ranges(self, InputDataError, "observer setting")
        keep = float(self.idle_keep_seconds)  # not a parameter
        if not (math.isfinite(keep) and keep >= 0):
            raise InputDataError(f"observer setting idle_keep_seconds = {keep!r} must be a number >= 0")


@dataclass(frozen=True)
class Rejection:
    """A speed whose windows did not give an observation, and why."""

    stamp: float
    joint_name: str
    cycle_id: int
    speed_index: int
    speed: float
    reason: str

    def __str__(self) -> str:
        return f"cycle {self.cycle_id} speed #{self.speed_index + 1} ({self.speed:g} rad/s): {self.reason}"


class ObserverOutput(NamedTuple):
    """What each call of the observer core returns: finished observations and rejections."""

    observations: list[FrictionObservationData]
    rejections: list[Rejection]


@dataclass(frozen=True)
class SpeedSegment:
    """One speed of a test cycle as the status stream delimits it: stamps [t_start, t_end)."""

    cycle_id: int
    speed_index: int
    speed: float
    window_center: float
    window_half_width: float
    t_start: float
    t_end: float = math.inf
    speeds_total: int = 0
    completed: bool = True
    end_state: int = CycleState.RUNNING
