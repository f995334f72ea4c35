"""One summary from several benchmark journals: a run of a later journal replaces the run of an
earlier one with the same puzzle, planner and run number.

    python scripts/merge_benchmarks.py OUT JOURNAL [JOURNAL ...]

For a table whose cells were run again: the clock-ended cells of docs/benchmark/paper-protocol.md
were rerun on their check budgets, with the same seeds, into their own folders, and merged over the
first journal this way. Each replaced run must have the same seed and puzzle digest (else the
"same run" would be another one: the script stops with an error). Writes ``OUT/summary.md``,
``summary.json``, ``benchmark.db``, ``logs/`` and ``results.html``, as a benchmark's ``--out``
does, into a new folder. Puzzles come in name order; a puzzle's "limit" is the shortest time limit
among its runs (a rerun's longer backstop does not replace the profile's limit). Each run keeps its
end reason: a clock-ended run that no rerun replaced still marks its cell incomplete.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # this checkout's code, not an installed one

from phyrogen_core.atomic_writes import OutputError  # noqa: E402
from solver.benchmark.journal import read_journal  # noqa: E402
from solver.benchmark.ompl_log import build_database, write_log  # noqa: E402
from solver.benchmark.plots import summary_json, summary_markdown, summary_rows  # noqa: E402
from solver.benchmark.results_page import write_results_page  # noqa: E402
from solver.planning.registry import PLANNERS  # noqa: E402


def merged_runs(journals: list[Path]) -> dict[tuple[str, str, int], tuple[dict, object]]:
    """(puzzle, planner title, run) -> (key, record), later journals winning."""
    runs: dict[tuple[str, str, int], tuple[dict, object]] = {}
    for journal in journals:
        for key_text, record in read_journal(journal, strict=True).items():
            key = json.loads(key_text)
            cell = (record.puzzle, record.planner, record.run)
            earlier = runs.get(cell)
            if earlier is not None and (earlier[0].get("seed"), earlier[0].get("puzzle_sha256")) != (
                    key.get("seed"), key.get("puzzle_sha256")):
                raise ValueError(f"{journal}: {cell} has another seed or puzzle than before")
            runs[cell] = (key, record)
    return runs


def write_summary(out: Path, runs: dict, journals: list[Path]) -> list[Path]:
    """The merged runs' logs, database, summaries and results page in ``out``; the logs written."""
    order = {spec.title: i for i, spec in enumerate(PLANNERS.values())}
    (out / "logs").mkdir(parents=True)
    logs = []
    for puzzle in sorted({p for p, _, _ in runs}):
        mine = [(k, r) for (p, _, _), (k, r) in runs.items() if p == puzzle]
        records = [r for _, r in mine]
        titles = sorted({r.planner for r in records}, key=lambda t: order.get(t, len(order)))
        versions = {r.planner: k.get("planner_version", "?") for k, r in mine}
        budgets = {k.get("budget_checks") for k, _ in mine}
        cpu_budgets = {k.get("budget_cpu") for k, _ in mine}
        log = out / "logs" / f"{puzzle}.log"
        # The shortest backstop: the profile's own limit where the first journal has the puzzle.
        write_log(log, puzzle, records, titles, min(r.time_limit for r in records),
                  max(r.run for r in records) + 1, 0, sum(r.wall for r in records),
                  "merged from " + ", ".join(str(j) for j in journals),
                  all(k.get("until") == "first" for k, _ in mine), versions,
                  budgets.pop() if len(budgets) == 1 else None, cpu_budgets.pop() if len(cpu_budgets) == 1 else None)
        logs.append(log)
    build_database(out / "benchmark.db", logs)
    rows = summary_rows(out / "benchmark.db")
    (out / "summary.json").write_text(summary_json(rows), encoding="utf-8")
    until_first = all(k.get("until") == "first" for k, _ in runs.values())
    (out / "summary.md").write_text(summary_markdown(rows, until_first=until_first), encoding="utf-8")
    write_results_page(out)
    return logs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="a new folder for the merged summary")
    parser.add_argument("journals", type=Path, nargs="+", help="runs.jsonl files, earliest first")
    args = parser.parse_args(argv)
    for journal in args.journals:
        if not journal.is_file():
            print(f"error: {journal}: no such journal", file=sys.stderr)
            return 2
    if args.out.exists():
        print(f"error: {args.out} exists; choose a new folder", file=sys.stderr)
        return 2
    try:
        runs = merged_runs(args.journals)
    except (ValueError, OutputError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if not runs:
        print("error: the journals hold no runs", file=sys.stderr)
        return 2
    # Written beside, then renamed into place: an interrupted merge leaves no half-written folder.
    staging = Path(tempfile.mkdtemp(prefix=".merge-", dir=args.out.resolve().parent))
    try:
        logs = write_summary(staging, runs, args.journals)
        staging.rename(args.out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    print(f"{len(runs)} runs of {len(logs)} puzzles: {args.out / 'summary.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
