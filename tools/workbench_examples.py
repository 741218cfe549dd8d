"""Rebuild the worked examples of docs/workbench.md: one diagnosis per verdict, with its plot.

Usage: python tools/workbench_examples.py [--out DIR] [--no-images]

Runs the commands the guide shows, as a user would (the ``jointwear`` CLI next
to this Python): ``jointwear data synth T.csv --seed 7`` with no hidden effect,
with ``--hidden ripple_fast`` and with ``--hidden ripple_fast --hidden warmup``,
each diagnosed on top of ``paper`` with ``--report``. The full printed output of
each diagnosis is written to ``DIR/<verdict>.txt`` and printed; the report's
``dependence.png`` is copied to ``docs/img/workbench_<verdict>.png`` (unless
``--no-images``). The excerpts in docs/workbench.md are cut from these outputs.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLI = Path(sys.executable).with_name("jointwear")

#: (expected verdict, hidden effects) of the three worked examples, all with seed 7.
EXAMPLES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("nothing_missing", ()),
    ("found", ("ripple_fast",)),
    ("unexplained", ("ripple_fast", "warmup")),
)
SEED = 7


def run(args: list[str]) -> str:
    proc = subprocess.run([str(CLI), *args], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"jointwear {' '.join(args)} failed ({proc.returncode}): {proc.stderr.strip()}")
    return proc.stdout


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="where the full outputs go (default: a temporary directory)")
    ap.add_argument("--no-images", action="store_true", help="do not overwrite docs/img/workbench_*.png")
    args = ap.parse_args(argv)
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="workbench_examples_"))
    out.mkdir(parents=True, exist_ok=True)
    status = 0
    for expected, hidden in EXAMPLES:
        work = out / expected
        work.mkdir(exist_ok=True)
        table = work / "T.csv"
        run(["data", "synth", str(table), "--seed", str(SEED), *[a for h in hidden for a in ("--hidden", h)]])
        text = run(["model", "diagnose", str(table), "--model", "paper", "--report", str(work / "report")])
        verdict = json.loads(run(["model", "diagnose", str(table), "--model", "paper", "--json"]))["verdict"]
        (out / f"{expected}.txt").write_text(text, encoding="utf-8")
        hid = " ".join(f"--hidden {h}" for h in hidden) or "(no hidden effect)"
        print(f"===== {expected}: jointwear data synth T.csv --seed {SEED} {hid}; verdict {verdict}")
        print(text)
        if verdict != expected:
            print(f"!! expected the verdict {expected}, got {verdict}", file=sys.stderr)
            status = 1
        if not args.no_images:
            shutil.copyfile(work / "report" / "dependence.png", ROOT / "docs" / "img" / f"workbench_{expected}.png")
    print(f"# full outputs in {out}")
    return status


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
