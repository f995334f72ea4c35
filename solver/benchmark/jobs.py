"""The benchmark's worker jobs: one run (planner, puzzle, run index) planned in a fresh worker process,
and the plain record it reports (:class:`RunRecord`, which the journal stores)."""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

from phyrogen_core.folder import PuzzleFolder
from solver.benchmark.profiles import Budget, Profile, budget_for, check_workers
from solver.parallel.tasks import task_pool
from solver.planning.goal_sampling import goal_seed
from solver.planning.registry import PLANNERS, get_planner, load_planner_source, run_seed


@dataclass(frozen=True)
class RunJob:
    planner: str
    puzzle: PuzzleFolder
    run: int
    seed: int
    time_limit: float
    progress_interval: float
    until_first: bool = False  # stop at the first solution that holds at fine resolution
    goal_seed: int = 0  # the shared goal sampler's seed: the same for every planner of a run
    budget_checks: int | None = None  # collision checks per run; then time_limit is only a backstop
    planner_source: tuple[str, str | None] | None = None  # where a fresh worker finds a registered planner
    budget_cpu: float | None = None  # CPU seconds per run (machine-dependent); time_limit only a backstop


@dataclass(frozen=True)
class RunRecord:
    """One run's outcome, plain data (travels between processes)."""

    planner: str
    puzzle: str
    run: int
    seed: int
    time_limit: float
    solved: bool
    status: str
    time: float
    first_solution_time: float | None
    action_cost: int | None
    length: float | None
    iterations: int
    rejected: int
    progress: tuple[tuple[float, float, int], ...]
    path: tuple[tuple[float, ...], ...] = ()  # chain joint order
    joint_order: tuple[str, ...] = ()
    wall: float = 0.0  # seconds the worker spent, loading and checking included
    error: str | None = None
    best_solution_time: float | None = None
    # None in records journaled before they were counted (still read; see parse_journal_line).
    checks: int | None = None  # collision checks the run spent (solver.planning.anytime.CheckCounter)
    cpu_time: float | None = None  # process CPU seconds of the planning, beside its wall ``time``
    first_solution_checks: int | None = None  # collision checks spent when the first kept path was found
    end: str | None = None  # why the run ended (END_REASONS); None in records journaled before it was


def _run_job(job: RunJob) -> RunRecord:
    started = time.perf_counter()
    try:
        load_planner_source(job.planner, job.planner_source)
        spec = get_planner(job.planner)
        from phyrogen_core.export import read_puzzle_dir
        from solver.planning.problem import chain_path, problem_for_chain
        from solver.planning.solve import seeded_plan

        loaded = read_puzzle_dir(job.puzzle.path)
        problem = problem_for_chain(loaded.chain, loaded.goal)
        result = seeded_plan(spec, problem, job.seed, job.goal_seed, job.time_limit, job.progress_interval,
                             job.until_first, job.budget_checks, job.budget_cpu)
        path = chain_path(problem, result.path) if result.solved else ()
        return RunRecord(
            spec.title, job.puzzle.name, job.run, job.seed, job.time_limit, result.solved, result.status,
            result.time, result.first_solution_time, result.action_cost,
            result.length if result.solved else None, result.iterations, result.rejected,
            tuple((p.time, p.best_cost, p.iterations) for p in result.progress), path, loaded.joint_order,
            time.perf_counter() - started, None, result.best_solution_time, result.checks, result.cpu_time,
            result.first_solution_checks, result.end)
    except Exception as exc:  # a crashed run is data, not the end of the benchmark
        return _crashed(job, time.perf_counter() - started,
                        f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=4)}")


def _crashed(job: RunJob, seconds: float, error: str) -> RunRecord:
    spec = PLANNERS.get(job.planner)
    title = job.planner if spec is None else spec.title
    return RunRecord(title, job.puzzle.name, job.run, job.seed, job.time_limit, False, "Crash", seconds, None, None,
                     None, 0, 0, (), (), (), seconds, error, end="stopped")


def _lost(job: RunJob, how: str) -> RunRecord:
    """A run whose worker died without a record (a planner's segfault, the out-of-memory killer)."""
    return _crashed(job, 0.0, f"the worker process ended ({how}) before it reported")


_PRELOAD = ["numpy", "ompl.base", "ompl.geometric", "phyrogen_core", "phyrogen_core.export", "solver.collision.kernels",
            "solver.planning.anytime", "solver.planning.goal_sampling", "solver.planning.la_rrt",
            "solver.planning.lbt_rrt", "solver.planning.ompl_planners", "solver.benchmark._server_warmup"]


def make_jobs(puzzles: Sequence[PuzzleFolder], planners: Sequence[str], profile: Profile,
              base_seed: int = 0, until_first: bool = False, budget_checks: Budget = None,
              budget_cpu: float | None = None) -> list[RunJob]:
    sources = {name: get_planner(name).source for name in planners}
    return [RunJob(planner, puzzle, run, run_seed(planner, puzzle.name, run, base_seed),
                   profile.time_limit(puzzle.generator), profile.progress_interval, bool(until_first),
                   goal_seed(puzzle.name, run, base_seed), budget_for(budget_checks, puzzle.generator),
                   sources[planner], None if budget_cpu is None else float(budget_cpu))
            for puzzle in puzzles for run in range(profile.runs) for planner in planners]


def run_all(jobs: Sequence[RunJob], workers: int = 2,
            on_done: Callable[[RunRecord], None] | None = None, ray: str | None = None) -> Iterator[RunRecord]:
    """Run every job in a fresh process (one per job), yielding records as they finish; with
    ``ray`` (an address, or :data:`solver.parallel.ray_pool.LOCAL`) as Ray tasks (:mod:`solver.parallel.ray_pool`)."""
    check_workers(workers)
    with task_pool(workers, len(jobs), _PRELOAD, ray) as pool:
        for record in pool.imap_unordered(_run_job, jobs, on_lost=_lost):
            if on_done is not None:
                on_done(record)
            yield record
