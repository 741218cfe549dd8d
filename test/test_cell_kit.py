"""The cell library's operator kit without a graph (issue 29: one kit for the demo and the tests):
:func:`run_until_accepted` asks for a cycle as an operator would, whoever sends the request; a simulated cell's
test_cycle gets one wall-clock watchdog floor, in the demos and in the test harness."""

from __future__ import annotations

from dataclasses import dataclass

from jointwear_ros.contract import RefusalReason
from jointwear_ros.nodes.cell import SIM_STATE_TIMEOUT_WALL, run_until_accepted, simulated_cycle_params


@dataclass
class Answer:
    accepted: bool
    reason: int = 0
    cycle_id: int = 0


def _script(*answers: Answer):
    """send() giving ``answers`` in turn, and the pauses it was asked to wait."""
    sent: list[Answer] = []
    pauses: list[float] = []

    def send() -> Answer:
        sent.append(answers[len(sent)])
        return sent[-1]

    return send, pauses.append, sent, pauses


def test_a_retryable_refusal_is_sent_again_until_accepted():
    send, wait, sent, pauses = _script(Answer(False, RefusalReason.STATE_MISSING), Answer(False, RefusalReason.BUSY),
                                       Answer(True, cycle_id=7))
    seen: list[Answer] = []
    answer = run_until_accepted(send, wait, 60.0, pause=0.2, progress=seen.append)
    assert answer.accepted and answer.cycle_id == 7
    assert len(sent) == 3 and pauses == [0.2, 0.2] and seen == sent[:2]


def test_a_refusal_that_is_not_retryable_is_the_answer_at_once():
    send, wait, sent, pauses = _script(Answer(False, RefusalReason.STATE_STALE), Answer(False, RefusalReason.BAD_SPEEDS),
                                       Answer(True))
    answer = run_until_accepted(send, wait, 60.0)
    assert not answer.accepted and answer.reason == RefusalReason.BAD_SPEEDS
    assert len(sent) == 2 and pauses == [1.0]


def test_retrying_stops_when_the_time_is_up():
    send, wait, sent, pauses = _script(*[Answer(False, RefusalReason.STATE_MISSING)] * 3)
    answer = run_until_accepted(send, wait, 0.0)  # no time to retry: the first answer
    assert not answer.accepted and len(sent) == 1 and pauses == []


def test_any_answer_shape_through_accepted_and_reason():
    answers = iter([(False, RefusalReason.BUSY), (True, RefusalReason.NONE)])
    answer = run_until_accepted(lambda: next(answers), lambda s: None, 60.0, accepted=lambda a: a[0],
                                reason=lambda a: a[1])
    assert answer == (True, RefusalReason.NONE)


def test_a_simulated_cells_test_cycle_gets_the_watchdog_floor_unless_it_sets_its_own():
    assert SIM_STATE_TIMEOUT_WALL == 3.0
    given = {"simulator": True, "use_sim_time": True}
    assert simulated_cycle_params(given) == {**given, "state_timeout_wall": 3.0}
    assert given == {"simulator": True, "use_sim_time": True}  # not changed in place
    own = {"simulator": True, "state_timeout_wall": 1.0}
    assert simulated_cycle_params(own) == own  # a test of the watchdog itself keeps its value
    real = {"joints": ["joint_1"], "motion_enabled": True}
    assert simulated_cycle_params(real) == real  # a real joint keeps the configured watchdog
    assert simulated_cycle_params({"simulator": False}) == {"simulator": False}
