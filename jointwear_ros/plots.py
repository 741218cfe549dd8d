"""Matplotlib figures (PNG, Agg backend): friction curves and their components."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import numpy.typing as npt

__all__ = ["new_figure", "plot_curve", "save_figure"]

Array = npt.NDArray[np.float64]


def new_figure(nrows: int = 1, ncols: int = 1, size: tuple[float, float] = (8.0, 5.0)):  # type: ignore[no-untyped-def]
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt.subplots(nrows, ncols, figsize=size, squeeze=False)


def save_figure(fig, path: Path) -> Path:  # type: ignore[no-untyped-def]
    """Write ``fig`` to ``path`` atomically (a temp file, then rename)."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.png")
    fig.tight_layout()
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
    return path


def plot_curve(
    path: Path,
    speed: Array,
    tau_f: Array,
    components: Mapping[str, Array],
    title: str = "",
    points: tuple[Array, Array] | None = None,
) -> Path:
    """Friction curve (thick) with each term's contribution (thin) against speed."""
    fig, axes = new_figure()
    ax = axes[0][0]
    ax.plot(speed, tau_f, color="black", lw=2.2, label="tau_f (total)")
    for name, comp in components.items():
        ax.plot(speed, np.broadcast_to(comp, np.shape(speed)), lw=1.2, label=name)
    if points is not None:
        ax.plot(points[0], points[1], "o", color="black", ms=4, label="evaluated speeds")
    ax.axhline(0.0, color="grey", lw=0.6)
    ax.set_xlabel("speed v, motor side [rad/s]")
    ax.set_ylabel("friction torque [normalized]")
    if title:
        ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    return save_figure(fig, path)
