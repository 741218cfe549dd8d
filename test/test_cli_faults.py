"""Every command-line fault an operator can cause: one line on stderr naming the problem, exit
code 2, no traceback, and nothing started or written (the fault is found before any work).

Each case ran into a traceback, exit code 0 or 1, or a whole demo cycle before the checks
were added (issue "The alarm must get through", point 6)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from jointwear_ros.cli import main
from jointwear_ros.data import synth_observations
from jointwear_ros.io.tables import write_bag, write_csv

# A directory no one can create files in, even root (the probe is real, not os.access).
UNWRITABLE = "/proc/jointwear-nope" if Path("/proc/self").is_dir() else None


def snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """Every file and directory under ``root`` with its size and modification time."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            st = p.stat()
            out[str(p.relative_to(root))] = (st.st_size if p.is_file() else -1, st.st_mtime_ns if p.is_file() else 0)
    return out


def run_main(capsys: pytest.CaptureFixture[str], args: list[str]) -> tuple[int, str, str]:
    try:
        rc = main(args)
    except SystemExit as exc:  # argparse errors
        rc = int(exc.code or 0)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def assert_fault(capsys: pytest.CaptureFixture[str], root: Path, args: list[str], message: str) -> str:
    """``jointwear ARGS`` exits 2 with one stderr line holding ``message`` and leaves ``root`` as it was."""
    before = snapshot(root)
    rc, _out, err = run_main(capsys, args)
    lines = err.strip().splitlines()
    assert rc == 2, f"exit code {rc}; stderr: {err[-2000:]}"
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}: {err[-2000:]}"
    assert lines[0].startswith("jointwear: error: "), lines[0]
    assert message in lines[0], lines[0]
    assert "Traceback" not in err
    assert snapshot(root) == before, "the command wrote or changed files before failing"
    return lines[0]


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Input files: a good CSV, bad CSVs, a binary file, a bag of observations."""
    d = tmp_path_factory.mktemp("inputs")
    table = synth_observations(n_cycles=4, seed=1)
    files = {
        "csv": write_csv(table, d / "obs.csv"),
        "bag": write_bag(table, d / "obs_bag"),
        "binary": d / "binary.yaml",
        "one_row": d / "one_row.csv",
        "negative_speed": d / "negative_speed.csv",
        "negative_std": d / "negative_std.csv",
        "nan_load": d / "nan_load.csv",
        "cold": d / "cold.csv",
    }
    files["binary"].write_bytes(bytes(range(256)) * 2)
    files["one_row"].write_text("speed,tau_f\n10,0.1\n")
    rows = "".join(f"{v},0.08,0.1,40,0.0015\n" for v in (20, 30, 40, 50, 60, 80, 100, 120))
    files["negative_speed"].write_text("speed,tau_f,load_torque,temperature,tau_f_std\n-10,0.08,0.1,40,0.0015\n" + rows)
    files["negative_std"].write_text("speed,tau_f,load_torque,temperature,tau_f_std\n10,0.08,0.1,40,-0.0015\n" + rows)
    files["nan_load"].write_text("speed,tau_f,load_torque,temperature,tau_f_std\n10,0.08,nan,40,0.0015\n" + rows)
    files["cold"].write_text("speed,tau_f,load_torque,temperature,tau_f_std\n10,0.08,0.1,-300,0.0015\n" + rows)
    return files


@pytest.fixture()
def work(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The current directory of the command: a file in it (``afile``) and nothing else."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("not a directory\n")
    return tmp_path


# -- output paths that cannot be written ------------------------------------------------
OUTPUT_CASES = [
    # (argument list with {csv}/{out}, the message)
    (["model", "curve", "--plot", "{out}.png"], "--plot"),
    (["model", "fit", "{csv}", "--model", "standard", "--report", "{out}"], "--report"),
    (["model", "fit", "{csv}", "--model", "standard", "--history", "{out}.json"], "--history"),
    (["model", "compare", "{csv}", "--model", "standard", "--plot", "{out}"], "--plot"),
    (["model", "add", "{csv}", "--model", "standard", "--term", "viscous", "--plot", "{out}"], "--plot"),
    (["model", "add", "{csv}", "--model", "standard", "--term", "viscous", "--history", "{out}.json"], "--history"),
    (["model", "report", "{csv}", "--model", "standard", "--out", "{out}", "--no-diagnose"], "--out"),
    (["study", "--runs", "20", "--speeds", "40", "--quiet", "--plot", "{out}"], "--plot"),
    (["study", "case", "--speeds", "40", "--quiet", "--plot", "{out}"], "--plot"),
    (["data", "synth", "{out}.csv", "--cycles", "2"], "OUT"),
    (["data", "synth", "{out}", "--cycles", "2"], "OUT"),
    (["demo", "--out", "{out}", "--timeout", "5"], "--out"),
]


@pytest.mark.parametrize(("args", "flag"), OUTPUT_CASES, ids=[" ".join(a[:2]) + " " + f for a, f in OUTPUT_CASES])
@pytest.mark.parametrize("where", ["under_a_file", "unwritable_dir"])
def test_an_output_path_that_cannot_be_written_is_refused_before_any_work(capsys, data, work, args, flag, where):
    if where == "unwritable_dir":
        if UNWRITABLE is None:
            pytest.skip("no /proc here")
        out = f"{UNWRITABLE}/x"
    else:
        out = str(work / "afile" / "x")  # a path under a regular file
    argv = [a.format(csv=data["csv"], out=out) for a in args]
    line = assert_fault(capsys, work, argv, flag)
    assert "afile" in line or "/proc" in line


def test_demo_out_naming_a_file_is_refused_before_any_node_starts(capsys, work):
    line = assert_fault(capsys, work, ["demo", "--out", "afile", "--timeout", "5"], "--out: 'afile'")
    assert "not a directory" in line


def test_a_directory_given_as_history_file_is_refused(capsys, data, work):
    (work / "hist").mkdir()
    assert_fault(capsys, work, ["model", "fit", str(data["csv"]), "--model", "standard", "--history", "hist"],
                 "--history: 'hist' is a directory")


# -- bad files and methods -----------------------------------------------------------------
@pytest.mark.parametrize("flag", ["--observer-params", "--estimator-params"])
def test_replay_with_a_binary_params_file_is_one_line(capsys, data, work, flag):
    assert_fault(capsys, work, ["replay", str(data["bag"]), flag, str(data["binary"])],
                 f"{flag}: '{data['binary']}' is not a UTF-8 text file")


def test_replay_with_a_directory_as_params_file_is_one_line(capsys, data, work):
    assert_fault(capsys, work, ["replay", str(data["bag"]), "--estimator-params", str(work)], "is a directory")


def test_replay_with_an_unknown_method_exits_2(capsys, data, work):
    assert_fault(capsys, work, ["replay", str(data["bag"]), "--method", "foo"],
                 "--method: unknown wear estimation method 'foo'; choose one of paper, paper-grid, bayes, joint")


@pytest.mark.parametrize("args", [["--method", "foo"], ["--set", "wear_estimator.method=foo"]])
def test_demo_with_an_unknown_method_is_refused_before_any_node_starts(capsys, work, args):
    line = assert_fault(capsys, work, ["demo", "--out", "cell", "--timeout", "5", *args], "unknown wear estimation method")
    assert not (work / "cell").exists()
    assert "'foo'" in line


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--timeout", "-5"], "--timeout: -5 must be more than 0"),
        (["--temperature", "-300"], "--temperature: temperature = -300 is outside the valid range [20, 60]"),
        (["--set", "joint_sim.temperature=-300"], "--set joint_sim.temperature=-300: outside the declared range"),
        (["--set", "joint_sim.temperature=90"], "--set joint_sim.temperature: temperature = 90 is outside"),
        (["--set", "joint_sim.no_such_param=1"], "--set joint_sim.no_such_param: joint_sim has no parameter"),
        (["--set", "joint_sim.wear=300"], "--set joint_sim.wear=300: outside the declared range [0.0, 100.0]"),
        (["--speeds", "10,1e6"], "--speeds: 1e+06 rad/s is above test_cycle's max_speed 280 rad/s"),
        (["--speeds", "1:100:1000"], "--speeds: 1000 speeds; a demo cycle takes at most 64"),
    ],
)
def test_demo_arguments_are_checked_before_any_node_starts(capsys, work, args, message):
    assert_fault(capsys, work, ["demo", "--out", "cell", "--timeout", "5", *args], message)


def test_a_binary_parameter_set_file_is_one_line(capsys, data, work):
    assert_fault(capsys, work, ["model", "curve", "--params", str(data["binary"])],
                 "not a UTF-8 text file")


# -- sizes a command cannot handle -------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["study", "--runs", "1000000000000", "--speeds", "40", "--quiet"],
         "--runs: 1,000,000,000,000 is more than the 1,000,000 a study handles"),
        (["study", "--runs", "20", "--speeds", "40", "--n-samples", "1000000000000", "--quiet"],
         "--n-samples: 1,000,000,000,000 is more than"),
        (["study", "--runs", "1000000", "--speeds", "0:280:5000", "--quiet"], "GB of memory"),
        (["study", "--runs", "20", "--speeds", "0:280:1000000000", "--quiet"], "--speeds: count 1000000000"),
        (["model", "curve", "--speeds", "0:280:1000000000"], "--speeds: count 1000000000"),
        (["cycle", "design", "--speeds-candidates", "0:280:100000000"], "--speeds-candidates: count 100000000"),
        (["cycle", "design", "--budget", "1e300"], "--budget 1e+300 s at 14 s per speed gives 7.143e+298 speeds"),
        (["data", "synth", "big.csv", "--cycles", "1000000000"], "--cycles 1,000,000,000 x 10 speeds"),
        (["data", "synth", "neg.csv", "--seed", "-1"], "--seed: -1 must be >= 0"),
        (["data", "synth", "loud.csv", "--noise", "1e308"], "--noise: 1e+308 must be within [0, 1]"),
    ],
)
def test_sizes_a_command_cannot_handle_are_refused_up_front(capsys, work, args, message):
    assert_fault(capsys, work, args, message)


# -- non-physical values -------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["study", "--true-temperature", "normal:-300:3", "--runs", "20", "--speeds", "40", "--quiet"],
         "--true-temperature: normal temperature N(-300, 3^2) reaches below absolute zero"),
        (["study", "--assumed-temperature", "1000:2000", "--runs", "20", "--speeds", "40", "--quiet"],
         "--assumed-temperature: uniform:1000:2000 puts more than 5 % of its mass"),
        (["study", "--method", "bayes", "--assumed-temperature", "normal:40:1e-300", "--runs", "20", "--speeds", "40",
          "--quiet"], "std below 1e-06 degC"),
        (["study", "--true-temperature", "uniform:-1e308:1e308", "--runs", "20", "--speeds", "40", "--quiet"],
         "must be finite"),
        (["study", "--load", "1e300", "--runs", "20", "--speeds", "40", "--quiet"], "--load: load_torque = 1e+300"),
        (["study", "--speeds", "1e300", "--runs", "20", "--quiet"], "--speeds: speed = 1e+300 is outside"),
        (["study", "--noise-std", "1e300", "--runs", "20", "--speeds", "40", "--quiet"], "--noise-std: 1e+300"),
        (["cycle", "design", "--prior", "uniform:-400:-300"], "--prior: uniform temperature range [-400, -300] "
                                                              "reaches below absolute zero"),
        (["cycle", "design", "--prior", "normal:40:15"], "outside the valid temperature range [20, 60]"),
        (["cycle", "design", "--noise-std", "1e-12"], "the bound's quadrature resolves at most"),
    ],
)
def test_non_physical_distributions_and_settings_are_refused(capsys, work, args, message):
    assert_fault(capsys, work, args, message)


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("one_row", "1 observation(s) cannot fit model 'coulomb + stribeck + viscous', which has 4 free parameters"),
        ("negative_speed", "column 'speed', row 1 (line 2): -10 is negative"),
        ("negative_std", "column 'tau_f_std', row 1 (line 2): -0.0015 is negative"),
        ("nan_load", "column 'load_torque', row 1 (line 2): 'nan' is not a finite number"),
        ("cold", "column 'temperature', row 1 (line 2): -300 degC is below absolute zero"),
    ],
)
@pytest.mark.parametrize("action", ["fit", "report"])
def test_model_fit_on_data_it_cannot_fit_is_refused(capsys, data, work, name, message, action):
    extra = ["--out", "report"] if action == "report" else ["--report", "report"]
    assert_fault(capsys, work, ["model", action, str(data[name]), "--model", "standard", *extra], message)
    assert not (work / "report").exists()


def test_fix_outside_the_parameter_bounds_is_refused(capsys, data, work):
    assert_fault(capsys, work, ["model", "fit", str(data["csv"]), "--model", "standard", "--fix", "Fc0=1e308"],
                 "--fix Fc0: 1e+308 is outside the parameter's bounds [0, 1]")


def test_design_never_prints_a_bound_below_the_known_temperature_bound(capsys):
    """The "bound std 0.000" of the issue: an unresolved quadrature gave a bound far below what knowing
    T gives, which no estimator can reach. Inside the set's range the shared-T bound stays above it."""
    import json

    rc, out, err = run_main(capsys, ["cycle", "design", "--prior", "uniform:20:60", "--budget", "42", "--json"])
    assert rc == 0, err
    d = json.loads(out)
    assert d["bound_std"] >= d["known_temperature_bound_std"] * 0.99
    assert d["bound_std"] > 0.1


# -- the real process ----------------------------------------------------------------------
def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "jointwear_ros", *args], capture_output=True, text=True,
                          timeout=120, cwd=cwd)


def test_the_real_process_prints_one_line_and_verbose_adds_the_traceback(data, tmp_path):
    r = run_cli("study", "--runs", "1000000000000", "--speeds", "40", "--quiet", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--runs" in r.stderr, r.stderr
    r = run_cli("model", "curve", "--params", str(data["binary"]), "--verbose", cwd=tmp_path)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert lines[0].startswith("Traceback") and "ParameterSetError" in r.stderr
    assert lines[-1].startswith("jointwear: error: ") and "not a UTF-8 text file" in lines[-1]
    assert list(tmp_path.iterdir()) == []


def test_an_error_of_the_environment_half_way_is_one_line(monkeypatch, capsys, data, work):
    """A write that fails after the checks (disk full) is still one line and exit 2."""
    import jointwear_ros.io.tables as tables

    def disk_full(*args, **kwargs):
        raise OSError(28, "No space left on device", "obs.csv")

    monkeypatch.setattr(tables, "write_csv", disk_full)
    rc, _out, err = run_main(capsys, ["data", "synth", "obs.csv", "--cycles", "2"])
    assert rc == 2 and err == "jointwear: error: obs.csv: No space left on device\n"
    assert not (work / "obs.csv").exists()


def test_an_error_over_several_lines_is_the_one_line_errors_makes(monkeypatch, capsys, data, work):
    """The CLI's line is :func:`jointwear_ros.errors.one_line` of its message (the one place): every word
    of an error whose text runs over several lines (a library's message inside ours), on one line."""
    import jointwear_ros.io.tables as tables
    from jointwear_ros.errors import InputDataError, one_line

    text = "obs.csv: cannot write:\n  while scanning a row\n    row 2, column 3"

    def refuse(*args, **kwargs):
        raise InputDataError(text)

    monkeypatch.setattr(tables, "write_csv", refuse)
    rc, _out, err = run_main(capsys, ["data", "synth", "obs.csv", "--cycles", "2"])
    assert rc == 2
    assert err == f"jointwear: {one_line('error: ' + text)}\n"
    assert err == "jointwear: error: obs.csv: cannot write: while scanning a row row 2, column 3\n"


def test_an_integer_above_what_a_command_handles_names_the_command(capsys):
    """One integer check (cli.common.parse_int) for every command: the study's own copy is gone, its words kept."""
    from jointwear_ros.cli import UsageError
    from jointwear_ros.cli.common import parse_int

    with pytest.raises(UsageError, match=r"^--runs: 2,000,000 is more than the 1,000,000 a study handles$"):
        parse_int("2000000", "--runs", 2, 1_000_000, handler="a study")
    with pytest.raises(UsageError, match=r"^--cycles: 5,000 is more than the 1,000 this command handles$"):
        parse_int(" 5000 ", "--cycles", 1, 1_000)
    assert parse_int(" 7 ", "--seed", 0) == 7


def test_the_demos_domain_is_the_given_one_else_the_environments(monkeypatch):
    from jointwear_ros.cli.demo_cmd import _domain_id

    monkeypatch.setenv("ROS_DOMAIN_ID", "42")
    assert _domain_id(7) == 7 and _domain_id(None) == 42
    monkeypatch.setenv("ROS_DOMAIN_ID", "")
    assert 10 <= _domain_id(None) <= 99
