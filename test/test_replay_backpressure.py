"""``replay --publish`` waits for a subscriber behind the playback instead of failing.

Seen in a loaded test run: the production demo's replay exited 2 with "cannot play the bag (RCLError:
Failed to publish: cannot publish data)": a KEEP_ALL publisher whose history a starved subscriber had
filled. The message is sent again once the subscribers have taken some; one that takes nothing for
``--wait-timeout`` s is one clear line naming the topic.
"""

from __future__ import annotations

import pytest

from jointwear_ros.cli.replay_cmd import _publish_waiting
from jointwear_ros.errors import InputDataError


class PublishRefused(Exception):
    """Stands in for rclpy's RCLError (the write timed out: the message was not sent)."""


class SlowSubscriberPublisher:
    """A publisher whose write is refused ``refusals`` times (the history full), then taken."""

    def __init__(self, refusals: int):
        self.refusals = refusals
        self.sent: list[bytes] = []
        self.waits = 0

    def publish(self, data: bytes) -> None:
        if self.refusals > 0:
            self.refusals -= 1
            raise PublishRefused("Failed to publish: cannot publish data, at rmw_publish.cpp:116")
        self.sent.append(data)

    def wait_for_all_acked(self, timeout) -> bool:
        self.waits += 1
        return False


def test_a_refused_write_is_sent_again_once_and_only_once():
    pub = SlowSubscriberPublisher(refusals=3)
    _publish_waiting(pub, b"m1", "/joint_states", 60.0, PublishRefused)
    _publish_waiting(pub, b"m2", "/joint_states", 60.0, PublishRefused)
    assert pub.sent == [b"m1", b"m2"]
    assert pub.waits == 3


def test_a_subscriber_that_takes_nothing_is_one_line_naming_the_topic():
    pub = SlowSubscriberPublisher(refusals=10**9)
    with pytest.raises(InputDataError) as err:
        _publish_waiting(pub, b"m1", "/joint_states", 0.3, PublishRefused)
    msg = str(err.value)
    assert "/joint_states" in msg and "--wait-timeout" in msg and "\n" not in msg
    assert pub.sent == []


def test_any_other_error_is_not_retried():
    class Broken:
        def publish(self, data):
            raise ValueError("not a message")

    with pytest.raises(ValueError):
        _publish_waiting(Broken(), b"m", "/x", 60.0, PublishRefused)
