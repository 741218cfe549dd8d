"""Each test file's measured cost, for the test runner's order: ``test/file_costs.json`` from JUnit XML reports.

``make test`` writes a JUnit report per tier (``out/test-results/``); this sums each file's test times
(setup, call and teardown, as pytest reports them) over the reports given and writes the files of 2 s or
more, rounded to the second, sorted by name::

    python tools/test_costs.py out/test-results/*.xml          # rewrites test/file_costs.json
    python tools/test_costs.py out/test-results/*.xml --check  # prints the new costs, writes nothing

``test/conftest.py`` runs the costliest files first, so that pytest-xdist's workers, which take one file at a
time (``--dist loadfile``), do not end with one long file on one worker while the other waits (longest
processing time first). A stale or missing entry changes only the order, never a result.
"""

from __future__ import annotations

import argparse
import json
import sys
import xml.etree.ElementTree as ET
from collections import defaultdict
from pathlib import Path

OUT = Path(__file__).resolve().parent.parent / "test" / "file_costs.json"
MIN_SECONDS = 2.0


def file_costs(reports: list[Path]) -> dict[str, int]:
    """Seconds per test file name, summed over every test case of every report (files of MIN_SECONDS or more)."""
    total: dict[str, float] = defaultdict(float)
    for report in reports:
        for case in ET.parse(report).iter("testcase"):
            name = case.get("classname", "").split(".")
            module = next((part for part in name if part.startswith("test_")), None)
            if module is not None:
                total[module + ".py"] += float(case.get("time") or 0.0)
    return {f: round(s) for f, s in sorted(total.items()) if s >= MIN_SECONDS}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reports", nargs="+", type=Path, help="JUnit XML reports (pytest --junitxml)")
    ap.add_argument("--check", action="store_true", help="print the costs, write nothing")
    args = ap.parse_args(argv)
    try:
        costs = file_costs(args.reports)
    except (OSError, ET.ParseError) as exc:
        print(f"test_costs: cannot read a report: {exc}", file=sys.stderr)
        return 2
    text = json.dumps(costs, indent=1) + "\n"
    if args.check:
        sys.stdout.write(text)
    else:
        OUT.write_text(text, encoding="utf-8")
        print(f"{OUT}: {len(costs)} files, {sum(costs.values())} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
