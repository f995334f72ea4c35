"""The planners' ranking under a budget in checks beside their ranking under a budget in CPU seconds.

    python scripts/budget_rankings.py --checks DIR [DIR ...] --cpu DIR [DIR ...]

Each DIR is a finished ``phyrogen benchmark`` output folder (its ``runs.jsonl`` is read): the same
puzzles, planners and seeds, once with ``--budget-checks``/``--budget-from-paper`` and once with
``--budget-cpu`` (one folder per generator when each generator has its own CPU budget). Prints, per
planner, the runs solved under each budget (95 % Wilson interval), the rank by runs solved, and the
median CPU seconds and checks a run spent; then per generator the runs solved side by side; then
every run's end reason counted, and the CPU hours of all runs. A clock-ended run is no result of its
budget (docs/benchmark/README.md#end-reasons): it is counted apart, not as a failure.

``cpu_budgets`` gives the CPU budget that matches a check budget: the checks over the median
checks per CPU second of the check-budget runs of that generator (every entry's runs pooled).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from solver.benchmark.jobs import RunRecord  # noqa: E402
from solver.benchmark.journal import JOURNAL, JournalFormatError, read_journal  # noqa: E402
from solver.benchmark.statistics import wilson_interval  # noqa: E402
from solver.planning.registry import PLANNERS  # noqa: E402


def generator_of(puzzle: str) -> str:
    """A generated puzzle's generator: its name without the ``_<seed>`` tail."""
    return puzzle.rsplit("_", 1)[0]


def records(folders: Iterable[Path], runs: int | None = None) -> list[RunRecord]:
    """The runs of the folders' journals (crashed ones left out); with ``runs``, only runs 0..runs-1
    (the same seeds in both benchmarks when one has more runs per cell than the other)."""
    out = []
    for folder in folders:
        journal = Path(folder) / JOURNAL
        if not journal.is_file():
            raise SystemExit(f"error: {journal}: no benchmark journal")
        try:
            read = read_journal(journal, strict=True)
        except JournalFormatError as exc:
            raise SystemExit(f"error: {exc}") from None
        out += [r for r in read.values() if r.error is None and (runs is None or r.run < runs)]
    return out


def cpu_budgets(check_runs: Sequence[RunRecord], budgets: dict[str, int]) -> dict[str, float]:
    """Per generator, the CPU seconds its check budget buys at the median checks per CPU second of
    ``check_runs`` on that generator (rounded to 3 significant digits)."""
    out = {}
    for generator, budget in budgets.items():
        rates = [r.checks / r.cpu_time for r in check_runs
                 if generator_of(r.puzzle) == generator and r.checks and r.cpu_time]
        if rates:
            out[generator] = float(f"{budget / statistics.median(rates):.3g}")
    return out


def _order(titles: Iterable[str]) -> list[str]:
    known = [spec.title for spec in PLANNERS.values()]
    return sorted(set(titles), key=lambda t: (known.index(t) if t in known else len(known), t))


def _counted(runs: Sequence[RunRecord]) -> list[RunRecord]:
    return [r for r in runs if r.end != "clock"]


def _rate(runs: Sequence[RunRecord]) -> str:
    counted = _counted(runs)
    if not counted:
        return "-"
    solved = sum(r.solved for r in counted)
    interval = wilson_interval(solved, len(counted))
    clock = len(runs) - len(counted)
    return (f"{solved}/{len(counted)} [{100 * interval.low:.0f}, {100 * interval.high:.0f}] %"
            + (f" (+{clock} clock)" if clock else ""))


def _ranks(by_planner: dict[str, list[RunRecord]]) -> dict[str, int]:
    """Rank 1 = most runs solved (ties share the better rank)."""
    solved = {p: sum(r.solved for r in _counted(runs)) for p, runs in by_planner.items()}
    return {p: 1 + sum(1 for other in solved.values() if other > mine) for p, mine in solved.items()}


def same_cells(checks: Sequence[RunRecord], cpu: Sequence[RunRecord]) -> tuple[list[RunRecord], list[RunRecord]]:
    """The runs of both benchmarks whose (puzzle, planner, run) both hold: the same seeds on either side."""
    both = {(r.puzzle, r.planner, r.run) for r in checks} & {(r.puzzle, r.planner, r.run) for r in cpu}
    return ([r for r in checks if (r.puzzle, r.planner, r.run) in both],
            [r for r in cpu if (r.puzzle, r.planner, r.run) in both])


def report(checks: Sequence[RunRecord], cpu: Sequence[RunRecord]) -> str:
    """The side-by-side tables of the runs both benchmarks hold (:func:`same_cells`)."""
    checks, cpu = same_cells(checks, cpu)
    planners = _order(r.planner for r in (*checks, *cpu))
    mine = {name: {p: [r for r in runs if r.planner == p] for p in planners}
            for name, runs in (("checks", checks), ("cpu", cpu))}
    ranks = {name: _ranks(by_planner) for name, by_planner in mine.items()}
    lines = ["| planner | check budget: runs solved [95 % Wilson] | rank | median CPU s a run "
             "| CPU budget: runs solved [95 % Wilson] | rank | median checks a run |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for p in planners:
        a, b = mine["checks"][p], mine["cpu"][p]
        cpu_median = statistics.median(r.cpu_time for r in a if r.cpu_time is not None) if a else None
        checks_median = statistics.median(r.checks for r in b if r.checks is not None) if b else None
        cpu_text = "-" if cpu_median is None else f"{cpu_median:.2f}"
        checks_text = "-" if checks_median is None else f"{checks_median:,.0f}"
        lines.append(f"| {p} | {_rate(a)} | {ranks['checks'].get(p, '-')} | {cpu_text} | {_rate(b)} "
                     f"| {ranks['cpu'].get(p, '-')} | {checks_text} |")
    generators = sorted({generator_of(r.puzzle) for r in (*checks, *cpu)})
    lines += ["", "| generator | " + " | ".join(f"{p}: checks / CPU" for p in planners) + " |",
              "|---|" + "---:|" * len(planners)]
    for g in generators:
        cells = []
        for p in planners:
            a = _counted([r for r in mine["checks"][p] if generator_of(r.puzzle) == g])
            b = _counted([r for r in mine["cpu"][p] if generator_of(r.puzzle) == g])
            cells.append(f"{sum(r.solved for r in a)}/{len(a)} / {sum(r.solved for r in b)}/{len(b)}")
        lines.append(f"| {g} | " + " | ".join(cells) + " |")
    for name, runs in (("check budget", checks), ("CPU budget", cpu)):
        ends: dict[str, int] = {}
        for r in runs:
            ends[r.end or "unknown"] = ends.get(r.end or "unknown", 0) + 1
        hours = sum(r.cpu_time or 0.0 for r in runs) / 3600
        counts = ", ".join(f"{k} {v}" for k, v in sorted(ends.items()))
        lines.append(f"\n{name}: {len(runs)} runs; end reasons {counts}; {hours:.3f} CPU h of planning")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checks", type=Path, nargs="+", required=True, help="benchmark folders budgeted in checks")
    parser.add_argument("--cpu", type=Path, nargs="*", default=[], help="benchmark folders budgeted in CPU seconds")
    parser.add_argument("--runs", type=int, help="use runs 0..RUNS-1 of each cell only")
    parser.add_argument("--suggest", action="store_true",
                        help="print the CPU budget per generator that matches the paper's check budgets, and stop")
    args = parser.parse_args(argv)
    checks = records(args.checks, args.runs)
    if args.suggest:
        from solver.benchmark.paper_budgets import paper_budgets

        for generator, seconds in cpu_budgets(checks, paper_budgets()).items():
            print(f"{generator} {seconds:g}")
        return 0
    print(report(checks, records(args.cpu, args.runs)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
