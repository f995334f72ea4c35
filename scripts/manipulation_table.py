"""The summary table of a `phyrogen manipulate --out` folder, made again from its report.json files.

    python scripts/manipulation_table.py OUT_DIR [--by-generator]

Prints the table `--table` writes (manipulation.outputs.summary_table) for every
``OUT_DIR/<puzzle>/report.json``, in name order; with ``--by-generator``, a second table per
generator: executed, median and slowest planning + execution time, regrasps, and each failure's cause.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from collections import defaultdict
from pathlib import Path
from types import SimpleNamespace

from manipulation.outputs import summary_table


def load(out_dir: Path) -> list[SimpleNamespace]:
    reports = []
    for path in sorted(out_dir.glob("*/report.json")):
        data = json.loads(path.read_text())
        data.setdefault("benchmark_seconds", 0.0)
        reports.append(SimpleNamespace(**data))
    return reports


def by_generator(reports: list[SimpleNamespace]) -> str:
    groups: dict[str, list[SimpleNamespace]] = defaultdict(list)
    for r in reports:
        groups[r.generator].append(r)
    lines = ["| generator | executed | median [s] | slowest [s] | regrasps | solution that ran | failures |",
             "|---|---|---|---|---|---|---|"]
    for name in sorted(groups):
        group = groups[name]
        totals = [r.planning_seconds + r.execution_seconds for r in group]
        ok = sum(r.success for r in group)
        benchmark = sum(r.solution.startswith("benchmark") for r in group)
        failures = "; ".join(f"{r.puzzle}: {r.message}" for r in group if not r.success) or "none"
        lines.append(f"| {name} | {ok}/{len(group)} | {statistics.median(totals):.1f} | {max(totals):.1f} | "
                     f"{sum(r.regrasps for r in group)} | benchmark {benchmark}, certificate "
                     f"{len(group) - benchmark} | {failures.replace('|', '/')} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--by-generator", action="store_true")
    args = parser.parse_args(argv)
    reports = load(args.out_dir)
    if not reports:
        print(f"error: no report.json under {args.out_dir}", file=sys.stderr)
        return 2
    print(summary_table(reports))
    if args.by_generator:
        print(by_generator(reports))
    return 0


if __name__ == "__main__":
    sys.exit(main())
