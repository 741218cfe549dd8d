"""The cell library (``jointwear_ros.nodes.cell``): the operator retries a refusal by its reason code only.

One real test_cycle process, no joint state source: its refusal is STATE_MISSING (retryable), which the
operator re-sends until ``retry_for`` runs out; a WRONG_JOINT refusal is final at once.
"""

from __future__ import annotations

import os
import time

import pytest

pytest.importorskip("rclpy")

from jointwear_ros.nodes.cell import CellError, Operator, start_child, stop_children
from jointwear_ros.nodes.runtime import loopback_env

pytestmark = pytest.mark.ros  # a real node process


def test_the_operator_retries_only_retryable_refusals(tmp_path):
    domain = int(os.environ["ROS_DOMAIN_ID"])
    cyc = start_child("test_cycle", {"simulator": True}, loopback_env(domain), tmp_path)
    lines: list[str] = []
    op = Operator("joint_1", domain, progress=lines.append)
    try:
        op.spin_until(op.client.service_is_ready, 60.0, [cyc], "/test_cycle/run")
        t0 = time.monotonic()
        with pytest.raises(CellError, match=r"refused the request \(STATE_MISSING\): refused: no joint state"):
            op.start_cycle([20.0], [cyc], retry_for=2.0)
        retries = [t for t in lines if "retrying" in t]
        assert retries and all("STATE_MISSING" in t for t in retries)
        assert time.monotonic() - t0 >= 2.0
        op.joints = ["joint_9"]  # the joints the operator asks for
        lines.clear()
        with pytest.raises(CellError, match=r"\(WRONG_JOINT\): refused: unknown joint 'joint_9'"):
            op.start_cycle([20.0], [cyc], retry_for=60.0)
        assert not [t for t in lines if "retrying" in t]
    finally:
        op.close()
        stop_children([cyc])
    assert cyc.proc.returncode == 0, cyc.log_tail()
