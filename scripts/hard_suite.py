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
            Markdown table of docs/benchmark/hard-suite.md.

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
SEARCH_SEEDS = (70001, 70002)
"""Seeds of the search; no test and not the measurement (90001-90010) uses them."""
MEASURE_SEEDS = "90001-90010"
BACKSTOP = 3600
"""Seconds: each benchmark run's time limit, only a backstop behind its check budget (a run that
reached it would be flagged in the table: unsolved with fewer checks than its budget)."""


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
                        "checks": result.checks, "cpu_time": result.cpu_time}
                log.write(json.dumps(line, sort_keys=True) + "\n")
                log.flush()
                print(f"  {puzzle.name} {overrides} {planner} run {run}: "
                      f"{'solved' if result.solved else 'failed'} after {result.checks} checks, "
                      f"{result.cpu_time:.1f} s CPU", flush=True)
                decided = verdict(outcomes, total)
    summary = {"generator": generator, "size": size, "overrides": overrides, "budget_checks": budget,
               "seeds": list(seeds), "uncertified": uncertified, "runs_per_seed": runs,
               "successes": {p: sum(o) for p, o in outcomes.items()}, "runs": {p: len(o) for p, o in outcomes.items()},
               "hard": bool(decided) if total else False, "generation_cpu": generation_cpu,
               "cpu_time": time.process_time() - cpu}
    log.write(json.dumps({"verdict": summary}, sort_keys=True) + "\n")
    log.flush()
    return summary


def _verdicts(log_path: Path) -> dict[tuple[str, int, int], dict]:
    """The sizes the search log has a verdict for: (generator, size, budget in checks) -> its summary.
    The budget is part of the key: a log may hold searches at several checks per second."""
    done = {}
    if log_path.is_file():
        for line in log_path.read_text().splitlines():
            data = json.loads(line)
            if "verdict" in data:
                found = data["verdict"]
                done[(found["generator"], found["size"], found["budget_checks"])] = found
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
                summary = (done.get((generator, size, paper_budget_checks(generator)))
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


def cmd_table(args) -> int:
    from solver.benchmark.runner import read_journal

    titles = {"bit_star": "BIT*", "rrt_star": "RRT*"}
    rows = ["| generator | parameters | budget (checks) | planner | solved / runs | success rate [95 % Wilson] "
            "| median checks to first (solved runs) | CPU h |", "|---|---|---|---|---|---|---|---|"]
    total_cpu = 0.0
    for entry in get_suite("hard"):
        journal = Path(args.bench) / entry.generator / "runs.jsonl"
        records = list(read_journal(journal).values()) if journal.is_file() else []
        sets = ", ".join(f"{k}={v}" for k, v in entry.overrides.items())
        for planner in PLANNERS:
            # A crashed run (the worker died before it reported) is no verdict on the puzzle: left out and named;
            # the benchmark runs it again when resumed.
            crashed = [r for r in records if r.planner == titles[planner] and r.error]
            if crashed:
                print(f"WARNING: {entry.generator} {titles[planner]}: {len(crashed)} crashed runs left out (run the "
                      "benchmark again to redo them)", file=sys.stderr)
            mine = [r for r in records if r.planner == titles[planner] and not r.error]
            if not mine:
                rows.append(f"| {entry.generator} | {sets} | {paper_budget_checks(entry.generator):,} | "
                            f"{titles[planner]} | not measured | | | |")
                continue
            solved = [r for r in mine if r.solved]
            low, high = wilson(len(solved), len(mine))
            median = statistics.median(r.checks for r in solved) if solved else math.nan
            cpu = sum(r.cpu_time or 0.0 for r in mine)
            total_cpu += cpu
            clock = [r for r in mine if not r.solved and (r.checks or 0) < paper_budget_checks(entry.generator)]
            if clock:
                print(f"WARNING: {entry.generator} {titles[planner]}: {len(clock)} runs ended before their budget "
                      f"(backstop or crash): {[r.status for r in clock]}", file=sys.stderr)
            budget = paper_budget_checks(entry.generator)
            rows.append(f"| {entry.generator} | {sets} | {budget:,} | {titles[planner]} | "
                        f"{len(solved)} / {len(mine)} | {len(solved) / len(mine):.2f} [{low:.2f}, {high:.2f}] | "
                        f"{'-' if not solved else f'{median:,.0f}'} | {cpu / 3600:.3f} |")
    print("\n".join(rows))
    print(f"\nCPU time of all runs: {total_cpu / 3600:.3f} h (the planners' own CPU seconds, `cpu time` of the logs)")
    return 0


def cmd_commands(args) -> int:
    out = args.out
    print(f".venv/bin/phyrogen generate --suite hard --seeds {MEASURE_SEEDS} --workers 1 --out {out}/puzzles")
    for entry in get_suite("hard"):
        print(f".venv/bin/phyrogen benchmark --puzzles {out}/puzzles --generator {entry.generator} --planners "
              f"{','.join(PLANNERS)} --runs {args.runs} --budget-checks {paper_budget_checks(entry.generator)} "
              f"--until first --time-limit {BACKSTOP} --workers 1 --out {out}/bench/{entry.generator}")
    print(f".venv/bin/python scripts/hard_suite.py table --bench {out}/bench")
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
                summary = (done.get((generator, size, paper_budget_checks(generator)))
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
            subprocess.run([*phyrogen, "benchmark", "--puzzles", str(out / "puzzles"), "--generator", generator,
                            "--planners",
                            ",".join(PLANNERS), "--runs", str(args.runs), "--budget-checks",
                            str(paper_budget_checks(generator)), "--until", "first", "--time-limit", str(BACKSTOP),
                            "--workers", "1", "--quiet",
                            "--out", str(out / "bench" / generator)], cwd=ROOT, check=False)
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
    table.set_defaults(func=cmd_table)
    commands = sub.add_parser("commands", help="print the commands that generate and measure the suite")
    commands.add_argument("--out", default="output/hard")
    commands.add_argument("--runs", type=int, default=3)
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
