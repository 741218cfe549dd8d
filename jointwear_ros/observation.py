"""The friction observation as plain data: what ``FrictionObservation.msg`` carries.

Pure Python; no ROS import and no package import, so the message contract (:mod:`jointwear_ros.contract`)
converts to it and the observer (:mod:`jointwear_ros.observer`) produces it without either importing
the other. :class:`FrictionObservationData` has the fields of ``jointwear_msgs/msg/FrictionObservation``
with the header reduced to its stamp (``stamp``, seconds), so the nodes and the bag reader convert field
by field. ``source`` says where the observation comes from: ``"test_cycle"`` (the dedicated cycle, the
default) or ``"production"`` (the robot's own program); :class:`jointwear_ros.contract.Source` names them.

>>> obs = FrictionObservationData(stamp=1.5, joint_name="joint_1", cycle_id=2, speed=0.5, tau_f=0.1,
...                               tau_f_std=0.01, tau_plus=0.2, tau_minus=0.0, load_torque=0.0,
...                               temperature=30.0, position=0.0, samples_plus=40, samples_minus=40)
>>> obs.to_dict()["tau_f"], obs.source
(0.1, 'test_cycle')
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

__all__ = ["FrictionObservationData"]


@dataclass(frozen=True)
class FrictionObservationData:
    """One static friction observation: the fields of ``FrictionObservation.msg``.

    ``stamp`` is the header stamp (s): the stamp of the last sample of the
    reverse window. Torques are normalized, ``speed`` is motor side. ``source`` is
    ``"test_cycle"`` or ``"production"`` (``contract.Source``); ``cycle_id`` is the test
    cycle's id, or the production shift's.
    """

    stamp: float
    joint_name: str
    cycle_id: int
    speed: float
    tau_f: float
    tau_f_std: float
    tau_plus: float
    tau_minus: float
    load_torque: float
    temperature: float
    position: float
    samples_plus: int
    samples_minus: int
    source: str = "test_cycle"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)
