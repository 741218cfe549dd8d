"""``jointwear model fit|diagnose|compare|add|report`` and ``jointwear data synth|effects|show``:
the documented JSON contracts (docs/workbench.md), reports, history, and one-line errors with exit code 2."""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import pickle
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from jointwear_ros.cli import main
from jointwear_ros.data import EFFECT_FAMILIES, synth_observations
from jointwear_ros.io.tables import write_csv
from jointwear_ros.types import ObservationTable
from jointwear_ros.workbench import parse_spec


def run_main(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    try:
        rc = main(list(args))
    except SystemExit as exc:  # argparse errors
        rc = int(exc.code or 0)
    out = capsys.readouterr()
    return rc, out.out, out.err


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "jointwear_ros", *args], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


@pytest.fixture(scope="module")
def ripple_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """400 observations of the paper model with a hidden position ripple."""
    return write_csv(synth_observations(n_cycles=40, effects=["ripple"], seed=4),
                     tmp_path_factory.mktemp("data") / "ripple.csv")


@pytest.fixture(scope="module")
def one_diagnosis() -> Iterator[dict[bytes, object]]:
    """The module's ``model diagnose`` runs of one table with one model and the same options compute the diagnosis
    once: each test reads its own rendering (JSON, text, Markdown, HTML) of the same result, through the whole
    command (reading, fitting, rendering). Different options or data are diagnosed anew."""
    import jointwear_ros.workbench as wb

    real, done = wb.diagnose, {}

    def diagnose(table: ObservationTable, model: object, **kw: object):
        key = hashlib.sha256(pickle.dumps(([(k, np.asarray(v).tobytes()) for k, v in table.columns.items()],
                                           model.spec, [(n, p.value) for n, p in model.params.items()],
                                           repr(sorted((k, v) for k, v in kw.items() if k != "progress"))))).digest()
        if key not in done:
            done[key] = real(table, model, **kw)
        return done[key]

    mp = pytest.MonkeyPatch()
    mp.setattr(wb, "diagnose", diagnose)
    yield done
    mp.undo()


@pytest.fixture(scope="module")
def diagnosis(ripple_csv: Path, one_diagnosis) -> dict:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["model", "diagnose", str(ripple_csv), "--model", "paper", "--json"]) == 0
    return json.loads(out.getvalue())


# -- the JSON contracts -------------------------------------------------------------
def test_fit_json_contract(ripple_csv, capsys):
    rc, out, err = run_main(capsys, "model", "fit", str(ripple_csv), "--model", "paper", "--json")
    assert rc == 0, err
    doc = json.loads(out)
    for key in ("rmse", "cv_rmse", "aic", "bic"):
        assert isinstance(doc[key], float), key
    assert doc["cv_rmse"] >= doc["rmse"] > 0
    assert set(doc["params"]) == set(parse_spec("paper").param_names)
    for name, p in doc["params"].items():
        assert {"value", "stderr"} <= set(p), name
        assert isinstance(p["value"], float) and isinstance(p["stderr"], float) and p["stderr"] > 0


@pytest.mark.slow
def test_fit_json_states_the_goodness_of_fit_against_the_noise_floor(ripple_csv, diagnosis, capsys):
    rc, out, err = run_main(capsys, "model", "fit", str(ripple_csv), "--model", "paper", "--json")
    assert rc == 0, err
    g = json.loads(out)["goodness_of_fit"]
    assert g["method"] == "chi-square with tau_f_std" and g["consistent"] is False and g["p_value"] < 1e-6
    # the spec diagnose suggests, added with `model add`, ends consistent with the noise
    rc, out, err = run_main(capsys, "model", "add", str(ripple_csv), "--model", "paper", "--term",
                            diagnosis["suggestion"], "--json")
    assert rc == 0, err
    doc = json.loads(out)
    assert doc["goodness_of_fit"]["after"]["consistent"] is True
    assert doc["after"]["cv_rmse"] < 1.3 * 0.0015


@pytest.mark.slow
def test_diagnose_json_contract(diagnosis):
    d = diagnosis
    assert {"model", "n", "rmse", "cv_rmse", "noise_floor", "missing_effect_found", "candidates", "verdict",
            "variables", "suggestion"} <= set(d)
    assert d["model"] == parse_spec("paper").spec
    assert d["n"] == 400 and isinstance(d["n"], int)
    for key in ("rmse", "cv_rmse"):
        assert isinstance(d[key], float), key
    assert d["noise_floor"]["value"] == pytest.approx(0.0015)
    assert d["noise_floor"]["method"] == "chi-square with tau_f_std" == d["noise_source"]
    assert d["noise_floor"]["consistent"] is False and d["noise_floor"]["p_value"] < 1e-6
    assert d["missing_effect_found"] is True and d["verdict"] == "found"
    assert d["variables"][0]["name"] == "position" and d["variables"][0]["p_value"] < 1e-6
    assert d["suggestion"] == d["candidates"][0]["term"]
    cands = d["candidates"]
    # guided library: the generic shapes of position (the column the ranking found) and the fitted shapes
    assert len(cands) >= 5
    for c in cands:
        assert {"term", "variables", "cv_rmse", "delta_bic", "significant"} <= set(c)
        assert isinstance(c["term"], str) and isinstance(c["variables"], list) and c["variables"]
        assert isinstance(c["cv_rmse"], float) and isinstance(c["delta_bic"], float)
        assert isinstance(c["significant"], bool)
    # best first: significant ones ahead, then by cross-validated error
    sig = [c["significant"] for c in cands]
    assert sig == sorted(sig, reverse=True)
    insignificant = [c["cv_rmse"] for c in cands if not c["significant"]]
    assert insignificant == sorted(insignificant)
    assert cands[0]["term"].startswith("ripple(position, w0=") and cands[0]["variables"] == ["position"]


@pytest.mark.slow
def test_every_candidate_term_appended_to_the_spec_is_accepted_by_fit(diagnosis, ripple_csv, capsys):
    for c in diagnosis["candidates"]:  # every one parses as 'SPEC + TERM'
        assert parse_spec(f"paper + {c['term']}").term_names[-1] == c["term"]
    for c in diagnosis["candidates"][:3]:  # and the best ones fit from the command line
        rc, out, err = run_main(capsys, "model", "fit", str(ripple_csv), "--model", f"paper + {c['term']}", "--json")
        assert rc == 0, err
        doc = json.loads(out)
        assert doc["model"].endswith(c["term"])
        assert doc["cv_rmse"] == pytest.approx(c["cv_rmse"], rel=0.05)
    # the model string diagnose reports works the same way
    rc, out, err = run_main(capsys, "model", "fit", str(ripple_csv), "--model",
                            f"{diagnosis['model']} + {diagnosis['candidates'][0]['term']}", "--json")
    assert rc == 0, err
    assert json.loads(out)["cv_rmse"] < 1.3 * diagnosis["noise_floor"]["value"]


def test_diagnose_table_names_the_effect_and_the_next_command(ripple_csv, one_diagnosis, capsys):
    rc, out, err = run_main(capsys, "model", "diagnose", str(ripple_csv), "--model", "paper", "--top", "3")
    assert rc == 0, err
    assert "Missing effect found: ripple(position, w0=" in out and "verdict: found" in out
    assert "friction periodic in position" in out
    assert "which columns explain the residual" in out and "periodogram" in out
    m = re.search(r'Try: --model "([^"]+)"', out)
    assert m and parse_spec(m.group(1)).term_names[-1].startswith("ripple(position, w0=")


# -- reports ----------------------------------------------------------------------------
def test_fit_report_writes_pngs_and_a_self_contained_html(ripple_csv, tmp_path, capsys):
    out_dir = tmp_path / "report"
    rc, out, err = run_main(capsys, "model", "fit", str(ripple_csv), "--model", "paper + ripple(position)",
                            "--report", str(out_dir))
    assert rc == 0, err
    assert f"report written to {out_dir / 'report.html'}" in out
    pngs = sorted(p.name for p in out_dir.glob("*.png"))
    assert pngs == ["bands.png", "fit.png", "residuals.png"]
    for p in pngs:
        assert (out_dir / p).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out_dir / "report.html").read_text(encoding="utf-8")
    assert html.count('src="data:image/png;base64,') == len(pngs)
    assert not re.search(r"https?://|<link|<script|src=\"(?!data:)|url\(", html)
    assert "ripple(position)" in html and "Parameters" in html
    assert "goodness of fit: chi-square with tau_f_std" in html and "consistent with the noise" in html
    assert sorted(p.name for p in out_dir.iterdir()) == sorted([*pngs, "report.html"])
    assert [p.name for p in tmp_path.iterdir()] == ["report"]  # no temporary directory left


@pytest.mark.slow
def test_diagnose_prints_json_and_html_say_the_same(ripple_csv, diagnosis, tmp_path, capsys):
    import html as html_lib

    rc, out, err = run_main(capsys, "model", "diagnose", str(ripple_csv), "--model", "paper", "--report",
                            str(tmp_path / "d"))
    assert rc == 0, err
    page = html_lib.unescape((tmp_path / "d" / "report.html").read_text(encoding="utf-8"))
    assert f"verdict: {diagnosis['verdict']}" in out and f"verdict: {diagnosis['verdict']}" in page
    assert diagnosis["summary"] in out and diagnosis["summary"] in page
    for v in diagnosis["variables"][:3]:
        assert v["shape_hint"] in out and v["shape_hint"] in page


def test_diagnose_markdown_says_what_the_json_says_in_markdown(ripple_csv, diagnosis, capsys):
    rc, out, err = run_main(capsys, "model", "diagnose", str(ripple_csv), "--model", "paper", "--markdown", "--top", "5")
    assert rc == 0, err
    lines = out.splitlines()
    assert lines[0] == f"## Diagnosis of `{diagnosis['model']}`"
    assert f"**verdict: {diagnosis['verdict']}**" in lines and diagnosis["summary"] in lines
    assert "| # | variable | explains | p (adj.) | signif. | test | shape |" in lines
    rows = [line for line in lines if line.startswith("| 1 | ")]
    assert len(rows) == 2 and diagnosis["variables"][0]["shape_hint"] in rows[0]
    assert rows[1].startswith(f"| 1 | {diagnosis['candidates'][0]['term']} | ")
    rc, _, err = run_main(capsys, "model", "diagnose", str(ripple_csv), "--model", "paper", "--markdown", "--json")
    assert rc == 2 and "not allowed with argument" in err


def test_report_command_with_diagnosis_and_history(ripple_csv, tmp_path, capsys):
    hist = tmp_path / "h.json"
    rc, _, err = run_main(capsys, "model", "add", str(ripple_csv), "--model", "paper", "--term", "ripple(position)",
                          "--history", str(hist))
    assert rc == 0, err
    rc, out, err = run_main(capsys, "model", "report", str(ripple_csv), "--model", "paper + ripple(position)",
                            "--history", str(hist), "--out", str(tmp_path / "r"))
    assert rc == 0, err
    assert "report written to" in out
    html = (tmp_path / "r" / "report.html").read_text(encoding="utf-8")
    assert "Diagnosis: which effect is missing?" in html and "verdict: nothing_missing" in html
    assert "Nothing missing" in html and (tmp_path / "r" / "dependence.png").is_file()
    assert "Model versions" in html and (tmp_path / "r" / "error_fall.png").is_file()
    assert not re.search(r"https?://|<link|<script", html)


# -- add and history ------------------------------------------------------------------
def test_add_shows_before_and_after_per_speed_band_and_keeps_a_json_history(ripple_csv, tmp_path, capsys):
    hist = tmp_path / "history.json"
    rc, out, err = run_main(capsys, "model", "add", str(ripple_csv), "--model", "paper",
                            "--term", "ripple(position)", "--history", str(hist), "--plot", str(tmp_path / "plots"))
    assert rc == 0, err
    assert "RMSE before" in out and "RMSE after" in out
    bands = re.findall(r"^\s*(\d+-\d+|\d+\+)\s+(\d+)\s+([0-9.]+)\s+([0-9.]+)\s+([0-9.]+)x$", out, re.M)
    assert [b[0] for b in bands] == ["0-10", "10-30", "30-60", "60-100", "100-150", "150-200", "200+"]
    assert sum(int(b[1]) for b in bands) == 400
    assert all(float(b[3]) < float(b[2]) for b in bands)  # the ripple is at every speed: every band improves
    assert "CV RMSE fell" in out
    doc = json.loads(hist.read_text())
    assert doc["format"] == "jointwear-model-history/1"
    assert [v["model"] for v in doc["versions"]] == [parse_spec("paper").spec, parse_spec("paper + ripple(position)").spec]
    assert doc["versions"][1]["cv_rmse"] < doc["versions"][0]["cv_rmse"]
    assert set(doc["versions"][0]["bands"]) == {b[0] for b in bands}
    for name in ("residuals_before_after.png", "bands_before_after.png", "error_fall.png"):
        assert (tmp_path / "plots" / name).is_file()
    # the next step appends one version (the 'before' is already the last one)
    rc, out, err = run_main(capsys, "model", "add", str(ripple_csv), "--model", "paper + ripple(position)",
                            "--term", "lin(time)", "--history", str(hist), "--json")
    assert rc == 0, err
    step = json.loads(out)
    assert [b["band"] for b in step["before"]["bands"]] == [b["band"] for b in step["after"]["bands"]]
    doc = json.loads(hist.read_text())
    assert len(doc["versions"]) == 3 and doc["versions"][2]["note"] == "added lin(time)"
    assert [v["version"] for v in doc["versions"]] == [1, 2, 3]


def test_compare_lists_errors_per_band_and_residual_structure(ripple_csv, capsys):
    rc, out, err = run_main(capsys, "model", "compare", str(ripple_csv), "--model", "standard", "--model", "paper",
                            "--json")
    assert rc == 0, err
    doc = json.loads(out)
    std, paper = doc["models"]
    assert paper["cv_rmse"] < std["cv_rmse"]
    assert {b["band"] for b in paper["bands"]} >= {"0-10", "200+"}
    # what is left after the paper model is structured in position (the hidden ripple)
    assert paper["residual_structure"][0]["column"] == "position"


# -- data synth / effects / show ----------------------------------------------------
def test_data_synth_writes_csv_and_bag_that_the_workbench_reads(tmp_path, capsys):
    rc, out, err = run_main(capsys, "data", "synth", str(tmp_path / "o.csv"), "--cycles", "3", "--hidden", "ripple",
                            "--seed", "9", "--json")
    assert rc == 0, err
    assert json.loads(out)["rows"] == 30
    rc, out, err = run_main(capsys, "data", "synth", str(tmp_path / "o_bag"), "--cycles", "3", "--seed", "9")
    assert rc == 0, err
    for data in ("o.csv", "o_bag"):
        rc, out, err = run_main(capsys, "data", "show", str(tmp_path / data), "--json")
        assert rc == 0, err
        doc = json.loads(out)
        assert doc["rows"] == 30 and doc["cycles"] == 3 and doc["noise_floor"] == pytest.approx(0.0015)
    rc, out, _ = run_main(capsys, "data", "effects")
    for name in EFFECT_FAMILIES:
        assert name in out
    # a bag is never overwritten
    rc, out, err = run_main(capsys, "data", "synth", str(tmp_path / "o_bag"), "--cycles", "3")
    assert rc == 2 and "already exists" in err


# -- bad input: one line, exit code 2, nothing written ------------------------------
BAD_CSV = {
    "missing.csv": ("speed,load_torque\n10,0.1\n", "column 'tau_f' is missing"),
    "nan.csv": ("speed,tau_f\n10,0.1\n20,nan\n", "column 'tau_f', row 2 (line 3)"),
    "text.csv": ("speed,tau_f,load_torque\n10,0.1,0.2\n20,0.1,heavy\n", "column 'load_torque', row 2 (line 3): 'heavy'"),
    "empty.csv": ("", "the file is empty"),
    "noload.csv": ("speed,tau_f\n10,0.1\n20,0.2\n", "column 'load_torque' is missing, needed by model"),
}


@pytest.mark.parametrize("action", ["fit", "diagnose", "add", "report"])
@pytest.mark.parametrize("name", sorted(BAD_CSV))
def test_bad_input_gives_one_line_error_exit_code_2_and_writes_nothing(tmp_path, capsys, action, name):
    content, message = BAD_CSV[name]
    data = tmp_path / name
    data.write_text(content)
    extra = {"fit": ["--report", str(tmp_path / "out"), "--history", str(tmp_path / "h.json")],
             "diagnose": ["--report", str(tmp_path / "out")],
             "add": ["--term", "ripple(position)", "--history", str(tmp_path / "h.json"), "--plot", str(tmp_path / "out")],
             "report": ["--out", str(tmp_path / "out")]}[action]
    rc, out, err = run_main(capsys, "model", action, str(data), "--model", "paper", *extra)
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("jointwear: error: ") and message in lines[0]
    if name != "noload.csv":
        assert str(data) in lines[0]  # names the file
    assert out == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--model", "paper + lubrication_drag"], "unknown term 'lubrication_drag'"),
        (["--model", "paper + wobble(position)"], "unknown term shape 'wobble'"),
        (["--model", "paper + x_stribeck(lube_hours)"], "column 'lube_hours' is missing, needed by model"),
        (["--model", "paper", "--fix", "Nope=1"], "--fix: model"),
        (["--model", "paper", "--fix", "Fc0=abc"], "--fix Fc0: 'abc' is not a number"),
        (["--model", "paper", "--folds", "1"], "--folds: 1 must be 0"),
        (["--model", "paper", "--params", "nosuchset"], "unknown parameter set 'nosuchset'"),
        (["--model", "paper", "--bogus"], "unrecognized arguments"),
        ([], "the following arguments are required: --model"),
    ],
)
def test_bad_arguments_give_one_line_error_and_exit_code_2(tmp_path, capsys, args, message):
    synth = synth_observations(n_cycles=3, seed=0)
    # without lube_hours, for the missing-column case
    table = ObservationTable({k: v for k, v in synth.columns.items() if k != "lube_hours"})
    data = write_csv(table, tmp_path / "obs.csv")
    rc, out, err = run_main(capsys, "model", "fit", str(data), *args)
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert message in lines[0]
    assert out == ""


def test_the_real_command_exits_2_with_one_line_on_bad_data(tmp_path):
    (tmp_path / "bad.csv").write_text("speed,tau_f\n10,0.1\n20,0.1O\n")
    r = run_cli("model", "diagnose", "bad.csv", "--model", "paper", "--json", cwd=tmp_path)
    assert r.returncode == 2
    assert r.stdout == ""
    assert r.stderr.strip() == "jointwear: error: bad.csv: column 'tau_f', row 2 (line 3): '0.1O' is not a number"
    r = run_cli("model", "fit", "missing.csv", "--model", "paper", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.strip() == "jointwear: error: missing.csv: no such file or directory"
