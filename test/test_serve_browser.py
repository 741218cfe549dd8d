"""The plant page as a person sees it: headless Chromium (Debian's package) loads it from a running
``jointwear serve``; the ERROR joint reads ERROR, a known joint shows its numbers, the plots are drawn,
the page follows the store without a reload, and a screenshot is written."""

from __future__ import annotations

import html
import json
import re
import sys
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from plant_example import ERROR_JOINT, STALE_JOINT, write_plant  # noqa: E402
from plant_screenshot import chromium, dump_dom, screenshot, start_serve, stop  # noqa: E402


@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    try:
        chromium()
    except RuntimeError as exc:
        pytest.fail(str(exc))
    db = str(tmp_path_factory.mktemp("plant") / "plant.db")
    write_plant(db)
    proc, base = start_serve(db)
    yield base
    stop(proc)


def _row(dom: str, robot: str, joint: str) -> str:
    m = re.search(rf'<tr data-robot="{robot}" data-joint="{joint}" data-level="\w+"[^>]*>(.*?)</tr>', dom, re.S)
    assert m, f"no row of {robot}/{joint}"
    return m.group(0)


def _text(fragment: str) -> str:
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", fragment)).split())


def test_chromium_shows_the_error_joint_as_error_with_its_numbers_and_the_plot_drawn(plant):
    with urllib.request.urlopen(plant + "/api/joints", timeout=30) as r:
        rows = {(j["robot"], j["joint"]): j for j in json.load(r)["joints"]}
    dom = dump_dom(plant + "/")
    err = _text(_row(dom, *ERROR_JOINT))
    a = rows[ERROR_JOINT]
    assert err.split()[:3] == [ERROR_JOINT[0], ERROR_JOINT[1], "ERROR"]
    assert f"{a['wear']:.1f} ± {a['wear_std']:.1f}" in err and "at the alarm now" in err
    stale = _text(_row(dom, *STALE_JOINT))
    assert stale.split()[2] == "STALE" and "no estimate for 2" in stale  # 22 days
    known = rows[("cell_2", "joint_2")]  # a rising joint: OK today, the alarm expected (the forecast), as the API says
    rising = _text(_row(dom, "cell_2", "joint_2"))
    assert rising.split()[2] == "OK" and "alarm expected" in rising and known["alarm_expected"] is True
    assert f"{known['wear']:.1f} ± {known['wear_std']:.1f}" in rising
    assert (f"{known['days_to_alarm']:.0f} ({known['days_to_alarm_low']:.0f} to "
            f"{known['days_to_alarm_high']:.0f})") in rising
    # the summary and the order a person reads: ERROR first, then WARN, STALE, OK
    order = re.findall(r'data-level="(\w+)"', dom)
    n_warn = order.count("WARN")
    assert re.search(r"1 ERROR", dom) and order[: 2 + n_warn] == ["ERROR"] + ["WARN"] * n_warn + ["STALE"]
    drawn = re.search(r'id="plant-plot"[^>]*data-drawn="(\d+)x(\d+)"', dom) or re.search(
        r'data-drawn="(\d+)x(\d+)"[^>]*id="plant-plot"', dom)
    assert drawn and int(drawn.group(1)) > 500 and int(drawn.group(2)) > 500, "the plant plot was not drawn"


def test_chromium_draws_the_joint_page_plot(plant):
    dom = dump_dom(plant + f"/joint/{ERROR_JOINT[0]}/{ERROR_JOINT[1]}")
    m = re.search(r'class="joint-plot"[^>]*data-drawn="(\d+)x(\d+)"', dom, re.S)
    assert m and int(m.group(1)) > 500, "the joint's trend plot was not drawn"


def test_a_screenshot_of_the_plant_page(plant, tmp_path):
    out = screenshot(plant + "/", tmp_path / "plant.png", size=(1280, 900))
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert (width, height) == (1280, 900) and len(data) > 50_000  # a page with content, not a blank frame


@pytest.mark.slow
def test_the_open_page_shows_a_new_estimate_without_a_reload(tmp_path):
    """Chromium keeps the plant page open (DevTools protocol over a websocket, tornado's client); a joint at
    ERROR written into the store appears in that same page, no reload, within the stated delay."""
    import asyncio
    import os
    import signal
    import subprocess
    import time

    from tornado.websocket import websocket_connect

    from jointwear_ros.history import EstimateRecord, HistoryStore

    db = tmp_path / "plant.db"
    write_plant(str(db))
    proc, base = start_serve(str(db), "--refresh", "0.5")
    prof = tmp_path / "profile"
    chrome = subprocess.Popen([chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                               "--no-first-run", f"--user-data-dir={prof}", "--remote-debugging-port=0",
                               base + "/"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              start_new_session=True)

    async def drive() -> float:
        port_file = prof / "DevToolsActivePort"
        deadline = time.monotonic() + 60
        while not port_file.is_file() or not port_file.read_text().strip():
            assert time.monotonic() < deadline and chrome.poll() is None, "chromium did not start"
            await asyncio.sleep(0.1)
        port = int(port_file.read_text().split()[0])
        while True:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
                pages = [t for t in json.load(r) if t["type"] == "page" and t["url"].startswith(base)]
            if pages:
                break
            assert time.monotonic() < deadline, "no page target"
            await asyncio.sleep(0.1)
        ws = await websocket_connect(pages[0]["webSocketDebuggerUrl"], max_message_size=1 << 24)
        ids = iter(range(1, 1 << 30))

        async def js(expr: str):
            i = next(ids)
            await ws.write_message(json.dumps({"id": i, "method": "Runtime.evaluate",
                                               "params": {"expression": expr, "returnByValue": True}}))
            while True:
                msg = json.loads(await ws.read_message())
                if msg.get("id") == i:
                    return msg["result"]["result"].get("value")

        row = 'document.querySelector(\'tr[data-robot="cell_9"][data-joint="joint_1"]\')'
        while await js("document.querySelectorAll('#joints tr[data-level]').length") != 30:
            assert time.monotonic() < deadline, "the page did not load"
            await asyncio.sleep(0.1)
        await js("window.__marker = 'same page'")  # gone if the page were reloaded
        assert await js(row) is None
        now = time.time()
        with HistoryStore(str(db)) as store:
            store.add_estimates([EstimateRecord("cell_9", "joint_1", cycle_id=k + 1, time=now - (6 - k) * 3600.0,
                                                wear=41.0, wear_std=0.85) for k in range(6)])
        t0 = time.monotonic()
        while await js(row + "?.dataset.level") != "ERROR":
            assert time.monotonic() - t0 < 15, "the new joint did not appear on the open page"
            await asyncio.sleep(0.1)
        delay = time.monotonic() - t0
        assert await js("window.__marker") == "same page"
        assert await js("document.getElementById('summary').textContent.includes('2 ERROR')")
        ws.close()
        return delay

    try:
        delay = asyncio.run(drive())
        print(f"open page updated {delay:.2f} s after the store changed (refresh 0.5 s, page poll 1 s)")
        assert delay < 5.0
    finally:
        os.killpg(chrome.pid, signal.SIGTERM)
        chrome.wait(timeout=30)
        stop(proc)
