"""Matplotlib figures (PNG, Agg backend): friction curves and their components, the plant's current wear, and
the helpers every figure of the suite shares: axes limited to the data (:func:`span_limits`,
:func:`wear_limits`; a forecast is clipped to them with :func:`clip_band` and :func:`inside`, never the axes
scaled to it), legends outside the data (:func:`legend_outside`), the wear unit (:data:`WEAR_LABEL`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

__all__ = ["WEAR_LABEL", "clip_band", "inside", "legend_outside", "new_figure", "plot_current_wear", "plot_curve",
           "save_figure", "span_limits", "wear_limits"]

Array = npt.NDArray[np.float64]


#: the wear axis: dimensionless, 0-100 % of a failure state (the paper's; 35 is its alarm)
WEAR_LABEL = "wear [% of failure state]"


def span_limits(*groups: Array | Sequence[float] | float, margin: float = 0.06,
                min_span: float = 1.0) -> tuple[float, float]:
    """``(lo, hi)`` covering every finite value of ``groups`` plus ``margin`` of the span each side.

    Non-finite values are ignored; a span below ``min_span`` is widened about its centre (one value, or
    values that all agree, still give a readable axis). With no finite value: ``(0, min_span)``.
    """
    vals = np.concatenate([np.atleast_1d(np.asarray(g, dtype=float)).ravel() for g in groups]) if groups else \
        np.zeros(0)
    vals = vals[np.isfinite(vals)]
    if not vals.size:
        return 0.0, float(min_span)
    lo, hi = float(vals.min()), float(vals.max())
    if hi - lo < min_span:
        mid = 0.5 * (lo + hi)
        lo, hi = mid - 0.5 * min_span, mid + 0.5 * min_span
    pad = margin * (hi - lo)
    return lo - pad, hi + pad


def wear_limits(wear: Array | Sequence[float], alarm: float, *extra: Array | Sequence[float] | float,
                margin: float = 0.06) -> tuple[float, float]:
    """A wear axis: ``[min(data, 0) - margin, max(data, alarm) + margin]`` (a forecast is clipped to it,
    never the other way round)."""
    return span_limits(wear, 0.0, alarm, *extra, margin=margin)


def clip_band(lo: Array, hi: Array, limits: tuple[float, float]) -> tuple[Array, Array]:
    """A band's edges clipped to the axis ``limits`` (a forecast of 1e30 is drawn to the edge, not scaled to)."""
    a, b = limits
    return np.clip(np.asarray(lo, float), a, b), np.clip(np.asarray(hi, float), a, b)


def inside(y: Array | Sequence[float], limits: tuple[float, float]) -> Array:
    """``y`` with the values outside ``limits`` as NaN (a line stops at the axis edge instead of running along it)."""
    y = np.asarray(y, dtype=float).copy()
    y[(y < limits[0]) | (y > limits[1])] = np.nan
    return y


def legend_outside(ax, where: str = "right", fontsize: float = 7.5, ncol: int = 1, in_layout: bool = True,  # type: ignore[no-untyped-def]
                   **kw: object):
    """The axes' legend outside its plotting area (``right`` or ``below``), so it never covers data, in at
    least 7 pt. :func:`save_figure`'s tight layout makes room for it; ``in_layout=False`` leaves the panels'
    spacing alone (a legend wider than its panel, below a grid) and the saved image grows to hold it.
    Returns the legend (None when nothing is labelled)."""
    handles, labels = kw.pop("handles", None), kw.pop("labels", None)
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    if where == "below":  # under the tick labels and the axis label, measured (in inches: layout-proof)
        import matplotlib.transforms as mtransforms

        fig = ax.figure
        renderer = fig.canvas.get_renderer()
        bb = ax.xaxis.get_tightbbox(renderer)
        below = 0.0 if bb is None else max(0.0, ax.get_window_extent(renderer).y0 - bb.y0) / fig.dpi
        shift = mtransforms.ScaledTranslation(0.0, -(below + 0.08), fig.dpi_scale_trans)
        place = {"loc": "upper left", "bbox_to_anchor": (0.0, 0.0), "bbox_transform": ax.transAxes + shift}
    else:
        place = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0)}
    leg = ax.legend(handles, labels, fontsize=max(float(fontsize), 7.0), ncol=ncol, frameon=False,
                    borderaxespad=0.0, **place, **kw)  # type: ignore[arg-type]
    leg.set_in_layout(in_layout)
    return leg


def new_figure(nrows: int = 1, ncols: int = 1, size: tuple[float, float] = (8.0, 5.0)):  # type: ignore[no-untyped-def]
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt.subplots(nrows, ncols, figsize=size, squeeze=False)


def save_figure(fig, path: Path) -> Path:  # type: ignore[no-untyped-def]
    """Write ``fig`` to ``path`` atomically (a temp file, then rename); the image holds every artist (a
    legend outside the axes included)."""
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.png")
    fig.tight_layout()
    extra = [leg for leg in (a.get_legend() for a in fig.axes) if leg is not None] + list(fig.legends)
    extra += [t for a in fig.axes for t in a.texts]  # notes written beside a plot
    fig.savefig(tmp, dpi=110, bbox_inches="tight", pad_inches=0.12, bbox_extra_artists=extra)
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
    legend_outside(ax, "right", fontsize=8)
    return save_figure(fig, path)


def plot_current_wear(path: Path, rows: Sequence[tuple[str, float, float, str, str]], alarm: float,
                      title: str = "") -> Path:
    """Every joint's current wear with its 90 % interval, one row each (the plant page's overview).

    ``rows``: ``(label, wear, wear_std, level name, colour)``, drawn bottom to top (give the most urgent
    last to have it on top). The wear axis covers the data and the alarm (never a fixed 0-108 that cuts a
    wear past it); the level names sit outside the plot, right of it.
    """
    rows = list(rows)
    fig, axes = new_figure(size=(9.0, 1.2 + 0.24 * max(len(rows), 1)))
    ax = axes[0][0]
    ends = []
    for i, (_label, wear, std, level, color) in enumerate(rows):
        if math.isfinite(wear):
            half = 1.645 * std if math.isfinite(std) else 0.0
            ax.errorbar([wear], [i], xerr=[[half]], fmt="o", color=color, ms=5, capsize=3)
            ends += [wear - half, wear + half]
        ax.text(1.01, i, level, transform=ax.get_yaxis_transform(), va="center", fontsize=7, color=color,
                fontweight="bold")
    ax.axvline(alarm, color="tab:red", lw=1.2, ls="--")
    ax.text(alarm, 1.0, f" alarm {alarm:g}", transform=ax.get_xaxis_transform(), color="tab:red", fontsize=7,
            va="bottom", ha="left")
    ax.set_xlim(*(wear_limits(np.clip(np.asarray(ends, float), -50.0, 200.0), alarm, margin=0.03) if ends
                  else (0.0, 100.0)))
    ax.set_yticks(range(len(rows)), [r[0] for r in rows], fontsize=7)
    ax.set_ylim(-0.8, max(len(rows), 1) - 0.2)
    ax.set_xlabel("wear the condition level stands on, with its 90 % interval, " + WEAR_LABEL)
    ax.grid(axis="x", alpha=0.3)
    if title:
        ax.set_title(title, fontsize=9, pad=12)
    return save_figure(fig, path)
