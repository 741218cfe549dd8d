"""Argument parsing helpers shared by the sub-commands."""

from __future__ import annotations

import json
import math
import sys
from typing import Any

import numpy as np

from ..fmt import format_table
from . import UsageError

__all__ = ["format_table", "parse_float", "parse_float_list", "print_json"]


def parse_float(text: str, what: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise UsageError(f"{what}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise UsageError(f"{what}: {text!r} is not finite")
    return value


def parse_float_list(text: str, what: str) -> list[float]:
    """``"0,10,25"`` -> [0, 10, 25]; ``"0:280:56"`` -> 56 values from 0 to 280 inclusive."""
    text = text.strip()
    if not text:
        raise UsageError(f"{what}: empty list")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise UsageError(f"{what}: range {text!r} must be START:STOP:COUNT")
        lo, hi = parse_float(parts[0], what), parse_float(parts[1], what)
        try:
            n = int(parts[2])
        except ValueError:
            raise UsageError(f"{what}: count {parts[2]!r} in {text!r} is not an integer") from None
        if n < 1:
            raise UsageError(f"{what}: count in {text!r} must be at least 1")
        return [float(x) for x in np.linspace(lo, hi, n)]
    return [parse_float(t, what) for t in text.split(",")]


def _clean(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        f = float(obj)
        return f if math.isfinite(f) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def print_json(obj: Any) -> None:
    """Print ``obj`` as JSON (numpy arrays and scalars converted; NaN/inf -> null)."""
    json.dump(_clean(obj), sys.stdout, indent=2)
    sys.stdout.write("\n")
