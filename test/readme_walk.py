"""The README walk's machinery (issue 24): README.md's and its guides' commands, and README.md's commands
run in order, in independent chains (issue 29).

Each chain runs in its own scratch directory on its own test file (``test_readme_walk_<chain>.py``), so the
ros tier's workers share the walk: a chain's commands run in README order, and a command's placeholders
(``BAG``, ``URL``, ...) are what its chain's earlier commands made. ``test_readme_runs.py`` checks that every
command is in exactly one chain and that each chain has its file. Not a test module: pytest does not
collect it.
"""

from __future__ import annotations

import glob
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```$", re.S | re.M)
LINK = re.compile(r"\]\((docs/[\w\-]+\.md)")


def documents() -> list[Path]:
    """README.md and every docs/ page it links."""
    text = README.read_text(encoding="utf-8")
    return [README] + [ROOT / p for p in sorted(set(LINK.findall(text)))]


def command_lines(md: Path) -> list[tuple[int, str]]:
    """(line number, command) of every ``jointwear`` command in the ``sh`` blocks of ``md``, comments cut,
    continuation lines joined."""
    text = md.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        if m.group(1) not in ("sh", "bash", ""):
            continue
        first = text.count("\n", 0, m.start(2)) + 1
        joined = re.sub(r"\\\n\s*", " ", m.group(2))
        # a synopsis continues on indented lines of options: `    [--json] --out FILE`
        joined = re.sub(r"\n[ \t]+(?=\[|--)", " ", joined)
        lines = m.group(2).splitlines()
        n = 0
        for line in joined.splitlines():
            while n < len(lines) and line.split()[:2] != lines[n].split()[:2] if line.split() else False:
                n += 1
            cmd = re.split(r"\s#\s|\s#$|\s{2,}#", line)[0].strip()
            if re.match(r"(\.venv/bin/)?jointwear\s", cmd):
                out.append((first + n, cmd))
    return out


def _words(cmd: str) -> list[str]:
    """The command's arguments with the optional parts taken (``[--json]`` -> ``--json``) and the
    repetition marks dropped (``BAG...`` -> ``BAG``; ``--db ...`` -> ``--db X``)."""
    # shell expansions of a documented script: arithmetic -> 1, "${array[@]}" -> nothing, others -> X
    cmd = re.sub(r"\$\(\(.*?\)\)", "1", cmd)
    cmd = re.sub(r'"?\$\{\w+\[@\]\}"?', " ", cmd)
    cmd = re.sub(r"\$\{[^}]*\}|\$\w+", "X", cmd)
    cmd = re.sub(r"(\w)\[(=[^\]]*)\]", r"\1\2", cmd)  # NAME[=VALUE] -> NAME=VALUE
    cmd = cmd.replace("]...", "]").replace("[", " ").replace("]", " ")
    words = []
    for w in shlex.split(cmd)[1:]:
        if "|" in w and not w.startswith("-"):  # alternatives: auto|plateaus|bins -> auto
            w = w.split("|")[0]
        if w == "...":
            w = "X"
        elif w in PLACEHOLDER_VALUES:
            w = PLACEHOLDER_VALUES[w]
        elif w.endswith("...") and len(w) > 3:
            w = w[:-3]
        if w:
            words.append(w)
    return words


#: placeholders of arguments that take a choice or a whole number, with a valid value
PLACEHOLDER_VALUES = {"EFFECT": "ripple", "N": "2", "K": "5"}



# --------------------------------------------------------------------------- README.md runs in order


#: lines that need what a test machine has not, with why
NOT_HERE = (
    ("postgresql://", "a PostgreSQL server at the documented host"),
    ("tcp://", "a running Dask scheduler"),
    ("--publish", "a live ROS graph to play onto (tests/test_replay.py covers it)"),
    ("demo --commission", "4-10 min of wall time (measured in docs/nodes-bag-demo.md); test_demo_commission.py "
                          "runs it on one joint, test_commission_arm_run.py its plan on both arms in one process"),
    ("demo --production", "a minute of wall time each; test_demo_production.py runs the demo with --json and checks "
                          "its estimates and its replay"),
    ("'archive/", "a plant's bag archive (the other fleet lines run on the demo bags)"),
    ("from-timeseries log.csv", "the user's own recorded time series (test_timeseries.py converts CSVs)"),
    ("from-timeseries BAG", "a bag in which that joint swept at constant speeds; the README's last demo is a "
                            "one-joint run (test_timeseries.py converts a live demo bag both ways)"),
)


def _substitute(cmd: str, cwd: Path) -> str:
    """The README's placeholders replaced by what the earlier commands made."""
    bags = sorted(glob.glob(str(cwd / "out" / "demo" / "bags" / "jointwear_*")))
    versions = []
    db = cwd / "history.db"
    if db.exists():
        from jointwear_ros.history import HistoryStore

        with HistoryStore(f"sqlite:///{db}") as store:
            versions = store.analysis_versions()
    subs = {
        "BAGS...": "out/demo/bags/jointwear_*", "BAG...": "out/demo/bags/jointwear_*",
        "BAG": bags[-1] if bags else "BAG", "URL": "history.db", "DIR": "recovered",
    }
    words = []
    for w in cmd.replace("[", " ").replace("]", " ").split():
        words.append(subs.get(w, w))
    cmd = " ".join(words)
    if "VERSION" in cmd and versions:
        cmd = cmd.replace("--from VERSION", f"--from {versions[0]}").replace("--to VERSION", f"--to {versions[-1]}")
    return cmd


#: README.md's commands in order: (index, line, command, why it is left out or None)
WALK = [(i, line, cmd, next((w for k, w in NOT_HERE if k in cmd), None))
        for i, (line, cmd) in enumerate(command_lines(README))]
RUNS = [step for step in WALK if step[3] is None]


#: The walk's chains: a README command belongs to the first chain whose pattern it matches (``re.search``).
#: The Panda's and the payload demos, the other multi-joint demos (one joint after another, the
#: independent-joint robot), every other demo with every command that reads the demo bags or the history
#: made from them (the history's commands name joint_3: the six-joint demo's), and the rest (synthetic
#: tables, the workbench, studies, curves).
CHAINS = (
    ("arms", r"^jointwear demo --joints \d+ (--arm panda|--payload)"),
    ("demos", r"^jointwear demo --joints \d+ (--sweep|--arm none|--wear)"),
    ("bags", r"^jointwear (demo|history|trend|bag|replay|fleet)\b|from-production"),
    ("offline", r""),
)


def chain_of(cmd: str) -> str:
    """The chain a README command runs in."""
    return next(name for name, pattern in CHAINS if re.search(pattern, cmd))


def chain_runs(chain: str) -> list[tuple[int, int, str, str | None]]:
    """The chain's commands of :data:`RUNS`, in README order."""
    return [step for step in RUNS if chain_of(step[2]) == chain]


def chain_params(chain: str) -> dict:
    """``pytest.mark.parametrize`` keywords for the chain's commands: argvalues and ids."""
    runs = chain_runs(chain)
    return {"argvalues": [s[:3] for s in runs],
            "ids": [f"{i:02d}-README.md:{line}-{'-'.join(cmd.split()[1:3])}" for i, line, cmd, _ in runs]}


class ReadmeWalk:
    """One chain of README.md's commands run in order in one scratch directory, each at most once: a
    command's test runs first the earlier commands of its chain that have not run (it needs what they
    made), then its own."""

    def __init__(self, cwd: Path, chain: str):
        self.cwd = cwd
        self.runs = chain_runs(chain)
        self.env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
        self.done: dict[int, str | None] = {}  # index -> None (exit 0) or what went wrong

    def argv(self, cmd: str) -> list[str]:
        run = _substitute(cmd, self.cwd)
        argv = [sys.executable, "-m", "jointwear_ros", *_words(run)]
        return [a for w in argv for a in (sorted(glob.glob(str(self.cwd / w))) or [w]
                                          if any(c in w for c in "*?") else [w])]

    def run(self, index: int) -> str | None:
        """Run README command ``index`` (after the earlier ones not run yet); None, or why it failed."""
        for i, line, cmd, _ in self.runs:
            if i > index:
                break
            if i in self.done:
                continue
            argv = self.argv(cmd)
            r = subprocess.run(argv, cwd=self.cwd, env=self.env, capture_output=True, text=True, timeout=1800)
            self.done[i] = None if r.returncode == 0 else (
                f"README.md:{line}: `{cmd}` (run as {' '.join(argv[3:])}) exit {r.returncode}:\n"
                f"{r.stdout[-2000:]}\n{r.stderr[-2000:]}")
        return self.done[index]




def chain_tests(chain: str):
    """The chain's module fixture and its test, for ``readme_walk, test_the_readme_commands_run_in_order =
    chain_tests(name)`` in the chain's own file (``--dist loadfile`` gives each file, so each chain, a worker of
    its own): the fixture is the chain's scratch directory, to which each command's test adds what it makes;
    the test runs README command ``index`` (after the chain's earlier ones) and expects exit 0 (marked ``slow``
    and ``ros``: the walk runs in ``make test``, with the process and graph tests)."""

    @pytest.fixture(scope="module")
    def readme_walk(tmp_path_factory) -> ReadmeWalk:
        return ReadmeWalk(tmp_path_factory.mktemp(f"readme-{chain}"), chain)

    @pytest.mark.slow
    @pytest.mark.ros
    @pytest.mark.parametrize(("index", "line", "cmd"), **chain_params(chain))
    def test_the_readme_commands_run_in_order(readme_walk, index, line, cmd):
        """Each exits 0, the placeholders replaced by what the chain's earlier commands made."""
        failed = readme_walk.run(index)
        assert failed is None, failed

    return readme_walk, test_the_readme_commands_run_in_order
