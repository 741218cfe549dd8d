"""The shipped Prometheus rules and Grafana dashboard against a real Prometheus scraping ``jointwear serve``.

Debian's ``prometheus`` package (installed by ``tools/install_system_deps.sh``, run by ``make test``):
``promtool`` checks the rules and the scrape example; the server scrapes a running ``jointwear serve``
on loopback, and its HTTP API must show every joint's level and the ERROR rule firing for the ERROR
joint only.
"""

from __future__ import annotations

import json
import re
import shutil
import socket
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from plant_example import (  # noqa: E402
    ERROR_JOINT,
    NEAR_JOINT,
    RISING_JOINTS,
    STALE_JOINT,
    WARN_JOINTS,
    expected_levels,
    write_plant,
)
from plant_screenshot import start_serve, stop  # noqa: E402

RULES = ROOT / "config" / "prometheus" / "jointwear-rules.yml"
SCRAPE = ROOT / "config" / "prometheus" / "prometheus.yml"
DASHBOARD = ROOT / "config" / "grafana" / "jointwear-dashboard.json"
INSTALL = "run tools/install_system_deps.sh as root (make test does): apt-get install prometheus"


def _tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        pytest.fail(f"{name} is not installed: {INSTALL}")
    return path


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _query(base: str, path: str, **params: str) -> dict:
    url = f"{base}{path}?{urllib.parse.urlencode(params)}" if params else base + path
    with urllib.request.urlopen(url, timeout=10) as r:
        body = json.load(r)
    assert body["status"] == "success", body
    return body["data"]


def test_promtool_accepts_the_rules_and_the_scrape_example():
    promtool = _tool("promtool")
    r = subprocess.run([promtool, "check", "rules", str(RULES)], capture_output=True, text=True)
    assert r.returncode == 0 and "SUCCESS: 7 rules found" in r.stdout, r.stdout + r.stderr
    r = subprocess.run([promtool, "check", "config", str(SCRAPE)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    db = str(tmp_path_factory.mktemp("plant") / "plant.db")
    write_plant(db)
    proc, base = start_serve(db)
    yield base
    stop(proc)


def test_every_metric_the_rules_and_the_dashboard_name_is_one_serve_exports(plant):
    with urllib.request.urlopen(plant + "/metrics", timeout=30) as r:
        exposed = set(re.findall(r"^# TYPE (jointwear_\w+) (\w+)", r.read().decode(), re.M))
    names = {n for n, _ in exposed} | {f"{n}_total" for n, kind in exposed if kind == "counter"}
    used = set(re.findall(r"jointwear_[a-z_]+", RULES.read_text()))
    dash = json.loads(DASHBOARD.read_text())
    exprs = [t["expr"] for p in dash["panels"] for t in p.get("targets", [])]
    used |= {n for e in exprs for n in re.findall(r"jointwear_[a-z_]+", e)}
    assert used and used <= names, f"not exported: {sorted(used - names)}"
    assert {"jointwear_joint_level", "jointwear_joint_wear", "jointwear_joint_days_to_alarm_low"} <= used


def test_a_real_prometheus_scrapes_serve_and_the_error_rule_fires_for_the_error_joint(plant, tmp_path):
    prometheus = _tool("prometheus")
    target = plant.split("//", 1)[1]
    shutil.copy(RULES, tmp_path / RULES.name)
    (tmp_path / "prometheus.yml").write_text(
        "global: {scrape_interval: 1s, evaluation_interval: 1s}\n"
        f"rule_files: [{RULES.name}]\n"
        f"scrape_configs:\n  - job_name: jointwear\n    static_configs: [{{targets: ['{target}']}}]\n")
    port = _free_port()
    base = f"http://127.0.0.1:{port}"
    log = (tmp_path / "prometheus.log").open("w")
    proc = subprocess.Popen([prometheus, f"--config.file={tmp_path / 'prometheus.yml'}",
                             f"--storage.tsdb.path={tmp_path / 'data'}", f"--web.listen-address=127.0.0.1:{port}"],
                            stdout=log, stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 90
        levels: dict[tuple[str, str], str] = {}
        firing: list[dict] = []
        while time.monotonic() < deadline:
            assert proc.poll() is None, (tmp_path / "prometheus.log").read_text()[-2000:]
            try:
                series = _query(base, "/api/v1/query", query="jointwear_joint_level")["result"]
                levels = {(s["metric"]["robot"], s["metric"]["joint"]): ["OK", "WARN", "ERROR", "STALE"][int(float(
                    s["value"][1]))] for s in series}
                alerts = _query(base, "/api/v1/alerts")["alerts"]
                firing = [a for a in alerts if a["labels"]["alertname"] == "JointwearJointError"
                          and a["state"] == "firing"]
            except OSError:
                pass
            if len(levels) == 30 and firing:
                break
            time.sleep(0.3)
        # scraped: every joint, the level jointwear decided (the near-threshold joint: whatever the rule said)
        assert all(want is None or levels[k] == want for k, want in expected_levels().items()) and len(levels) == 30
        assert [(a["labels"]["robot"], a["labels"]["joint"]) for a in firing] == [ERROR_JOINT]
        assert firing[0]["labels"]["severity"] == "critical"
        target_health = _query(base, "/api/v1/targets")["activeTargets"]
        assert [t["health"] for t in target_health] == ["up"]
        # the other rules are loaded and pending/firing where they should be (WARN and STALE wait their `for`)
        alerts = _query(base, "/api/v1/alerts")["alerts"]
        by_rule: dict[str, set] = {}
        for a in alerts:
            by_rule.setdefault(a["labels"]["alertname"], set()).add((a["labels"]["robot"], a["labels"]["joint"]))
        assert by_rule.get("JointwearJointWarn", set()) <= set(WARN_JOINTS) | {NEAR_JOINT}
        assert by_rule.get("JointwearAlarmExpected", set()) <= set(RISING_JOINTS)
        assert by_rule.get("JointwearJointStale", set()) <= {STALE_JOINT}
        groups = _query(base, "/api/v1/rules")["groups"]
        assert {r["name"] for g in groups for r in g["rules"]} >= {
            "JointwearJointError", "JointwearJointWarn", "JointwearAlarmExpected", "JointwearAlarmWithinHorizon",
            "JointwearJointStale",
            "JointwearStoreDown", "JointwearServeDown"}
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()
