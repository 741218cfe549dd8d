"""The planted-bug check (tools/mutation_check.py): every mutation still applies to the source,
and the fast ones (no ROS graph) are caught by the tests. The full run is `make mutation`."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import mutation_check  # noqa: E402


@pytest.mark.parametrize("m", mutation_check.MUTATIONS, ids=[m.name for m in mutation_check.MUTATIONS])
def test_every_mutation_applies_to_the_current_source(m, tmp_path):
    (tmp_path / m.path).parent.mkdir(parents=True)
    (tmp_path / m.path).write_text((ROOT / m.path).read_text())
    mutation_check.apply(m, tmp_path)
    assert (tmp_path / m.path).read_text() != (ROOT / m.path).read_text()
    for t in m.tests:
        assert (ROOT / t).is_file(), t


def test_the_csv_nan_and_input_check_mutations_are_caught():
    names = ["csv_nan_optional_column", "estimator_checks_off", "cli_method_unchecked"]
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "mutation_check.py"), "--json", "--jobs", "3",
                        *[a for n in names for a in ("--only", n)]],
                       capture_output=True, text=True, timeout=600, cwd=ROOT)
    doc = json.loads(r.stdout)
    got = {d["mutation"]: d for d in doc["mutations"]}
    assert set(got) == set(names)
    for n in names:
        assert got[n]["status"] == "caught", got[n]
        assert got[n]["caught_by"], got[n]
    assert r.returncode == 0, r.stderr
