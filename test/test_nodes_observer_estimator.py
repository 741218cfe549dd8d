"""friction_observer and wear_estimator on a real rclpy graph (loopback DDS), fed a synthetic test cycle."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import spin_until  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402
from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import JointState, Temperature  # noqa: E402

from jointwear_ros import contract  # noqa: E402
from jointwear_ros.nodes.friction_observer import (  # noqa: E402
    FrictionObserverNode,
    high_rate_qos,
    observation_from_msg,
    observation_to_msg,
    seconds_to_stamp,
)
from jointwear_ros.nodes.wear_estimator import WearEstimatorNode  # noqa: E402
from jointwear_ros.observer import ObserverConfig, observe_arrays  # noqa: E402
from jointwear_ros.observer.synthetic import synthetic_cycle  # noqa: E402

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[1]
NS = "/jw_obs_test"
TOPICS = {
    "joint_states_topic": f"{NS}/joint_states",
    "status_topic": f"{NS}/status",
    "temperature_topic": f"{NS}/temperature",
    "observations_topic": f"{NS}/observations",
}


def _joint_state(t, names, pos, vel, eff):
    m = JointState()
    m.header.stamp = seconds_to_stamp(t)
    m.name = list(names)
    m.position = [float(x) for x in pos]
    m.velocity = [float(x) for x in vel]
    m.effort = [float(x) for x in eff]
    return m


def _status(st: contract.CycleStatus):
    return contract.status_to_msg(st, TestCycleStatus)


def _running(stamp: float, cycle_id: int) -> contract.CycleStatus:
    """Cycle ``cycle_id``'s first speed (40 rad/s of 2) sweeping forward on joint_1 at ``stamp``."""
    return contract.CycleStatus(stamp=stamp, cycle_id=cycle_id, state=contract.CycleState.RUNNING,
                                phase=contract.CyclePhase.FORWARD, current_speed=40.0, speeds_total=2,
                                window_half_width=0.1, joint_name="joint_1")


def test_observation_message_round_trip():
    cyc = synthetic_cycle(speeds=(40,), rate=500.0, seed=2)
    out = observe_arrays(ObserverConfig(), cyc.stamps, cyc.position, cyc.velocity, cyc.effort, cyc.statuses)
    o = out.observations[0]
    back = observation_from_msg(observation_to_msg(o))
    assert back.stamp == pytest.approx(o.stamp, abs=1e-9)
    assert back == type(o)(**{**o.to_dict(), "stamp": back.stamp})


def test_observer_and_estimator_nodes_on_a_synthetic_cycle(ros_context):
    wear = 45.0
    cyc = synthetic_cycle(speeds=(20, 40, 80), wear=wear, rate=500.0, seed=5, temperature_rate=2.0, cycle_id=3)
    obs_node = FrictionObserverNode(context=ros_context, parameter_overrides=[
        Parameter(k, value=v) for k, v in TOPICS.items()])
    est_node = WearEstimatorNode(context=ros_context, parameter_overrides=[
        Parameter("observations_topic", value=TOPICS["observations_topic"]),
        Parameter("status_topic", value=TOPICS["status_topic"]),
        Parameter("estimate_topic", value=f"{NS}/wear_estimate"),
        Parameter("diagnostics_topic", value=f"{NS}/diagnostics"),
        Parameter("hardware_id", value="cell7/robot2"),
        Parameter("diagnostics_period", value=0.2),
    ])
    io = rclpy.create_node("jw_obs_test_io", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    for n in (obs_node, est_node, io):
        ex.add_node(n)
    got_obs, got_est, got_diag = [], [], []
    try:
        js_pub = io.create_publisher(JointState, TOPICS["joint_states_topic"], high_rate_qos())
        st_pub = io.create_publisher(TestCycleStatus, TOPICS["status_topic"], high_rate_qos())
        tp_pub = io.create_publisher(Temperature, TOPICS["temperature_topic"], high_rate_qos())
        io.create_subscription(FrictionObservation, TOPICS["observations_topic"], got_obs.append, high_rate_qos())
        io.create_subscription(WearEstimate, f"{NS}/wear_estimate", got_est.append, 10)
        io.create_subscription(DiagnosticArray, f"{NS}/diagnostics", got_diag.append, 10)
        assert spin_until(ex, lambda: js_pub.get_subscription_count() > 0 and st_pub.get_subscription_count() > 1
                           and tp_pub.get_subscription_count() > 0)

        # the idle diagnostics come first: OK, "no test cycle estimated yet"
        assert spin_until(ex, lambda: len(got_diag) > 0)
        first = got_diag[0].status[0]
        assert first.name == "wear_estimator: joint_1" and first.level == DiagnosticStatus.OK

        # bad JointState messages: logged and skipped, the node keeps running
        t_bad = float(cyc.stamps[0]) - 5.0
        bad = [
            _joint_state(t_bad, ["joint_1", "joint_2"], [0.0], [0.0, 0.0], [0.0, 0.0]),  # lengths differ
            _joint_state(t_bad, ["joint_1"], [0.0], [0.0], []),  # no effort
            _joint_state(t_bad, ["joint_1"], [math.nan], [0.0], [0.0]),  # NaN
            _joint_state(t_bad, ["joint_9"], [0.0], [0.0], [0.0]),  # joint missing
        ]
        for m in bad:
            js_pub.publish(m)
        assert spin_until(ex, lambda: sum(obs_node.bad_messages.values()) == len(bad))
        assert set(obs_node.bad_messages) == {"array lengths", "no effort", "non-finite value for joint_1",
                                             "joint 'joint_1' not in name ['joint_9']; set joint_name"}

        # the cycle, in stamp order; another joint in the message first, as a broadcaster would send it
        events = [(s.stamp, 0, s) for s in cyc.statuses] + [(t[0], 1, t) for t in cyc.temperatures]
        events += [(float(t), 2, i) for i, t in enumerate(cyc.stamps)]
        events.sort(key=lambda e: (e[0], e[1]))
        sent = 0
        for _, kind, a in events:
            if kind == 0:
                st_pub.publish(_status(a))
            elif kind == 1:
                m = Temperature()
                m.header.stamp = seconds_to_stamp(a[0])
                m.temperature = a[1]
                tp_pub.publish(m)
            else:
                i = a
                js_pub.publish(_joint_state(cyc.stamps[i], ["joint_0", "joint_1"], [0.3, cyc.position[i]],
                                            [0.0, cyc.velocity[i]], [1.0, cyc.effort[i]]))
                sent += 1
                if sent % 200 == 0:  # let the observer keep up (KEEP_LAST 1000)
                    assert spin_until(ex, lambda n=sent: obs_node.observer.cores["joint_1"].samples_seen >= n)
        assert spin_until(ex, lambda: len(got_obs) == 3 and len(got_est) == 1
                           and obs_node.observer.cores["joint_1"].samples_seen == cyc.stamps.size)
        assert obs_node.rejections == []

        offline = observe_arrays(ObserverConfig(), cyc.stamps, cyc.position, cyc.velocity, cyc.effort,
                                 cyc.statuses, cyc.temperatures)
        live = [observation_from_msg(m) for m in got_obs]
        assert [o.speed for o in live] == pytest.approx([o.speed for o in offline.observations], rel=1e-12)
        assert [o.tau_f for o in live] == pytest.approx([o.tau_f for o in offline.observations], rel=1e-12)
        for o, truth in zip(live, cyc.tau_f_true):
            assert o.tau_f == pytest.approx(truth, abs=4 * o.tau_f_std + 2e-4)
            assert o.temperature == pytest.approx(40.0) and o.cycle_id == 3

        e = got_est[0]
        assert e.cycle_id == 3 and e.joint_name == "joint_1" and e.method == "paper"
        assert abs(e.wear - wear) < 3 * e.wear_std + 1.0
        assert 0.5 < e.wear_std < 4.0  # bounded: a huge reported std would pass the line above
        assert e.alarm and e.alarm_threshold == 35.0 and len(e.speeds) == 3

        # /diagnostics: ERROR with the key/values, republished periodically
        def errors():
            return [a.status[0] for a in got_diag if a.status[0].level == DiagnosticStatus.ERROR]

        assert spin_until(ex, lambda: len(errors()) >= 3, timeout=10.0)
        s = errors()[-1]
        assert s.name == "wear_estimator: joint_1" and s.hardware_id == "cell7/robot2"
        kv = {v.key: v.value for v in s.values}
        assert float(kv["wear"]) == pytest.approx(e.wear, abs=1e-3)
        assert kv["method"] == "paper" and kv["cycle_id"] == "3" and kv["n_observations"] == "3"
        assert {"wear_std", "temperature_estimate"} <= set(kv)
        assert "at or above the alarm 35" in s.message
    finally:
        ex.shutdown()
        for n in (obs_node, est_node, io):
            n.destroy_node()


def test_estimator_node_revises_a_cycle_when_an_observation_comes_late(ros_context):
    """The last speed's observation arrives after done_timeout: the cycle is first judged from the speeds in
    hand (2 of 3, the temperature unknown: too few for a level, so no WearEstimate and a status that says so),
    then the late observation revises it: a WearEstimate from all three and /diagnostics with ``revision 1``."""
    ns = "/jw_late_test"
    cyc = synthetic_cycle(speeds=(20, 40, 80), wear=20.0, rate=500.0, seed=8, cycle_id=5)
    obs = observe_arrays(ObserverConfig(), cyc.stamps, cyc.position, cyc.velocity, cyc.effort, cyc.statuses).observations
    assert len(obs) == 3
    est_node = WearEstimatorNode(context=ros_context, parameter_overrides=[
        Parameter("observations_topic", value=f"{ns}/observations"),
        Parameter("status_topic", value=f"{ns}/status"),
        Parameter("estimate_topic", value=f"{ns}/wear_estimate"),
        Parameter("diagnostics_topic", value=f"{ns}/diagnostics"),
        Parameter("diagnostics_period", value=0.1),
        Parameter("done_timeout", value=0.3),
    ])
    io = rclpy.create_node("jw_late_test_io", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    for n in (est_node, io):
        ex.add_node(n)
    got_est, got_diag = [], []
    try:
        ob_pub = io.create_publisher(FrictionObservation, f"{ns}/observations", high_rate_qos())
        st_pub = io.create_publisher(TestCycleStatus, f"{ns}/status", high_rate_qos())
        io.create_subscription(WearEstimate, f"{ns}/wear_estimate", got_est.append, 10)
        io.create_subscription(DiagnosticArray, f"{ns}/diagnostics", got_diag.append, 10)
        assert spin_until(ex, lambda: ob_pub.get_subscription_count() > 0 and st_pub.get_subscription_count() > 0)
        running, done = cyc.statuses[0], cyc.statuses[-1]
        st_pub.publish(_status(running))
        for o in obs[:2]:
            ob_pub.publish(observation_to_msg(o))
        st_pub.publish(_status(done))

        def first_verdict():
            return [a.status[0] for a in got_diag if "no wear level from this cycle" in a.status[0].message]

        assert spin_until(ex, lambda: bool(first_verdict()), timeout=10.0)
        assert "2 speed(s) observed; a wear level needs 3" in first_verdict()[-1].message and not got_est
        ob_pub.publish(observation_to_msg(obs[2]))  # late
        assert spin_until(ex, lambda: len(got_est) == 1, timeout=10.0)
        rev = got_est[0]
        assert rev.cycle_id == 5 and list(rev.speeds) == [20.0, 40.0, 80.0]
        assert abs(rev.wear - 20.0) < 3 * rev.wear_std + 1.0
        assert 1.0 < rev.wear_std < 6.0  # T unknown here: wider, still bounded

        def revised():
            return [a.status[0] for a in got_diag if ("revision", "1") in {(v.key, v.value) for v in a.status[0].values}]

        assert spin_until(ex, lambda: bool(revised()), timeout=10.0)
        d = revised()[-1]
        kv = {v.key: v.value for v in d.values}
        assert kv["n_observations"] == "3" and float(kv["wear"]) == pytest.approx(rev.wear, abs=1e-3)
        assert "late observation(s) at 80 rad/s" in d.message
        assert est_node.ignored_messages == 0
    finally:
        ex.shutdown()
        for n in (est_node, io):
            n.destroy_node()


def test_console_scripts_start_with_their_params_files_and_stop_on_sigint(ros_context):
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    bindir = Path(sys.executable).parent
    procs = []
    probe = rclpy.create_node("jw_obs_probe", context=ros_context)
    try:
        for name in ("friction_observer", "wear_estimator"):
            procs.append(subprocess.Popen(
                [str(bindir / name), "--ros-args", "--params-file", str(ROOT / "config" / f"{name}.yaml"),
                 "-r", f"__ns:={NS}_cli"],
                env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True))
        ex = SingleThreadedExecutor(context=ros_context)
        ex.add_node(probe)

        def up():
            names = set(probe.get_node_names())
            return {"friction_observer", "wear_estimator"} <= names

        ok = spin_until(ex, up, timeout=30.0)
        ex.shutdown()
        for p in procs:
            assert p.poll() is None, p.communicate()[0]
        assert ok, "the nodes did not appear on the graph"
    finally:
        outputs = []
        for p in procs:
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in procs:
            try:
                outputs.append(p.communicate(timeout=15)[0])
            except subprocess.TimeoutExpired:
                p.kill()
                outputs.append(p.communicate()[0])
        probe.destroy_node()
    assert [p.returncode for p in procs] == [0, 0], outputs


# -- the alarm flag, levels in sequence, run-time parameters ----------------------------------
def _cycle_result(wear, level, cycle_id=1):
    from jointwear_ros.monitor import CycleResult
    from jointwear_ros.types import WearResult

    res = WearResult(wear=wear, wear_std=1.0, wear_low=wear - 2, wear_high=wear + 2, method="paper",
                     temperature=40.0, speeds=(30.0, 40.0), per_speed_wear=(wear, wear))
    return CycleResult(cycle_id, "joint_1", 10.0, res, level, f"level {level}", (("cycle_id", str(cycle_id)),))


@pytest.mark.parametrize(("wear", "alarm"), [(34.999, False), (35.0, True), (35.001, True), (10.0, False)])
def test_wear_estimate_alarm_is_set_at_exactly_the_threshold_and_not_below(wear, alarm):
    from jointwear_ros.nodes.wear_estimator import estimate_to_msg

    m = estimate_to_msg(_cycle_result(wear, 2 if alarm else 1))
    assert m.alarm is alarm and m.alarm_threshold == 35.0 and m.wear == wear


def test_estimator_node_logs_every_level_in_sequence_and_keeps_running(ros_context):
    """rclpy keys severity by call site: one line choosing info/warning/error died at the second level."""
    node = WearEstimatorNode(context=ros_context, parameter_overrides=[
        Parameter("estimate_topic", value=f"{NS}/seq_estimate"), Parameter("diagnostics_topic", value=f"{NS}/seq_diag")])
    try:
        for cid, (wear, level) in enumerate([(10.0, 0), (45.0, 2), (32.0, 1), (10.0, 0), (45.0, 2)], start=1):
            r = _cycle_result(wear, level, cid)
            node.channels["joint_1"].monitor.last = r
            node._handle([r])
            st = node.health.status("joint_1")
            assert st.level == level and st.message == f"level {level}"
    finally:
        node.destroy_node()


def _model_observation(cycle_id, speed, wear, temperature=40.0, stamp=1.0):
    from jointwear_ros.model import load_parameter_set, paper_wear_model
    from jointwear_ros.observer import FrictionObservationData

    tau = float(paper_wear_model().evaluate(load_parameter_set("ref-2011r"), speed=speed, load_torque=0.1,
                                            temperature=40.0, wear=wear))
    return FrictionObservationData(stamp=stamp, joint_name="joint_1", cycle_id=cycle_id, speed=speed, tau_f=tau,
                                   tau_f_std=3e-4, tau_plus=0.1 + tau, tau_minus=0.1 - tau, load_torque=0.1,
                                   temperature=temperature, position=0.0, samples_plus=500, samples_minus=500)


def test_estimator_thresholds_apply_at_run_time_and_bad_changes_are_refused(ros_context):
    ns = "/jw_param_test"
    node = WearEstimatorNode(context=ros_context, parameter_overrides=[
        Parameter("observations_topic", value=f"{ns}/observations"), Parameter("status_topic", value=f"{ns}/status"),
        Parameter("estimate_topic", value=f"{ns}/estimate"), Parameter("diagnostics_topic", value=f"{ns}/diag")])
    io = rclpy.create_node("jw_param_test_io", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    for n in (node, io):
        ex.add_node(n)
    got = []
    try:
        pub = io.create_publisher(FrictionObservation, f"{ns}/observations", high_rate_qos())
        io.create_subscription(WearEstimate, f"{ns}/estimate", got.append, 10)
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0 and node.estimate_pub.get_subscription_count() > 0)

        # invalid changes: refused with the reason, nothing changes
        res = node.set_parameters_atomically([Parameter("warn_threshold", value=40.0)])
        assert not res.successful and "warn_threshold <= alarm_threshold" in res.reason
        res = node.set_parameters_atomically([Parameter("method", value="nonsense")])
        assert not res.successful and "unknown wear estimation method 'nonsense'" in res.reason
        res = node.set_parameters_atomically([Parameter("estimator_options", value="[1, 2]")])
        assert not res.successful and "not a JSON object" in res.reason
        res = node.set_parameters_atomically([Parameter("estimator_options", value='{"n_samples": 50}')])
        assert res.successful, res.reason
        assert dict(node.channels["joint_1"].monitor.config.estimator_options) == {"n_samples": 50}
        res = node.set_parameters_atomically([Parameter("estimator_options", value='{"no_such_option": 1}')])
        assert not res.successful and "no_such_option" in res.reason
        assert dict(node.channels["joint_1"].monitor.config.estimator_options) == {"n_samples": 50}
        res = node.set_parameters_atomically([Parameter("estimator_options", value="")])
        assert res.successful and dict(node.channels["joint_1"].monitor.config.estimator_options) == {}
        res = node.set_parameters_atomically([Parameter("observations_topic", value="/x")])
        assert not res.successful and "read-only" in res.reason
        assert node.channels["joint_1"].monitor.config.warn_threshold == 30.0 and node.channels["joint_1"].monitor.config.method == "paper"

        # a valid change applies from the next estimate: wear 25 is OK at 30/35, ERROR at 15/20
        res = node.set_parameters_atomically([Parameter("warn_threshold", value=15.0),
                                              Parameter("alarm_threshold", value=20.0)])
        assert res.successful, res.reason
        assert (node.channels["joint_1"].monitor.config.warn_threshold, node.channels["joint_1"].monitor.config.alarm_threshold) == (15.0, 20.0)
        node.channels["joint_1"].monitor.on_status(contract.CycleStatus(cycle_id=7, state=contract.CycleState.RUNNING, speeds_total=3, joint_name="joint_1"), now=0.0)
        for i, v in enumerate((30.0, 40.0, 50.0)):
            pub.publish(observation_to_msg(_model_observation(7, v, 25.0, stamp=100.0 + i)))
        assert spin_until(ex, lambda: len(got) == 1, timeout=10.0)
        assert got[0].alarm and got[0].alarm_threshold == 20.0 and node.health.status("joint_1").level == 2
        res = node.set_parameters_atomically([Parameter("warn_threshold", value=30.0),
                                              Parameter("alarm_threshold", value=35.0)])
        assert res.successful
        node.channels["joint_1"].monitor.on_status(contract.CycleStatus(cycle_id=8, state=contract.CycleState.RUNNING, speeds_total=3, joint_name="joint_1"), now=0.0)
        for i, v in enumerate((30.0, 40.0, 50.0)):
            pub.publish(observation_to_msg(_model_observation(8, v, 25.0, stamp=200.0 + i)))
        assert spin_until(ex, lambda: len(got) == 2, timeout=10.0)
        assert not got[1].alarm and got[1].alarm_threshold == 35.0 and node.health.status("joint_1").level == 0
    finally:
        ex.shutdown()
        for n in (node, io):
            n.destroy_node()


def test_observer_node_reports_its_health_and_refuses_changes_during_a_speed(ros_context):
    ns = "/jw_obs_health"
    topics = {k: v.replace(NS, ns) for k, v in TOPICS.items()}
    node = FrictionObserverNode(context=ros_context, parameter_overrides=[Parameter(k, value=v) for k, v in topics.items()]
                                + [Parameter("diagnostics_period", value=0.2)])
    try:
        st = node.health.status("joint_1")
        assert st.level == 0 and st.name == "friction_observer: joint_1"
        res = node.set_parameters_atomically([Parameter("min_samples", value=50)])
        assert res.successful and node.observer.cores["joint_1"].config.min_samples == 50
        res = node.set_parameters_atomically([Parameter("min_samples", value=1)])
        assert not res.successful and "min_samples=1: outside the declared range [2, 1000000]" in res.reason
        res = node.set_parameters_atomically([Parameter("joint_name", value="joint_2")])
        assert not res.successful and "read-only" in res.reason
        # a speed is being observed: no change until it is done
        node._on_status(_status(_running(10.0, 3)))
        res = node.set_parameters_atomically([Parameter("min_samples", value=20)])
        assert not res.successful and "cycle 3 speed #1 is being observed" in res.reason
        assert node.observer.cores["joint_1"].config.min_samples == 50
        # a bad JointState during cycle 3: WARN with the reason, the counts in the key/values
        node._on_joint_state(_joint_state(10.5, ["joint_1"], [math.nan], [0.0], [0.0]))
        node.observer.cores["joint_1"].on_temperature(10.6, -300.0)
        st = node.health.update()[0]
        kv = dict(st.values)
        assert st.level == 1 and "cycle 3" in st.message and "non-finite value" in st.message
        assert kv["bad_messages"] == "2" and kv["temperatures_skipped"] == "1" and kv["cycle_id"] == "3"
        # the next cycle starts clean
        node._on_status(_status(_running(20.0, 4)))
        st = node.health.update()[0]
        assert st.level == 0
    finally:
        node.destroy_node()
