"""The simulated production on the rigid-body arm (jointwear_ros.sim.production) and its bag (io.production_bag)."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from jointwear_ros.errors import InputDataError
from jointwear_ros.io.bags import JOINT_STATE_TYPE, TEMPERATURE_TYPE, read_messages, recorded_settings
from jointwear_ros.io.production_bag import production_truth, record_production
from jointwear_ros.sim import (
    Move,
    ProductionProgram,
    SelfHeating,
    arm_spec,
    check_program,
    machine_tending,
    pick_and_place,
    production_program,
    run_production,
)
from jointwear_ros.sim.production import MOVING_SPEED, ProductionRun

ARMS = ("ur5", "panda")
WEAR = {"ur5": [5.0, 12.0, 20.0, 30.0, 45.0, 0.0], "panda": [5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 0.0]}


@pytest.fixture(scope="module")
def runs() -> dict[str, ProductionRun]:
    """One pick-and-place cycle (after the move from home) on each arm, at different wear per joint."""
    return {arm: run_production(arm, pick_and_place(arm), cycles=1, wear=WEAR[arm], seed=3) for arm in ARMS}


def _shuttle(arm: str = "ur5") -> ProductionProgram:
    """A small program (two waypoints, there and back) for the tests that run several times."""
    home = tuple(j.home for j in arm_spec(arm).joints)
    there = tuple(h + (0.3 if i < 4 else 0.0) for i, h in enumerate(home))
    return ProductionProgram("shuttle", arm, {"home": home, "there": there}, "home", (),
                             (Move("there", 0.15, dwell=0.2, event="pick"), Move("home", 0.15, dwell=0.2, event="place")),
                             payload=1.0)


@pytest.mark.parametrize("arm", ARMS)
@pytest.mark.parametrize("make", [pick_and_place, machine_tending])
def test_program_paths_are_inside_the_limits_and_clear_of_collisions(arm: str, make: object) -> None:
    program = make(arm)  # type: ignore[operator]
    spec = arm_spec(arm)
    for q in program.waypoints.values():
        assert all(j.lower <= x <= j.upper for j, x in zip(spec.joints, q, strict=True))
    assert check_program(program) >= 0.0  # every move's closest pair keeps its clearance (else InputDataError)


@pytest.mark.parametrize("arm", ARMS)
def test_pick_and_place_retraces_every_line_with_the_payload_one_way_only(runs: dict[str, ProductionRun],
                                                                        arm: str) -> None:
    run = runs[arm]
    cycle = [m for m in run.moves if m.cycle == 1]
    assert len(cycle) == 6
    by_line = {(m.frm, m.to): m for m in cycle}
    for m in cycle:
        back = by_line[(m.to, m.frm)]  # the same line, the other way
        assert np.allclose(back.velocity, -np.asarray(m.velocity))
        assert {m.payload, back.payload} == {0.0, 2.0}  # on one direction only
    assert len({round(max(np.abs(m.velocity)), 6) for m in cycle}) >= 2  # slow approaches, faster transfers
    for m in cycle:  # the samples carry the payload of their move
        assert np.all(run.payload[run.segment == m.index] == m.payload)
    tending = machine_tending(arm)
    lines = {(a, b) for a, b, _ in tending.lines()}
    assert not any((b, a) in lines for a, b in lines)  # the loop retraces nothing


@pytest.mark.parametrize("arm", ARMS)
def test_the_held_wrist_joint_never_moves_at_a_constant_speed(runs: dict[str, ProductionRun], arm: str) -> None:
    run = runs[arm]
    held = run.arm_joints.index(run.program.held[0])
    assert all(m.velocity[held] == 0.0 for m in run.moves)
    assert np.max(np.abs(run.v[:, held])) * run.gear_ratio[held] < MOVING_SPEED
    moved = [i for i in range(len(run.names)) if any(m.velocity[i] != 0.0 for m in run.moves if m.cycle == 1)]
    assert held not in moved and len(moved) >= len(run.names) - 2


@pytest.mark.parametrize("arm", ARMS)
def test_every_moving_joint_cruises_at_a_constant_speed(runs: dict[str, ProductionRun], arm: str) -> None:
    """Inside each move's cruise, after the velocity loops settle from the acceleration (0.25 s: the slowest
    joints, a few rad/s motor side, need up to 0.2 s), every joint the move drives stays within 1 % of its
    cruise speed (the friction observer accepts 10 %)."""
    run = runs[arm]
    for m in run.moves:
        at = (run.t > m.cruise[0] + 0.25) & (run.t < m.cruise[1])
        assert at.sum() > 50
        w = np.asarray(m.velocity)
        for i in np.flatnonzero(w):
            err = np.max(np.abs(run.v[at, i] - w[i])) / abs(w[i])
            assert err < 0.01, (m.label, run.names[i], err)
        assert np.all(np.isfinite(np.asarray(m.true_friction)[w != 0])) and all(
            f > 0 for f in np.asarray(m.true_friction)[w != 0])


def test_a_run_is_deterministic_for_a_seed_and_wear_changes_per_shift() -> None:
    wear = [[0.0] * 6, [40.0] * 6]
    a = run_production("ur5", _shuttle(), shifts=2, cycles=1, wear=wear, seed=7)
    b = run_production("ur5", _shuttle(), shifts=2, cycles=1, wear=lambda s: [40.0 * s] * 6, seed=7)
    c = run_production("ur5", _shuttle(), shifts=2, cycles=1, wear=wear, seed=8)
    for k in ("t", "q", "v", "effort", "temperature", "payload"):
        assert np.array_equal(getattr(a, k), getattr(b, k)), k
    assert not np.array_equal(a.effort, c.effort)
    assert a.wear == [(0.0,) * 6, (40.0,) * 6] and len(a.shift_start) == 2
    first, second = (next(m for m in a.moves if m.shift == s and m.to == "there") for s in (0, 1))
    assert all(f2 > f1 for f1, f2 in zip(first.true_friction[:4], second.true_friction[:4], strict=True))
    # a shift by duration: cycles are started while less than that has passed; progress after each cycle
    seen: list[tuple[int, int, float]] = []
    d = run_production("ur5", _shuttle(), shifts=2, duration=3.0, seed=7, progress=lambda *p: seen.append(p))
    cycle_time = a.shift_start[1] - a.shift_start[0]
    assert [(s, c) for s, c, _ in seen] == [(0, 1), (0, 2), (1, 1), (1, 2)] and cycle_time < 3.0 < 2 * cycle_time
    assert seen[-1][2] == d.t[-1] and d.shift_start[1] == seen[1][2]


def test_the_recorded_bag_reads_back_with_the_same_samples(tmp_path: Path) -> None:
    run = run_production("ur5", _shuttle(), cycles=1, wear=WEAR["ur5"], seed=1,
                         heating=SelfHeating(rise=10.0, time_constant=20.0, update_period=0.5))
    bag = record_production(run, tmp_path / "production")
    states = list(read_messages(bag, msgtypes=[JOINT_STATE_TYPE]))
    assert [m.topic for m in states[:1]] == ["/joint_states"] and len(states) == len(run.t)
    assert list(states[0].msg.name) == list(run.names)
    for key, field in (("q", "position"), ("v", "velocity"), ("effort", "effort")):
        assert np.array_equal(np.array([getattr(m.msg, field) for m in states]), getattr(run, key)), key
    stamps = np.array([m.msg.header.stamp.sec + 1e-9 * m.msg.header.stamp.nanosec for m in states])
    assert np.max(np.abs(stamps - run.t)) < 1e-9
    temps = [m for m in read_messages(bag, msgtypes=[TEMPERATURE_TYPE])]
    assert {m.topic for m in temps} == {"/joint_temperature"} and {m.msg.header.frame_id for m in temps} == set(run.names)
    for m in temps[-6:]:
        k = int(np.argmin(np.abs(run.t - (m.msg.header.stamp.sec + 1e-9 * m.msg.header.stamp.nanosec))))
        assert m.msg.temperature == run.temperature[k, run.names.index(m.msg.header.frame_id)]
    settings = recorded_settings(bag)["joint_sim"]
    assert settings["arm"] == "ur5" and settings["joint_5.wear"] == 45.0 and settings["joint_1.temperature"] == 40.0
    assert production_truth(bag) == json.loads(json.dumps({**run.truth(), "stamp_offset": 0.0}))


def test_self_heating_follows_the_documented_first_order_law() -> None:
    heat = SelfHeating(rise=20.0, time_constant=30.0, update_period=1.0)
    run = run_production("ur5", _shuttle(), cycles=2, wear=10.0, temperature=[30.0, 35.0, 40.0, 40.0, 40.0, 50.0],
                         seed=2, heating=heat)
    start = np.array([30.0, 35.0, 40.0, 40.0, 40.0, 50.0])
    # replay the law on the recorded samples: every update_period, one exact step toward start + rise * m
    per = round(heat.update_period * 250.0)
    gear = np.asarray(run.gear_ratio)
    temp = start.copy()
    for k in range(per, len(run.t) + 1, per):
        assert np.allclose(run.temperature[k - per:k], temp, rtol=0, atol=1e-9)  # held for the whole period
        m = np.mean(np.abs(run.v[k - per:k]) * gear > MOVING_SPEED, axis=0)
        temp = start + heat.rise * m + (temp - start - heat.rise * m) * math.exp(-heat.update_period / 30.0)
    end = run.temperature[-1]
    assert np.all(end[:4] > start[:4] + 1.0) and np.all(end[:4] < start[:4] + heat.rise)  # the moving joints heat
    assert np.all(run.temperature[:, 4:] == start[4:])  # the held ones stay where they started
    # the friction runs at the recorded temperature (the truth at mid-cruise)
    for mv in run.moves:
        k = int(np.searchsorted(run.t, 0.5 * sum(mv.cruise)))
        assert np.allclose(mv.temperature, run.temperature[k]) or np.allclose(mv.temperature, run.temperature[k - 1])


@pytest.mark.parametrize(("change", "match"), [
    (lambda p: replace(p, waypoints={**p.waypoints, "there": (0.0, -1.0, 3.5, 0.7, 0.0, 0.0)}),
     r"waypoint 'there': elbow_joint at 3.5 rad is outside its limits \[-3.14159, 3.14159\]"),
    (lambda p: replace(p, cycle=(Move("there", -0.1), p.cycle[1])), r"move 1 \(home -> there\): speed must be > 0, got -0.1"),
    (lambda p: replace(p, cycle=(Move("there", 1.5), p.cycle[1])), r"speed 1.5 is a fraction of the velocity limits"),
    (lambda p: replace(p, cycle=(Move("nowhere", 0.1), p.cycle[1])), r"waypoint 'nowhere' is not defined"),
    (lambda p: replace(p, cycle=(Move("there", 0.1, event="drop"), p.cycle[1])), r"event 'drop' is not one of"),
    (lambda p: replace(p, cycle=(p.cycle[0],)), r"the cycle ends at 'there', not where it begins \('home'\)"),
    (lambda p: replace(p, waypoints={**p.waypoints, "there": (0.0, -1.3, 3.1, 0.7, 0.0, 0.0)}),
     r"move 1 \(home -> there\): upper_arm_link and wrist_\d_link"),
])
def test_bad_program_data_gives_one_clear_line(change: object, match: str) -> None:
    program = change(_shuttle())  # type: ignore[operator]
    with pytest.raises(InputDataError, match=match) as err:
        run_production("ur5", program, cycles=1)
    assert "\n" not in str(err.value) and "'shuttle' (ur5)" in str(err.value)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"cycles": 1, "duration": 10.0}, "give either cycles or duration"),
    ({"cycles": 1, "wear": [1.0, 2.0]}, r"wear needs one value or 6 \(one per joint\), got 2"),
    ({"cycles": 1, "wear": [[0.0] * 6], "shifts": 2}, "wear is given for 1 shifts, shift 2 has none"),
    ({"cycles": 1, "payload": -1.0}, "payload must be >= 0 kg"),
    ({"cycles": 1, "heating": SelfHeating(time_constant=-1.0)}, "time_constant must be"),
])
def test_bad_run_settings_give_one_clear_line(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputDataError, match=match) as err:
        run_production("ur5", _shuttle(), **kwargs)  # type: ignore[arg-type]
    assert "\n" not in str(err.value)
    with pytest.raises(InputDataError, match="known: pick_and_place, machine_tending"):
        production_program("palletize")
    with pytest.raises(InputDataError, match="is for arm ur5, not panda"):
        run_production("panda", _shuttle(), cycles=1)


def test_a_move_too_short_to_reach_its_cruise_records_its_peak_speed() -> None:
    home = tuple(j.home for j in arm_spec("ur5").joints)
    near = (home[0] + 0.02, *home[1:])
    program = ProductionProgram("jog", "ur5", {"home": home, "near": near}, "home", (),
                                (Move("near", 1.0, dwell=0.1), Move("home", 1.0, dwell=0.1)))
    run = run_production("ur5", program, cycles=1, seed=0)
    out = run.moves[0]
    peak = 0.02 * math.sqrt(program.acceleration / 0.02)  # a triangle: accelerate half way, decelerate
    assert out.cruise[0] == out.cruise[1] and out.velocity[0] == pytest.approx(peak)
    assert out.velocity[0] < arm_spec("ur5").joints[0].velocity
    assert np.max(run.v[:, 0]) == pytest.approx(peak, rel=0.05)
