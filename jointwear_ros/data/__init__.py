"""Synthetic observation tables with hidden effects (pure numpy).

>>> t = synth_observations(n_cycles=3, speeds=(10.0, 47.0), effects=["load_viscous"], seed=0)
>>> len(t), sorted(set(t["cycle"].tolist()))
(6, [0.0, 1.0, 2.0])
>>> "load_viscous" in HIDDEN_EFFECTS, float(t["tau_f_std"][0]) == NOISE_STD
(True, True)
"""

from __future__ import annotations

from .published import PANDA_FRICTION, panda_friction, panda_friction_sweep
from .synth import DEFAULT_SPEEDS, EFFECT_FAMILIES, HIDDEN_EFFECTS, NOISE_STD, HiddenEffect, synth_observations

__all__ = [
    "DEFAULT_SPEEDS",
    "EFFECT_FAMILIES",
    "HIDDEN_EFFECTS",
    "NOISE_STD",
    "PANDA_FRICTION",
    "HiddenEffect",
    "panda_friction",
    "panda_friction_sweep",
    "synth_observations",
]
