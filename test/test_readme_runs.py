"""Every command the README and the guides it links show runs as written (issue 24).

Fast, always: every ``jointwear ...`` line of a ``sh`` block of README.md and of each docs/ page it
links is parsed by the real CLI parser (optional ``[...]`` parts included), so a sub-command or a
flag the docs name and the code lacks fails here; every ``--params`` names a parameter set that
exists and every ``--method`` an estimator.

Slow (the full suite, ``-m slow``): README.md's command blocks run in order, in four independent chains
(``test_readme_walk_<chain>.py``, each in a scratch directory; ``readme_walk.py``), with the placeholders
(``BAG``, ``URL``, ...) replaced by what the chain's earlier commands made; lines that need what a test
machine has not (a PostgreSQL server at ``dbhost``, a Dask scheduler, a live graph for ``--publish``) are
listed and left out. Here: every command is in exactly one chain, and each chain has its file.
"""

from __future__ import annotations

import argparse
import re

import pytest
from readme_walk import CHAINS, ROOT, RUNS, WALK, _words, chain_of, command_lines, documents

ALL = [(md, line, cmd) for md in documents() for line, cmd in command_lines(md)]


def test_the_docs_have_commands_to_check():
    assert len(ALL) >= 60 and {md.name for md, _, _ in ALL} >= {"README.md", "fleet.md", "workbench.md",
                                                                  "history-trend.md"}


@pytest.mark.parametrize(("md", "line", "cmd"), ALL, ids=[f"{md.name}:{line}" for md, line, _ in ALL])
def test_every_documented_command_parses_with_the_real_cli(md, line, cmd):
    from jointwear_ros.cli import build_parser
    from jointwear_ros.estimation import ESTIMATORS as ESTIMATOR_METHODS
    from jointwear_ros.model import load_parameter_set_info

    words = _words(cmd)
    try:
        args = build_parser().parse_args(words)
    except (SystemExit, argparse.ArgumentError) as exc:
        pytest.fail(f"{md.relative_to(ROOT)}:{line}: `{cmd}` does not parse (exit {exc.code})")
    params = getattr(args, "params", None)
    if params and params not in ("SET", "X") and not params.endswith((".yaml", ".yml")):
        load_parameter_set_info(params)  # a set the docs name must exist
    method = getattr(args, "method", None)
    if isinstance(method, str) and method not in ("M", "X"):
        assert method in ESTIMATOR_METHODS, f"{md.relative_to(ROOT)}:{line}: unknown method {method!r}"


def test_the_readme_walk_runs_most_commands_and_says_why_it_leaves_the_others():
    left_out = [(line, cmd, why) for _, line, cmd, why in WALK if why is not None]
    assert len(RUNS) >= 25, RUNS
    assert len(left_out) <= 10, left_out


def test_every_readme_command_runs_in_one_chain_and_each_chain_has_its_test_file():
    chains = [name for name, _ in CHAINS]
    seen = {chain_of(cmd) for _, _, cmd, _ in RUNS}
    assert seen == set(chains), (seen, chains)  # no chain is empty
    for name in chains:
        text = (ROOT / "test" / f"test_readme_walk_{name}.py").read_text(encoding="utf-8")
        assert f'chain_tests("{name}")' in text, name
    # the demos that make the bags run in the chain of the commands that read them
    assert all(chain_of(cmd) == "bags" for _, _, cmd, _ in RUNS if re.search(r"\bBAGS?\b|history\.db|URL", cmd))
