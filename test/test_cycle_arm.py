"""The test cycles on a real arm (the UR5 and the Panda in Pinocchio), the whole cell in one process.

``jointwear_ros.simcell.run_cycle``: the arm sampled at 500 Hz, the cycle runner at 100 Hz, one observer
core and one wear monitor per joint, the cell settings of ``jointwear demo --joints N`` (each joint at the
arm's test pose). The truth of an observation is the simulator's friction at the speed and the load of the
arm's configuration and velocities where the joint crossed its window centre.
"""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest

from jointwear_ros.contract import CycleState
from jointwear_ros.sim.arm import ArmSim, arm_configs
from jointwear_ros.sim.arms import arm_spec
from jointwear_ros.simcell import cycle_settings, run_cycle

WEARS = (12.0, 20.0, 26.0, 31.0, 39.0, 46.0, 15.0)


def _cell(arm: str, n: int, speeds=(40.0, 160.0), noise: bool = False, payload: float = 0.0, seed: int = 1):
    spec = arm_spec(arm)
    names = [f"joint_{i}" for i in range(1, n + 1)]
    cycles, observers = cycle_settings(arm, names, speeds=tuple(speeds))
    quiet = {} if noise else {"noise_std": 0.0, "effort_noise_std": 0.0}
    sims = [replace(c, wear=WEARS[i], temperature=40.0, **quiet) for i, c in enumerate(arm_configs(spec, names))]
    return ArmSim(spec, names, sims, seeds=[seed * 100 + i for i in range(n)], payload=payload), cycles, observers


def _errors(sim: ArmSim, run, observers) -> dict[str, list[float]]:
    """Each observation's relative error against its truth, per joint, in speed order."""
    out = {}
    for i, j in enumerate(sim.names):
        out[j] = []
        for o in run.observations[j]:
            q, v = run.crossing(j, o.speed)
            truth = sim.true_friction(j, abs(v[i]), q, v) / observers[j].torque_scale
            out[j].append(abs(o.tau_f - truth) / truth)
    return out


@functools.cache
def _one_after_another(arm: str, n: int):
    """The default cell's cycle with the joints one after another (noise off: deterministic), run once for the
    module: the baseline of the together test's cell time and the subject of the one-after-another tests."""
    sim, cycles, observers = _cell(arm, n)
    return sim, run_cycle(sim, cycles, observers, together=False), observers


@pytest.mark.parametrize(("arm", "n"), [("ur5", 6), ("panda", 7)])
def test_every_joint_at_once_on_the_arm_observes_each_joints_friction_in_a_fraction_of_the_cell_time(arm, n):
    sim, cycles, observers = _cell(arm, n)
    run = run_cycle(sim, cycles, observers, together=True)
    assert run.state == CycleState.DONE, run.message
    errors = _errors(sim, run, observers)
    for j, errs in errors.items():
        assert len(errs) == 2, (j, run.observations[j])
        assert max(errs) < 0.02, (j, errs)  # the coupling cancels: < 2 % of tau_f (the bound), noise off
    _, sequential, _ = _one_after_another(arm, n)
    assert sequential.state == CycleState.DONE, sequential.message
    assert run.cell_seconds < 0.3 * sequential.cell_seconds, (run.cell_seconds, sequential.cell_seconds)


def test_one_after_another_on_the_arm_the_held_joints_are_held_so_each_observation_is_its_friction():
    """A velocity loop at zero lets a held joint creep under the tested joint's push; the shoulder held
    elsewhere in the reverse sweep than in the forward one changed the elbow's gravity between them: 20 %
    off at 1.6 rad/s before the hold correction (at the earlier test pose)."""
    sim, run, observers = _one_after_another("ur5", 6)
    assert run.state == CycleState.DONE, run.message
    errors = _errors(sim, run, observers)
    assert max(max(e) for e in errors.values()) < 0.02, errors


def test_one_after_another_on_the_panda_each_observation_is_its_friction_with_joint_3_nearly_coaxial_to_1():
    """The Panda's test pose has joints 1 and 3 nearly coaxial: joint 1's run-up pushes joint 3 past its
    breakaway, and it sticks again while joint 1 sweeps. The simulator's stick band, solved with the other
    joints' accelerations of the previous step, chattered there and loaded joint 1's drive: 192, 155 and
    75 % off on joints 1, 2 and 4 (noise off, default speeds) before it was solved within the step."""
    sim, run, observers = _one_after_another("panda", 7)  # the default speeds, 40 and 160
    assert run.state == CycleState.DONE, run.message
    errors = _errors(sim, run, observers)
    for j, errs in errors.items():
        assert len(errs) == 2, (j, run.observations[j])
        assert max(errs) < 0.02, (j, errs)


def test_a_payload_between_two_cycles_moves_the_load_column_and_not_the_wear_estimates():
    """Noise off, so what moves is the payload's doing (with noise, two cycles differ by their noise: the
    bench prints the shift over seeds against the std). 3 kg more moves the shoulder's load column, and
    its effort scale, and no estimate by a third of its std."""
    speeds = (20.0, 40.0, 80.0, 160.0)
    runs = [run_cycle(*_cell("ur5", 6, speeds, payload=kg), together=True) for kg in (0.0, 3.0)]
    assert all(r.state == CycleState.DONE for r in runs), [r.message for r in runs]
    load = {j: [np.mean([o.load_torque for o in r.observations[j]]) for r in runs] for j in runs[0].estimates}
    assert load["joint_2"][1] - load["joint_2"][0] > 0.1  # the shoulder carries 3 kg (normalized load: 11 N·m)
    for j in runs[0].estimates:
        (w0, s0), (w3, s3) = runs[0].estimates[j], runs[1].estimates[j]
        assert np.isfinite(w0) and np.isfinite(w3), j
        assert abs(w3 - w0) < 0.3 * max(s0, s3), (j, w0, s0, w3, s3)
        assert abs(w0 - WEARS[int(j[-1]) - 1]) < 3 * s0, (j, w0, s0)
