"""The production_observer node over real DDS with the wear_estimator: a simulated pick-and-place on the UR5
published as /joint_states and /joint_temperature with its sim stamps gives, shift by shift, exactly the
observations of observe_production over the same samples (replay equals live), the /production/status DONE
of every joint with its count, and production WearEstimates for the joints moved, none for the held one."""

from __future__ import annotations

import math

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("pinocchio")
from conftest import GraphClient, NodeProcess  # noqa: E402
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402
from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate  # noqa: E402
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState, Temperature  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from jointwear_ros.contract import CycleState, observation_from_msg, stamp_to_seconds  # noqa: E402
from jointwear_ros.nodes.runtime import seconds_to_stamp  # noqa: E402
from jointwear_ros.observer import ProductionConfig, observe_production  # noqa: E402
from jointwear_ros.sim.arm import ArmModel  # noqa: E402
from jointwear_ros.sim.arms import arm_spec  # noqa: E402
from jointwear_ros.sim.production import pick_and_place, run_production  # noqa: E402

pytestmark = pytest.mark.ros

UR5 = arm_spec("ur5")
NAMES = [f"joint_{i + 1}" for i in range(6)]
SHIFT = 20.0  # s of sim time per shift: two cycles make two shifts
TEMP_EVERY = 25  # a temperature per joint every 25 samples (10 Hz at 250 Hz)


@pytest.fixture(scope="module")
def production():
    run = run_production("ur5", pick_and_place("ur5"), cycles=2, wear=[10.0, 20.0, 30.0, 15.0, 25.0, 5.0], seed=3)
    # the stamps as the node reads them (sec, nanosec)
    t = np.array([stamp_to_seconds(seconds_to_stamp(float(x))) for x in run.t])
    return run, t


def _expected(run, t):
    """observe_production per shift over the same samples, the temperatures as published (the latest reading
    at or before each sample), the shift of each sample 1 + floor(t / SHIFT)."""
    idx = np.arange(t.size)
    reading = (idx // TEMP_EVERY) * TEMP_EVERY  # the sample whose stamp the latest reading carries
    temps = run.temperature[reading]
    configs = [ProductionConfig(gear_ratio=j.gear_ratio, torque_scale=j.torque_scale) for j in UR5.joints]
    models = ArmModel("ur5", NAMES).observer_models()  # what the node builds for arm ur5
    shift_of = 1 + np.floor(t / SHIFT).astype(int)
    out = {}
    for sid in np.unique(shift_of).tolist():
        sel = shift_of == sid
        out[sid] = observe_production(t[sel], run.q[sel], run.v[sel], run.effort[sel], temps[sel], joint_names=NAMES,
                                      config=configs, shift_id=sid, **models)
    return out


class Cell(GraphClient):
    """Publishes the production; collects the observations, statuses and estimates."""

    def __init__(self, context, children):
        super().__init__(context, "production_cell", children, diagnostics=["/diagnostics"])
        deep = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=20000)
        self.js = self.node.create_publisher(JointState, "/joint_states", deep)
        self.temp = self.node.create_publisher(Temperature, "/joint_temperature", deep)
        self.obs: list[FrictionObservation] = []
        self.status: list[TestCycleStatus] = []
        self.estimates: list[WearEstimate] = []
        rel = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
        self.node.create_subscription(FrictionObservation, "/jointwear/friction_observations", self.obs.append, rel)
        self.node.create_subscription(TestCycleStatus, "/production/status", self.status.append, rel)
        self.node.create_subscription(WearEstimate, "/jointwear/wear_estimate", self.estimates.append, rel)
        self.end_shift = self.node.create_client(Trigger, "/production_observer/end_shift")

    def publish(self, run, t) -> None:
        for k in range(t.size):
            stamp = seconds_to_stamp(float(run.t[k]))
            msg = JointState(name=NAMES, position=run.q[k].tolist(), velocity=run.v[k].tolist(),
                             effort=run.effort[k].tolist())
            msg.header.stamp = stamp
            self.js.publish(msg)
            if k % TEMP_EVERY == 0:
                for i, j in enumerate(NAMES):
                    tm = Temperature(temperature=float(run.temperature[k, i]))
                    tm.header.stamp = stamp
                    tm.header.frame_id = j
                    self.temp.publish(tm)
            if k % 200 == 0:
                self.executor.spin_once(timeout_sec=0.02)


def test_live_production_shifts_equal_observe_production_and_the_estimator_estimates_the_moved_joints(
        ros_context, production):
    run, t = production
    expected = _expected(run, t)
    assert len(expected) == 2 and all(s.observations for s in expected.values())
    observer = NodeProcess("production_observer", {
        "arm": "ur5", "shift_seconds": SHIFT, "shift_idle": 3.0, "poll_period": 0.1,
        "qos_overrides./joint_states.subscription.depth": 20000,
        "qos_overrides./joint_temperature.subscription.depth": 20000})
    estimator = NodeProcess("wear_estimator", {"done_timeout": 1.0})
    cell = Cell(ros_context, [observer, estimator])
    try:
        cell.spin_until(lambda: cell.js.get_subscription_count() >= 1 and cell.temp.get_subscription_count() >= 1
                        and cell.end_shift.service_is_ready(), 60.0, "the production observer's subscriptions")
        cell.spin_until(lambda: any(n.startswith("wear_estimator") for n in cell.diag), 60.0, "the wear_estimator")
        cell.publish(run, t)
        n_obs = sum(len(s.observations) for s in expected.values())
        done = lambda: [s for s in cell.status if s.state == CycleState.DONE]  # noqa: E731
        # shift 1 ends at the first sample of shift 2, shift 2 by the idle rule (the node's clock is past it)
        cell.spin_until(lambda: len(done()) == 12 and len(cell.obs) == n_obs, 60.0, "both shifts' DONE statuses")
        answer = cell.call(cell.end_shift, Trigger.Request())
        assert not answer.success and "no production shift is being observed" in answer.message

        # replay equals live: every field of every observation, bit for bit
        got = [observation_from_msg(m) for m in cell.obs]
        want = [o for s in expected.values() for o in s.observations]
        assert [o.cycle_id for o in got] == [o.cycle_id for o in want]
        for g, w in zip(got, want, strict=True):
            assert g.source == "production"
            assert g.stamp == stamp_to_seconds(seconds_to_stamp(w.stamp))
            for f in ("joint_name", "speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque",
                      "position", "samples_plus", "samples_minus"):
                assert getattr(g, f) == getattr(w, f), (f, g, w)
            assert g.temperature == w.temperature or (math.isnan(g.temperature) and math.isnan(w.temperature))

        # per joint and shift: DONE with the count; the held flange joint's says why it gave none
        for sid, shift in expected.items():
            for j in NAMES:
                n = sum(1 for o in shift.observations if o.joint_name == j)
                (st,) = [s for s in done() if s.cycle_id == sid and s.joint_name == j]
                assert st.speeds_total == n
                if n == 0 and not shift.joints[j].informative:
                    assert "never moved at a constant speed >= 10 rad/s motor" in st.message
                elif n == 0:  # it moved, every pass rejected: the counts say why
                    assert st.message.startswith(f"{j}: ") and "rejected (" in st.message
        assert all(s.speeds_total == 0 for s in done() if s.joint_name == "joint_6")

        # the wear_estimator estimates each shift's moved joints (production), the held joint never
        moved = {(sid, o.joint_name) for sid, s in expected.items() for o in s.observations}
        cell.spin_until(lambda: {(e.cycle_id, e.joint_name) for e in cell.estimates} >= moved, 60.0,
                        "production WearEstimates of the moved joints")
        # joint_6's shifts are closed without a level once done_timeout passed: then no estimate can come
        cell.spin_until(lambda: any("production shift 2" in s.message for s in
                                    cell.diag.get("wear_estimator: joint_6", [])), 30.0, "joint_6's shift 2 closed")
        assert {(e.cycle_id, e.joint_name) for e in cell.estimates} == moved
        assert all(e.source == "production" for e in cell.estimates)
        assert "joint_6" not in {e.joint_name for e in cell.estimates}

        # the observer's own health: OK, the held joint says so at level OK, no bad or lost message
        cell.spin_until(lambda: any("last_shift" in {kv.key for kv in s.values}
                                    for s in cell.diag.get("production_observer: joint_6", [])), 10.0,
                        "the observer's status after a shift")
        last = {n: s[-1] for n, s in cell.diag.items() if n.startswith("production_observer: ")}
        assert set(last) == {f"production_observer: {j}" for j in NAMES}
        assert all(s.level == DiagnosticStatus.OK for s in last.values())
        assert "never moved" in last["production_observer: joint_6"].message
        values = {kv.key: kv.value for kv in last["production_observer: joint_1"].values}
        assert values["bad_messages"] == "0" and values["lost_messages"] == "0"
        assert values["samples"] == str(t.size)
    finally:
        cell.close()
        codes = [p.stop() for p in (observer, estimator)]
        logs = [p.output()[-3000:] for p in (observer, estimator)]
        observer.close()
        estimator.close()
    assert codes == [0, 0], logs


def test_bad_messages_are_counted_and_skipped_and_the_status_warns_with_the_reason(ros_context):
    observer = NodeProcess("production_observer", {"shift_idle": 1000.0, "poll_period": 0.1})
    cell = Cell(ros_context, [observer])
    try:
        cell.spin_until(lambda: cell.js.get_subscription_count() >= 1 and cell.end_shift.service_is_ready(), 60.0,
                        "the production observer")
        base = dict(name=NAMES, position=[0.0] * 6, velocity=[0.0] * 6, effort=[1.0] * 6)
        for k, change in enumerate([{}, {"position": [0.0] * 5}, {"effort": [math.nan] + [1.0] * 5},
                                    {"name": NAMES[:5], "position": [0.0] * 5, "velocity": [0.0] * 5,
                                     "effort": [1.0] * 5}, {}]):
            msg = JointState(**{**base, **change})
            msg.header.stamp = seconds_to_stamp(1.0 + 0.004 * k if k != 4 else 0.5)  # the last goes backwards
            cell.js.publish(msg)
        cell.spin_until(lambda: any(s.level == DiagnosticStatus.WARN
                                    for s in cell.diag.get("production_observer: joint_1", [])), 20.0,
                        "a WARN for the bad messages")
        warn = [s for s in cell.diag["production_observer: joint_1"] if s.level == DiagnosticStatus.WARN][-1]
        values = {kv.key: kv.value for kv in warn.values}
        assert values["bad_messages"] == "4"
        assert (values["bad_lengths"], values["bad_not_finite"], values["bad_joint_missing"],
                values["bad_stamp_not_after_the_previous"]) == ("1", "1", "1", "1")
        answer = cell.call(cell.end_shift, Trigger.Request())
        assert answer.success and "production shift 1 ended" in answer.message, answer.message
        assert observer.alive()
    finally:
        cell.close()
        code = observer.stop()
        out = observer.output()
        observer.close()
    assert code == 0, out[-3000:]
    assert "message skipped (lengths): position has 5 value(s) for 6 name(s)" in out


@pytest.mark.parametrize(("params", "line"), [
    ({"arm": "kuka"}, "production_observer: unknown arm 'kuka'; known arms: ur5, panda"),
    ({"shift_seconds": 0.0}, "production_observer: Invalid parameter value (0.0) for parameter. Reason: Parameter "
                             "shift_seconds out of range Min: 0.001, Max: 1000000000.0, value: 0.0: shift_seconds"),
    ({"joint_3.min_samples": 1}, "production_observer: joint_3: min_samples=1: outside the declared range [2, 1000000]"),
])
def test_a_start_up_setting_that_cannot_work_is_one_line_and_exit_status_2(params, line):
    observer = NodeProcess("production_observer", params)
    try:
        code = observer.proc.wait(60)
        out = observer.output()
    finally:
        observer.close()
    assert code == 2, out
    assert [s for s in out.strip().splitlines() if not s.startswith("$ ")] == [line]
