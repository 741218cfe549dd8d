"""A node that fails keeps its cause: ``run_node`` logs the traceback of a fatal error, not only its text."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("rclpy")

from jointwear_ros.nodes.runtime import loopback_env

pytestmark = pytest.mark.ros  # a real node process

SCRIPT = textwrap.dedent("""
    import sys
    from jointwear_ros.nodes.runtime import run_node

    def read_calibration():
        raise ValueError("calibration table has 3 columns, expected 4")

    def broken_node():
        read_calibration()

    sys.exit(run_node(broken_node, []))
""")


def test_a_fatal_error_in_a_node_logs_its_traceback_and_exits_1():
    proc = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120,
                          env=loopback_env())
    err = proc.stderr
    assert proc.returncode == 1, err
    assert "[ERROR]" in err and "fatal: calibration table has 3 columns, expected 4" in err
    # the cause: the traceback down to the function that raised
    assert "Traceback (most recent call last)" in err and "in read_calibration" in err and "ValueError" in err
