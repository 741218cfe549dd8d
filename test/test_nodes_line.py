"""Every joint at once on a real graph: test_cycle with ``sweep: simultaneous`` (rclpy over DDS).

joint_sim (three independent joints, clock source at 4x real time), test_cycle, friction_observer
and wear_estimator run as child processes on loopback; the cell library's :class:`Operator` asks for
one cycle of the three joints, as ``jointwear demo`` does. Every joint is swept at once: each gets an
observation at every speed, its DONE, an estimate, and the robot cycle ends on the last joint's DONE
(``Operator.robot_cycle_over``, ``estimated``, ``complete``, ``cell_seconds``) after about one joint's
cell time, not three.
"""

from __future__ import annotations

import os

import pytest

pytest.importorskip("rclpy")

from jointwear_ros.contract import CyclePhase, CycleState
from jointwear_ros.cycle import CycleConfig, plan_line_cycle, plan_robot_cycle
from jointwear_ros.nodes.cell import CellError, Operator, start_child, stop_children
from jointwear_ros.nodes.runtime import loopback_env

pytestmark = pytest.mark.ros

JOINTS = ["joint_1", "joint_2", "joint_3"]
SPEEDS = [20.0, 40.0, 80.0]


def test_a_simultaneous_cycle_observes_every_joint_at_every_speed_in_about_one_joints_time(tmp_path):
    domain = int(os.environ["ROS_DOMAIN_ID"])
    env = loopback_env(domain)
    joints = "[" + ", ".join(JOINTS) + "]"
    sim_time = {"use_sim_time": True, "joints": joints}
    children = [
        start_child("joint_sim", {"publish_clock": True, "real_time_factor": 4.0, "wear": 20.0, **sim_time}, env,
                    tmp_path, as_module=True),
        start_child("test_cycle", {"simulator": True, "sweep": "simultaneous", **sim_time}, env, tmp_path,
                    as_module=True),
        start_child("friction_observer", sim_time, env, tmp_path, as_module=True),
        start_child("wear_estimator", {"diagnostics_period": 0.5, **sim_time}, env, tmp_path, as_module=True),
    ]
    op = Operator(JOINTS, domain)
    try:
        op.spin_until(lambda: op.client.service_is_ready()
                      and {"friction_observer", "wear_estimator"} <= op.subscribers("/test_cycle/status")
                      and "wear_estimator" in op.subscribers("/jointwear/friction_observations")
                      and all(j in op.observer_status for j in JOINTS), 60.0, children, "the graph")
        with pytest.raises(CellError, match=r"test_cycle refused parameter\(s\) sweep: sweep 'diagonal' must be one "
                                            r"of sequential, simultaneous"):
            op.set_parameters("test_cycle", {"sweep": "diagonal"}, children)
        cid, plan = op.start_cycle(SPEEDS, children)
        assert "3 joints at once along one line" in plan, plan
        op.spin_until(lambda: op.robot_cycle_over(cid), 60.0, children, f"the end of cycle {cid}")
        op.spin_until(lambda: op.estimated(cid) and op.complete(cid), 60.0, children, f"the estimates of cycle {cid}")
        mine = [s for s in op.statuses if s.cycle_id == cid]
        # all three joints ran at once: their sweeps interleave, each status carries its own joint
        sweeping = [s.joint_name for s in mine if s.phase == CyclePhase.FORWARD]
        assert set(sweeping[:6]) == set(JOINTS), sweeping[:6]
        for k, j in enumerate(JOINTS):
            own = [s for s in mine if s.joint_name == j]
            assert all(s.joints_done == k and list(s.joints) == JOINTS for s in own)
            end = op.joint_end(cid, j)
            assert end is not None and end.state == CycleState.DONE, (j, end)
            obs = sorted(o.speed for o in op.observations if o.cycle_id == cid and o.joint_name == j)
            assert obs == pytest.approx(sorted(SPEEDS), rel=0.01), (j, obs)  # measured speeds, within 1 % of the plan
            assert len(op.estimates_of(cid, j)[-1].speeds) == len(SPEEDS)
        # the robot cycle ended on the last joint's DONE, the first to end it
        assert next(s for s in mine if s.robot_cycle_over).joint_name == JOINTS[-1]
        # about one joint's cell time: the plan of the line, a third of one joint after another
        configs = {j: CycleConfig(joint_name=j, joint_limits=(-1.2, 1.2) if j == "joint_3" else (-1.5, 1.5))
                   for j in JOINTS}
        start = dict.fromkeys(JOINTS, 0.0)
        line = plan_line_cycle(configs, JOINTS, SPEEDS, None, start).duration
        sequential = plan_robot_cycle(configs, JOINTS, SPEEDS, None, start).duration
        cell = op.cell_seconds(cid)
        print(f"cell time {cell:.1f} s (planned {line:.1f} s at once, {sequential:.1f} s one after another)")
        assert 0.8 * line < cell < 1.5 * line and cell < 0.5 * sequential
    finally:
        op.close()
        stop_children(children)
    assert all(c.proc.returncode == 0 for c in children), [c.log_tail() for c in children]
