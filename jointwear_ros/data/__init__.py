"""Synthetic observation tables with hidden effects (pure numpy)."""

from __future__ import annotations

from .synth import DEFAULT_SPEEDS, EFFECT_FAMILIES, HIDDEN_EFFECTS, NOISE_STD, HiddenEffect, synth_observations

__all__ = ["DEFAULT_SPEEDS", "EFFECT_FAMILIES", "HIDDEN_EFFECTS", "NOISE_STD", "HiddenEffect", "synth_observations"]
