"""The benchmark stage: planners on puzzle folders (OMPL logs, database, plots), resumed from its journal."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from phyrogen.options import MAX_BENCHMARK_SEED
from phyrogen.ray_options import check_ray, ray_connection
from phyrogen.stage_checks import check_within, check_workers
from phyrogen.usage import UsageError, generator_names
from phyrogen_core.stage_records.benchmark import BenchmarkPlan, BenchmarkRequest, BenchmarkResult

MAX_RUNS = 10_000
"""``runs``: the paper's protocol takes 100 runs per planner and puzzle."""
MAX_TIME_LIMIT = 24 * 3600.0
"""``time_limit`` in seconds: a day per run; the paper's longest limit is 600 s."""


def plan(request: BenchmarkRequest) -> BenchmarkPlan:
    """What the benchmark would run, everything checked (every puzzle read, every output path), nothing run or
    written."""
    return _plan(request)[1]


def run(request: BenchmarkRequest, *, on_plan: Callable[[BenchmarkPlan], None] | None = None) -> BenchmarkResult:
    """Run the benchmark (resuming the runs its output folder's journal holds) and write its outputs;
    ``on_plan`` gets the checked plan before the first run."""
    from solver.benchmark.runner import run_plan

    checked, told = _plan(request)
    if on_plan is not None:
        on_plan(told)
    with ray_connection(request.ray, request.workers):
        output = run_plan(checked, progress=request.progress, ray=request.ray)
    out = Path(request.out)
    return BenchmarkResult(out=str(out), database=str(output.database), results_page=str(out / "results.html"),
                           crashed=sum(1 for r in output.records if r.error),
                           unsaved_solutions=tuple(output.unsaved_solutions),
                           summary=json.loads((out / "summary.json").read_text(encoding="utf-8")))


def _plan(request: BenchmarkRequest):
    from phyrogen_core.folder import find_puzzle_folders
    from solver.benchmark.profiles import backstop_profile, get_profile
    from solver.benchmark.runner import plan_benchmark
    from solver.planning.registry import select_planners

    check_workers(request.workers)
    check_within("runs", request.runs, 1, MAX_RUNS)
    check_within("time_limit", request.time_limit, 0, MAX_TIME_LIMIT, " seconds", above_low=True)
    check_within("seed", request.seed, 0, MAX_BENCHMARK_SEED)
    generators = None if request.generator == "all" else generator_names(request.generator)
    try:
        planners = select_planners(request.planners)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    profile = get_profile(request.profile, request.runs, request.time_limit)
    budget_checks = request.budget_checks
    if request.budget_from_paper:
        from solver.benchmark.paper_budgets import paper_budgets

        if request.budget_checks is not None:
            raise UsageError("--budget-from-paper sets each generator's check budget; give no --budget-checks with it")
        budget_checks = paper_budgets()
    if request.budget_cpu is not None and budget_checks is not None:
        raise UsageError("--budget-cpu gives every run a budget in CPU seconds; give no check budget with it")
    if (budget_checks is not None or request.budget_cpu is not None) and request.time_limit is None:
        # The budget ends a run; the clock, derived from the budget, only a hang (a tight one: --time-limit).
        profile = backstop_profile(profile, budget_checks, request.budget_cpu)
    puzzles = find_puzzle_folders(Path(request.puzzles), generators)
    # Every puzzle is read and every output path checked here, before the first run.
    until_first = request.until == "first"
    checked = plan_benchmark(puzzles, planners, profile, Path(request.out), request.workers, request.seed,
                             save_solutions=request.save_solutions, until_first=until_first,
                             budget_checks=budget_checks, budget_cpu=request.budget_cpu)
    check_ray(request.ray)  # an unreachable cluster is bad input, refused before any line of progress
    told = BenchmarkPlan(len(puzzles), len(planners), profile.runs, profile.name, until_first,
                         checked.estimate_seconds(overhead=1.0), request.workers, len(checked.jobs),
                         len(checked.done), str(checked.journal))
    return checked, told
