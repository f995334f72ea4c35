"""The tables of docs/benchmark/paper-protocol.md from benchmark journals: per planner, per puzzle,
and every cell's end reasons.

    python scripts/protocol_tables.py JOURNAL [JOURNAL ...] [--added-from RUN]

Journals are merged as ``scripts/merge_benchmarks.py`` merges them (a later journal's run replaces
the same puzzle, planner and run of an earlier one). A cell with more than 10 runs is shown in bold
with its 95 % Wilson interval. ``--added-from 10`` also prints the cost of the runs numbered 10 and
up and how each extended cell moved. Markdown on stdout; a bad journal is one line on stderr, exit 2.
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from merge_benchmarks import merged_runs  # noqa: E402

from solver.benchmark.journal import JournalFormatError  # noqa: E402
from solver.benchmark.statistics import wilson_interval  # noqa: E402
from solver.planning.registry import PLANNERS  # noqa: E402

GENERATORS = ["simple_slider", "continuous_space", "grid_world", "move_n_times", "rooms", "lockbox_random"]
SHORT = {"LA-RRT+push (ours)": "LA-RRT+push", "LA-RRT, original segment check": "abl. segment",
         "LA-RRT, fixed factor order": "abl. order"}
PAPER = {"LA-RRT": "23/24", "RRT*": "6/24", "LBT-RRT": "7/24", "BIT*": "24/24"}
ENDS = ("solved", "budget", "clock")


def _puzzle_order(name: str) -> tuple[int, int]:
    generator, seed = name.rsplit("_", 1)
    return (GENERATORS.index(generator) if generator in GENERATORS else len(GENERATORS), int(seed))


def _interval(k: int, n: int) -> str:
    w = wilson_interval(k, n)
    return f"[{100 * w.low:.0f}, {100 * w.high:.0f}] %"


def tables(records: list, added_from: int | None = None) -> str:
    order = [spec.title for spec in PLANNERS.values()]
    planners = sorted({r.planner for r in records}, key=lambda p: order.index(p) if p in order else len(order))
    puzzles = sorted({r.puzzle for r in records}, key=_puzzle_order)
    cell = collections.defaultdict(list)
    for r in records:
        cell[(r.puzzle, r.planner)].append(r)
    out = ["| planner | runs | puzzles solved in all runs | in at least one run | runs solved (pooled) "
           "[95 % Wilson] | end reasons (solved / budget / clock) | CPU s of planning | paper: solved in all runs |",
           "|---|---:|---:|---:|---:|---|---:|---:|"]
    for p in planners:
        mine = [r for r in records if r.planner == p]
        in_all = sum(all(r.solved for r in cell[(z, p)]) for z in puzzles if cell[(z, p)])
        in_any = sum(any(r.solved for r in cell[(z, p)]) for z in puzzles)
        k = sum(r.solved for r in mine)
        ends = collections.Counter(r.end for r in mine)
        out.append(f"| {p} | {len(mine)} | {in_all}/{len(puzzles)} | {in_any}/{len(puzzles)} | "
                   f"{k}/{len(mine)} {_interval(k, len(mine))} | {' / '.join(str(ends[e]) for e in ENDS)} | "
                   f"{sum(r.cpu_time for r in mine):.0f} | {PAPER.get(p, '-')} |")
    header = ["", "| puzzle | " + " | ".join(SHORT.get(p, p) for p in planners) + " |",
              "|---|" + "---:|" * len(planners)]
    out += header
    for z in puzzles:
        row = []
        for p in planners:
            mine = cell[(z, p)]
            k = sum(r.solved for r in mine)
            row.append(f"**{k}/{len(mine)}** {_interval(k, len(mine))}" if len(mine) > 10 else f"{k}/{len(mine)}")
        out.append(f"| {z} | " + " | ".join(row) + " |")
    out += ["", "End reasons per cell, solved / budget / clock:"] + header
    for z in puzzles:
        row = []
        for p in planners:
            ends = collections.Counter(r.end for r in cell[(z, p)])
            if set(ends) - set(ENDS):
                raise ValueError(f"{z}, {p}: an end reason this table does not know: {sorted(set(ends) - set(ENDS))}")
            row.append("/".join(str(ends[e]) for e in ENDS))
        out.append(f"| {z} | " + " | ".join(row) + " |")
    ends = collections.Counter(r.end for r in records)
    out += ["", f"runs {len(records)}; end reasons {dict(ends)}; planning CPU "
            f"{sum(r.cpu_time for r in records) / 3600:.3f} h; worker wall {sum(r.wall for r in records) / 3600:.3f} h"]
    if added_from is not None:
        added = [r for r in records if r.run >= added_from]
        out.append(f"added runs {len(added)}: CPU {sum(r.cpu_time for r in added):.0f} s, "
                   f"worker wall {sum(r.wall for r in added):.0f} s")
        for (z, p), mine in sorted(cell.items()):
            if len(mine) > added_from:
                first = sum(r.solved for r in mine if r.run < added_from)
                k = sum(r.solved for r in mine)
                out.append(f"  {z} {p}: {first}/{added_from} -> {k}/{len(mine)} {_interval(k, len(mine))}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("journals", nargs="+", type=Path)
    parser.add_argument("--added-from", type=int, default=None, metavar="RUN")
    args = parser.parse_args(argv)
    try:
        records = [record for _, record in merged_runs(args.journals).values()]
        if not records:
            raise ValueError(f"{args.journals[0]}: no runs")
        crashed = [r for r in records if r.error]
        if crashed:
            raise ValueError(f"{crashed[0].puzzle}, {crashed[0].planner}, run {crashed[0].run}: crashed "
                             f"({len(crashed)} crashed runs in all); a table of crashed runs would mislead")
        print(tables(records, args.added_from))
    except (OSError, ValueError, JournalFormatError) as error:
        print(f"protocol_tables: {error}".splitlines()[0], file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
