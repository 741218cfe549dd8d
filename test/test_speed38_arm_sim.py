"""The arm simulator's fast paths give the floats of the plain ones, bit for bit.

``ArmSim`` steps every joint in Python once per physics step: its drive constants are taken once per step (and again
when a joint's config or friction table changes), the friction of a table with no position or time effect is
interpolated inline from :meth:`FrictionTable.speed_tables`, the integration runs joint by joint on lists. These must
change no float: the runs of the arm below were pinned on the code before those paths (the per-joint loop reading each
config, ``FrictionTable.__call__`` per joint, the integration on arrays); a sum that moves means the simulator's
physics or its random draws changed, and every result built on it (cycles, commissioning, production) with them.
The sums are compared to 1e-9 (Pinocchio's floats could differ in the last bit on another CPU).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.sim.arm import ArmSim, _solve_spd, arm_configs
from jointwear_ros.sim.arms import arm_spec
from jointwear_ros.sim.friction import FrictionTable

#: Per joint, the sums over the run of the positions, velocities and efforts of :func:`_arm_run_summary`, taken on
#: the code before the fast paths (equal bit for bit on this machine; compared to 1e-9 so that another CPU's last
#: bits do not matter, while a stale drive setting or a changed draw moves them far more)
PINNED: dict[str, list[list[float]]] = {
    "ur5": [[9.817080309251313, -747.0375019501245, 191.97140739486923, 460.09206002387134, 14.176132191248662,
             47.521773219612214],
            [2.0898297579714105, 17.773341709524594, 2.975730945627194, 24.89741616128351, 4.085698302985131,
             33.527381441362216],
            [-50.38583374320634, -15859.93830035303, -6718.714646489423, -172.94342485117528, 1.012618159420749,
             15.709628586372485]],
    "panda": [[9.823304566575333, -147.09007556438877, 11.971661389233136, -949.8058839895136, 14.171318255608329,
               1547.938397753138, 487.4304032915292],
              [2.0950774112714416, 17.725242568684017, 2.982569070277726, 25.09804841567371, 4.11308576136644,
               33.90530145826186, 5.565742480301137],
              [-141.83429074384262, -13217.717707069112, -239.9444742770033, 14035.457002803863, 377.5677626846896,
               1969.5748366698517, -12.240425825444053]],
}


def _arm_run_summary(arm: str) -> np.ndarray:
    """1.2 s of the whole arm with noise: every joint reversing every 0.2 s (through the stick band, each joint's
    drive ramping), joint 2 with a position and a time effect (the table's own lookup), joint 1's wear and
    temperature changed and the payload taken off halfway (the drive constants and friction tables replaced)."""
    spec = arm_spec(arm)
    n = len(spec.joints)
    names = [f"joint_{i}" for i in range(1, n + 1)]
    cfgs = arm_configs(spec, names, wear=20.0)
    cfgs[1] = replace(cfgs[1], hidden_effects=("ripple", "time_drift"))
    sim = ArmSim(spec, names, cfgs, seeds=range(n), payload=1.0)
    total = np.zeros((3, n))
    for k in range(600):
        if k % 5 == 0:
            s = 1.0 if (k // 100) % 2 == 0 else -1.0
            sim.set_commands([s * (0.4 if i % 2 else 0.15) * (1 + i / 10) for i in range(n)])
        if k == 300:
            sim.reconfigure(names[0], replace(sim[names[0]].config, wear=60.0, temperature=30.0))
            sim.set_payload(0.0)
        sim.step(0.002)
        pos, vel, eff = sim.sample()
        total += np.array([pos, vel, eff])
    return total


@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_a_fixed_seed_run_of_the_arm_gives_the_floats_it_gave_before_the_fast_paths(arm):
    np.testing.assert_allclose(_arm_run_summary(arm), np.array(PINNED[arm]), rtol=1e-9, atol=1e-9)


def test_a_tables_speed_tables_interpolate_to_its_own_lookup_bit_for_bit():
    table = FrictionTable(wear=30.0, temperature=35.0)
    tables = table.speed_tables()
    assert tables is not None
    ta, tb, inv_step, last = tables
    rng = np.random.default_rng(5)
    speeds = [*rng.uniform(-450.0, 450.0, 3000), 0.0, -0.0, 0.01, 12.34, table.max_speed, -table.max_speed, 1e4]
    loads = [*rng.uniform(0.0, 2.0, 3000), 0.0, 0.5, 1.0, 0.0, 1.5, 0.2, 0.7]
    for speed, load in zip(speeds, loads, strict=True):
        x = abs(speed) * inv_step
        k = int(x)
        if k > last:
            k, f = last, 1.0
        else:
            f = x - k
        inline = ta[k] + f * (ta[k + 1] - ta[k]) + load * (tb[k] + f * (tb[k + 1] - tb[k])) + 0.0
        direct = table(speed, load, 0.3, 12.0)
        assert inline == direct and math.copysign(1.0, inline) == math.copysign(1.0, direct), (speed, load)


@pytest.mark.parametrize("effects", [("ripple",), ("time_drift",)])
def test_a_table_with_a_position_or_time_effect_gives_no_speed_tables(effects):
    table = FrictionTable(hidden_effects=effects)
    assert table.speed_tables() is None
    assert table(10.0, 0.5, 0.0, 0.0) != table(10.0, 0.5, 0.7, 3600.0)  # its lookup reads them


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 7))
def test_the_stick_bands_cholesky_solves_any_subset_of_an_arms_mass_matrix_as_numpy_does(seed, size):
    """The held-joint solve (:func:`_solve_spd` on crba's upper triangle) against numpy's on the same sub-matrix: a real
    mass matrix of the Panda in a random pose, any subset of its joints in any order."""
    rng = np.random.default_rng(seed)
    spec = arm_spec("panda")
    names = [f"joint_{i}" for i in range(1, len(spec.joints) + 1)]
    sim = ArmSim(spec, names, arm_configs(spec, names), seeds=range(len(names)))
    lo, hi = sim.model.lowerPositionLimit, sim.model.upperPositionLimit
    q = lo + rng.uniform(0.05, 0.95, lo.size) * (hi - lo)
    up = pin.crba(sim.model, sim.data, q)
    full = np.triu(up) + np.triu(up, 1).T
    idx = [int(i) for i in rng.permutation(lo.size)[:size]]
    rhs = rng.normal(0.0, 10.0, size)
    got = _solve_spd(up.tolist(), idx, rhs.tolist())
    np.testing.assert_allclose(got, np.linalg.solve(full[np.ix_(idx, idx)], rhs), rtol=1e-9, atol=1e-9)
