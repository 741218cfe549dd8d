"""The pictures a maintenance engineer reads say what is true (issue 24, Pictures), and the smaller flows
of the README (model add twice, bag info of several bags, a synthetic history, .gitignore).

Each figure is checked on the matplotlib objects that were saved (legend entries, band edges, axis
labels, annotations, limits), captured as the code saves them; the PNGs themselves were looked at.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from jointwear_ros.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
DAY = 86400.0


def _labels(ax) -> list[str]:
    return ax.get_legend_handles_labels()[1]


def _trend(times, wear, std, maint=()):
    from jointwear_ros.trend import TrendConfig, analyze_joint

    cfg = TrendConfig()
    r = analyze_joint(times, wear, std, cycle_ids=list(range(1, len(times) + 1)), maintenance_times=list(maint),
                      cfg=cfg, robot="cell_7", joint="joint_3", smooth=True)
    return r, cfg


def test_trend_of_one_estimate_lists_no_empty_trend_and_draws_no_forecast(saved, tmp_path):
    from jointwear_ros.trend.report import plot_trend

    t0 = 1.79e9
    r, cfg = _trend([t0], [22.5], [1.2])
    plot_trend(tmp_path / "one.png", r, cfg, [t0], [22.5], [1.2])
    ax = saved["one.png"].axes[0]
    assert "trend (smoothed)" not in _labels(ax) and "trend 90 %" not in _labels(ax)
    assert "forecast 90 %" not in _labels(ax)  # one estimate is no trend: no band, as the title says


def test_trend_figure_shows_maintenance_in_its_legend(saved, tmp_path):
    from jointwear_ros.trend.report import plot_trend

    t = 1.79e9 + DAY * np.arange(40.0)
    w = np.where(np.arange(40) < 20, 10 + 0.5 * np.arange(40), 2 + 0.5 * (np.arange(40) - 20))
    m = float(t[20] - 3600)
    r, cfg = _trend(t, w, np.full(40, 0.8), [m])
    plot_trend(tmp_path / "m.png", r, cfg, t, w, np.full(40, 0.8), [m])
    labels = _labels(saved["m.png"].axes[0])
    assert labels.count("maintenance") == 1 and any(lb.startswith("fit: ") for lb in labels)  # the trend drawn


def test_joints_past_the_alarm_say_so_and_the_page_shows_figures_in_the_ranked_order(tmp_path, capsys):
    from jointwear_ros.history import EstimateRecord, HistoryStore

    now = 1.79e9
    recs = []
    for joint, w0, rate in (("joint_a", 5.0, 0.0), ("joint_b", 30.0, 0.3), ("joint_c", 20.0, 0.2)):
        for k in range(30):
            recs.append(EstimateRecord(robot="r", joint=joint, cycle_id=k + 1, time=now + k * DAY,
                                       wear=w0 + rate * k, wear_std=0.5))
    with HistoryStore(f"sqlite:///{tmp_path / 'h.db'}") as store:
        store.add_estimates(recs)
    assert cli_main(["trend", "--db", str(tmp_path / "h.db"), "--html", str(tmp_path / "page")]) == 0
    text = capsys.readouterr().out
    row_b = next(line for line in text.splitlines() if "joint_b" in line)
    assert "past the alarm already" in row_b and "0 (0-0)" not in text
    page = (tmp_path / "page" / "index.html").read_text()
    table_order = re.findall(r"<td>r</td><td>(joint_\w)</td>", page)
    figure_order = re.findall(r'<h3 id="r-(joint_\w)">', page)
    assert table_order == figure_order == ["joint_b", "joint_c", "joint_a"]


@pytest.fixture(scope="module")
def workbench(tmp_path_factory):
    """A table with a hidden ripple, and the workbench's figures and report for it (files and figures)."""
    import jointwear_ros.plots as plots
    import jointwear_ros.workbench.report as wb_report

    d = tmp_path_factory.mktemp("wb")
    figs: dict[str, object] = {}
    orig = plots.save_figure

    def capture(fig, path):
        figs[Path(path).name] = fig  # (the report is drawn in a scratch directory, then moved)
        return orig(fig, path)

    mp = pytest.MonkeyPatch()
    mp.setattr(plots, "save_figure", capture)
    mp.setattr(wb_report, "save_figure", capture)
    try:
        assert cli_main(["data", "synth", str(d / "obs.csv"), "--hidden", "ripple_fast", "--cycles", "24"]) == 0
        assert cli_main(["data", "synth", str(d / "clean.csv"), "--cycles", "20"]) == 0
        args = ["model", "add", str(d / "obs.csv"), "--model", "paper", "--term", "ripple(position, w0=17.07)",
                "--history", str(d / "history.json"), "--plot", str(d / "plots")]
        assert cli_main(args) == 0
        assert cli_main(args) == 0  # the same step again
        assert cli_main(["model", "report", str(d / "clean.csv"), "--model", "paper", "--out", str(d / "report")]) == 0
    finally:
        mp.undo()
    return d, figs


@pytest.mark.slow
def test_model_add_twice_adds_no_duplicate_versions_and_error_fall_says_what_each_added(workbench):
    d, figs = workbench
    versions = json.loads((d / "history.json").read_text())["versions"]
    assert len(versions) == 2
    texts = [t.get_text() for t in figs["error_fall.png"].axes[0].texts]
    assert texts[0] == "base model" and texts[1].startswith("+ ripple(position")
    assert "temp_viscous" not in texts[0]


@pytest.mark.slow
def test_band_legend_is_below_the_bars(workbench):
    _d, figs = workbench
    fig = figs["bands_before_after.png"]
    ax = fig.axes[0]
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    leg = ax.get_legend().get_window_extent(renderer)
    axes_box = ax.get_window_extent(renderer)
    assert leg.y1 <= axes_box.y0  # entirely below the plotting area


@pytest.mark.slow
def test_residual_axes_have_units_and_fitted_marks_lie_under_the_data(workbench):
    _d, figs = workbench
    xlabels = [a.get_xlabel() for a in figs["residuals.png"].axes if a.get_xlabel()]
    assert "speed [rad/s, motor side]" in xlabels and "time [s]" in xlabels
    ax = figs["fit.png"].axes[0]
    z = {ln.get_label(): ln.get_zorder() for ln in ax.get_lines()}
    fitted = next(k for k in z if k.startswith("fitted"))
    assert z["observed tau_f"] > z[fitted]


@pytest.mark.slow
def test_nothing_missing_report_names_no_term_has_no_empty_table_and_formats_its_numbers(workbench):
    d, figs = workbench
    html = (d / "report" / "report.html").read_text()
    assert "verdict: nothing_missing" in html
    title = figs["dependence.png"].axes[1].get_title()
    assert "no significant dependence" in title and "periodic" not in title
    assert "none tried" in html
    assert "<th>term</th>" not in html  # no candidate table with a header and no rows
    assert not re.search(r"\de-1\d", html)  # no 5.15004e-15


@pytest.mark.slow
def test_case_study_figure_shows_every_curve_whole(saved, tmp_path):
    assert cli_main(["study", "case", "--plot", str(tmp_path)]) == 0
    ax = saved["case_study.png"].axes[1]
    lo, hi = ax.get_ylim()
    for line in ax.get_lines():
        y = np.asarray(line.get_ydata(), float)
        y = y[np.isfinite(y)]
        assert lo <= y.min() and y.max() <= hi, line.get_label()


def test_synth_history_gives_a_trend_a_new_user_can_see(tmp_path, capsys):
    assert cli_main(["data", "synth-history", str(tmp_path / "s.csv"), "--robots", "1", "--joints", "4", "--days",
                     "60", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["joints"] == 4 and out["estimates"] > 200
    assert cli_main(["history", "import", str(tmp_path / "s.csv"), "--db", str(tmp_path / "h.db")]) == 0
    capsys.readouterr()
    assert cli_main(["trend", "--db", str(tmp_path / "h.db"), "--json"]) == 0
    joints = json.loads(capsys.readouterr().out)["joints"]
    assert len(joints) == 4 and all(j["estimates"] >= 40 for j in joints)
    assert any(j["time_to_alarm_days"] is not None for j in joints)  # a growing joint has a forecast
    # cycle ids unique per joint: every night is its own entry, none collapsed
    import csv

    rows = list(csv.DictReader((tmp_path / "s.csv").open()))
    per_joint: dict[str, list[str]] = {}
    for r in rows:
        per_joint.setdefault(r["joint"], []).append(r["cycle_id"])
    assert all(len(v) == len(set(v)) for v in per_joint.values())
    assert cli_main(["data", "synth-history", str(tmp_path / "s.txt")]) == 2


def test_gitignore_covers_what_the_readme_writes():
    ignored = set((ROOT / ".gitignore").read_text().split())
    assert {"history.db", "fig/", "page/", "fleet-page/", "out/", "plots/", "report/"} <= ignored


def test_bag_info_takes_several_bags_each_once_and_says_whether_messages_were_lost(tmp_path, capsys):
    from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_fleet

    bags = write_fleet(tmp_path / "b", fleet_specs(1, 2, 1, rates=(0.0,), start_wear=10.0))
    assert cli_main(["bag", "info", str(tmp_path / "b" / "**" / "*")]) == 0
    out = capsys.readouterr().out
    assert out.count("bag: ") == len(bags) == 2
    assert out.count("messages lost while recording: none") == 2
    assert not math.isnan(0.0)
