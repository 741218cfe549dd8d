"""The cell library (``jointwear_ros.nodes.cell``): the operator retries a refusal by its reason code only, and
jogs a joint listening to the joint states only while it jogs.

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


def test_the_operator_jogs_a_joint_to_its_target_and_then_stops_listening_to_the_joint_states(tmp_path):
    # a subscription kept after the jog took every joint state of the cycles that followed (1.5 kHz in a
    # six-joint demo at 3x) on this process's Python executor
    domain = int(os.environ["ROS_DOMAIN_ID"])
    sim = start_child("joint_sim", {"joints": ["joint_1"]}, loopback_env(domain), tmp_path)
    op = Operator("joint_1", domain)
    try:
        for target in (0.25, -0.1):
            op.jog_to({"joint_1": target}, [sim], speed=0.5, tolerance=0.03, timeout=30.0)
            assert abs(op.positions["joint_1"] - target) < 0.03
            assert [s.topic_name for s in op.node.subscriptions if s.topic_name == "/joint_states"] == []
    finally:
        op.close()
        stop_children([sim])
    assert sim.proc.returncode == 0, sim.log_tail()
