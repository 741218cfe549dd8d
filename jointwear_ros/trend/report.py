"""Figures and a static HTML page of wear trends (matplotlib, Agg; no server).

:func:`plot_trend` draws one joint: every estimate with its ±2 std error bar
(all segments; maintenance events as vertical lines; a detected step without
an event dashed), the fit of the current segment by its top-weighted model with
its 90 % band, the forecast of the model average (median and 90 % band), the
alarm threshold, the predicted crossing (median, 90 % interval shaded, and why
it has no upper bound when it has none), and beside it the weights of the
bank's models.
:func:`write_html` writes ``index.html`` ranking joints by time to alarm
(ERROR first, then WARN, then the soonest median; no growth last).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..contract import level_rank
from .alarm import forecast_band, forecast_basis
from .analysis import TrendResult
from .config import DAY, TrendConfig
from .filters import rts_smooth

__all__ = ["plot_trend", "rank_key", "write_html"]

Z90 = 1.6448536269514722
Array = NDArray[np.float64]


def rank_key(r: TrendResult) -> tuple[float, float, str, str]:
    """Sort key: ERROR, WARN, STALE, OK (:func:`~jointwear_ros.contract.level_rank`, as the plant page ranks; a
    byte the contract does not define first); within a level the soonest median time to alarm first."""
    tta = r.time_to_alarm
    med = math.inf if tta is None else tta.median
    return (float(-level_rank(r.level)), med if math.isfinite(med) else 1e12 + (0 if tta is not None else 1),
            r.robot, r.joint)


def _dt(t: np.ndarray) -> list[datetime]:
    return [datetime.fromtimestamp(float(x), UTC) for x in np.atleast_1d(t)]


def _history_fit(r: TrendResult, cfg: TrendConfig) -> tuple[Array, Array, Array, str] | None:
    """The top-weighted member's fit over the segment: times (s), level, 90 % half-width, its name."""
    if not r.components or not len(r.times):
        return None
    w: dict[int, float] = {}
    for c in r.components:
        w[c.member] = w.get(c.member, 0.0) + c.weight
    best = max(w, key=lambda i: w[i])
    m = r.members[best]
    if m.kind == "adaptive":
        f = r.smoothed if r.smoothed is not None else (rts_smooth(r.filtered, cfg) if r.filtered is not None else None)
        if f is None:
            return None
        return r.times, f.mean[:, 0], Z90 * np.sqrt(np.maximum(f.cov[:, 0, 0], 0)), m.name
    mine = [c for c in r.components if c.member == best]
    c = max(mine, key=lambda c: c.weight)
    first = c.step_at if c.step_at >= 0 else 0
    x = r.times[first:]
    H, _ = forecast_basis(m, (x - r.last_time) / DAY, cfg)
    mu = c.mean @ H
    sd = np.sqrt(np.maximum(np.einsum("ig,ij,jg->g", H, c.cov, H), 0))
    return x, mu, Z90 * sd, m.name + (" after the step" if c.step_at >= 0 else "")


def _window(r: TrendResult, cfg: TrendConfig, t: Array, maintenance_times: Sequence[float],
            forecast: bool) -> tuple[float, float, float]:
    """The x window (s) and the forecast horizon (days) a reader needs: the current segment and its forecast
    fill the plot, older segments at most as wide again to the left.

    The forecast reaches the 90 % interval's end of the time to alarm when the data can carry it: at most
    three times the current segment's span (at least ``cfg.horizon_days`` once the segment spans a few days),
    so estimates minutes apart are not squashed against the edge by a forecast of months.
    """
    cur = np.asarray(r.times, float)
    maint = [float(m) for m in maintenance_times if math.isfinite(float(m))]
    horizon = 0.0
    if cur.size:
        focus_lo, last = float(cur[0]), float(r.last_time)
        if forecast and r.time_to_alarm is not None:
            tta = r.time_to_alarm
            want = (tta.hi90 * 1.1 if math.isfinite(tta.hi90) else tta.median * 1.2 if math.isfinite(tta.median)
                    else cfg.horizon_days)
            span = (last - focus_lo) / DAY
            cap = max(3.0 * span, min(float(cfg.horizon_days), 10.0 * span))
            horizon = float(min(max(want, 0.0), cap, cfg.max_horizon_days))
        focus_hi = last + horizon * DAY
    else:  # no estimate since the last maintenance: the history up to that event
        focus_lo = float(t.min()) if t.size else (max(maint) if maint else 0.0)
        focus_hi = max([focus_lo, *maint, *([float(t.max())] if t.size else [])])
    width = focus_hi - focus_lo
    lo = max(float(t.min()) if t.size else focus_lo, focus_lo - width)
    for m in maint:  # the event that opened the current segment stays in view
        if focus_lo - width <= m <= focus_lo:
            lo = min(lo, m)
    pad = 0.03 * (focus_hi - lo) if focus_hi > lo else 1800.0  # one estimate: an hour around it
    return lo - pad, focus_hi + pad, horizon


def plot_trend(path: Path, r: TrendResult, cfg: TrendConfig, all_times: Sequence[float],
               all_wear: Sequence[float], all_std: Sequence[float], maintenance_times: Sequence[float] = (),
               sources: Sequence[str] | None = None) -> Path:
    """One joint's history and trend as a PNG: left the estimates, the fit, the forecast and the alarm-time
    interval; right the weights of the bank's models (what the interval is made of).

    What is drawn agrees with the title: a fit only once the segment has ``cfg.min_estimates`` estimates, a
    forecast only when there is a time to alarm, the models' weights only when there is a trend. The axes
    are limited to the data and the useful part of the forecast (:func:`_window`; wear from
    :func:`~jointwear_ros.plots.wear_limits`, the forecast clipped to it), the legend sits outside the plot.
    ``sources`` (each estimate's ``test_cycle`` or ``production``; None: all test cycles) draws the production
    estimates with their own marker and legend entry once there are any.
    """
    import matplotlib.dates as mdates

    from ..plots import WEAR_LABEL, clip_band, inside, legend_outside, new_figure, save_figure, wear_limits

    tta = r.time_to_alarm
    has_trend = r.estimates >= cfg.min_estimates and len(r.times) >= 2
    forecast = has_trend and tta is not None and bool(r.components)
    weights = r.model_weights if has_trend else {}
    if weights:
        fig, axes = new_figure(1, 2, size=(13.0, 5.0))
        ax, axw = axes[0]
        ax.get_gridspec().set_width_ratios([3.3, 1.0])
    else:
        fig, axes = new_figure(1, 1, size=(10.5, 5.0))
        ax, axw = axes[0][0], None
    t = np.asarray(all_times, float)
    wear = np.asarray(all_wear, float)
    std = np.asarray(all_std, float)
    x0, x1, end = _window(r, cfg, t, maintenance_times, forecast)
    shown = (t >= x0) & (t <= x1)
    ylim = wear_limits(np.concatenate([wear[shown], np.clip(wear[shown] - 2 * std[shown], -5.0, None),
                                       np.clip(wear[shown] + 2 * std[shown], None, 105.0)]), cfg.alarm)
    hidden = int(np.sum(t < x0))
    older = f" ({hidden} older ones left of the plot)" if hidden else ""
    prod = (np.asarray([s == "production" for s in sources], dtype=bool) if sources is not None
            else np.zeros(t.size, dtype=bool))
    if prod.any():  # two sources: each its marker and legend entry
        tc = ~prod
        if tc.any():
            ax.errorbar(_dt(t[tc]), wear[tc], yerr=2 * std[tc], fmt="o", ms=2.5, lw=0.6, color="0.35", ecolor="0.7",
                        label="test-cycle estimates ± 2 std" + older)
            older = ""
        ax.errorbar(_dt(t[prod]), wear[prod], yerr=2 * std[prod], fmt="^", ms=3.0, lw=0.6, color="tab:brown",
                    ecolor="burlywood", mfc="none", label="production estimates ± 2 std" + older)
    else:
        ax.errorbar(_dt(t), wear, yerr=2 * std, fmt="o", ms=2.5, lw=0.6, color="0.35", ecolor="0.7",
                    label="estimates ± 2 std" + older)
    for i, m in enumerate(maintenance_times):
        ax.axvline(_dt(np.array([m]))[0], color="tab:green", ls=":", lw=1.2, label="maintenance" if i == 0 else None)
    if r.step_probability >= 0.5 and math.isfinite(r.step_time):
        ax.axvline(_dt(np.array([r.step_time]))[0], color="tab:purple", ls="--", lw=1.0,
                   label=f"step without a maintenance event (P = {r.step_probability:.2f})")
    fit = _history_fit(r, cfg) if has_trend else None
    if fit is not None:
        x_s, lvl, half, name = fit
        x = _dt(x_s)
        ax.plot(x, inside(lvl, ylim), color="tab:blue", lw=1.6, label=f"fit: {name}")
        band_lo, band_hi = clip_band(lvl - half, lvl + half, ylim)
        ax.fill_between(x, band_lo, band_hi, color="tab:blue", alpha=0.2, lw=0, label="fit 90 %")
    if forecast and tta is not None and end > 0:
        tau = np.linspace(0.0, end, 90)
        band = forecast_band(r.components, r.members, cfg, tau)
        xf = _dt(r.last_time + tau * DAY)
        # wear does not fall within a segment (maintenance starts a new one) and is never below 0: the band's
        # lower edge and the median stop at the current wear's lower bound (a band of a few estimates, or the
        # median of a mixture far out, would reach below)
        floor = max(0.0, float(r.wear - Z90 * r.wear_std)) if math.isfinite(r.wear) and math.isfinite(r.wear_std) else 0.0
        ax.plot(xf, inside(np.maximum(band[:, 1], floor), ylim), color="tab:orange", lw=1.4, ls="--",
                label="forecast (all models, median)")
        f_lo, f_hi = clip_band(np.maximum(band[:, 0], floor), band[:, 2], ylim)
        ax.fill_between(xf, f_lo, f_hi, color="tab:orange", alpha=0.15, lw=0, label="forecast 90 %")
        if math.isfinite(tta.median) and tta.median > 0:
            f_end = r.last_time + end * DAY  # the interval shaded as far as the forecast is drawn
            lo = min(r.last_time + tta.lo90 * DAY, f_end)
            hi = min(r.last_time + (tta.hi90 if math.isfinite(tta.hi90) else math.inf) * DAY, f_end)
            lab = "alarm time 90 %" + ("" if math.isfinite(tta.hi90) else " (no upper bound)")
            if lo < f_end:
                ax.axvspan(_dt(np.array([lo]))[0], _dt(np.array([hi]))[0], color="tab:red", alpha=0.12, label=lab)
            cross = r.last_time + tta.median * DAY
            if cross <= f_end:
                ax.plot(_dt(np.array([cross])), [cfg.alarm], "v", color="tab:red", ms=9,
                        label="predicted crossing (median)")
            else:
                ax.annotate(f"crossing in {_fmt_days(tta.median)} d, beyond the plot \u2192", (0.99, cfg.alarm),
                            xycoords=("axes fraction", "data"), xytext=(0, 4), textcoords="offset points",
                            ha="right", va="bottom", fontsize=7.5, color="tab:red")
    ax.axhline(cfg.alarm, color="tab:red", lw=1.2, label=f"alarm {cfg.alarm:g}")
    ax.set_xlim(_dt(np.array([x0]))[0], _dt(np.array([x1]))[0])
    ax.set_ylim(*ylim)
    ax.set_ylabel(WEAR_LABEL)
    locator = mdates.AutoDateLocator()
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(mdates.ConciseDateFormatter(locator))
    ax.set_xlabel("date, time (UTC)")
    title = f"{r.robot} / {r.joint}: {r.level_name}"
    if forecast and tta is not None and tta.median > 0:
        title += (f" - alarm in {_fmt_days(tta.median)} d (90 %: {_fmt_days(tta.lo90)} to "
                  f"{_fmt_days(tta.hi90)} d)")
    else:  # the forecast's own reason (no growth, too few estimates, at the alarm), after the condition's
        fc = r.message.split("forecast: ", 1)[1] if "forecast: " in r.message else r.message
        title += " - " + fc.split(";")[0]
    ax.set_title(title, fontsize=9)
    if forecast and tta is not None and tta.unbounded_reason:
        import textwrap

        ax.text(1.01, 0.0, textwrap.fill("no upper bound: " + tta.unbounded_reason, 42), transform=ax.transAxes,
                fontsize=7, color="tab:red", va="bottom", ha="left")  # outside, beside the legend
    ax.grid(alpha=0.3)
    legend_outside(ax, "right")
    if axw is not None:
        names = list(weights)[::-1]
        vals = [weights[k] for k in names]
        colors = ["tab:blue" if k == "line" else "tab:orange" if k.startswith("accelerated") else "tab:gray"
                  for k in names]
        axw.barh(names, vals, color=colors)
        for i, v in enumerate(vals):
            inside_bar = v > 0.75
            axw.text(v - 0.02 if inside_bar else v + 0.02, i, f"{100 * v:.0f} %", va="center", fontsize=7,
                     ha="right" if inside_bar else "left", color="white" if inside_bar else "black")
        axw.set_xlim(0, 1.0)
        axw.set_xlabel("weight (evidence × prior) [fraction]")
        axw.set_title("models of the trend", fontsize=9)
        axw.tick_params(axis="y", labelsize=7)
        axw.grid(alpha=0.3, axis="x")
    return save_figure(fig, Path(path))


def time_to_alarm_text(r: Any, sep: str = " to ") -> str:
    """A joint's days to alarm in words: the median and 90 % interval, or why there is none
    (past the alarm already, no growth detected, no estimate since the last maintenance)."""
    tta = r.time_to_alarm
    if not math.isfinite(r.wear):
        return "no estimate since the last maintenance"
    if tta is None:
        return "no growth detected"
    if math.isfinite(tta.hi90) and tta.hi90 <= 0.0:
        return "past the alarm already"
    return f"{_fmt_days(tta.median)} ({_fmt_days(tta.lo90)}{sep}{_fmt_days(tta.hi90)})"


def _fmt_days(x: float) -> str:
    return "unbounded" if not math.isfinite(x) else f"{x:.0f}"


def write_html(out_dir: Path, results: Sequence[TrendResult], images: dict[tuple[str, str], str],
               title: str = "Wear trends: joints ranked by time to alarm") -> Path:
    """``out_dir/index.html``: a table of the joints ranked by :func:`rank_key`, each with its figure."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    colors = {"OK": "#2e7d32", "WARN": "#ef6c00", "ERROR": "#c62828", "STALE": "#6d4c41"}
    rows = []
    for i, r in enumerate(sorted(results, key=rank_key), start=1):
        cell = time_to_alarm_text(r)
        img = images.get((r.robot, r.joint))
        link = f'<a href="{html.escape(img)}">figure</a>' if img else ""
        rows.append(
            f"<tr><td>{i}</td><td>{html.escape(r.robot)}</td><td>{html.escape(r.joint)}</td>"
            f'<td style="color:{colors[r.level_name]};font-weight:bold">{r.level_name}</td>'
            f"<td>{r.wear:.1f} ± {r.wear_std:.1f}</td><td>{r.rate_per_day:+.3f}</td><td>{cell}</td>"
            f"<td>{r.estimates}</td><td>{html.escape(r.message)}</td><td>{link}</td></tr>")
    figs = "\n".join(f'<h3 id="{html.escape(a)}-{html.escape(b)}">{html.escape(a)} / {html.escape(b)}</h3>'
                     f'<img src="{html.escape(p)}" alt="trend of {html.escape(a)} {html.escape(b)}" width="900">'
                     for (a, b), p in ((k, images[k]) for k in ((r.robot, r.joint)
                                                                for r in sorted(results, key=rank_key))
                                       if k in images))  # in the table's ranked order
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:3px 8px;font-size:13px}}th{{background:#eee}}</style></head>
<body><h1>{html.escape(title)}</h1>
<p>{len(results)} joint(s). Time to alarm in days from each joint's last estimate: median (90 % interval).
WARN: growth detected and the 90 % interval's lower bound within the horizon; ERROR: wear at the alarm.</p>
<table><tr><th>#</th><th>robot</th><th>joint</th><th>level</th><th>wear</th><th>rate /day</th>
<th>time to alarm, days</th><th>estimates</th><th>message</th><th></th></tr>
{chr(10).join(rows)}
</table>
{figs}
</body></html>
"""
    path = out / "index.html"
    tmp = path.with_name("index.html.part")
    tmp.write_text(page, encoding="utf-8")
    tmp.replace(path)
    return path
