"""``phyrogen benchmark``: planners on puzzle folders (OMPL logs, database, plots), resumed from its journal;
``--report DIR`` writes a finished benchmark's results page again."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from phyrogen.json_output import add_json_option
from phyrogen.options import (
    MAX_BENCHMARK_SEED,
    add_quiet_option,
    add_workers_option,
    benchmark_seed_option,
    budget_checks_option,
    path_option,
    whole_number,
)
from phyrogen.ray_options import add_ray_option
from phyrogen.stages import benchmark
from phyrogen.stages.benchmark import MAX_RUNS, MAX_TIME_LIMIT
from phyrogen_core.stage_records.benchmark import BenchmarkRequest


def add_parser(sub) -> None:
    bench = sub.add_parser("benchmark", help="benchmark planners on puzzle folders (OMPL logs, database, plots)")
    bench.add_argument("--puzzles", type=path_option, default="output",
                       help="folder of puzzle folders (default: output)")
    bench.add_argument("--generator", default="all", help="generators to include (default: all found)")
    bench.add_argument("--planners", default="all", help=_planners_help())
    bench.add_argument("--profile", default="quick", help="paper (100 runs, the paper's limits) or quick")
    bench.add_argument("--runs", type=runs_option,
                       help=f"runs per planner and puzzle, 1..{MAX_RUNS} (overrides the profile)")
    bench.add_argument("--time-limit", type=time_limit_option,
                       help=f"seconds per run for every puzzle, above 0 and at most {MAX_TIME_LIMIT:g} "
                            "(overrides the profile); with a budget, a wall-clock backstop of your choice (a run "
                            "it ends is recorded as clock-ended and its cell marked incomplete)")
    bench.add_argument("--seed", type=benchmark_seed_option, default=0,
                       help=f"base seed of every run's seed, 0..{MAX_BENCHMARK_SEED} (default 0)")
    bench.add_argument("--out", type=path_option, default="output/benchmark",
                       help="output folder (default: output/benchmark)")
    add_workers_option(bench)
    add_ray_option(bench, "runs")
    bench.add_argument("--until", choices=("limit", "first"), default="limit",
                       help="limit (default): every run lasts its time limit; first: a run stops at its first "
                            "solution (success within the limit and time to it, affordably)")
    bench.add_argument("--budget-checks", type=budget_checks_option, metavar="N",
                       help="every run ends after N collision checks (1..10^9; a motion counts its length in "
                            "resolution steps), the same result on any machine; the wall-clock backstop is derived "
                            "from the budget (docs/benchmark/README.md#end-reasons) unless --time-limit is given")
    bench.add_argument("--budget-cpu", type=budget_cpu_option, metavar="S",
                       help="every run ends after S CPU seconds of its own process (machine-dependent: the summary "
                            "says so); not with a check budget")
    bench.add_argument("--budget-from-paper", action="store_true",
                       help="every run ends after its generator's paper time limit in collision checks, at the "
                            "checks per second of the paper's harness (docs/benchmark/README.md#paper-budgets); "
                            "not with --budget-checks")
    bench.add_argument("--no-solutions", action="store_true", help="do not save LA-RRT's best path per puzzle")
    bench.add_argument("--dry-run", action="store_true", help="print the job count and time estimate only")
    bench.add_argument("--report", type=path_option, metavar="DIR",
                       help="run nothing: write DIR/results.html again from the finished benchmark in DIR "
                            "(its benchmark.db)")
    add_quiet_option(bench)
    add_json_option(bench, "summary.json's content under 'summary', and the output's paths")
    bench.set_defaults(func=run)


def run(args) -> int:
    if args.report is not None:
        return benchmark_report(Path(args.report))
    request = BenchmarkRequest(args.puzzles, args.generator, args.planners, args.profile, args.runs, args.time_limit,
                               args.seed, args.out, args.workers, args.ray, args.until, args.budget_checks,
                               args.budget_cpu, args.budget_from_paper, not args.no_solutions, not args.quiet)
    if args.dry_run:
        _show_plan(benchmark.plan(request))
        return 0
    result = benchmark.run(request, on_plan=_show_plan)
    print((Path(result.out) / "summary.md").read_text(encoding="utf-8"))
    print(f"database: {result.database}  figure: {Path(result.out) / 'fig4.png'}  results page: {result.results_page}")
    for line in result.unsaved_solutions:
        print(f"phyrogen: warning: {line}", file=sys.stderr)
    args.json_result = result
    return result.exit_code


def _show_plan(plan) -> None:
    print(f"{plan.puzzles} puzzles x {plan.planners} planners x {plan.runs} runs, profile {plan.profile}: "
          f"{'at most ' if plan.until_first else ''}about {plan.estimate_seconds / 3600:.1f} h on {plan.workers} "
          "workers", file=sys.stderr)
    if plan.done:
        print(f"resuming: {plan.done} of {plan.jobs} runs already done (journal {plan.journal}; "
              "delete it to run them again)", file=sys.stderr)


def benchmark_report(folder: Path) -> int:
    """``phyrogen benchmark --report DIR``: the results page of a finished benchmark, made again from
    its database; a missing or broken database is bad input (exit 2, nothing written)."""
    from solver.benchmark.results_page import write_results_page

    print(f"results page: {write_results_page(folder)}")
    return 0


def _planners_help() -> str:
    """``benchmark --planners`` help, from the planner registry (docs/adding-a-planner.md)."""
    from solver.planning.registry import PLANNERS, planner_names

    names = planner_names()
    # argparse %-formats help texts: a title with "%" must not break --help.
    from solver.planning.registry import GROUPS

    listed = "; ".join(f"{name} ({PLANNERS[name].title})" for name in names).replace("%", "%%")
    groups = "; ".join(f"{group}: {what}" for group, what in GROUPS.items()).replace("%", "%%")
    return (f"all (default: every planner outside a group), a group ({groups}) or comma-separated names, "
            f"in any mix: {listed}")




def runs_option(text: str) -> int:
    return whole_number(text, 1, MAX_RUNS)


def budget_cpu_option(text: str) -> float:
    """``benchmark --budget-cpu``: CPU seconds, above 0 and at most a day."""
    from solver.planning.anytime import MAX_BUDGET_CPU

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of CPU seconds, got {text!r}") from None
    if not 0 < value <= MAX_BUDGET_CPU:  # NaN fails both comparisons
        raise argparse.ArgumentTypeError(f"must be above 0 and at most {MAX_BUDGET_CPU:g} CPU seconds, got {text!r}")
    return value


def time_limit_option(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = None
    # NaN fails both comparisons, and inf the upper one: neither is a time limit.
    if value is None or not 0 < value <= MAX_TIME_LIMIT:
        raise argparse.ArgumentTypeError(f"must be a number of seconds above 0 and at most {MAX_TIME_LIMIT:g} "
                                         f"(24 h), got {text!r}")
    return value
