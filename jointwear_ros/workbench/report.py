"""Workbench outputs: PNG plots (matplotlib) and a self-contained HTML report.

* :func:`plot_fit` — data against speed with the fitted model and each term's
  contribution (at the median of the other inputs);
* :func:`plot_residuals` — residuals against speed and every other numeric
  column, several model versions overlaid, the noise floor as a band;
* :func:`plot_band_errors` — RMSE per speed band, several versions side by side;
* :func:`plot_error_fall` — RMSE and CV RMSE over the model versions of a history;
* :func:`write_report` — all of the above plus tables in one HTML file with the
  images embedded (base64), written into a directory without leaving
  anything half-written.
"""

from __future__ import annotations

import base64
import html
import math
import os
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..model.scaling import DataScales
from ..plots import legend_outside, new_figure, save_figure
from ..types import ObservationTable
from .compare import band_rmse, noise_floor, noise_test, residual_structure
from .diagnose import Diagnosis
from .fit import FitResult
from .history import History
from .render import (
    candidate_region_label,
    diagnosis_summary,
    goodness_of_fit,
    noise_line,
    shape_hint,
    stability_text,
)

__all__ = ["plot_band_errors", "plot_dependence", "plot_error_fall", "plot_fit", "plot_residuals", "residual_columns",
           "write_report"]

Array = npt.NDArray[np.float64]

_SKIP = ("tau_f", "tau_f_std", "tau_plus", "tau_minus")


def _units(table: ObservationTable) -> tuple[str, str]:
    """Axis units: (torque unit, speed axis label). The paper's (normalized, motor side) only for data at its scale."""
    s = DataScales.from_table(table)
    if s.identity:
        return "normalized", "speed v, motor side [rad/s]"
    return "unit of tau_f", "speed v [rad/s]"


def residual_columns(table: ObservationTable) -> list[str]:
    """Columns to plot residuals against: speed first, then every other non-constant numeric column."""
    cols = ["speed"] + [c for c in table.names if c not in _SKIP and c != "speed"]
    return [c for c in cols if np.all(np.isfinite(table[c])) and np.ptp(table[c]) > 0]


#: units of the standard observation columns on a plot axis
COLUMN_UNITS = {"speed": "rad/s, motor side", "time": "s", "temperature": "°C", "load_torque": "normalized",
                "position": "rad", "wear": "0-100", "cycle_id": "", "lube_hours": "h", "hours_running": "h",
                "motor_temperature": "°C"}


def column_label(name: str, table: ObservationTable | None = None) -> str:
    """``speed [rad/s, motor side]``: a column's name with its unit when known (the speed side and the
    torque unit of ``table``'s scale, as :func:`_units`)."""
    unit = COLUMN_UNITS.get(name)
    if table is not None and name in ("speed", "load_torque"):
        tu, side = _units(table)
        unit = ("rad/s, motor side" if "motor side" in side else "rad/s") if name == "speed" else tu
    return f"{name} [{unit}]" if unit else name


def plot_fit(path: Path, table: ObservationTable, fit: FitResult, title: str = "") -> Path:
    """Data and fitted values against speed; term contributions at the median of the other inputs."""
    fig, axes = new_figure(1, 2, size=(13.0, 5.0))
    ax, axc = axes[0]
    v = table.speed
    # the fitted values as small marks under the data (open circles on top), so the data stays visible
    ax.plot(v, fit.fitted, "_", ms=7, mew=1.2, color="C3", alpha=0.8, zorder=2, label=f"fitted ({fit.n_free} params)")
    ax.plot(v, table.tau_f, "o", ms=4, mfc="none", mew=0.7, color="0.35", zorder=3, label="observed tau_f")
    tu, side = _units(table)
    ax.set_xlabel(side)
    ax.set_ylabel(f"friction torque [{tu}]")
    ax.set_title(title or f"fit: RMSE {fit.rmse:.5f}, CV RMSE {fit.cv_rmse:.5f}")
    ax.grid(alpha=0.3)
    legend_outside(ax, "below", fontsize=8, ncol=2)
    vv = np.linspace(0.0, float(max(np.max(np.abs(v)), 1.0)), 300)
    inputs = {c: np.full(vv.size, float(np.median(table[c]))) for c in fit.model.variables if c != "speed"}
    inputs["speed"] = vv
    vals = fit.params.valuesdict()
    total = fit.model.evaluate(vals, **inputs)
    axc.plot(vv, total, color="black", lw=2.2, label="total")
    for name, comp in fit.model.components(vals, **inputs).items():
        axc.plot(vv, comp, lw=1.2, label=name)
    med = ", ".join(f"{c}={float(np.median(table[c])):.3g}" for c in inputs if c != "speed")
    axc.set_title(f"components at the median inputs ({med})" if med else "components", fontsize=9)
    axc.axhline(0.0, color="grey", lw=0.6)
    axc.set_xlabel(side)
    axc.set_ylabel(f"friction torque (contribution) [{tu}]")
    axc.grid(alpha=0.3)
    legend_outside(axc, "right", fontsize=7.5)
    return save_figure(fig, path)


def plot_residuals(
    path: Path, table: ObservationTable, fits: Sequence[tuple[str, FitResult]], columns: Sequence[str] | None = None
) -> Path:
    """Residuals against each column, one colour per model version; the noise floor as a grey band."""
    cols = list(columns) if columns is not None else residual_columns(table)
    ncol = min(3, max(len(cols), 1))
    nrow = max(1, math.ceil(len(cols) / ncol))
    fig, axes = new_figure(nrow, ncol, size=(4.6 * ncol, 3.4 * nrow))
    nf, _ = noise_floor(table)
    for k, c in enumerate(cols):
        ax = axes[k // ncol][k % ncol]
        for i, (label, f) in enumerate(fits):
            ax.plot(table[c], f.residuals, ".", ms=3, alpha=0.6, color=f"C{i}", label=f"{_short(label)} (RMSE {f.rmse:.4f})")
        if math.isfinite(nf):
            ax.axhspan(-nf, nf, color="0.85", zorder=0, label=f"noise floor ±{nf:.4f}")
        ax.axhline(0.0, color="grey", lw=0.6)
        ax.set_xlabel(column_label(c, table))
        ax.set_ylabel(f"residual [{_units(table)[0]}]")
        ax.grid(alpha=0.3)
    for k in range(len(cols), nrow * ncol):
        axes[k // ncol][k % ncol].axis("off")
    handles, labels = axes[0][0].get_legend_handles_labels()
    if len(cols) < nrow * ncol:  # an empty panel holds the legend
        axes[nrow - 1][ncol - 1].legend(handles, labels, loc="center", fontsize=8)
    else:  # below the panels, never over the residuals
        legend_outside(axes[nrow - 1][0], "below", fontsize=8, in_layout=False, handles=handles, labels=labels)
    return save_figure(fig, path)


def _short(label: str, width: int = 60) -> str:
    """A long model spec, shortened from the front (the newest terms are at the end)."""
    return label if len(label) <= width else label[: label.find(":") + 1] + " …" + label[-(width - 12):]


def plot_band_errors(path: Path, table: ObservationTable, fits: Sequence[tuple[str, FitResult]]) -> Path:
    """RMSE per speed band, one bar per model version."""
    fig, axes = new_figure(size=(9.0, 4.5))
    ax = axes[0][0]
    bands = [band_rmse(table.speed, f.residuals) for _, f in fits]
    labels = [b.label for b in bands[0]] if bands else []
    width = 0.8 / max(len(fits), 1)
    x = np.arange(len(labels))
    for i, ((label, _), bb) in enumerate(zip(fits, bands)):
        ax.bar(x + i * width, [b.rmse for b in bb], width, label=label, color=f"C{i}")
    nf, _ = noise_floor(table)
    if math.isfinite(nf):
        ax.axhline(nf, color="black", ls="--", lw=1, label="noise floor")
    ax.set_xticks(x + width * (len(fits) - 1) / 2, labels)
    ax.set_xlabel("speed band [rad/s]")
    ax.set_ylabel(f"RMSE [{_units(table)[0]}]")
    ax.grid(alpha=0.3, axis="y")
    # below the axes, never over the bars (model specs are long)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=1, frameon=False)
    fig.set_size_inches(9.0, 4.5 + 0.22 * (len(fits) + 1))
    return save_figure(fig, path)


def plot_error_fall(path: Path, history: History) -> Path:
    """RMSE and CV RMSE of every model version in ``history`` (log scale), with the noise floor."""
    fig, axes = new_figure(size=(9.0, 4.8))
    ax = axes[0][0]
    vs = history.versions
    x = np.arange(1, len(vs) + 1)

    def arr(vals: Sequence[float | None]) -> Array:
        return np.array([np.nan if v is None else v for v in vals], dtype=float)

    ax.plot(x, arr([v.rmse for v in vs]), "o-", label="RMSE")
    ax.plot(x, arr([v.cv_rmse for v in vs]), "s--", label="CV RMSE")
    nf = arr([v.noise_floor for v in vs])
    if np.any(np.isfinite(nf)):
        ax.plot(x, nf, ":", color="black", label="noise floor")
    ax.set_yscale("log")
    ax.set_xticks(x, [f"v{v.version}" for v in vs])
    prev: list[str] = []
    for xi, v in zip(x, vs):
        terms = [t.strip() for t in v.model.split(" + ")]
        added = [t for t in terms if t not in prev]
        text = ("base model" if not prev else "+ " + " + ".join(added) if added
                else "- " + " - ".join(t for t in prev if t not in terms) or "refit")
        prev = terms
        ax.annotate(_short(text, 40), (xi, v.cv_rmse or v.rmse or 1.0), fontsize=7, rotation=20,
                    xytext=(4, 6), textcoords="offset points")
    ax.set_xlabel("model version")
    ax.set_ylabel("error [unit of tau_f]")
    ax.set_title("error over model versions")
    ax.grid(alpha=0.3, which="both")
    legend_outside(ax, "right", fontsize=8)
    return save_figure(fig, path)


def plot_dependence(path: Path, table: ObservationTable, diagnosis: Diagnosis) -> Path:
    """The verdict's evidence: each column's explained share (model-free), and the strongest column's residual.

    Left: the cross-validated share of the residual each column (or pair)
    explains, significant ones in red. Right: what the model misses (data
    minus model) against the strongest single column, with the suggested
    term's contribution when there is one.
    """
    fig, axes = new_figure(1, 2, size=(13.0, 4.6))
    ax, axr = axes[0]
    vs = diagnosis.variables[:12]
    names = [v.name for v in vs]
    ax.barh(np.arange(len(vs)), [100 * v.explained_share for v in vs],
            color=["C3" if v.significant else "0.6" for v in vs])
    ax.set_yticks(np.arange(len(vs)), names)
    ax.invert_yaxis()
    ax.set_xlabel("share of the residual explained, cross-validated [%] (red: significant)")
    ax.set_title(f"verdict: {diagnosis.verdict}", fontsize=10)
    ax.grid(alpha=0.3, axis="x")
    single = next((v for v in diagnosis.variables if "," not in v.name), None)
    base = diagnosis.base
    if single is not None:
        x = table[single.name]
        axr.plot(x, -base.residuals, ".", ms=3, color="0.5", label=f"data - model ({_short(base.spec, 40)})")
        best = diagnosis.best
        if best is not None:
            comp = best.fit.model.components(best.fit.params.valuesdict(),
                                             **{c: table[c] for c in best.fit.model.variables})
            contrib = comp[best.fit.model.terms[-1].name]
            contrib = contrib - float(np.mean(contrib))
            axr.plot(x, contrib, ".", ms=3, color="C3", label=f"{_short(best.term, 40)} (fitted)")
        nf = diagnosis.noise.value
        if math.isfinite(nf):
            axr.axhspan(-nf, nf, color="0.88", zorder=0, label=f"noise floor ±{nf:.4f}")
        axr.set_xlabel(column_label(single.name, table))
        axr.set_ylabel(f"data - model [{_units(table)[0]}]")
        axr.set_title(f"{single.name}: {shape_hint(single)}" if single.significant else
                      f"{single.name}: no significant dependence (the strongest column, for reference)", fontsize=9)
        axr.grid(alpha=0.3)
        legend_outside(axr, "below", fontsize=7.5)
    else:
        axr.axis("off")
    return save_figure(fig, path)


def _table_html(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    def cell(v: object) -> str:
        if isinstance(v, (float, np.floating)):
            f = float(v)
            if not math.isfinite(f):
                return "nan"
            if f != 0.0 and abs(f) < 1e-9:
                return "< 1e-9" if f > 0 else "> -1e-9"
            return f"{f:.4g}"
        return html.escape(str(v))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{cell(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _img(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"><figcaption>{html.escape(alt)}</figcaption></figure>'


def write_report(
    out_dir: str | os.PathLike[str],
    table: ObservationTable,
    fit: FitResult,
    *,
    diagnosis: Diagnosis | None = None,
    history: History | None = None,
    before: FitResult | None = None,
    title: str = "jointwear model workbench",
) -> Path:
    """Write PNGs and ``report.html`` (images embedded) into ``out_dir``; returns the HTML path.

    Everything is built in a temporary directory first and moved in at the
    end, so an error leaves ``out_dir`` as it was.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        from ..errors import InputDataError

        raise InputDataError(f"{out}: exists and is not a directory; give a directory for the report")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".report-", dir=out.parent))
    try:
        fits = [("before: " + before.spec, before), ("after: " + fit.spec, fit)] if before is not None else [(fit.spec, fit)]
        files = {
            "fit.png": plot_fit(tmp / "fit.png", table, fit),
            "residuals.png": plot_residuals(tmp / "residuals.png", table, fits),
            "bands.png": plot_band_errors(tmp / "bands.png", table, fits),
        }
        if history is not None and history.versions:
            files["error_fall.png"] = plot_error_fall(tmp / "error_fall.png", history)
        nf, src = noise_floor(table)
        gof_txt = goodness_of_fit(noise_test(table, fit.residuals, fit.n_free), fit.cv_rmse)
        parts = [f"<h1>{html.escape(title)}</h1>",
                 f"<p>data: <code>{html.escape(table.source)}</code>, {len(table)} observations; "
                 f"noise floor {nf:.5f} ({html.escape(src)})</p>",
                 f"<p>{html.escape(gof_txt)}</p>",
                 f"<h2>Model</h2><p><code>{html.escape(fit.spec)}</code></p><p><code>{html.escape(fit.model.equation())}</code></p>",
                 _table_html(["", "RMSE", "CV RMSE", "AIC", "BIC", "free params", "converged"],
                             [[lbl, f.rmse, f.cv_rmse, f.aic, f.bic, f.n_free, f.success] for lbl, f in fits]),
                 "<h2>Parameters</h2>",
                 _table_html(["name", "value", "stderr", "unit", "free"],
                             [[n, p.value, p.stderr if p.stderr is not None else math.nan, p.unit, p.vary]
                              for n, p in fit.params.items()]),
                 _img(files["fit.png"], "fit against the data, with each term's contribution"),
                 "<h2>Error per speed band</h2>",
                 _table_html(["band [rad/s]", "n", *[f"RMSE {lbl}" for lbl, _ in fits]],
                             [[b.label, b.n, *[bb[i].rmse for bb in [band_rmse(table.speed, f.residuals) for _, f in fits]]]
                              for i, b in enumerate(band_rmse(table.speed, fit.residuals))]),
                 _img(files["bands.png"], "RMSE per speed band"),
                 "<h2>Residuals</h2>",
                 _table_html(["column", "binned R²", "correlation"],
                             [[s.column, s.r2_binned, s.corr] for s in residual_structure(table, fit.residuals)]),
                 _img(files["residuals.png"], "residuals against each variable")]
        if diagnosis is not None:
            files["dependence.png"] = plot_dependence(tmp / "dependence.png", table, diagnosis)
            nft = diagnosis.noise
            parts.append("<h2>Diagnosis: which effect is missing?</h2>")
            parts.append(f"<p><b>verdict: {html.escape(diagnosis.verdict)}</b></p>")
            parts.append(f"<p>{html.escape(diagnosis_summary(diagnosis))}</p>")
            parts.append(f"<p>{html.escape(noise_line(nft))}</p>")
            parts.append("<h3>Which columns explain the residual (model-free)</h3>")
            parts.append(_table_html(
                ["variable", "explains", "p (adjusted)", "significant", "test", "shape"],
                [[v.name, f"{100 * v.explained_share:.0f} %", v.p_value, "yes" if v.significant else "no",
                  v.test, shape_hint(v)] for v in diagnosis.variables[:15]]))
            parts.append(_img(files["dependence.png"], "explained share per column; the strongest column's residual"))
            parts.append("<h3>Candidate terms</h3>")
            if not diagnosis.candidates:
                parts.append("<p>none tried: the residual is consistent with the noise and no column explains "
                             "it, so no term was fitted.</p>")
            else:
                parts.append(_table_html(
                    ["term", "variables", "meaning", "CV RMSE", "x floor", "ΔBIC", "p", "significant",
                     "speed region"],
                    [[c.term, ", ".join(c.variables), c.description, c.cv_rmse, diagnosis.noise.ratio(c.cv_rmse),
                      c.delta_bic, c.p_value, "yes" if c.significant else "no",
                      candidate_region_label(c.speed_region)]
                     for c in diagnosis.candidates[:15]]))
            if diagnosis.stability:
                parts.append("<p>chosen in bootstrap resamples by cycle: " + html.escape(stability_text(diagnosis))
                             + "</p>")
        if "error_fall.png" in files and history is not None:
            parts.append("<h2>Model versions</h2>")
            parts.append(_table_html(["version", "model", "RMSE", "CV RMSE", "BIC", "noise floor"],
                                     [[v.version, v.model, v.rmse, v.cv_rmse, v.bic, v.noise_floor]
                                      for v in history.versions]))
            parts.append(_img(files["error_fall.png"], "error over model versions"))
        style = ("body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}"
                 "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;"
                 "text-align:right}th{background:#eee}img{max-width:100%}code{background:#f4f4f4}")
        doc = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
               f"<style>{style}</style></head><body>{''.join(parts)}</body></html>\n")
        (tmp / "report.html").write_text(doc, encoding="utf-8")
        out.mkdir(parents=True, exist_ok=True)
        for f in sorted(tmp.iterdir()):
            os.replace(f, out / f.name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out / "report.html"
