"""Plain-text tables for reports (the CLI and the pure cores' ``summary_text`` share them).

>>> print(format_table(["speed", "tau_f"], [[10.0, 0.07498], [47.0, float("nan")]]))
   speed    tau_f
--------  -------
10.00000  0.07498
47.00000      nan
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["format_table"]


def format_table(headers: Sequence[str], rows: Sequence[Sequence[Any]], floatfmt: str = ".5f") -> str:
    """A plain aligned text table; floats with ``floatfmt``, non-finite ones as ``nan``/``inf``/``-inf``."""

    def fmt(v: Any) -> str:
        if isinstance(v, (float, np.floating)):
            x = float(v)
            return format(x, floatfmt) if math.isfinite(x) else ("nan" if math.isnan(x) else ("inf" if x > 0 else "-inf"))
        return str(v)

    cells = [[fmt(v) for v in r] for r in rows]
    widths = [max([len(h)] + [len(r[i]) for r in cells]) for i, h in enumerate(headers)]
    lines = ["  ".join(h.rjust(w) for h, w in zip(headers, widths))]
    lines.append("  ".join("-" * w for w in widths))
    lines.extend("  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells)
    return "\n".join(lines)
