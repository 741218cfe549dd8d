"""Issue 29 (the quick tier): the trend's speed-ups keep its numbers. A small fixed-seed case run through the
model-averaged states (every night, one prior; two nights under a contaminated fleet prior with the mixtures)
and a nightly backtest, pinned to the values the code gave before it was made faster (stop 39's parent commit,
0486d97), to 1e-9 relative: the speed-ups give the same numbers bit for bit on the machine they were made on,
and another CPU's exp, log or matrix product may round the last bits differently.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from jointwear_ros.trend import RatePrior, TrendConfig, trend_states
from jointwear_ros.trend.backtest import backtest_joint
from jointwear_ros.trend.families import EPOCH0, make_family

INF = math.inf
REL = 1e-9


def _case():
    """45 estimates at random times over 60 days, each with its own std: accelerated wear (e-fold 80 days) with an
    unrecorded step of +4 at estimate 22, WARN near the end."""
    rng = np.random.default_rng(39)
    d = np.sort(rng.uniform(0, 60, 45))
    d[0] = 0.0
    w = 20 + 0.1 * 80 * np.expm1(d / 80) + rng.normal(0, 0.85, 45)
    w[22:] += 4.0
    return d, w, rng.uniform(0.5, 1.5, 45)


ROWS = [9, 19, 29, 37, 44]
FLEET = RatePrior(mean=0.12, std=0.03, weights=(0.5, 0.1, 0.1, 0.1, 0.05, 0.05, 0.04, 0.03, 0.03), source="fleet",
                  joints=6, unlike=0.4)


def test_every_nights_states_keep_the_numbers_of_the_code_before_the_speed_ups():
    st = trend_states(*_case(), TrendConfig())
    assert st.level.tolist() == A_LEVEL
    for name in ("wear", "wear_std", "rate", "rate_std", "p_growth", "p_growth_steady", "step_probability"):
        assert getattr(st, name)[ROWS].tolist() == pytest.approx(globals()[f"A_{name.upper()}"], rel=REL), name
    assert st.quantiles[ROWS].ravel().tolist() == pytest.approx(np.ravel(A_QUANTILES).tolist(), rel=REL)
    assert st.weights[:, -1].tolist() == pytest.approx(A_WEIGHTS_LAST, rel=REL, abs=1e-18)
    assert st.reach[-1].tolist() == pytest.approx(A_REACH_LAST, rel=REL)


def test_a_contaminated_fleet_priors_mixture_keeps_its_components_and_numbers():
    st = trend_states(*_case(), TrendConfig(), rows=np.array([20, 44]), prior=FLEET, keep=True)
    assert st.quantiles.ravel().tolist() == pytest.approx(np.ravel(B_QUANTILES).tolist(), rel=REL)
    got = [[st.wear[k], st.wear_std[k], st.rate[k], st.rate_std[k]] for k in range(2)]
    assert np.ravel(got).tolist() == pytest.approx(np.ravel(B_WEAR_RATE).tolist(), rel=REL)
    assert [len(m) for m in st.mixtures] == B_COUNTS
    for row, want in zip(st.mixtures, B_FIRST, strict=True):
        assert [[c.member, c.step_at] for c in row[:4]] == [x[:2] for x in want]
        got = [[c.weight, float(c.mean[0]), float(c.mean[1])] for c in row[:4]]
        assert np.ravel(got).tolist() == pytest.approx(np.ravel([x[2:] for x in want]).tolist(), rel=REL)


def test_a_nightly_backtest_keeps_its_levels_growth_and_intervals():
    b = backtest_joint(make_family("step", 1, days=110, seed=39)[0], TrendConfig(), EPOCH0)
    assert b.level.tolist() == C_LEVEL and b.growth.astype(int).tolist() == C_GROWTH
    assert np.flatnonzero(np.isfinite(b.lo90))[::9].tolist() == C_ROWS
    got = np.c_[b.lo90[C_ROWS], b.median[C_ROWS], b.hi90[C_ROWS]]
    assert got.ravel().tolist() == pytest.approx(np.ravel(C_QUANTILES).tolist(), rel=REL)


# --------------------------------------------------------------------------- computed by the code at 0486d97

A_LEVEL = [
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1,
]
A_WEAR = [21.845726207188203, 23.014162808215534, 29.04782484950604, 30.62302489663619, 32.81985581580482]
A_WEAR_STD = [
    0.5323703802717715, 0.35555737493483996, 0.5672155856628793, 0.42074200998841166, 0.32356723913627117,
]
A_RATE = [
    0.17670522995231758, 0.10910121693621609, 0.13626569337125166, 0.17096538336857114, 0.1967786756181802,
]
A_RATE_STD = [
    0.06177107996795952, 0.030100069092040514, 0.10856194091702479, 0.044888255243988213, 0.02657976312274866,
]
A_P_GROWTH = [
    0.9977139496683232, 0.9930260464849776, 0.8954744671247499, 0.9999434958200627, 0.9999999997142067,
]
A_P_GROWTH_STEADY = [0.9985216871133265, 0.9999805526005544, 0.8954744661862315, 0.9999434964138723, 1.0]
A_STEP_PROBABILITY = [
    0.00027855375965319106, 0.0005399180883626246, 0.999999991002649, 0.999999999406156, 0.9999999997142067,
]
A_QUANTILES = [
    [36.66031026210206, 67.92143056732151, 208.243433163957], [53.43708953385669, 103.86942242939807, INF],
    [15.907446271845538, 41.75568010653954, INF], [14.826363439580193, 25.021319912498264, 49.5804471045324],
    [6.766548678672316, 11.04349880479974, 16.774476939548993],
]
A_WEIGHTS_LAST = [
    0.7356273682822522, 0.06476592209936823, 0.06125386904833139, 0.05629879952354653, 0.04600632023191939,
    0.03604772052878892, 1.5537240367617532e-14, 2.8577555136620546e-10, 8.964509311413224e-16,
]
A_REACH_LAST = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0]
B_QUANTILES = [
    [54.660086539416035, 98.63039547696172, 195.3801441977422],
    [7.604711997485008, 12.649472757624553, 19.10305242113513],
]
B_WEAR_RATE = [
    [23.201834618411322, 0.32362171954527125, 0.11435697333520665, 0.02637207459359497],
    [32.64164602387367, 0.3167241734755384, 0.1855104742580464, 0.027642097469007944],
]
B_COUNTS = [54, 24]
B_FIRST = [

    [[0, -1, 0.5442803918859412, 23.200109865059535, 0.11204912574231585], [0, 15, 0.00010587843270506738, 22.921032181411682, 0.1247910302687463], [0, 1, 6.598223004487706e-05, 23.15744731909071, 0.10514793160071527], [0, 2, 6.201320558191409e-05, 23.111749931921352, 0.09378739117609441]],
    [[0, -1, 4.412929113523781e-25, 32.75747182796479, 0.24812741953388184], [0, 22, 0.47755837984798, 32.5257819887635, 0.16810452782924148], [1, -1, 3.1912958103748186e-21, 33.27813888629484, 0.29967381969244616], [1, 22, 0.11463799695833715, 32.65013371796073, 0.18819443908501945]],
]
C_LEVEL = [
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
]
C_GROWTH = [
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
    1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
]
C_ROWS = [0, 9, 18, 27, 36, 45, 54, 63, 72, 81, 90, 99]
C_QUANTILES = [
    [42.128089304948276, INF, INF], [281.96491257975515, INF, INF],
    [40.27065847342317, 76.7149634541536, 158.59554381093594],
    [29.953215502489314, 53.34957591731146, 79.18493587666055],
    [28.49500525208424, 50.837548033768044, 66.24484099804799], [96.69525092600372, INF, INF],
    [60.017129838013894, 93.69494442176277, 176.95165085937873],
    [73.95990100740855, 108.04384147337686, 144.46036566670668],
    [83.37220446117412, 117.8944306514014, 141.23747231765464],
    [102.6721380547319, 117.54943294889807, 132.6920756522574],
    [100.33750774718496, 110.22279182533424, 120.64839677334528],
    [95.24371696401786, 102.45581400889553, 110.20628022336757],
]
