"""Start ``jointwear serve`` on a history, load its plant page in headless Chromium, write a screenshot.

    python tools/plant_screenshot.py --db history.db --out out/plant/plant.png
    python tools/plant_screenshot.py --example --out out/plant/plant.png   # the 30-joint example plant

Needs Debian's ``chromium`` (tools/install_system_deps.sh installs it). The helpers here
(:func:`start_serve`, :func:`dump_dom`, :func:`screenshot`) are also what the tests use.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def chromium() -> str:
    """The Chromium binary, or an error saying how to install it."""
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    raise RuntimeError("chromium is not installed: run tools/install_system_deps.sh as root (apt-get install chromium)")


def _chromium_args(profile: str) -> list[str]:
    return [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
            "--no-first-run", "--hide-scrollbars", f"--user-data-dir={profile}"]


def dump_dom(url: str, timeout: float = 90.0, budget_ms: int = 4000) -> str:
    """The page's DOM after it loaded (images and scripts included), as Chromium sees it."""
    with tempfile.TemporaryDirectory(prefix="jw-chromium-") as prof:
        r = subprocess.run([*_chromium_args(prof), f"--virtual-time-budget={budget_ms}", "--dump-dom", url],
                           capture_output=True, text=True, timeout=timeout, check=False)
    if r.returncode != 0 or "<html" not in r.stdout:
        raise RuntimeError(f"chromium --dump-dom {url} failed ({r.returncode}): {r.stderr.strip()[-400:]}")
    return r.stdout


def screenshot(url: str, out: Path, size: tuple[int, int] = (1280, 1500), timeout: float = 90.0) -> Path:
    """A PNG of the page at ``url``."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="jw-chromium-") as prof:
        r = subprocess.run([*_chromium_args(prof), f"--window-size={size[0]},{size[1]}", "--virtual-time-budget=4000",
                            f"--screenshot={out.resolve()}", url], capture_output=True, text=True, timeout=timeout,
                           check=False)
    if r.returncode != 0 or not out.is_file():
        raise RuntimeError(f"chromium --screenshot {url} failed ({r.returncode}): {r.stderr.strip()[-400:]}")
    return out


def start_serve(db: str, *extra: str, timeout: float = 60.0) -> tuple[subprocess.Popen[str], str]:
    """``jointwear serve --db DB --port 0 ...`` as a process; (process, base URL) once it answers."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "jointwear_ros", "serve", "--db", db, "--port", "0", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=str(ROOT))
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if "http://" not in line:
        proc.kill()
        raise RuntimeError(f"jointwear serve did not start: {line.strip()} {proc.stderr.read() if proc.stderr else ''}")
    url = line.split("http://", 1)[1].split("/", 1)[0]
    base = f"http://{url}"
    deadline = time.monotonic() + timeout
    while True:
        try:
            with urllib.request.urlopen(base + "/api/state", timeout=5) as r:
                json.load(r)
            return proc, base
        except OSError:
            if time.monotonic() > deadline or proc.poll() is not None:
                stop(proc)
                raise RuntimeError(f"jointwear serve at {base} does not answer") from None
            time.sleep(0.1)


def stop(proc: subprocess.Popen[str]) -> None:
    """Stop a process started by :func:`start_serve` (SIGINT, then SIGKILL)."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for f in (proc.stdout, proc.stderr):
        if f is not None:
            f.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--db", help="history store (file path or URL)")
    src.add_argument("--example", action="store_true", help="write the 30-joint example plant into a temp store")
    ap.add_argument("--out", default="out/plant/plant.png", help="PNG to write (default out/plant/plant.png)")
    ap.add_argument("--page", default="/", help="page to shoot (default the plant page /)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="jw-plant-") as tmp:
        db = args.db
        if args.example:
            sys.path.insert(0, str(Path(__file__).resolve().parent))
            from plant_example import write_plant

            db = str(Path(tmp) / "plant.db")
            write_plant(db)
        proc, base = start_serve(db)
        try:
            out = screenshot(base + args.page, Path(args.out))
        finally:
            stop(proc)
    print(f"screenshot: {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
