"""The ``hard`` suite: search each generator's size at which BIT* and RRT* fail, then tabulate a benchmark of it.

Two steps, each a sub-command:

``search``  For each generator, from its paper size up in small steps of its
            difficulty knob: generate the search seeds (the Maker must still
            certify them), run BIT* and RRT* on each, at the paper's budget in
            collision checks (:func:`phyrogen_core.suites.paper_budget_checks`),
            until their first solution; the first size at which both planners
            solve fewer than half of their runs is the generator's hard size.
            Runs are seeded like the benchmark's and stop as soon as the
            verdict is certain (a planner that solved half of the size's runs
            clears it; both failing more than half decides it). Every run is
            appended to ``--log`` (JSON lines) as it finishes, and a size whose
            verdict is in the log is not searched again.

``table``   Read the benchmark journals of the suite measured on held-out
            seeds (``phyrogen benchmark ... --out DIR/<generator>``, one per
            generator, since each has its own paper budget) and print the
            Markdown table of docs/benchmark/hard-suite.md: every benchmark
            entry (both LA-RRTs, RRT*, LBT-RRT, BIT*) on every generator, those
            without a hard size (yet) at the size ``--sizes`` gives (default:
            the largest paper size), with each run's end reason counted.

``commands`` Print the commands that generate and measure the suite.

``pipeline`` For each generator in turn: search, then generate its hard size
            on the held-out seeds and benchmark it (the commands ``commands``
            prints, with ``--generator G --set KNOB=SIZE``, which make the same
            puzzles as ``--suite hard``), one process at a time.

Run from the repository root: ``.venv/bin/python scripts/hard_suite.py search --generators simple_slider``.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from phyrogen_core.maker import GenerationError  # noqa: E402
from phyrogen_core.registry import get_generator  # noqa: E402
from phyrogen_core.suites import get_suite  # noqa: E402
from solver.benchmark.paper_budgets import PAPER_CHECKS_PER_SECOND  # noqa: E402

CHECKS_PER_SECOND = PAPER_CHECKS_PER_SECOND
"""Checks per second of the paper's limits used by this run (``--checks-per-second``; default the
benchmark's calibration)."""


def paper_budget_checks(generator: str) -> int:
    """``generator``'s paper time limit in collision checks at :data:`CHECKS_PER_SECOND`."""
    return round(get_generator(generator).time_limit("paper") * CHECKS_PER_SECOND)

PLANNERS = ("bit_star", "rrt_star")
"""The planners whose failure defines a hard size (the search runs these two)."""
ENTRIES = ("la_rrt", "la_rrt_push", "rrt_star", "lbt_rrt", "bit_star")
"""The entries the suite is measured with (``table``, ``commands``, ``pipeline``): the benchmark's five."""
CHARGE = "motion-length"
"""How the search's checks were counted: a motion by its length in resolution steps (the benchmark's
unit since planner versions paper-4/push-5/ompl-5/py-4). Search lines without it counted a motion once
(``per-motion``, the committed hard-suite-search*.jsonl): their verdicts are not reused at the same budget."""
SEARCH_SEEDS = (70001, 70002)
"""Seeds of the search; no test and not the measurement (90001-90010) uses them."""
MEASURE_SEEDS = "90001-90010"


@dataclass(frozen=True)
class Knob:
    """How a generator's size is stepped: ``knob`` from ``start`` by ``step`` up to ``stop``; ``tied``
    parameters take the knob's value too (Rooms: as many doors as rooms)."""

    knob: str
    start: int
    step: int
    stop: int
    tied: tuple[str, ...] = ()

    def overrides(self, size: int) -> dict[str, str]:
        return {name: str(size) for name in (self.knob, *self.tied)}


KNOBS = {
    # The paper's sizes: Simple Slider seeds 1-4 have 2-5 sliders, Move N Times n = 1-4, the others Table I's.
    "simple_slider": Knob("n_objects", 5, 1, 12),
    "move_n_times": Knob("n", 4, 1, 12),
    "continuous_space": Knob("n_objects", 4, 1, 12),
    "grid_world": Knob("n_objects", 5, 2, 25),
    "rooms": Knob("n_rooms", 4, 1, 6, ("doors",)),
    "lockbox_random": Knob("n_objects", 7, 2, 19),
}


def verdict(outcomes: dict[str, list[bool]], total: int) -> bool | None:
    """True: every planner solves under half of ``total`` runs whatever the rest do; False: one
    solved at least half; None: not decided yet."""
    if any(2 * sum(got) >= total for got in outcomes.values()):
        return False
    if all(2 * (len(got) - sum(got)) > total for got in outcomes.values()):
        return True
    return None


def search_size(generator: str, size: int, knob: Knob, seeds: tuple[int, ...], runs: int, log) -> dict:
    from solver.benchmark.difficulty import DifficultySettings, difficulty_run
    from solver.pipelines.generation import generate_here

    spec = get_generator(generator)
    overrides = knob.overrides(size)
    params = spec.parse_params(overrides)
    budget = paper_budget_checks(generator)
    puzzles, uncertified = [], []
    cpu = time.process_time()
    for seed in seeds:
        try:
            puzzles.append(generate_here(generator, seed, params))
        except GenerationError as exc:
            uncertified.append(seed)
            print(f"  {generator} {overrides} seed {seed}: not certified ({exc})", flush=True)
    generation_cpu = time.process_time() - cpu
    total = len(puzzles) * runs
    outcomes: dict[str, list[bool]] = {planner: [] for planner in PLANNERS}
    decided = None if total else False
    for puzzle in puzzles:
        for run in range(runs):
            for planner in PLANNERS:
                if decided is not None:
                    break
                result = difficulty_run(puzzle.chain, puzzle.goal, puzzle.name, run,
                                        DifficultySettings(1, budget, planner))
                outcomes[planner].append(result.solved)
                line = {"generator": generator, "size": size, "overrides": overrides, "puzzle": puzzle.name,
                        "planner": planner, "run": run, "budget_checks": budget, "solved": result.solved,
                        "checks": result.checks, "cpu_time": result.cpu_time, "charge": CHARGE,
                        "end": result.end}
                log.write(json.dumps(line, sort_keys=True) + "\n")
                log.flush()
                print(f"  {puzzle.name} {overrides} {planner} run {run}: "
                      f"{'solved' if result.solved else 'failed'} after {result.checks} checks, "
                      f"{result.cpu_time:.1f} s CPU", flush=True)
                decided = verdict(outcomes, total)
    summary = {"generator": generator, "size": size, "overrides": overrides, "budget_checks": budget, "charge": CHARGE,
               "seeds": list(seeds), "uncertified": uncertified, "runs_per_seed": runs,
               "successes": {p: sum(o) for p, o in outcomes.items()}, "runs": {p: len(o) for p, o in outcomes.items()},
               "hard": bool(decided) if total else False, "generation_cpu": generation_cpu,
               "cpu_time": time.process_time() - cpu}
    log.write(json.dumps({"verdict": summary}, sort_keys=True) + "\n")
    log.flush()
    return summary


def _verdicts(log_path: Path) -> dict[tuple[str, int, int, str], dict]:
    """The sizes the search log has a verdict for: (generator, size, budget in checks, charge) -> its
    summary. The budget and the unit it was counted in (:data:`CHARGE`; ``per-motion`` for lines without
    one) are part of the key: a log may hold searches at several checks per second and in either unit."""
    done = {}
    if log_path.is_file():
        for line in log_path.read_text().splitlines():
            data = json.loads(line)
            if "verdict" in data:
                found = data["verdict"]
                done[(found["generator"], found["size"], found["budget_checks"],
                      found.get("charge", "per-motion"))] = found
    return done


def _starts(text: str) -> dict[str, int]:
    """``--start simple_slider=6,move_n_times=7`` -> the first size to search per generator."""
    starts = {}
    for item in filter(None, text.split(",")):
        name, _, size = item.partition("=")
        if name not in KNOBS or not size.isdigit():
            print(f"hard_suite.py: bad --start item {item!r} (GENERATOR=SIZE, generators: {', '.join(KNOBS)})",
                  file=sys.stderr)
            raise SystemExit(2)
        starts[name] = int(size)
    return starts


def _sizes(generator: str, starts: dict[str, int]) -> range:
    """The sizes the search steps through: from the paper's size, or ``--start``'s (a size found hard at a
    smaller budget: a larger budget can only make a size easier), up by the knob's step."""
    knob = KNOBS[generator]
    return range(starts.get(generator, knob.start), knob.stop + 1, knob.step)


def cmd_search(args) -> int:
    seeds = tuple(int(s) for s in args.seeds.split(","))
    log_path = Path(args.log)
    done = _verdicts(log_path)
    starts = _starts(args.start)
    with log_path.open("a") as log:
        for generator in args.generators.split(","):
            knob = KNOBS[generator]
            for size in _sizes(generator, starts):
                summary = (done.get((generator, size, paper_budget_checks(generator), CHARGE))
                           or search_size(generator, size, knob, seeds, args.runs, log))
                print(f"{generator} {knob.knob}={size}: {summary['successes']} of {summary['runs']} runs solved "
                      f"(budget {summary['budget_checks']} checks), uncertified seeds {summary['uncertified']}: "
                      f"{'HARD' if summary['hard'] else 'not hard'}", flush=True)
                if summary["hard"] or len(summary["uncertified"]) == len(seeds):
                    break
    return 0


def wilson(successes: int, runs: int) -> tuple[float, float]:
    from solver.benchmark.statistics import wilson_interval

    interval = wilson_interval(successes, runs)
    return interval.low, interval.high


def _sizes_option(text: str) -> dict[str, int]:
    """``--sizes rooms=4,lockbox_random=7``: the size of each generator without a hard size (yet)."""
    return _starts(text)


def measured_sizes(sizes: dict[str, int]) -> list[tuple[str, dict[str, str], bool]]:
    """(generator, overrides, in the suite) for every generator of :data:`KNOBS`: the suite's size, else
    ``sizes``'s, else the knob's start (the largest paper size)."""
    suite = {entry.generator: dict(entry.overrides) for entry in get_suite("hard")}
    out = []
    for generator, knob in KNOBS.items():
        if generator in suite:
            out.append((generator, suite[generator], True))
        else:
            out.append((generator, knob.overrides(sizes.get(generator, knob.start)), False))
    return out


def table_rows(bench: Path, sizes: dict[str, int]) -> tuple[list[str], float, list[str]]:
    """The Markdown rows of the measured suite in ``bench`` (one benchmark folder per generator), the CPU
    seconds of its runs and warnings (crashed runs left out, clock-ended runs)."""
    from solver.benchmark.journal import read_journal
    from solver.planning.registry import get_planner

    rows = ["| generator | parameters | budget (checks) | entry | solved / runs | success rate [95 % Wilson] "
            "| median checks to first (solved runs) | end reasons | CPU h |",
            "|---|---|---:|---|---|---|---:|---|---:|"]
    warnings = []
    total_cpu = 0.0
    for generator, overrides, in_suite in measured_sizes(sizes):
        journal = bench / generator / "runs.jsonl"
        records = list(read_journal(journal, strict=True).values()) if journal.is_file() else []
        sets = ", ".join(f"{k}={v}" for k, v in overrides.items()) + ("" if in_suite else " (not a hard size)")
        budget = paper_budget_checks(generator)
        for planner in ENTRIES:
            title = get_planner(planner).title
            # A crashed run (the worker died before it reported) is no verdict on the puzzle: left out and named;
            # the benchmark runs it again when resumed.
            crashed = [r for r in records if r.planner == title and r.error]
            if crashed:
                warnings.append(f"{generator} {title}: {len(crashed)} crashed runs left out (run the benchmark "
                                "again to redo them)")
            mine = [r for r in records if r.planner == title and not r.error]
            # A run the wall clock ended is no result of its budget (docs/benchmark/README.md#end-reasons).
            clock = [r for r in mine if r.end == "clock" or (r.end is None and not r.solved and
                                                              (r.checks or 0) < budget)]
            counted = [r for r in mine if r not in clock]
            if clock:
                warnings.append(f"{generator} {title}: {len(clock)} runs ended by the clock before their budget: "
                                "left out, the cell is incomplete")
            if not mine:
                rows.append(f"| {generator} | {sets} | {budget:,} | {title} | not measured | | | | |")
                continue
            ends: dict[str, int] = {}
            for r in mine:
                ends[r.end or "unknown"] = ends.get(r.end or "unknown", 0) + 1
            end_text = ", ".join(f"{k} {v}" for k, v in sorted(ends.items())) + (" (incomplete)" if clock else "")
            cpu = sum(r.cpu_time or 0.0 for r in mine)
            total_cpu += cpu
            if not counted:
                rows.append(f"| {generator} | {sets} | {budget:,} | {title} | 0 / 0 | - | - | {end_text} "
                            f"| {cpu / 3600:.3f} |")
                continue
            solved = [r for r in counted if r.solved]
            low, high = wilson(len(solved), len(counted))
            median = statistics.median(r.checks for r in solved) if solved else math.nan
            rows.append(f"| {generator} | {sets} | {budget:,} | {title} | "
                        f"{len(solved)} / {len(counted)} | {len(solved) / len(counted):.2f} [{low:.2f}, {high:.2f}] | "
                        f"{'-' if not solved else f'{median:,.0f}'} | {end_text} | {cpu / 3600:.3f} |")
    return rows, total_cpu, warnings


def cmd_table(args) -> int:
    from solver.benchmark.journal import JournalFormatError

    try:
        rows, total_cpu, warnings = table_rows(Path(args.bench), _sizes_option(args.sizes))
    except JournalFormatError as exc:
        print(f"hard_suite.py: {exc}", file=sys.stderr)
        return 2
    for line in warnings:
        print(f"WARNING: {line}", file=sys.stderr)
    print("\n".join(rows))
    print(f"\nCPU time of all runs: {total_cpu / 3600:.3f} h (the planners' own CPU seconds, `cpu time` of the logs)")
    return 0


def benchmark_command(out: str, generator: str, runs: int) -> list[str]:
    """The ``phyrogen benchmark`` arguments that measure ``generator``'s puzzles in ``out/puzzles`` with every
    entry, until the first solution, at its paper budget; the backstop derived from the budget."""
    return ["benchmark", "--puzzles", f"{out}/puzzles", "--generator", generator, "--planners", ",".join(ENTRIES),
            "--runs", str(runs), "--budget-checks", str(paper_budget_checks(generator)), "--until", "first",
            "--workers", "1", "--no-solutions", "--out", f"{out}/bench/{generator}"]


def cmd_commands(args) -> int:
    out = args.out
    print(f".venv/bin/phyrogen generate --suite hard --seeds {MEASURE_SEEDS} --workers 1 --out {out}/puzzles")
    for generator, overrides, in_suite in measured_sizes(_sizes_option(args.sizes)):
        if not in_suite:
            sets = " ".join(f"--set {k}={v}" for k, v in overrides.items())
            print(f".venv/bin/phyrogen generate --generator {generator} {sets} --seeds {MEASURE_SEEDS} --workers 1 "
                  f"--out {out}/puzzles")
    for generator, _, _ in measured_sizes(_sizes_option(args.sizes)):
        print(".venv/bin/phyrogen " + " ".join(benchmark_command(out, generator, args.runs)))
    print(f".venv/bin/python scripts/hard_suite.py table --bench {out}/bench"
          + (f" --sizes {args.sizes}" if args.sizes else ""))
    return 0


def cmd_pipeline(args) -> int:
    import subprocess

    phyrogen = [sys.executable, "-m", "phyrogen"]
    seeds = tuple(int(s) for s in args.seeds.split(","))
    out = Path(args.out)
    done = _verdicts(Path(args.log))
    starts = _starts(args.start)
    with Path(args.log).open("a") as log:
        for generator in args.generators.split(","):
            knob = KNOBS[generator]
            hard = None
            for size in _sizes(generator, starts):
                summary = (done.get((generator, size, paper_budget_checks(generator), CHARGE))
                           or search_size(generator, size, knob, seeds, args.search_runs, log))
                print(f"{generator} {knob.knob}={size}: {summary['successes']} of {summary['runs']} solved, "
                      f"uncertified {summary['uncertified']}: {'HARD' if summary['hard'] else 'not hard'}", flush=True)
                if summary["hard"]:
                    hard = size
                    break
                if len(summary["uncertified"]) == len(seeds):
                    break
            if hard is None:
                print(f"{generator}: no hard size found up to {knob.stop}", flush=True)
                continue
            sets = [arg for key, value in knob.overrides(hard).items() for arg in ("--set", f"{key}={value}")]
            started = time.time()
            subprocess.run([*phyrogen, "generate", "--generator", generator, *sets, "--seeds", MEASURE_SEEDS,
                            "--workers", "1", "--quiet", "--out", str(out / "puzzles")], cwd=ROOT, check=False)
            subprocess.run([*phyrogen, *benchmark_command(str(out), generator, args.runs), "--quiet"], cwd=ROOT,
                           check=False)
            print(f"{generator}: measured at {knob.knob}={hard} in {time.time() - started:.0f} s wall", flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    search = sub.add_parser("search", help="find each generator's hard size")
    search.add_argument("--generators", default=",".join(KNOBS))
    search.add_argument("--seeds", default=",".join(str(s) for s in SEARCH_SEEDS))
    search.add_argument("--runs", type=int, default=2, help="runs per planner and seed")
    search.add_argument("--log", default="hard_suite_search.jsonl")
    search.add_argument("--start", default="", help="GENERATOR=SIZE,...: the first size to search (default the "
                        "paper's)")
    search.set_defaults(func=cmd_search)
    table = sub.add_parser("table", help="the Markdown table of a measured suite")
    table.add_argument("--bench", required=True, help="folder with one benchmark output folder per generator")
    table.add_argument("--sizes", default="", help="GENERATOR=SIZE,...: the size measured of a generator without "
                       "a hard size (default: its largest paper size)")
    table.set_defaults(func=cmd_table)
    commands = sub.add_parser("commands", help="print the commands that generate and measure the suite")
    commands.add_argument("--out", default="output/hard")
    commands.add_argument("--runs", type=int, default=3)
    commands.add_argument("--sizes", default="", help="GENERATOR=SIZE,...: the size to measure of a generator "
                          "without a hard size (default: its largest paper size)")
    commands.set_defaults(func=cmd_commands)
    pipeline = sub.add_parser("pipeline", help="search, generate and benchmark each generator in turn")
    pipeline.add_argument("--generators", default=",".join(KNOBS))
    pipeline.add_argument("--seeds", default=",".join(str(s) for s in SEARCH_SEEDS))
    pipeline.add_argument("--search-runs", type=int, default=2, help="search runs per planner and seed")
    pipeline.add_argument("--runs", type=int, default=3, help="benchmark runs per planner and puzzle")
    pipeline.add_argument("--log", default="hard_suite_search.jsonl")
    pipeline.add_argument("--start", default="", help="GENERATOR=SIZE,...: the first size to search")
    pipeline.add_argument("--out", default="output/hard")
    pipeline.set_defaults(func=cmd_pipeline)
    parser.add_argument("--checks-per-second", type=int, default=PAPER_CHECKS_PER_SECOND,
                        help=f"checks per second of the paper's time limits (default {PAPER_CHECKS_PER_SECOND:,}, "
                             "solver.benchmark.paper_budgets, at which the committed suite was searched)")
    args = parser.parse_args(argv)
    global CHECKS_PER_SECOND
    CHECKS_PER_SECOND = args.checks_per_second
    print(f"paper budget: {CHECKS_PER_SECOND:,} checks per second of the paper's limits", file=sys.stderr)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
