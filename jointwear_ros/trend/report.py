"""Figures and a static HTML page of wear trends (matplotlib, Agg; no server).

:func:`plot_trend` draws one joint: every estimate with its ±2 std error bar
(all segments; maintenance events as vertical lines), the smoothed trend of
the current segment with its 90 % band, the forecast with its 90 % band, the
alarm threshold, and the predicted crossing (median, 90 % interval shaded).
:func:`write_html` writes ``index.html`` ranking joints by time to alarm
(ERROR first, then WARN, then the soonest median; no growth last).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from typing import Any
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from .core import DAY, TrendConfig, TrendResult, rts_smooth

__all__ = ["plot_trend", "rank_key", "write_html"]

Z90 = 1.6448536269514722


def rank_key(r: TrendResult) -> tuple[float, float, str, str]:
    """Sort key: ERROR, WARN, OK; within a level the soonest median time to alarm first."""
    tta = r.time_to_alarm
    med = math.inf if tta is None else tta.median
    return (-float(r.level), med if math.isfinite(med) else 1e12 + (0 if tta is not None else 1), r.robot, r.joint)


def _dt(t: np.ndarray) -> list[datetime]:
    return [datetime.fromtimestamp(float(x), UTC) for x in np.atleast_1d(t)]


def plot_trend(path: Path, r: TrendResult, cfg: TrendConfig, all_times: Sequence[float],
               all_wear: Sequence[float], all_std: Sequence[float], maintenance_times: Sequence[float] = ()) -> Path:
    """One joint's history and trend as a PNG."""
    from ..plots import new_figure, save_figure

    fig, axes = new_figure(size=(9.0, 4.8))
    ax = axes[0][0]
    t = np.asarray(all_times, float)
    ax.errorbar(_dt(t), all_wear, yerr=2 * np.asarray(all_std, float), fmt="o", ms=2.5, lw=0.6, color="0.35",
                ecolor="0.7", label="estimates ± 2 std")
    for i, m in enumerate(maintenance_times):
        ax.axvline(_dt(np.array([m]))[0], color="tab:green", ls=":", lw=1.2, label="maintenance" if i == 0 else None)
    if r.filtered is not None and len(r.times):
        s = r.smoothed if r.smoothed is not None else rts_smooth(r.filtered, cfg)
        lvl, sd = s.mean[:, 0], np.sqrt(np.maximum(s.cov[:, 0, 0], 0))
        x = _dt(r.times)
        if len(x) >= 2:  # a trend of one estimate is that estimate: nothing more to draw (or to list)
            ax.plot(x, lvl, color="tab:blue", lw=1.6, label="trend (smoothed)")
            ax.fill_between(x, lvl - Z90 * sd, lvl + Z90 * sd, color="tab:blue", alpha=0.2, lw=0, label="trend 90 %")
        f = r.filtered
        m, P, q, d = f.mean[-1], f.cov[-1], f.q, f.order
        tta = r.time_to_alarm
        end = 60.0
        if tta is not None and math.isfinite(tta.hi90):
            end = max(end, tta.hi90 * 1.1)
        elif tta is not None and math.isfinite(tta.median):
            end = max(end, tta.median * 1.5)
        end = min(end, cfg.max_horizon_days)
        tau = np.linspace(0.0, end, 120)
        H = np.stack([np.ones_like(tau), tau, tau * tau / 2][:d])
        mu = m @ H
        var = np.einsum("ig,ij,jg->g", H, P, H) + (q * tau ** 3 / 3 if d == 2 else q * tau ** 5 / 20)
        xf = _dt(r.last_time + tau * DAY)
        ax.plot(xf, mu, color="tab:orange", lw=1.4, ls="--", label="forecast")
        # wear does not fall within a segment (maintenance starts a new one) and is never below 0: the band's
        # lower edge stops at the current level's lower bound (a Gaussian band of a few estimates would reach below)
        floor = max(0.0, float(m[0] - Z90 * math.sqrt(max(P[0, 0], 0.0))))
        ax.fill_between(xf, np.maximum(mu - Z90 * np.sqrt(var), floor), mu + Z90 * np.sqrt(var), color="tab:orange",
                        alpha=0.15, lw=0, label="forecast 90 %")
        if tta is not None and math.isfinite(tta.median) and tta.median > 0:
            lo = r.last_time + tta.lo90 * DAY
            hi = r.last_time + (tta.hi90 if math.isfinite(tta.hi90) else end) * DAY
            ax.axvspan(_dt(np.array([lo]))[0], _dt(np.array([hi]))[0], color="tab:red", alpha=0.12,
                       label="alarm time 90 %")
            ax.plot(_dt(np.array([r.last_time + tta.median * DAY])), [cfg.alarm], "v", color="tab:red", ms=9,
                    label="predicted crossing (median)")
    ax.axhline(cfg.alarm, color="tab:red", lw=1.2, label=f"alarm {cfg.alarm:g}")
    ax.set_ylabel("wear (0-100)")
    ax.set_title(f"{r.robot} / {r.joint}: {r.level_name} - {r.message}", fontsize=8.5)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.autofmt_xdate()
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
    colors = {"OK": "#2e7d32", "WARN": "#ef6c00", "ERROR": "#c62828"}
    rows = []
    for i, r in enumerate(sorted(results, key=rank_key), start=1):
        tta = r.time_to_alarm
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
