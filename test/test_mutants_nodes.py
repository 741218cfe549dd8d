"""The planted bugs of issue 10 that pure-core tests must catch (tools/mutants_nodes.py --pure).

The ROS-level mutants (alarm flag, logging severity, run-time parameters) take a graph each;
run them with ``tools/mutants_nodes.py``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_planted_pure_core_bug_is_caught():
    proc = subprocess.run([sys.executable, str(ROOT / "tools" / "mutants_nodes.py"), "--pure"], cwd=ROOT,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "of 12 planted bugs caught" in proc.stdout and "MISSED" not in proc.stdout, proc.stdout
