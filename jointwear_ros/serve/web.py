"""The web adapter of ``jointwear serve``: Starlette routes over the watcher's snapshot.

Why these parts: **Starlette** (ASGI, served by **uvicorn**) is a small, typed routing toolkit with
no ORM or template system forced on us, runs our blocking work (plots, the store) in its thread
pool, and uvicorn bounds connections (``limit_concurrency``) and idle keep-alives; **Jinja2**
renders the pages with HTML autoescaping on (robot and joint names come from the store);
**prometheus_client** is the official exposition-format library; the plots are the trend's own
**matplotlib** figure (:func:`~jointwear_ros.trend.report.plot_trend`), the one ``trend --plot``
writes, so the page and the files show the same picture.

Routes (GET only): ``/`` the plant page, ``/robot/{robot}``, ``/joint/{robot}/{joint}``,
``/plot/plant.png``, ``/plot/{robot}/{joint}.png``, ``/api/joints``, ``/api/state``,
``/metrics``. No request reads the store (the watcher does, in its thread); one request renders
at most one figure (of at most ``max_plot_estimates`` estimates, cached per snapshot).
"""

from __future__ import annotations

import contextlib
import html
import math
import tempfile
import threading
from collections import OrderedDict
from collections.abc import AsyncIterator, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from jinja2 import DictLoader, Environment, select_autoescape
from prometheus_client import CollectorRegistry, Counter, ProcessCollector, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.exposition import CONTENT_TYPE_LATEST
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Route

from .. import __version__
from ..contract import DiagnosticLevel
from .core import JointView, level_counts, rank_views
from .watch import Snapshot, StoreWatcher

__all__ = ["create_app", "metrics_text"]

COLORS = {"OK": "#2e7d32", "WARN": "#ef6c00", "ERROR": "#c62828", "STALE": "#6d4c41"}


# ---------------------------------------------------------------------------- metrics


def _level_point(v: JointView) -> tuple[float, float]:
    """The estimate a joint's condition level stands on (the trend's wear when there is none)."""
    if math.isfinite(v.level_wear):
        return v.level_wear, v.level_wear_std
    return v.wear, v.wear_std


class _PlantCollector:
    """Per-joint gauges from the current snapshot, and the store's health. While the store cannot be read the
    per-joint series keep the last known values (``jointwear_store_up`` 0 marks them): an alert on a joint's
    level must not resolve because the store went away."""

    def __init__(self, watcher: StoreWatcher) -> None:
        self.watcher = watcher

    def collect(self) -> Iterator[Metric]:
        snap = self.watcher.snapshot
        lab = ["robot", "joint"]
        fams = {
            "level": GaugeMetricFamily("jointwear_joint_level", "Joint condition level: 0 OK, 1 WARN, 2 ERROR, "
                                       "3 STALE (diagnostic_msgs/DiagnosticStatus; docs/levels.md)", labels=lab),
            "expected": GaugeMetricFamily("jointwear_joint_alarm_expected", "Forecast: 1 when the alarm is expected "
                                          "within horizon_days (growth detected, 90 % lower bound of the time to "
                                          "alarm within it), else 0; never part of the level", labels=lab),
            "level_wear": GaugeMetricFamily("jointwear_joint_level_wear", "The estimate the condition level stands "
                                            "on (the newest confirmed one), 0-100", labels=lab),
            "wear": GaugeMetricFamily("jointwear_joint_wear", "Current wear (trend level, 0-100)", labels=lab),
            "wear_std": GaugeMetricFamily("jointwear_joint_wear_std", "Standard deviation of the current wear",
                                          labels=lab),
            "tta": GaugeMetricFamily("jointwear_joint_days_to_alarm", "Days from the last estimate until the trend "
                                     "reaches the alarm, median (+Inf: beyond the prediction horizon; absent: no "
                                     "growth detected or too few estimates)", labels=lab),
            "lo": GaugeMetricFamily("jointwear_joint_days_to_alarm_low", "Time to alarm, 90 % interval lower "
                                    "bound (5 % quantile), days", labels=lab),
            "hi": GaugeMetricFamily("jointwear_joint_days_to_alarm_high", "Time to alarm, 90 % interval upper "
                                    "bound (95 % quantile), days (+Inf: unbounded)", labels=lab),
            "age": GaugeMetricFamily("jointwear_joint_estimate_age_seconds", "Age of the joint's newest estimate",
                                     labels=lab),
            "last": GaugeMetricFamily("jointwear_joint_last_estimate_timestamp_seconds",
                                      "Time stamp of the joint's newest estimate", labels=lab),
            "n": GaugeMetricFamily("jointwear_joint_estimates", "Estimates in the joint's current segment",
                                   labels=lab),
            "src_n": GaugeMetricFamily("jointwear_joint_source_estimates", "Estimates of the joint in the history "
                                       "per source: test_cycle (the dedicated cycle) or production (the robot's own "
                                       "program)", labels=[*lab, "source"]),
            "src_last": GaugeMetricFamily("jointwear_joint_source_last_estimate_timestamp_seconds",
                                          "Time stamp of the joint's newest estimate per source", labels=[*lab, "source"]),
            "src_wear": GaugeMetricFamily("jointwear_joint_source_wear", "The joint's newest estimate per source, "
                                          "0-100 (not the trend level: jointwear_joint_wear)", labels=[*lab, "source"]),
            "src_std": GaugeMetricFamily("jointwear_joint_source_wear_std", "Standard deviation of the newest "
                                         "estimate per source", labels=[*lab, "source"]),
            "refused": GaugeMetricFamily("jointwear_joint_estimates_refused", "Estimates of the joint refused: by the "
                                         "history's screening (impossible values, bad times), or the whole history "
                                         "when the trend cannot use it", labels=lab),
        }
        now = self.watcher.clock()
        if snap.store_ok or snap.views:  # the last known rows stay while the store is down (store_up 0)
            for v in snap.views:
                k = [v.robot, v.joint]
                fams["level"].add_metric(k, float(v.level))
                fams["expected"].add_metric(k, 1.0 if v.alarm_expected else 0.0)
                if math.isfinite(v.level_wear):
                    fams["level_wear"].add_metric(k, v.level_wear)
                fams["refused"].add_metric(k, float(v.rows_refused + (v.estimates_total if v.refused else 0)))
                if math.isfinite(v.time):
                    fams["age"].add_metric(k, max(0.0, now - v.time))
                    fams["last"].add_metric(k, v.time)
                for name, s in v.sources:
                    ks = [*k, name]
                    fams["src_n"].add_metric(ks, float(s.estimates))
                    for skey, sx in (("src_last", s.newest_time), ("src_wear", s.wear), ("src_std", s.wear_std)):
                        if math.isfinite(sx):
                            fams[skey].add_metric(ks, sx)
                if v.refused:
                    continue
                fams["n"].add_metric(k, float(v.estimates))
                if math.isfinite(v.wear):
                    fams["wear"].add_metric(k, v.wear)
                    fams["wear_std"].add_metric(k, v.wear_std)
                for key, x in (("tta", v.days_to_alarm), ("lo", v.days_to_alarm_low), ("hi", v.days_to_alarm_high)):
                    if x is not None and not math.isnan(x):
                        fams[key].add_metric(k, x)
            per_level = GaugeMetricFamily("jointwear_joints", "Joints per level", labels=["level"])
            for name, n in level_counts(snap.views).items():
                per_level.add_metric([name], float(n))
            yield per_level
        yield from fams.values()
        yield GaugeMetricFamily("jointwear_store_up", "1 when the last poll read the history store, else 0",
                                value=1.0 if snap.store_ok else 0.0)
        yield GaugeMetricFamily("jointwear_store_last_success_timestamp_seconds",
                                "When the store was last read successfully (0: never)",
                                value=snap.loaded_at if math.isfinite(snap.loaded_at) else 0.0)
        yield CounterMetricFamily("jointwear_store_poll_failures", "Polls of the store that failed",
                                  value=float(snap.failures))
        yield CounterMetricFamily("jointwear_store_loads", "Times the history was re-read (it changed)",
                                  value=float(snap.loads))
        yield GaugeMetricFamily("jointwear_store_load_duration_seconds", "Duration of the last history read and "
                                "trend", value=snap.last_load_s if math.isfinite(snap.last_load_s) else 0.0)
        yield GaugeMetricFamily("jointwear_store_estimates", "Estimates of the served analysis version in the store (last read)",
                                value=float(snap.estimates))
        info = GaugeMetricFamily("jointwear_serve_info", "The service: software version and settings",
                                 labels=["version", "alarm", "horizon_days", "stale_days"])
        info.add_metric([__version__, f"{self.watcher.cfg.alarm:g}", f"{self.watcher.cfg.horizon_days:g}",
                         f"{self.watcher.stale_days:g}"], 1.0)
        yield info


def metrics_text(registry: CollectorRegistry) -> bytes:
    return generate_latest(registry)


# ---------------------------------------------------------------------------- pages

_BASE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{{ title }}</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
body{font-family:sans-serif;margin:1.2em;color:#222}
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #ccc;padding:3px 8px;font-size:13px}
th{background:#eee;text-align:left}td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
.lv{font-weight:bold;color:#fff;padding:1px 6px;border-radius:3px}
.fc{font-weight:bold;color:#ef6c00}
{% for k, c in colors.items() %}.lv-{{ k }}{background:{{ c }}}{% endfor %}
.banner{padding:.5em .8em;margin:.5em 0;border-radius:4px}.bad{background:#ffebee;border:1px solid #c62828}
.good{background:#f1f8e9;border:1px solid #9ccc65}.muted{color:#777}nav a{margin-right:1em}
</style></head>
<body><nav><a href="/">plant</a><a href="/api/joints">/api/joints</a><a href="/metrics">/metrics</a>
<span id="conn" class="muted"></span></nav>
<main data-version="{{ snap.version }}">
<h1>{{ title }}</h1>
{% if snap.store_ok %}<div class="banner good" id="store">store read {{ ts(snap.loaded_at) }}; {{ snap.estimates }}
estimates; refreshed every {{ refresh }} s</div>
{% else %}<div class="banner bad" id="store"><b>History store not readable</b> since {{ ts(snap.error_since) }}:
{{ snap.error }}.{% if snap.views %} The rows below are as read {{ ts(snap.loaded_at) }}, not current.{% endif %}</div>
{% endif %}
{% block body %}{% endblock %}
<p class="muted">Levels: OK; WARN when growth is detected and the 90 % lower bound of the time to alarm is within
{{ cfg.horizon_days|round(1) }} days; ERROR at wear &ge; {{ cfg.alarm }}; STALE when the newest estimate is older
than {{ stale_days }} days (and not ERROR). Times to alarm in days from the joint's last estimate: median (90 %).
jointwear {{ version }}.</p>
</main>
<script>
let version = {{ snap.version }};
async function tick() {
  const conn = document.getElementById("conn");
  try {
    const r = await fetch("/api/state", {cache: "no-store"});
    const s = await r.json();
    conn.textContent = "";
    if (s.version !== version) {
      const page = await fetch(location.href, {cache: "no-store"});
      const doc = new DOMParser().parseFromString(await page.text(), "text/html");
      const main = doc.querySelector("main");
      document.querySelector("main").replaceWith(main);
      version = Number(main.dataset.version);
      document.title = doc.title;
    }
  } catch (e) { conn.textContent = "service unreachable (" + e + "); retrying"; }
}
setInterval(tick, {{ poll_ms }});
</script>
</body></html>
"""

_TABLE = """{% macro table(views) %}
<table id="joints"><tr><th>robot</th><th>joint</th><th>level</th><th>forecast</th><th>wear</th><th>rate /day</th>
<th>days to alarm (90 %)</th><th>last estimate</th><th>estimates</th><th>message</th></tr>
{% for v in views %}<tr data-robot="{{ v.robot }}" data-joint="{{ v.joint }}" data-level="{{ v.level_name }}" data-alarm-expected="{{ 'true' if v.alarm_expected else 'false' }}">
<td><a href="/robot/{{ v.robot|urlencode }}">{{ v.robot }}</a></td>
<td><a href="/joint/{{ v.robot|urlencode }}/{{ v.joint|urlencode }}">{{ v.joint }}</a></td>
<td><span class="lv lv-{{ v.level_name }}">{{ v.level_name }}</span>{% if v.confirmation == "unconfirmed" %} <span class="muted">(newest held)</span>{% endif %}{% if v.evidence == "partial" %} <span class="muted">(partial cycle)</span>{% endif %}</td>
<td>{% if v.alarm_expected %}<span class="fc">alarm expected</span>{% else %}<span class="muted">–</span>{% endif %}</td>
<td class="num wear">{{ wear(v) }}</td><td class="num">{{ num(v.rate_per_day, "%+.3f") }}</td>
<td class="num tta">{{ tta(v) }}</td><td class="last" data-newest-source="{{ v.newest_source }}">{{ ts(v.time) }} <span class="muted">({{ num(v.age_days, "%.1f") }} d ago{% if v.newest_source %}, from {{ "production" if v.newest_source == "production" else "a test cycle" }}{% endif %})</span></td>
<td class="num">{{ v.estimates }}{% if v.sources|length > 1 %} <span class="muted">({% for name, s in v.sources %}{{ s.estimates }} {{ "production" if name == "production" else "test cycle" }}{% if not loop.last %}, {% endif %}{% endfor %})</span>{% endif %}</td><td>{{ v.message }}</td></tr>
{% endfor %}</table>{% endmacro %}"""

_PLANT = """{% extends "base" %}{% from "table" import table %}{% block body %}
<p id="summary">{{ views|length }} joint(s) of {{ robots|length }} robot(s):
{% for name, n in counts.items() %}<span class="lv lv-{{ name }}">{{ n }} {{ name }}</span> {% endfor %}</p>
<p>Robots: {% for r in robots %}<a href="/robot/{{ r|urlencode }}">{{ r }}</a> {% endfor %}</p>
{{ table(views) }}
{% if views %}<h2>Wear of every joint</h2>
<img id="plant-plot" src="/plot/plant.png?v={{ snap.version }}" alt="wear of every joint with its 90 % interval"
 onload="this.dataset.drawn = this.naturalWidth + 'x' + this.naturalHeight" onerror="this.dataset.drawn = 'error'">
{% endif %}{% endblock %}"""

_ROBOT = """{% extends "base" %}{% from "table" import table %}{% block body %}
{{ table(views) }}
{% for v in views %}{% if not v.refused %}<h3>{{ v.joint }}</h3>
<img class="joint-plot" src="/plot/{{ v.robot|urlencode }}/{{ v.joint|urlencode }}.png?v={{ snap.version }}"
 alt="wear history and trend of {{ v.robot }} {{ v.joint }}" width="900"
 onload="this.dataset.drawn = this.naturalWidth + 'x' + this.naturalHeight" onerror="this.dataset.drawn = 'error'">
{% endif %}{% endfor %}{% endblock %}"""

_JOINT = """{% extends "base" %}{% from "table" import table %}{% block body %}
{{ table([view]) }}
{% if not view.refused %}<img class="joint-plot" src="/plot/{{ view.robot|urlencode }}/{{ view.joint|urlencode }}.png?v={{ snap.version }}"
 alt="wear history and trend of {{ view.robot }} {{ view.joint }}"
 onload="this.dataset.drawn = this.naturalWidth + 'x' + this.naturalHeight" onerror="this.dataset.drawn = 'error'">{% endif %}
<h2>Newest estimates</h2>
<table id="estimates"><tr><th>time (UTC)</th><th>estimated from</th><th>cycle / shift</th><th>wear</th><th>std</th><th>method</th><th>source</th></tr>
{% for e in recent %}<tr><td>{{ ts(e.time) }}</td><td data-cycle-source="{{ e.cycle_source }}">{{ "production" if e.cycle_source == "production" else "test cycle" }}</td><td class="num">{{ e.cycle_id }}</td>
<td class="num">{{ "%.2f"|format(e.wear) }}</td><td class="num">{{ "%.2f"|format(e.wear_std) }}</td>
<td>{{ e.method }}</td><td>{{ e.source }}</td></tr>{% endfor %}</table>
{% if maintenance %}<p>Maintenance: {% for t in maintenance %}{{ ts(t) }} {% endfor %}</p>{% endif %}
{% endblock %}"""


def _ts(t: float) -> str:
    if t is None or not math.isfinite(t):
        return "-"
    return datetime.fromtimestamp(t, UTC).strftime("%Y-%m-%d %H:%M UTC")


def _num(x: float | None, fmt: str = "%.1f") -> str:
    if x is None or math.isnan(x):
        return "-"
    return "unbounded" if math.isinf(x) else fmt % x


def _wear(v: JointView) -> str:
    return "-" if not math.isfinite(v.wear) else f"{v.wear:.1f} ± {v.wear_std:.1f}"


def _tta(v: JointView) -> str:
    if v.refused:
        return "-"
    if v.days_to_alarm is None:
        return "no growth detected" if v.estimates else "-"
    if v.trend_level == DiagnosticLevel.ERROR and v.days_to_alarm == 0:
        return "at the alarm now"
    return f"{_num(v.days_to_alarm, '%.0f')} ({_num(v.days_to_alarm_low, '%.0f')} to {_num(v.days_to_alarm_high, '%.0f')})"


class _Plots:
    """Figures rendered on demand, one at a time (matplotlib is not thread-safe), cached per snapshot."""

    def __init__(self, watcher: StoreWatcher, max_estimates: int, cache_size: int = 64) -> None:
        self.watcher, self.max_estimates, self.cache_size = watcher, max_estimates, cache_size
        self._cache: OrderedDict[tuple[Any, ...], bytes] = OrderedDict()
        self._lock = threading.Lock()
        self._dir = tempfile.TemporaryDirectory(prefix="jointwear-serve-")

    def get(self, key: tuple[Any, ...], draw: Any) -> bytes:
        with self._lock:
            if key in self._cache:
                self._cache.move_to_end(key)
                return self._cache[key]
            path = Path(self._dir.name) / "fig.png"
            draw(path)
            data = path.read_bytes()
            self._cache[key] = data
            while len(self._cache) > self.cache_size:
                self._cache.popitem(last=False)
            return data

    def plant(self, snap: Snapshot) -> bytes:
        def draw(path: Path) -> None:
            from ..plots import plot_current_wear

            views = list(reversed(rank_views(snap.views)[:200]))
            shown = f"{len(views)} joints" if len(views) == len(snap.views) else \
                f"the first {len(views)} of {len(snap.views)} joints"
            # each joint at the estimate its condition level stands on, so the colour and the point agree
            plot_current_wear(path, [(f"{v.robot} / {v.joint}", *_level_point(v), v.level_name, COLORS[v.level_name])
                                     for v in views], self.watcher.cfg.alarm,
                              title=f"{shown}, ranked: ERROR, WARN, STALE, OK (read {_ts(snap.loaded_at)})")

        return self.get(("plant", snap.version), draw)

    def joint(self, snap: Snapshot, robot: str, joint: str) -> bytes | None:
        d = snap.joints.get((robot, joint))
        if d is None or d.result is None:
            return None
        from ..trend.report import plot_trend

        recs = d.records[-self.max_estimates:]
        result = d.result

        def draw(path: Path) -> None:
            plot_trend(path, result, self.watcher.cfg, [r.time for r in recs], [r.wear for r in recs],
                       [r.wear_std for r in recs], d.maintenance_times, sources=[r.cycle_source for r in recs])

        return self.get(("joint", snap.loads, robot, joint), draw)

    def close(self) -> None:
        self._dir.cleanup()


def create_app(watcher: StoreWatcher, *, poll_ms: int = 2000, max_plot_estimates: int = 5000) -> Starlette:
    """The ASGI application over ``watcher`` (started and stopped by the caller)."""
    env = Environment(loader=DictLoader({"base": _BASE, "table": _TABLE, "plant": _PLANT, "robot": _ROBOT,
                                         "joint": _JOINT}), autoescape=select_autoescape(default=True))
    env.globals.update(ts=_ts, num=_num, wear=_wear, tta=_tta, colors=COLORS, version=__version__)
    plots = _Plots(watcher, max_plot_estimates)
    registry = CollectorRegistry(auto_describe=True)
    registry.register(_PlantCollector(watcher))  # type: ignore[arg-type]
    ProcessCollector(registry=registry)
    requests = Counter("jointwear_http_requests", "HTTP requests served", ["route", "code"], registry=registry)

    def page(name: str, title: str, code: int = 200, **kw: Any) -> HTMLResponse:
        snap = watcher.snapshot
        text = env.get_template(name).render(title=title, snap=snap, cfg=watcher.cfg, stale_days=watcher.stale_days,
                                             refresh=f"{watcher.refresh_s:g}", poll_ms=poll_ms, **kw)
        return HTMLResponse(text, status_code=code, headers={"Cache-Control": "no-store"})

    def count(route: str, resp: Response) -> Response:
        requests.labels(route, str(resp.status_code)).inc()
        return resp

    def plant(request: Request) -> Response:
        snap = watcher.snapshot
        views = rank_views(snap.views)
        return count("/", page("plant", "Plant: wear of every joint", views=views, counts=level_counts(views),
                               robots=sorted({v.robot for v in views})))

    def robot(request: Request) -> Response:
        name = request.path_params["robot"]
        views = [v for v in rank_views(watcher.snapshot.views) if v.robot == name]
        if not views:
            return count("/robot", _not_found(f"no robot {name!r} in the history"))
        return count("/robot", page("robot", f"Robot {name}", views=views))

    def joint(request: Request) -> Response:
        rb, jt = request.path_params["robot"], request.path_params["joint"]
        snap = watcher.snapshot
        view = next((v for v in snap.views if (v.robot, v.joint) == (rb, jt)), None)
        d = snap.joints.get((rb, jt))
        if view is None or d is None:
            return count("/joint", _not_found(f"no joint {jt!r} of robot {rb!r} in the history"))
        return count("/joint", page("joint", f"{rb} / {jt}", view=view, recent=list(reversed(d.records[-20:])),
                                    maintenance=d.maintenance_times))

    def plant_plot(request: Request) -> Response:
        snap = watcher.snapshot
        if not snap.views:
            return count("/plot", _not_found("no joints to draw"))
        return count("/plot", Response(plots.plant(snap), media_type="image/png",
                                       headers={"Cache-Control": "no-store"}))

    def joint_plot(request: Request) -> Response:
        data = plots.joint(watcher.snapshot, request.path_params["robot"], request.path_params["joint"])
        if data is None:
            return count("/plot", _not_found("no trend of that joint to draw"))
        return count("/plot", Response(data, media_type="image/png", headers={"Cache-Control": "no-store"}))

    def api_joints(request: Request) -> Response:
        snap = watcher.snapshot
        return count("/api/joints", JSONResponse({
            "joints": [v.as_api() for v in snap.views], "store_ok": snap.store_ok, "error": snap.error or None,
            "read_at": snap.loaded_at if math.isfinite(snap.loaded_at) else None,
        }, headers={"Cache-Control": "no-store"}))

    def api_state(request: Request) -> Response:
        snap = watcher.snapshot
        return JSONResponse({"version": snap.version, "store_ok": snap.store_ok, "error": snap.error or None,
                             "joints": len(snap.views), "checked_at": _finite(snap.checked_at),
                             "read_at": _finite(snap.loaded_at)}, headers={"Cache-Control": "no-store"})

    def metrics(request: Request) -> Response:
        requests.labels("/metrics", "200").inc()
        return Response(metrics_text(registry), media_type=CONTENT_TYPE_LATEST)

    routes = [
        Route("/", plant, methods=["GET"]),
        Route("/robot/{robot}", robot, methods=["GET"]),
        Route("/plot/plant.png", plant_plot, methods=["GET"]),
        Route("/plot/{robot}/{joint}.png", joint_plot, methods=["GET"]),
        Route("/joint/{robot}/{joint}", joint, methods=["GET"]),
        Route("/api/joints", api_joints, methods=["GET"]),
        Route("/api/state", api_state, methods=["GET"]),
        Route("/metrics", metrics, methods=["GET"]),
    ]
    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        yield
        plots.close()

    return Starlette(routes=routes, lifespan=lifespan)


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _not_found(msg: str) -> Response:
    return HTMLResponse(f"<!DOCTYPE html><html><body><p>{html.escape(msg)}</p><p><a href='/'>plant</a></p>"
                        "</body></html>", status_code=404)

