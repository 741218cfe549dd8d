"""The arm simulator's fast paths give the floats of the plain ones, bit for bit.

``ArmSim`` steps every joint in Python once per physics step: its drive constants are taken once per step (and again
when a joint's config or friction table changes), the friction of a table with no position or time effect is
interpolated inline from :meth:`FrictionTable.speed_tables`, the integration runs joint by joint on lists. These must
change no float: the runs of the arm below were pinned on the code before those paths (the per-joint loop reading each
config, ``FrictionTable.__call__`` per joint, the integration on arrays); a digest that moves means the simulator's
physics or its random draws changed, and every result built on it (cycles, commissioning, production) with them.
The digests are this machine's (Pinocchio's floats could differ in the last bit on another CPU).
"""

from __future__ import annotations

import hashlib
import math
import struct
from dataclasses import replace

import numpy as np
import pytest

from jointwear_ros.sim.arm import ArmSim, arm_configs
from jointwear_ros.sim.arms import arm_spec
from jointwear_ros.sim.friction import FrictionTable

#: sha256 of every sample's positions, velocities and efforts (float64) of :func:`_arm_run_digest`, taken on the
#: code before the fast paths
PINNED = {
    "ur5": "a00f099a703b14645dd77c3077554b8f8a6efab31257837e69870c3dbca60135",
    "panda": "1f07bf28ad1c39e2f50ee809ac2f3f6dbdbdf38597b69bfae9e87cc9db929b10",
}


def _arm_run_digest(arm: str) -> str:
    """1.2 s of the whole arm with noise: every joint reversing every 0.2 s (through the stick band, each joint's
    drive ramping), joint 2 with a position and a time effect (the table's own lookup), joint 1's wear and
    temperature changed and the payload taken off halfway (the drive constants and friction tables replaced)."""
    spec = arm_spec(arm)
    n = len(spec.joints)
    names = [f"joint_{i}" for i in range(1, n + 1)]
    cfgs = arm_configs(spec, names, wear=20.0)
    cfgs[1] = replace(cfgs[1], hidden_effects=("ripple", "time_drift"))
    sim = ArmSim(spec, names, cfgs, seeds=range(n), payload=1.0)
    h = hashlib.sha256()
    for k in range(600):
        if k % 5 == 0:
            s = 1.0 if (k // 100) % 2 == 0 else -1.0
            sim.set_commands([s * (0.4 if i % 2 else 0.15) * (1 + i / 10) for i in range(n)])
        if k == 300:
            sim.reconfigure(names[0], replace(sim[names[0]].config, wear=60.0, temperature=30.0))
            sim.set_payload(0.0)
        sim.step(0.002)
        pos, vel, eff = sim.sample()
        h.update(struct.pack(f"{3 * n}d", *pos, *vel, *eff))
    return h.hexdigest()


@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_a_fixed_seed_run_of_the_arm_gives_the_floats_it_gave_before_the_fast_paths(arm):
    assert _arm_run_digest(arm) == PINNED[arm]


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
