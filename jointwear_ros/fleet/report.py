"""The fleet page: a static HTML page (PNG plots, no server) of every joint's wear trend.

:func:`write_report` writes ``index.html`` and ``img/*.png`` to a directory:

- robots ranked by their most urgent joint, then every joint ranked by time to
  alarm (ERROR first, then WARN, then the shortest median time to alarm; joints
  with no growth detected last), with wear ± std, rate and the 90 % interval;
- each joint's trend (:func:`jointwear_ros.trend.report.plot_trend`, as
  ``jointwear trend --plot``): its estimates with ±2 std bars, maintenance
  events, the smoothed trend and the forecast with their 90 % bands, the alarm
  level, and the predicted crossing with its 90 % interval;
- when two analysis versions are given, the joints whose level or time to alarm
  changed between them, with the size of the change, and a plot of the wear
  before against after.

Everything shown comes from the store through the trend core
(:func:`~jointwear_ros.history.trends_from_store`) and :func:`~.compare.compare_trends`.
"""

from __future__ import annotations

import datetime as _dt
import html
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..trend.report import plot_trend, rank_key
from .compare import JointChange, compare_versions

__all__ = ["newest_versions", "write_report"]

def newest_versions(store: Any) -> list[str]:
    """The store's analysis versions, oldest first by when their newest estimate was written."""
    return list(store.versions_by_recency())


def _slug(robot: str, joint: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{robot}__{joint}")[:150]


def _fmt(x: Any, spec: str = ".1f") -> str:
    if x is None:
        return "–"
    v = float(x)
    if math.isnan(v):
        return "–"
    if math.isinf(v):
        return "∞"
    return format(v, spec)


def _tta_text(t: Any) -> str:
    tta = t.time_to_alarm
    if tta is None:
        return "no growth detected" if t.estimates >= 1 else "–"
    return f"{_fmt(tta.median, '.0f')} d ({_fmt(tta.lo90, '.0f')}–{_fmt(tta.hi90, '.0f')})"


def _plot_changes(changes: Sequence[JointChange], path: Path, v_from: str, v_to: str) -> None:
    from ..plots import legend_outside, new_figure, save_figure, span_limits

    fig, ax = new_figure(size=(5.2, 4.6))
    a = ax[0][0]
    both = [c for c in changes if c.wear_from is not None and c.wear_to is not None]
    if both:
        xs = [float(c.wear_from or 0.0) for c in both]
        ys = [float(c.wear_to or 0.0) for c in both]
        for changed, col, lab in ((False, "C0", "unchanged"), (True, "C3", "changed")):
            pick = [i for i, c in enumerate(both) if bool(c.changed) == changed]
            if pick:
                a.scatter([xs[i] for i in pick], [ys[i] for i in pick], c=col, s=14, label=lab, zorder=3)
        lo, hi = span_limits(xs, ys, margin=0.05)
        a.plot([lo, hi], [lo, hi], color="0.5", lw=0.8, label="no change", zorder=1)
        a.set_xlim(lo, hi)
        a.set_ylim(lo, hi)
        legend_outside(a, "below", fontsize=7.5, ncol=3)
    a.set_xlabel(f"wear [% of failure state], {v_from}"[:70])
    a.set_ylabel(f"wear [% of failure state], {v_to}"[:70])
    a.set_title("each joint's current wear", fontsize=9)
    save_figure(fig, path)


_CSS = """body{font-family:sans-serif;margin:1.5em;max-width:1100px}
table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}
td.l,th.l{text-align:left}.ERROR{background:#f8c8c8}.WARN{background:#fbe7b0}.OK{background:#dff3df}
.STALE{background:#e8dcd6}
img{max-width:100%}.joint{margin:1em 0;border-top:1px solid #ddd}"""


def write_report(store: Any, out: str | os.PathLike[str], *, version: str | None = None,
                 from_version: str | None = None, to_version: str | None = None, cfg: Any = None,
                 title: str = "jointwear fleet", stale_days: float = 7.0, now: float | None = None,
                 plots: bool = True) -> Path:
    """Write the fleet page of ``store`` to ``out``; return the path of ``index.html``.

    ``version``: the analysis version ranked and plotted (default: the newest written).
    ``from_version``/``to_version``: the changes section (default: the two newest, when there are two).
    Each joint's level is the plant's (:func:`~jointwear_ros.condition.plant_level`: the condition level, STALE
    when its newest estimate is older than ``stale_days`` at ``now`` and it is not ERROR), as ``trend --json``,
    ``jointwear serve`` and ``/metrics`` show it; the forecast is its own column. ``plots=False``: the tables
    and each joint's message without its trend plot (a plot costs about 0.4 s of CPU; the page of a large fleet
    in seconds).
    """
    import time as _time

    from ..condition import plant_level
    from ..contract import level_name
    from ..errors import InputDataError
    from ..history import trends_from_store
    from ..trend import TrendConfig

    versions = newest_versions(store)
    if not versions:
        raise InputDataError(f"{store.display_url}: the history has no estimates; nothing to report")
    for v in (version, from_version, to_version):
        if v is not None and v not in versions:
            raise InputDataError(f"analysis version {v!r} is not in {store.display_url} "
                                 f"(there: {', '.join(versions)})")
    if (from_version is None) != (to_version is None):
        raise InputDataError("give both --from and --to (or neither: the two newest analysis versions)")
    version = version or versions[-1]
    if from_version is None and len(versions) >= 2:
        from_version, to_version = versions[-2], versions[-1]
    cfg = cfg if cfg is not None else TrendConfig()
    alarm = float(cfg.alarm)
    trends = trends_from_store(store, cfg, analysis_version=version)
    history = store.history(version)
    t_now = _time.time() if now is None else float(now)
    shown: dict[tuple[str, str], str] = {}
    for t in trends:
        newest = max((r.time for r in history[(t.robot, t.joint)][0]), default=math.nan)
        shown[(t.robot, t.joint)] = level_name(plant_level(t.level, newest, t_now, stale_days))
    order = {"ERROR": 0, "WARN": 1, "STALE": 2, "OK": 3}
    trends = sorted(trends, key=lambda t: (order[shown[(t.robot, t.joint)]], *rank_key(t)[1:]))
    changes: list[JointChange] = []
    if from_version is not None and to_version is not None:
        changes = compare_versions(store, from_version, to_version, cfg)
    root = Path(out)
    img = root / "img"
    img.mkdir(parents=True, exist_ok=True)
    e = html.escape
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{e(title)}</title>"
             f"<style>{_CSS}</style></head><body>",
             f"<h1>{e(title)}</h1>",
             f"<p>history <code>{e(store.display_url)}</code>, analysis version <code>{e(version)}</code> "
             f"(versions there: {', '.join(f'<code>{e(v)}</code>' for v in versions)}); "
             f"{len(trends)} joints of {len({t.robot for t in trends})} robots; alarm at wear {alarm:g}; "
             f"written {_dt.datetime.now(_dt.UTC):%Y-%m-%d %H:%M} UTC.</p>"]
    # robots ranked by their most urgent joint
    by_robot: dict[str, list[Any]] = {}
    for t in trends:
        by_robot.setdefault(t.robot, []).append(t)
    parts.append("<h2>Robots, most urgent first</h2><table><tr><th class=l>robot</th><th>joints</th>"
                 "<th class=l>worst level</th><th class=l>most urgent joint</th><th class=l>time to alarm "
                 "(median, 90 %)</th></tr>")
    rank = {(t.robot, t.joint): i for i, t in enumerate(trends)}
    for robot, ts in sorted(by_robot.items(), key=lambda kv: rank[(kv[1][0].robot, kv[1][0].joint)]):
        w = ts[0]
        lw = shown[(w.robot, w.joint)]
        parts.append(f"<tr class={lw}><td class=l>{e(robot)}</td><td>{len(ts)}</td>"
                     f"<td class=l>{lw}</td><td class=l><a href='#{_slug(w.robot, w.joint)}'>"
                     f"{e(w.joint)}</a></td><td class=l>{e(_tta_text(w))}</td></tr>")
    parts.append("</table>")
    parts.append("<h2>Joints ranked by condition level, then time to alarm</h2><p>Condition level (the standing "
                 "estimate against warn and alarm) and forecast (alarm expected within the horizon) as every "
                 f"jointwear surface shows them (docs/levels.md); STALE: no estimate for {stale_days:g} days and "
                 "not ERROR.</p><table><tr><th>#</th>"
                 "<th class=l>robot</th><th class=l>joint</th><th class=l>level</th><th class=l>forecast</th>"
                 "<th>estimates</th><th>level wear</th><th>trend wear</th><th>± std</th>"
                 "<th>rate /day</th><th class=l>time to alarm (median, 90 %)</th><th class=l>newest estimate</th></tr>")
    for i, t in enumerate(trends, 1):
        lv = shown[(t.robot, t.joint)]
        fc = "alarm expected" if t.alarm_expected else "–"
        note = {"unconfirmed": "held (unconfirmed)", "step": "step"}.get(t.confirmation, "")
        if t.evidence == "partial":
            note = (note + ", " if note else "") + "partial cycle"
        parts.append(f"<tr class={lv}><td>{i}</td><td class=l>{e(t.robot)}</td>"
                     f"<td class=l><a href='#{_slug(t.robot, t.joint)}'>{e(t.joint)}</a></td>"
                     f"<td class=l data-level='{lv}'>{lv}</td><td class=l data-alarm-expected="
                     f"'{'true' if t.alarm_expected else 'false'}'>{fc}</td><td>{t.estimates}</td>"
                     f"<td>{_fmt(t.level_wear)}</td><td>{_fmt(t.wear)}</td>"
                     f"<td>{_fmt(t.wear_std)}</td><td>{_fmt(t.rate_per_day, '+.3f')}</td>"
                     f"<td class=l>{e(_tta_text(t))}</td><td class=l>{e(note)}</td></tr>")
    parts.append("</table>")
    if changes:
        n_changed = sum(c.changed for c in changes)
        _plot_changes(changes, img / "changes.png", str(from_version), str(to_version))
        parts.append(f"<h2>Changed between <code>{e(str(from_version))}</code> and <code>{e(str(to_version))}</code>"
                     f"</h2><p>{n_changed} of {len(changes)} joints changed (level, time to alarm, or wear).</p>"
                     "<img src='img/changes.png' alt='wear before and after'>"
                     "<table><tr><th class=l>robot</th><th class=l>joint</th><th class=l>level</th><th>wear before"
                     "</th><th>after</th><th>change</th><th>change / std</th><th>days to alarm before</th>"
                     "<th>after</th><th>change</th><th class=l>why</th></tr>")
        for c in changes:
            if not c.changed:
                continue
            parts.append(
                f"<tr class={c.level_to or 'OK'}><td class=l>{e(c.robot)}</td><td class=l>{e(c.joint)}</td>"
                f"<td class=l>{c.level_from or '–'} → {c.level_to or '–'}</td><td>{_fmt(c.wear_from)}</td>"
                f"<td>{_fmt(c.wear_to)}</td><td>{_fmt(c.wear_change, '+.1f')}</td>"
                f"<td>{_fmt(c.wear_change_std, '+.1f')}</td><td>{_fmt(c.days_from, '.0f')}</td>"
                f"<td>{_fmt(c.days_to, '.0f')}</td><td>{_fmt(c.days_change, '+.0f')}</td>"
                f"<td class=l>{e('; '.join(c.reasons))}</td></tr>")
        parts.append("</table>")
    parts.append("<h2>Every joint's trend</h2>")
    for t in trends:
        slug = _slug(t.robot, t.joint)
        recs, events = history[(t.robot, t.joint)]
        picture = ""
        if plots:
            plot_trend(img / f"{slug}.png", t, cfg, [r.time for r in recs], [r.wear for r in recs],
                       [r.wear_std for r in recs], [e.time for e in events])
            picture = f"<img src='img/{slug}.png' alt='trend of {e(t.robot)} {e(t.joint)}'>"
        parts.append(f"<div class=joint id='{slug}'><h3>{e(t.robot)} / {e(t.joint)}: {shown[(t.robot, t.joint)]}</h3>"
                     f"<p>{e(t.message)}</p>{picture}</div>")
    parts.append("</body></html>\n")
    index = root / "index.html"
    tmp = root / "index.html.tmp"
    tmp.write_text("\n".join(parts), encoding="utf-8")
    tmp.replace(index)
    return index
