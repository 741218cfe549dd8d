"""The message contract: ``jointwear_ros.contract`` mirrors the ``.msg``/``.srv`` constants exactly, and no module
outside it writes a cycle state, phase or diagnostic level as a literal."""

from __future__ import annotations

import ast
import itertools
import math
import re
from pathlib import Path

import pytest

from jointwear_ros.contract import (
    ENDED_STATES,
    CyclePhase,
    CycleState,
    DiagnosticLevel,
    RefusalReason,
    observation_from_msg,
    observation_to_msg,
    seconds_to_stamp_fields,
    stamp_to_seconds,
)
from jointwear_ros.observer import FrictionObservationData

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "jointwear_ros"
MSG_DEFS = ROOT / "msg_defs"


def _constants(text: str) -> dict[str, int]:
    """``uint8 NAME=VALUE`` lines of a .msg/.srv text (comments stripped)."""
    out = {}
    for line in text.splitlines():
        m = re.match(r"\s*u?int\d+\s+([A-Z][A-Z0-9_]*)\s*=\s*(\d+)", line.split("#")[0])
        if m:
            out[m.group(1)] = int(m.group(2))
    return out


def _members(enum: type) -> dict[str, int]:
    return {m.name: int(m.value) for m in enum}  # type: ignore[attr-defined]


def test_cycle_states_and_phases_mirror_test_cycle_status_msg():
    consts = _constants((MSG_DEFS / "msg/TestCycleStatus.msg").read_text())
    states = {k: v for k, v in consts.items() if not k.startswith("PHASE_")}
    phases = {k.removeprefix("PHASE_"): v for k, v in consts.items() if k.startswith("PHASE_")}
    assert states == _members(CycleState) and len(states) == 5
    assert phases == _members(CyclePhase) and len(phases) == 5


def test_refusal_reasons_mirror_run_test_cycle_srv_response():
    request, response = (MSG_DEFS / "srv/RunTestCycle.srv").read_text().split("\n---\n")
    assert _constants(request) == {}
    reasons = {k.removeprefix("REASON_"): v for k, v in _constants(response).items()}
    assert reasons == _members(RefusalReason) and len(reasons) == 9
    assert re.search(r"^uint8 reason\b", response, re.M), "the response has no reason field"


def test_the_generated_messages_carry_the_same_constants():
    pytest.importorskip("rclpy")
    from diagnostic_msgs.msg import DiagnosticStatus
    from jointwear_msgs.msg import TestCycleStatus
    from jointwear_msgs.srv import RunTestCycle

    for s in CycleState:
        assert getattr(TestCycleStatus, s.name) == s
    for p in CyclePhase:
        assert getattr(TestCycleStatus, f"PHASE_{p.name}") == p
    for r in RefusalReason:
        assert getattr(RunTestCycle.Response, f"REASON_{r.name}") == r
    assert RunTestCycle.Response().reason == RefusalReason.NONE
    for lv in DiagnosticLevel:
        raw = getattr(DiagnosticStatus, lv.name)
        assert (raw[0] if isinstance(raw, bytes) else int(raw)) == lv
    assert len(DiagnosticLevel) == 4


def test_ended_states_and_retryable_reasons():
    assert {s for s in CycleState if s.ended} == set(ENDED_STATES) == {CycleState.DONE, CycleState.ABORTED,
                                                                      CycleState.FAILED}
    assert 2 in ENDED_STATES and 1 not in ENDED_STATES  # a message's plain int works too
    assert {r for r in RefusalReason if r.retryable} == {RefusalReason.BUSY, RefusalReason.STATE_MISSING,
                                                       RefusalReason.STATE_STALE}
    assert CycleState.name_of(3) == "ABORTED" and CycleState.name_of(7) == "7"


@pytest.mark.parametrize("t, fields", [(0.0, (0, 0)), (-3.0, (0, 0)), (math.nan, (0, 0)), (12.25, (12, 250_000_000)),
                                       (5.9999999999, (6, 0)), (1.5e9 + 0.125, (1_500_000_000, 125_000_000))])
def test_stamp_conversion_round_trips(t, fields):
    sec, nsec = seconds_to_stamp_fields(t)
    assert (sec, nsec) == fields and 0 <= nsec < 1_000_000_000
    stamp = type("Time", (), {"sec": sec, "nanosec": nsec})()
    header = type("Header", (), {"stamp": stamp})()
    assert stamp_to_seconds(stamp) == stamp_to_seconds(header)
    if t > 0:
        assert stamp_to_seconds(stamp) == pytest.approx(t, abs=1e-9 * max(1.0, t) * 2)


def test_observation_round_trips_through_the_generated_message():
    pytest.importorskip("rclpy")
    from jointwear_msgs.msg import FrictionObservation

    o = FrictionObservationData(stamp=100.5, joint_name="joint_2", cycle_id=7, speed=40.0, tau_f=0.1, tau_f_std=0.001,
                                tau_plus=0.2, tau_minus=0.0, load_torque=0.1, temperature=math.nan, position=0.0,
                                samples_plus=900, samples_minus=901)
    back = observation_from_msg(observation_to_msg(o, FrictionObservation))
    assert math.isnan(back.temperature)
    assert {**vars(back), "temperature": 0} == {**vars(o), "temperature": 0}


# -- no literal outside the contract ----------------------------------------------------------------
_CONTRACT_NAMES = {m.name for e in (CycleState, CyclePhase, DiagnosticLevel, RefusalReason) for m in e}
_FIELD = re.compile(r"(^|_)(state|level|phase|reason)s?$")
_CONST_NAME = re.compile(r"^_?(STATE|PHASE|STATUS|LEVEL|REASON)_[A-Z_]*$|^_?(OK|WARN|ERROR|STALE|IDLE|RUNNING|DONE"
                         r"|ABORTED|FAILED)$")


def _is_int(node: ast.AST) -> bool:
    if isinstance(node, ast.Constant):
        return isinstance(node.value, int) and not isinstance(node.value, bool)
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return bool(node.elts) and all(_is_int(e) for e in node.elts)
    return False


def _names_a_field(node: ast.AST) -> bool:
    while True:  # s.level[0], int(msg.state)
        if isinstance(node, ast.Subscript):
            node = node.value
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "int" and node.args:
            node = node.args[0]
        else:
            break
    if isinstance(node, ast.Attribute):
        return bool(_FIELD.search(node.attr))
    if isinstance(node, ast.Name):
        return bool(_FIELD.search(node.id))
    return False


def literal_violations(source: str, where: str) -> list[str]:
    """Cycle states, phases, levels or reasons written as numbers (or names keyed by numbers) in ``source``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            for a, b in itertools.pairwise(sides):
                if (_names_a_field(a) and _is_int(b)) or (_names_a_field(b) and _is_int(a)):
                    found.append(f"{where}:{node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.Dict):
            if (node.keys and all(k is not None and _is_int(k) for k in node.keys)
                    and any(isinstance(v, ast.Constant) and v.value in _CONTRACT_NAMES for v in node.values)):
                found.append(f"{where}:{node.lineno}: {ast.unparse(node)[:60]}")
        elif isinstance(node, ast.Assign) and _is_int(node.value):
            targets = [t for tgt in node.targets for t in (tgt.elts if isinstance(tgt, ast.Tuple) else [tgt])]
            if any(isinstance(t, ast.Name) and _CONST_NAME.match(t.id) for t in targets):
                found.append(f"{where}:{node.lineno}: {ast.unparse(node)}")
        elif isinstance(node, ast.Assign) and isinstance(node.value, ast.Tuple) and len(node.targets) == 1 \
                and isinstance(node.targets[0], ast.Tuple):
            for t, v in zip(node.targets[0].elts, node.value.elts, strict=False):
                if isinstance(t, ast.Name) and _CONST_NAME.match(t.id) and _is_int(v):
                    found.append(f"{where}:{node.lineno}: {ast.unparse(node)}")
    return found


MODULES = sorted(p for p in PKG.rglob("*.py") if p.name != "contract.py" or p.parent != PKG)


@pytest.mark.parametrize("path", MODULES, ids=[str(p.relative_to(PKG)) for p in MODULES])
def test_no_state_phase_or_level_literal_outside_the_contract(path):
    bad = literal_violations(path.read_text(), str(path.relative_to(ROOT)))
    assert not bad, "write these with jointwear_ros.contract's enums:\n" + "\n".join(bad)


@pytest.mark.parametrize("source", [
    "if r.level == 1: pass",
    "x = s.level[0] >= 2",
    "ok = msg.state in (2, 3, 4)",
    "done = 2 == int(msg.state)",
    "_STATES = {0: 'IDLE', 1: 'RUNNING'}",
    "_LEVELS = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}",
    "_STATUS_RUNNING, _STATUS_ENDS = 1, (2, 3, 4)",
    "OK, WARN, ERROR = 0, 1, 2",
    "STATE_RUNNING = 1",
    "PHASE_FORWARD = 2",
    "if resp.reason == 5: pass",
])
def test_the_literal_check_catches_what_it_is_for(source):
    assert literal_violations(source, "planted"), source


@pytest.mark.parametrize("source", [
    "if r.level == DiagnosticLevel.WARN: pass",
    "n = len(states) == 0",
    "OK = DiagnosticLevel.OK",
    "x = {0: 'zero'}",
    "speed = 1",
])
def test_the_literal_check_passes_the_contract_spelling(source):
    assert not literal_violations(source, "ok"), source


# -- one name and one rank of a level ---------------------------------------------------------------
def test_the_contract_names_every_level_once_and_a_byte_it_does_not_define_as_its_number():
    from jointwear_ros.contract import level_name

    assert [level_name(lv) for lv in DiagnosticLevel] == ["OK", "WARN", "ERROR", "STALE"]
    assert [level_name(int(lv)) for lv in DiagnosticLevel] == ["OK", "WARN", "ERROR", "STALE"]
    assert (level_name(7), level_name(None)) == ("7", "NONE")


def test_the_contract_ranks_error_over_warn_over_stale_over_ok_and_an_unknown_byte_above_all():
    from jointwear_ros.contract import level_rank, worst_level

    lv = DiagnosticLevel
    assert sorted(lv, key=level_rank) == [lv.OK, lv.STALE, lv.WARN, lv.ERROR]
    assert worst_level([lv.STALE, lv.ERROR, lv.OK]) == lv.ERROR  # age never hides an alarm
    assert worst_level([lv.OK, lv.STALE]) == lv.STALE and worst_level([]) == lv.OK
    assert worst_level([lv.ERROR, 9]) == 9


def test_the_demo_reports_the_worst_joint_by_the_contracts_rank_not_by_its_name():
    from jointwear_ros.cli.demo_cmd import _worst_level

    assert _worst_level(["STALE", "ERROR", "OK"]) == "ERROR"  # ordered as strings, STALE came last
    assert _worst_level(["OK", "STALE", "WARN"]) == "WARN"
    assert _worst_level(["OK", "UNKNOWN", "ERROR"]) == "UNKNOWN"  # no status heard: nothing says the joint is fine
