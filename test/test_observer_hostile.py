"""Hostile input streams thrown at the friction observer core (hypothesis)."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.contract import CycleStatus
from jointwear_ros.observer import FrictionObserverCore, ObserverConfig

anything = st.floats(allow_nan=True, allow_infinity=True)
ints = st.integers(min_value=-(2**31), max_value=2**31)
status = st.tuples(st.just("status"), st.builds(
    CycleStatus, stamp=anything, cycle_id=ints, state=st.integers(-2, 6), phase=st.integers(-2, 6),
    current_speed=anything, speeds_done=ints, speeds_total=ints, window_center=anything, window_half_width=anything,
    joint_name=st.sampled_from(["", "joint_1", "joint_2"])))
sample = st.tuples(st.just("js"), anything, anything, anything, anything)
temperature = st.tuples(st.just("temp"), anything, anything)
poll = st.tuples(st.just("poll"), anything)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(status, sample, temperature, poll), max_size=60))
def test_any_message_sequence_gives_only_finite_physical_observations(events):
    core = FrictionObserverCore(ObserverConfig(min_samples=2))
    outs = []
    for ev in events:
        kind, *args = ev
        if kind == "status":
            outs.append(core.on_status(*args))
        elif kind == "js":
            outs.append(core.on_joint_state(*args))
        elif kind == "temp":
            outs.append(core.on_temperature(*args))
        else:
            outs.append(core.poll(args[0]))
    outs.append(core.flush())
    for out in outs:
        for o in out.observations:
            assert math.isfinite(o.tau_f) and math.isfinite(o.speed) and math.isfinite(o.load_torque)
            assert math.isnan(o.temperature) or -50.0 <= o.temperature <= 200.0
            assert math.isnan(o.tau_f_std) or o.tau_f_std >= 0.0
        for r in out.rejections:
            assert r.reason
    assert core.buffered_samples <= core.samples_seen
