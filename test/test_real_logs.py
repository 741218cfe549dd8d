"""Real logs in: measured joint data go through `data from-timeseries` and commissioning to a parameter set.

Data (``test/data/real/``, each with its licence beside it; see its README):

* a PAL TIAGo arm joint 1 identification run (FIGAROH, Apache-2.0): 100 Hz, continuous excitation, no
  plateaus, no temperature: the converter picks its own steady-speed bins, drops the speeds where friction
  is not developed and reports every speed it rejected; commissioning replaces the temperature terms, fixes
  the load terms a single sweep cannot identify, validates on held-out speeds and writes a set;
* a Kinova Gen3 joint 1 constant-speed move (MIT): one direction only, so no friction observation can be
  formed: the refusal names the filter and the options;
* a plateau sweep of a real arm's published friction (Franka Emika Panda joint 1, Gaz et al., RA-L 2019,
  :mod:`jointwear_ros.data.published`) at one temperature with a noisy velocity column: every plateau speed
  is found or reported, and commissioning fixes the temperature sensitivities.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from jointwear_ros.cli import main
from jointwear_ros.commission import commission
from jointwear_ros.data.published import panda_friction
from jointwear_ros.io.tables import read_table
from jointwear_ros.model import SetUnits, load_parameter_set_info, parameter_set_document

#: The logs' own units: joint side rad/s and N·m (gear ratio and torque scale 1: no motor-side mapping given).
JOINT = SetUnits("joint", 1.0, 1.0)

REAL = Path(__file__).parent / "data" / "real"


def _convert(capsys, args: list[str]) -> dict:
    assert main(["data", "from-timeseries", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _write_set(res, path: Path) -> None:
    import yaml

    path.write_text(yaml.safe_dump(parameter_set_document(res.parameter_set(path.stem)), sort_keys=False),
                    encoding="utf-8")


def test_a_real_100hz_log_without_plateaus_is_converted_and_commissioned_to_a_set(tmp_path, capsys):
    out = tmp_path / "tiago.csv"
    doc = _convert(capsys, [str(REAL / "tiago_arm_1.csv"), "--time", "t", "--position", "arm_1_position",
                            "--velocity", "arm_1_velocity", "--effort", "arm_1_effort", "--joint", "arm_1",
                            "--out", str(out)])
    src = doc["sources"][0]
    assert src["method"] == "bins" and doc["observations"] >= 5
    assert any("bins picked from the data" in w for w in doc["warnings"])
    # every rejected speed level is reported with its reason (plateaus tried first, then bins)
    assert src["rejected"] and any(r.startswith("plateaus: ") for r in src["rejected"])
    t = read_table(str(out))
    tau, v = np.asarray(t.tau_f), np.asarray(t.speed)
    assert (tau >= 0.2 * np.median(tau)).all()
    # the friction of the README's quick look (0.22 N·m at 0.035 rad/s ... 0.70 at 0.25 rad/s)
    assert 0.15 < float(np.interp(0.035, v, tau)) < 0.3 and 0.55 < float(np.interp(0.25, v, tau)) < 0.85
    res = commission(t, joint="arm_1", units=JOINT, wear_calibration="paper", sources=[str(out)])
    assert "temp_stribeck" not in res.spec and "stribeck" in res.spec and "viscous" in res.spec
    assert res.validation == "held-out speeds" and math.isfinite(res.cv_rmse)
    assert any("no temperature was measured" in p for p in res.priors)
    assert res.fixed.get("Fctm") == 0.0 and res.fixed.get("Fstm") == 0.0  # load only changes with the speed
    assert res.params["Fs"].value >= 0 and res.params["Fv"].value >= 0  # physical signs
    assert res.valid["speed"] == (pytest.approx(0.95 * v.min()), pytest.approx(1.05 * v.max()))  # the level match
    assert res.verdict in ("nothing_missing", "found", "unexplained", "undetermined")
    _write_set(res, tmp_path / "arm_1.yaml")
    info = load_parameter_set_info(str(tmp_path / "arm_1.yaml"))
    assert info.provenance["validation"] == "held-out speeds" and info.provenance["fixed"]["Fctm"] == 0.0


def test_a_real_one_direction_move_is_refused_naming_the_filter_and_the_option(tmp_path, capsys):
    rc = main(["data", "from-timeseries", str(REAL / "kinova_gen3_joint_1_trapez.csv"), "--time", "Time",
               "--position", "Position1", "--velocity", "Velocity1", "--effort", "TorqueCur1",
               "--temperature", "Temp1", "--out", str(tmp_path / "k.csv")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "\n" not in err and "Traceback" not in err
    assert "0 reverse" in err and "need 20 each" in err and "--min-samples" in err
    assert not (tmp_path / "k.csv").exists()


def _panda_plateau_log(speeds: list[float], seconds: float = 6.0, rate: float = 250.0, temperature: float = 31.0,
                       velocity_noise: float = 0.0, seed: int = 0) -> dict[str, np.ndarray]:
    """Forward and reverse plateaus of Panda joint 1 (its published friction), gravity 2 N·m, 250 Hz."""
    rng = np.random.default_rng(seed)
    parts_v = []
    for s in speeds:
        n = int(seconds * rate)
        parts_v += [np.full(n, s), np.zeros(int(0.5 * rate)), np.full(n, -s), np.zeros(int(0.5 * rate))]
    v = np.concatenate(parts_v)
    t = np.arange(v.size) / rate
    q = np.concatenate(([0.0], np.cumsum(v[:-1]) / rate))
    u = panda_friction(0, v) + 2.0 + rng.normal(0.0, 0.01, v.size)
    vm = v + rng.normal(0.0, velocity_noise * np.maximum(np.abs(v), 1e-3), v.size)
    return {"t": t, "q": q, "v": vm, "u": u, "temp": np.full(v.size, temperature)}


def _write_log(path: Path, cols: dict[str, np.ndarray]) -> None:
    names = list(cols)
    data = np.column_stack([cols[n] for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.9g")


def test_a_published_sweep_at_one_temperature_with_a_noisy_velocity_is_converted_and_commissioned(tmp_path, capsys):
    speeds = [0.002, 0.05, 0.1, 0.2, 0.35, 0.5]
    log = tmp_path / "panda.csv"
    _write_log(log, _panda_plateau_log(speeds, velocity_noise=0.08))
    out = tmp_path / "panda_obs.csv"
    doc = _convert(capsys, [str(log), "--time", "t", "--position", "q", "--velocity", "v", "--effort", "u",
                            "--temperature", "temp", "--out", str(out)])
    src = doc["sources"][0]
    t = read_table(str(out))
    found = sorted({round(float(x), 3) for x in t.speed})
    # every plateau speed is an observation, or is reported with its reason (the lowest: friction not developed)
    for s in speeds:
        ok = any(abs(f - s) < 0.05 * s for f in found)
        said = any(abs(float(r.split(" rad/s")[0].split()[-1]) - s) < 0.05 * s for r in src["rejected"]
                   if " rad/s" in r)
        assert ok or said, (s, found, src["rejected"])
    assert any(abs(f - 0.05) < 0.003 for f in found) and any(abs(f - 0.1) < 0.005 for f in found)
    assert not any(abs(f - 0.002) < 0.0005 for f in found)  # tau_f ~ 0 there: dropped, and said so
    assert any("friction not developed" in r for r in src["rejected"])
    res = commission(t, joint="panda_joint_1", units=JOINT, wear_calibration="paper")
    assert {"FsT", "vsT", "FvT"} <= set(res.fixed) and all(res.fixed[n] == 0.0 for n in ("FsT", "vsT", "FvT"))
    assert any("temperature span" in p and "fixed at 0" in p for p in res.priors)
    lo, hi = res.valid["temperature"]
    assert 30.9 <= lo <= hi <= 31.1
    truth = 0.5 * (panda_friction(0, np.asarray(t.speed)) - panda_friction(0, -np.asarray(t.speed)))
    assert float(np.sqrt(np.mean((np.asarray(t.tau_f) - truth) ** 2))) < 0.01  # the converter measures it
    assert res.parameter_set("panda").provenance["fixed"]["FsT"] == 0.0


def test_a_long_recording_with_gaps_is_split_into_cycles_and_validated_on_held_out_cycles(tmp_path, capsys):
    # four sweeps of the published arm, logged one after the other with a pause in the logging between them
    sweeps = [_panda_plateau_log([0.05, 0.1, 0.2, 0.35, 0.5], seconds=3.0, temperature=30.0 + i, seed=i)
              for i in range(4)]
    t0, cols = 0.0, {k: [] for k in sweeps[0]}
    for s in sweeps:
        for k, v in s.items():
            cols[k].append(v + t0 if k == "t" else v)
        t0 += float(s["t"][-1]) + 20.0
    log = tmp_path / "long.csv"
    _write_log(log, {k: np.concatenate(v) for k, v in cols.items()})
    out = tmp_path / "long_obs.csv"
    doc = _convert(capsys, [str(log), "--time", "t", "--position", "q", "--velocity", "v", "--effort", "u",
                            "--temperature", "temp", "--out", str(out)])
    assert any("split into 4 parts" in w and "gap" in w for w in doc["warnings"])
    t = read_table(str(out))
    assert np.unique(t["cycle"]).size == 4 and len(t) == 20
    res = commission(t, joint="panda_joint_1", units=JOINT, wear_calibration="paper", diagnose_baseline=False)
    assert res.validation == "held-out cycles" and res.n_cycles == 4 and math.isfinite(res.cv_rmse)
