"""The recorder process killed or starved of disk, then ``jointwear bag recover``: real DDS, real files.

A 1 kHz JointState stream whose messages carry their index (``header.stamp.sec``)
is published from this process; what the recovered bag holds is compared,
index by index, with what was published and when.
"""

from __future__ import annotations

import json
import random
import resource
import signal
import subprocess
import time
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import GraphClient, NodeProcess  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from jointwear_ros.cli import main as cli_main  # noqa: E402
from jointwear_ros.io.bags import read_messages  # noqa: E402

pytestmark = pytest.mark.ros

RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def _recorder(tmp_path: Path, topic: str, *extra: str, preexec_fn=None) -> tuple[subprocess.Popen, Path]:
    log = tmp_path / "recorder.log"
    rec = NodeProcess("recorder", {"output_dir": tmp_path / "bags", "discovery_period": 0.1,
                                   "include": f"['^{topic}$', '^/diagnostics$']", "diagnostics_period": 0.2},
                      args=extra, config=False, log=log, preexec_fn=preexec_fn)
    return rec.proc, log


def _state(i: int) -> JointState:
    m = JointState()
    m.header.stamp.sec = i
    m.name = [f"joint_{k}" for k in range(6)]
    m.position = [0.001 * i] * 6
    m.velocity = [0.5] * 6
    m.effort = [12.5 + 1e-4 * i] * 6
    return m


class _Graph(GraphClient):
    """A publisher node (and a /diagnostics listener) on this test's domain."""

    def __init__(self, ctx, topic: str) -> None:
        super().__init__(ctx, "jw_crash_pub")
        self.pub = self.node.create_publisher(JointState, topic, RELIABLE)
        self.diagnostics: list = []
        self.node.create_subscription(DiagnosticArray, "/diagnostics",
                                      lambda m: self.diagnostics.extend(m.status), 100)
        self.sent_at: list[float] = []

    def stream(self, rate: float, until) -> None:
        """Publish at ``rate`` (catching up when late, so the count is exact) until ``until()``."""
        t0 = time.monotonic()
        while not until():
            due = int((time.monotonic() - t0) * rate) + 1
            while len(self.sent_at) < due:
                self.pub.publish(_state(len(self.sent_at)))
                self.sent_at.append(time.monotonic())
            self.ex.spin_once(timeout_sec=0.0005)


def _indices(bag: Path, topic: str) -> list[int]:
    out = []
    for m in read_messages(bag, topics=[topic]):
        i = int(m.msg.header.stamp.sec)
        assert m.msg.effort[0] == pytest.approx(12.5 + 1e-4 * i, abs=1e-12)
        out.append(i)
    return out


def test_recorder_killed_with_sigkill_mid_stream_loses_at_most_the_last_second(ros_context_per_test, tmp_path,
                                                                                capsys):
    topic = "/jw_kill/joint_states"
    kill_after = random.Random(20261123).uniform(2.0, 4.0)  # a "random" moment, reproducible
    proc, log = _recorder(tmp_path, topic)
    g = _Graph(ros_context_per_test, topic)
    try:
        assert g.spin_until(lambda: g.pub.get_subscription_count() > 0, 30.0), log.read_text()
        start = time.monotonic()
        g.stream(1000.0, lambda: time.monotonic() - start >= kill_after)
        proc.send_signal(signal.SIGKILL)
        killed_at = time.monotonic()
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
        g.close()
    assert proc.returncode == -signal.SIGKILL
    (bag,) = [p for p in (tmp_path / "bags").iterdir() if p.is_dir()]
    assert (bag / "metadata.yaml").is_file()  # written when the bag was opened, kept current since
    before = {f.name: f.read_bytes() for f in bag.iterdir()}
    out = tmp_path / "recovered"
    capsys.readouterr()
    assert cli_main(["bag", "recover", str(bag), "--out", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert {f.name: f.read_bytes() for f in bag.iterdir()} == before  # the input is untouched
    got = _indices(out, topic)
    assert rep["messages"] == rep["topics"][topic]["count"] + rep["topics"].get("/diagnostics", {}).get("count", 0)
    assert rep["topics"][topic]["count"] == len(got) and rep["skipped_chunks"] == [] and rep["damaged"] == []
    assert got == list(range(len(got)))  # in order, no gaps, no duplicates, nothing invented
    due = sum(t <= killed_at - 1.0 for t in g.sent_at)  # published up to one second before the kill
    assert len(g.sent_at) >= 1500
    print(f"published {len(g.sent_at)}, due (up to 1 s before the kill) {due}, recovered {len(got)}")
    assert len(got) >= 0.99 * due, (len(got), due, len(g.sent_at))


def _limit_file_size(limit: int):
    def preexec() -> None:  # in the child: writes past `limit` bytes fail with EFBIG, no SIGXFSZ death
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    return preexec


def test_recorder_hitting_a_file_size_limit_reports_error_exits_nonzero_and_recover_restores_what_it_wrote(
        ros_context_per_test, tmp_path, capsys):
    topic = "/jw_full/joint_states"
    # uncompressed, 300 kB: about a second of this stream fits
    proc, log = _recorder(tmp_path, topic, "-p", "compression:=none", preexec_fn=_limit_file_size(300_000))
    g = _Graph(ros_context_per_test, topic)
    try:
        assert g.spin_until(lambda: g.pub.get_subscription_count() > 0, 30.0), log.read_text()
        start = time.monotonic()
        g.stream(1000.0, lambda: proc.poll() is not None or time.monotonic() - start > 30.0)
        rc = proc.wait(30)
        g.spin_until(lambda: any(s.level == b"\x02" for s in g.diagnostics), 5.0)
    finally:
        if proc.poll() is None:
            proc.kill()
        g.close()
    text = log.read_text()
    assert rc == 1, text
    assert "File too large (EFBIG)" in text and "recording stopped" in text, text
    (bag,) = [p for p in (tmp_path / "bags").iterdir() if p.is_dir()]
    errors = [s for s in g.diagnostics if s.level == b"\x02"]
    assert errors, [(s.name, s.level, s.message) for s in g.diagnostics]
    err = errors[-1]
    assert err.name == f"recorder: {bag.name}" and "File too large" in err.message
    values = {kv.key: kv.value for kv in err.values}
    assert int(values["write_errors"]) == 1
    on_disk, recorded = int(values["messages_on_disk"]), int(values["messages_recorded"])
    assert 0 < on_disk <= recorded
    oks = [s for s in g.diagnostics if s.level == b"\x00" and s.name == f"recorder: {bag.name}"]
    assert oks and oks[0].message == "recording"  # healthy before the disk refused

    out = tmp_path / "recovered"
    capsys.readouterr()
    assert cli_main(["bag", "recover", str(bag), "--out", str(out), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    got = _indices(out, topic)
    # everything the recorder had made durable comes back, as the first messages of the stream
    print(f"on disk {on_disk}, recorded {recorded}, recovered {rep['messages']}, published {len(g.sent_at)}")
    assert on_disk <= rep["messages"] <= recorded
    assert got == list(range(len(got))) and len(got) <= len(g.sent_at)
    assert rep["skipped_chunks"] == [] and rep["damaged"] == []
