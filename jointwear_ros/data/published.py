"""Friction models of real robots, from their publications: sweeps a plateau test would measure.

Only numbers printed in the cited papers are used (no file of theirs is copied); the tables made
from them are synthetic, in the robot's own units (joint side, rad/s, N·m).

``PANDA_FRICTION``: the Franka Emika Panda (seven joints with harmonic drives), C. Gaz, M. Cognetti,
A. Oliva, P. Robuffo Giordano, A. De Luca, "Dynamic Identification of the Franka Emika Panda Robot
With Retrieval of Feasible Parameters Using Penalty-Based Optimization", IEEE RA-L 4(4):4147-4154,
2019: per joint ``tau_f(v) = phi1 / (1 + exp(-phi2 (v + phi3))) - phi1 / (1 + exp(-phi2 phi3))``,
v in rad/s, tau_f in N·m. A forward and reverse sweep at speed v measures
``(tau_f(v) - tau_f(-v)) / 2`` (Eq. 5).

>>> t = panda_friction_sweep(6, np.array([0.016, 0.36, 1.35]), noise=0.0)
>>> [round(float(x), 3) for x in t["tau_f"]]
[0.023, 0.269, 0.282]
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ..types import ObservationTable

__all__ = ["PANDA_FRICTION", "panda_friction", "panda_friction_sweep"]

Array = npt.NDArray[np.float64]

#: (phi1 N·m, phi2 s/rad, phi3 rad/s) of joints 1..7 (Gaz et al. 2019).
PANDA_FRICTION: tuple[tuple[float, float, float], ...] = (
    (0.54615, 5.1181, 0.039533),
    (0.87224, 9.0657, 0.025882),
    (0.64068, 10.136, -0.04607),
    (1.2794, 5.5903, 0.036194),
    (0.83904, 8.3469, 0.026226),
    (0.30301, 17.133, -0.021047),
    (0.56489, 10.336, 0.0035526),
)


def panda_friction(joint: int, velocity: npt.ArrayLike) -> Array:
    """Signed friction torque (N·m) of Panda joint ``joint`` (0-based) at ``velocity`` (rad/s)."""
    a, b, c = PANDA_FRICTION[joint]
    v = np.asarray(velocity, dtype=float)
    return np.asarray(a / (1 + np.exp(-b * (v + c))) - a / (1 + np.exp(-b * c)), dtype=float)


def panda_friction_sweep(
    joint: int, speeds: npt.ArrayLike | None = None, *, noise: float = 0.002, seed: int = 0,
) -> ObservationTable:
    """The friction a plateau sweep measures on Panda joint ``joint`` (0-based), one row per speed.

    Default speeds: 25 from 0.001 to 0.5 rad/s, geometric. ``noise`` (N·m) is
    Gaussian on ``tau_f`` (seeded) and is the ``tau_f_std`` column.
    """
    v = np.geomspace(0.001, 0.5, 25) if speeds is None else np.asarray(speeds, dtype=float)
    y = 0.5 * (panda_friction(joint, v) - panda_friction(joint, -v))
    if noise > 0:
        y = y + np.random.default_rng(seed + joint).normal(0.0, noise, v.size)
    return ObservationTable({"speed": v, "tau_f": y, "tau_f_std": np.full(v.size, float(noise)),
                             "cycle": np.arange(v.size, dtype=float)}, source=f"panda_joint_{joint + 1}")
