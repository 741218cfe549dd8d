"""Pictures checked as a user looks at them (issue 28, item 4): every figure type rendered on awkward histories
and checked on the matplotlib objects that were saved (axis limits, units, legend place and size, what is drawn
against what the title says).

The trend figure on: slow growth (the forecast band reaches 1e28 and the median -2e30 far out), one estimate,
a maintenance event with no estimate since, estimates minutes apart, a current segment after maintenance, wear
that falls; then the workbench's fit and residuals, commissioning's figure, the case study's Fig. 13, the
fleet page's change plot and the plant's current-wear overview.
"""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest

DAY = 86400.0
T0 = 1.79e9


# ------------------------------------------------------------------------------------------------ helpers


def _draw(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    renderer = canvas.get_renderer()
    fig.draw(renderer)
    return renderer


def _points(ax) -> np.ndarray:
    """The display coordinates of every marker drawn in ``ax`` (lines with markers, scatter points)."""
    out = []
    for ln in ax.get_lines():
        if ln.get_marker() in (None, "None", "", " ") or not ln.get_visible():
            continue
        xy = np.asarray(ln.get_xydata(), float)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if xy.size:
            out.append(ax.transData.transform(xy))
    for c in ax.collections:
        offs = np.asarray(c.get_offsets(), float)
        if offs.ndim == 2 and offs.shape[0] > 1 and c.get_offset_transform() is ax.transData:
            out.append(ax.transData.transform(offs[np.all(np.isfinite(offs), axis=1)]))
    return np.concatenate(out) if out else np.zeros((0, 2))


def assert_legends_clear_and_readable(fig) -> None:
    """No legend covers a data point of any axes, and every legend's text is 7 pt or more."""
    renderer = _draw(fig)
    pts = np.concatenate([_points(a) for a in fig.axes]) if fig.axes else np.zeros((0, 2))
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        assert min(t.get_fontsize() for t in leg.get_texts()) >= 7.0
        box = leg.get_window_extent(renderer)
        inside = ((pts[:, 0] > box.x0) & (pts[:, 0] < box.x1) & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1))
        assert not inside.any(), f"the legend of {ax.get_title()!r} covers {int(inside.sum())} data points"


def _unit(label: str) -> bool:
    return bool(re.search(r"\[[^\]]+\]", label))


def _trend(times, wear, std, maint=()):
    from jointwear_ros.trend import TrendConfig, analyze_joint

    cfg = TrendConfig()
    r = analyze_joint(np.asarray(times, float), np.asarray(wear, float), np.asarray(std, float),
                      cycle_ids=list(range(1, len(times) + 1)), maintenance_times=list(maint), cfg=cfg,
                      robot="cell_7", joint="joint_3", smooth=True)
    return r, cfg


def _plot(saved, tmp_path, name, times, wear, std, maint=(), trend=None):
    from jointwear_ros.trend.report import plot_trend

    r, cfg = trend if trend is not None else _trend(times, wear, std, maint)
    plot_trend(tmp_path / name, r, cfg, list(times), list(wear), list(std), list(maint))
    fig = saved[name]
    return r, cfg, fig, fig.axes[0]


def _labels(ax) -> list[str]:
    return ax.get_legend_handles_labels()[1]


def _x_share(ax, t: np.ndarray) -> float:
    """The share of the x axis the times ``t`` (s) span."""
    from datetime import UTC, datetime

    import matplotlib.dates as mdates

    lo, hi = ax.get_xlim()
    d = mdates.date2num([datetime.fromtimestamp(float(x), UTC) for x in (t.min(), t.max())])
    return float((d[1] - d[0]) / (hi - lo))


def _everything_drawn_within_limits(ax) -> None:
    lo, hi = ax.get_ylim()
    for ln in ax.get_lines():
        y = np.asarray(ln.get_ydata(), float)
        y = y[np.isfinite(y)]
        if ln.get_label().startswith("forecast") or ln.get_label().startswith("fit"):
            assert y.size == 0 or (lo <= y.min() and y.max() <= hi), ln.get_label()
    for c in ax.collections:
        if str(c.get_label()).endswith("90 %") and c.get_paths():
            ys = np.concatenate([p.vertices[:, 1] for p in c.get_paths()])
            assert lo - 1e-9 <= ys.min() and ys.max() <= hi + 1e-9, c.get_label()


def _slow():
    rng = np.random.default_rng(1)
    n = 100
    return T0 + DAY * np.arange(n), 4 + 0.013 * np.arange(n) + rng.normal(0, 0.4, n), np.full(n, 0.4)


@pytest.fixture(scope="module")
def slow():
    """A joint growing by 0.013 a day (a crossing years out, as 3 of the README's synthetic fleet) and its trend."""
    t, w, s = _slow()
    return t, w, s, _trend(t, w, s)


# ------------------------------------------------------------------------------------------------ trend


def test_slow_growth_keeps_the_data_readable_and_the_forecast_clipped_to_the_wear_axis(saved, tmp_path, slow):
    t, w, s, trend = slow
    r, cfg, fig, ax = _plot(saved, tmp_path, "slow.png", t, w, s, trend=trend)
    assert r.time_to_alarm is not None and r.time_to_alarm.median > 1000  # the awkward case: a crossing years out
    lo, hi = ax.get_ylim()
    assert -10 < lo <= min(0.0, w.min()) and cfg.alarm <= hi < 50  # not 1e28: data, 0 and the alarm
    assert (hi - lo) < 5 * (w.max() - min(w.min(), 0.0) + cfg.alarm)
    assert _x_share(ax, t) >= 0.2  # the estimates are not a flat line against the left edge
    assert "% of failure state" in ax.get_ylabel() and ax.get_xlabel()
    _everything_drawn_within_limits(ax)
    assert "forecast 90 %" in _labels(ax)
    assert any("beyond the plot" in tx.get_text() for tx in ax.texts)  # the crossing is named, not drawn far off
    assert_legends_clear_and_readable(fig)


def test_one_estimate_draws_no_band_no_fit_and_no_model_weights_as_its_title_says(saved, tmp_path):
    _r, cfg, fig, ax = _plot(saved, tmp_path, "one.png", [T0], [22.5], [1.2])
    assert "a trend needs" in ax.get_title()
    labels = _labels(ax)
    assert not any(lb.startswith(("forecast", "fit", "alarm time", "predicted")) for lb in labels), labels
    assert len(fig.axes) == 1  # no panel of a trend's models (they would be the prior, not evidence)
    lo, hi = ax.get_ylim()
    assert lo <= 0.0 and cfg.alarm <= hi < 50
    assert_legends_clear_and_readable(fig)


def test_maintenance_with_no_estimate_since_leaves_no_blank_panel(saved, tmp_path):
    t = T0 + DAY * np.arange(40.0)
    w = 10 + 0.3 * np.arange(40.0)
    m = T0 + DAY * 45
    _r, _cfg, fig, ax = _plot(saved, tmp_path, "after.png", t, w, np.full(40, 0.8), [m])
    assert "no estimates since the last maintenance" in ax.get_title()
    assert all(a.axison for a in fig.axes)  # no empty third of the figure
    assert "maintenance" in _labels(ax) and not any(lb.startswith("forecast") for lb in _labels(ax))
    assert _x_share(ax, np.array([t[0], m])) >= 0.85  # the history up to the event fills the plot
    assert_legends_clear_and_readable(fig)


def test_estimates_minutes_apart_fill_the_plot(saved, tmp_path):
    rng = np.random.default_rng(1)
    t = T0 + 60.0 * np.arange(8)
    w = 12 + rng.normal(0, 0.5, 8)
    _r, _cfg, fig, ax = _plot(saved, tmp_path, "minutes.png", t, w, np.full(8, 0.5))
    assert _x_share(ax, t) >= 0.8
    assert "no growth detected" in ax.get_title() and "forecast 90 %" not in _labels(ax)
    assert ax.get_xlabel() and "% of failure state" in ax.get_ylabel()
    assert_legends_clear_and_readable(fig)


def test_a_falling_wear_has_a_fit_but_no_forecast_band_since_no_growth_is_detected(saved, tmp_path):
    t, _w, s = _slow()
    w = 30 - 0.05 * np.arange(t.size) + np.random.default_rng(1).normal(0, 0.4, t.size)
    r, _cfg, _fig, ax = _plot(saved, tmp_path, "falling.png", t, w, s)
    assert r.time_to_alarm is None and "no growth detected" in ax.get_title()
    assert any(lb.startswith("fit: ") for lb in _labels(ax))
    assert not any(lb.startswith("forecast") for lb in _labels(ax))
    assert _x_share(ax, t) >= 0.85


def test_the_current_segment_and_its_forecast_fill_the_plot_after_maintenance(saved, tmp_path):
    m = np.arange(60)
    t = T0 + DAY * m
    w = np.where(m < 50, 5 + 0.4 * m, 1 + 0.4 * (m - 50))
    event = T0 + DAY * 49.5
    r, _cfg, fig, ax = _plot(saved, tmp_path, "seg.png", t, w, np.full(60, 0.6), [event])
    assert r.time_to_alarm is not None
    _lo, hi = ax.get_ylim()
    assert hi < 50  # the accelerated members' band (300 here) does not set the scale
    _everything_drawn_within_limits(ax)
    x0, x1 = ax.get_xlim()
    from datetime import UTC, datetime

    import matplotlib.dates as mdates

    seg0 = mdates.date2num(datetime.fromtimestamp(float(t[50]), UTC))
    assert (x1 - seg0) / (x1 - x0) >= 0.5  # the current segment and its forecast: at least half the width
    ev = mdates.date2num(datetime.fromtimestamp(event, UTC))
    assert x0 <= ev <= x1
    assert_legends_clear_and_readable(fig)


def test_a_forecast_median_that_runs_off_to_minus_infinity_is_not_drawn_below_the_current_level(saved, tmp_path,
                                                                                                 slow):
    from jointwear_ros.trend import forecast_band

    t, w, s, (r, cfg) = slow
    far = forecast_band(r.components, r.members, cfg, np.linspace(0.0, cfg.max_horizon_days, 200))
    assert np.nanmax(np.abs(far)) > 1e6  # the awkward numbers of the core, far out
    _r, _cfg, _fig, ax = _plot(saved, tmp_path, "neg.png", t, w, s, trend=(r, cfg))
    med = next(ln for ln in ax.get_lines() if ln.get_label().startswith("forecast"))
    y = np.asarray(med.get_ydata(), float)
    y = y[np.isfinite(y)]
    assert y.size and y.min() >= max(0.0, r.wear - 1.645 * r.wear_std) - 1e-9
    _everything_drawn_within_limits(ax)


# ------------------------------------------------------------------------------------------------ workbench


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    from jointwear_ros.cli import main as cli_main
    from jointwear_ros.io.tables import read_table
    from jointwear_ros.workbench import parse_spec
    from jointwear_ros.workbench.fit import fit_model

    d = tmp_path_factory.mktemp("wbfig")
    assert cli_main(["data", "synth", str(d / "obs.csv"), "--cycles", "6", "--seed", "3"]) == 0
    table = read_table(d / "obs.csv")
    fits = [(spec, fit_model(parse_spec(spec), table, cv_folds=3, n_starts=1)) for spec in ("standard", "paper")]
    return table, fits


def test_workbench_fit_has_units_on_both_panels_and_legends_off_the_data(saved, tmp_path, fitted):
    from jointwear_ros.workbench.report import plot_fit

    table, fits = fitted
    plot_fit(tmp_path / "fit.png", table, fits[1][1])
    fig = saved["fit.png"]
    for ax in fig.axes:
        assert _unit(ax.get_xlabel()) and _unit(ax.get_ylabel()), (ax.get_xlabel(), ax.get_ylabel())
    assert_legends_clear_and_readable(fig)


def test_workbench_residual_legend_is_readable_and_covers_no_residual(saved, tmp_path, fitted):
    from jointwear_ros.workbench.report import plot_residuals, residual_columns

    table, fits = fitted
    cols = residual_columns(table)[:3]  # a full grid: no empty panel to hold the legend
    plot_residuals(tmp_path / "residuals.png", table, fits, cols)
    fig = saved["residuals.png"]
    legends = [a.get_legend() for a in fig.axes if a.get_legend() is not None]
    assert len(legends) == 1 and len(legends[0].get_texts()) == 3  # two models and the noise floor
    for ax in fig.axes:
        assert _unit(ax.get_ylabel())
    assert_legends_clear_and_readable(fig)


# ------------------------------------------------------------------------------------------------ commission


def test_commission_figure_shows_the_fitted_model_over_the_baseline_with_units(saved, tmp_path, fitted):
    from jointwear_ros.cli.commission_cmd import _report
    from jointwear_ros.units import SetUnits

    table, fits = fitted
    fit = fits[1][1]
    res = SimpleNamespace(spec=fit.spec, params=fit.params, units=SetUnits(), joint="joint_3", cv_rmse=fit.cv_rmse,
                          verdict="nothing_missing")
    _report(tmp_path / "rep", table, res, {})
    fig = saved["commission.png"]
    base = fig.axes[0]
    assert any("fitted model" in lb for lb in _labels(base))
    model_line = next(ln for ln in base.get_lines() if ln.get_label().startswith("fitted model at the median"))
    y = np.asarray(model_line.get_ydata(), float)
    assert np.all(np.isfinite(y)) and table.tau_f.min() - 0.1 < y.mean() < table.tau_f.max() + 0.1
    for ax in fig.axes[:2]:
        assert _unit(ax.get_xlabel()) and _unit(ax.get_ylabel())
    assert_legends_clear_and_readable(fig)


# ------------------------------------------------------------------------------------------------ study (Fig. 13)


def test_case_study_paper_and_bayes_traces_can_be_told_apart(saved, tmp_path):
    from jointwear_ros.cli.study_cmd import _plot_case

    k = np.arange(60)
    truth = 0.004 * k**2
    speeds = np.array([10.0, 20.0, 40.0])
    rng = np.random.default_rng(2)
    est = truth[:, None] + rng.normal(0, 1.0, (60, 3))
    methods = {m: {"best_index": 1, "estimates": est + off, "mean": np.array([0.1, 0.2, 0.3]),
                   "worst": np.array([2.0, 3.0, 4.0]), "std": np.array([0.5, 0.6, 0.7])}
               for m, off in (("paper", 0.0), ("bayes", 0.05))}  # traces that lie on each other
    res = SimpleNamespace(k=k, w_true=truth, w_ref=truth, methods=methods, speeds=speeds)
    _plot_case(res, tmp_path)
    fig = saved["case_study.png"]
    ax = fig.axes[0]
    lines = {ln.get_label().split(" ")[0]: ln for ln in ax.get_lines()}
    p, b = lines["paper"], lines["bayes"]
    assert p.get_linestyle() != b.get_linestyle() and p.get_marker() != b.get_marker()
    assert p.get_color() != b.get_color()
    assert "% of failure state" in ax.get_ylabel() and ax.get_xlabel()
    assert any("largest" in tx.get_text() for tx in ax.texts)  # how far apart they are, in numbers
    assert _unit(fig.axes[1].get_xlabel()) and _unit(fig.axes[1].get_ylabel())
    assert_legends_clear_and_readable(fig)


# ------------------------------------------------------------------------------------------------ fleet and plant


def test_fleet_change_plot_is_square_on_the_data_with_units(saved, tmp_path):
    from jointwear_ros.fleet.report import _plot_changes

    changes = [SimpleNamespace(wear_from=10.0 + i, wear_to=10.0 + i + (3.0 if i == 2 else 0.0), changed=i == 2)
               for i in range(5)]
    _plot_changes(changes, tmp_path / "changes.png", "paper:ref-2011r:0.1.0", "bayes:ref-2011r:0.1.0")
    ax = saved["changes.png"].axes[0]
    assert ax.get_xlim() == ax.get_ylim() and 8 < ax.get_xlim()[0] < 10 and 15 < ax.get_xlim()[1] < 17
    assert "% of failure state" in ax.get_xlabel() and "% of failure state" in ax.get_ylabel()
    assert_legends_clear_and_readable(saved["changes.png"])


def test_plant_overview_shows_a_wear_past_100_and_names_its_unit(saved, tmp_path):
    from jointwear_ros.plots import plot_current_wear

    rows = [("r / j1", 5.0, 0.5, "OK", "green"), ("r / j2", 31.0, 1.0, "WARN", "orange"),
            ("r / j3", 118.0, 2.0, "ERROR", "red"), ("r / j4", float("nan"), float("nan"), "STALE", "grey")]
    plot_current_wear(tmp_path / "plant.png", rows, 35.0, title="4 joints")
    ax = saved["plant.png"].axes[0]
    lo, hi = ax.get_xlim()
    assert lo <= 0.0 and hi >= 118.0 + 1.645 * 2.0 * 0.99
    assert "% of failure state" in ax.get_xlabel()
