"""Benchmark planners x puzzles x runs; OMPL benchmark logs, the SQLite database, plots, best solutions.

Each run (planner, puzzle, run index) is planned in its own fresh worker
process (OMPL's global RNG can be seeded only once per process) with a seed
derived from (base seed, planner, puzzle, run): the same runs give the same
random draws in any order, on any number of workers. Results are written in
OMPL's benchmark log format, one log per puzzle (an *experiment*), then
turned into one SQLite database with ``ompl.tools.readBenchmarkLog`` and
``computeViews`` (Planner Arena opens it). LA-RRT's best solution per puzzle
is saved into the puzzle's folder for the manipulation stage
(:attr:`~phyrogen_core.folder.PuzzleFolder.best_solution`).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import platform
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from phyrogen_core.folder import PuzzleFolder, atomic_directory, write_file_atomic
from phyrogen_core.registry import benchmark_time_limits

from .planners import PLANNERS, get_planner, run_seed
from .pool import fresh_process_pool

PAPER_TIME_LIMITS: Mapping[str, float] = benchmark_time_limits("paper")
"""Seconds per run for each generator's puzzles, as in the paper (from the generator registry)."""

STATUS_NAMES = ("Unknown status", "Invalid start", "Invalid goal", "Unrecognized goal type", "Timeout",
                "Approximate solution", "Exact solution", "Crash", "Abort")
"""OMPL's PlannerStatus values, in enum order (the log stores the index)."""

RUN_PROPERTIES = (
    ("time", "REAL"),
    ("solved", "BOOLEAN"),
    ("status", "ENUM"),
    ("solution length", "REAL"),
    ("action cost", "INTEGER"),
    ("time to first solution", "REAL"),
    ("iterations", "INTEGER"),
    ("seed", "INTEGER"),
    ("rejected paths", "INTEGER"),
)
PROGRESS_PROPERTIES = (("time", "REAL"), ("best cost", "REAL"), ("iterations", "INTEGER"))


@dataclass(frozen=True)
class Profile:
    """How much to run: runs per (planner, puzzle) and seconds per run for each generator."""

    name: str
    runs: int
    time_limits: Mapping[str, float]
    progress_interval: float

    def time_limit(self, generator: str) -> float:
        try:
            return self.time_limits[generator]
        except KeyError:
            raise ValueError(f"profile {self.name!r} has no time limit for generator {generator!r}; "
                             f"it has: {', '.join(self.time_limits)}") from None


QUICK_TIME_LIMITS: Mapping[str, float] = benchmark_time_limits("quick")
"""About a tenth of the paper's limits, from the generator registry (docs/generators.md says
why Move N Times and Lockbox Random differ)."""

PROFILES: Mapping[str, Profile] = {
    "paper": Profile("paper", 100, PAPER_TIME_LIMITS, 0.5),
    "quick": Profile("quick", 10, QUICK_TIME_LIMITS, 0.1),
}


def get_profile(name: str, runs: int | None = None, time_limit: float | None = None) -> Profile:
    """A registered profile, optionally with another run count or one time limit for every generator."""
    try:
        profile = PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown profile {name!r}; valid: {', '.join(PROFILES)}") from None
    if runs is not None:
        if runs < 1:
            raise ValueError(f"runs must be at least 1, got {runs}")
        profile = Profile(profile.name, runs, profile.time_limits, profile.progress_interval)
    if time_limit is not None:
        if not time_limit > 0:
            raise ValueError(f"time limit must be positive seconds, got {time_limit}")
        limits = {g: float(time_limit) for g in profile.time_limits}
        profile = Profile(f"{profile.name}-{time_limit:g}s", profile.runs, limits,
                          min(profile.progress_interval, time_limit / 20))
    return profile


@dataclass(frozen=True)
class RunJob:
    planner: str
    puzzle: PuzzleFolder
    run: int
    seed: int
    time_limit: float
    progress_interval: float


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


def _run_job(job: RunJob) -> RunRecord:
    started = time.perf_counter()
    spec = get_planner(job.planner)
    try:
        if spec.uses_ompl_rng:
            from .validation import seed_ompl

            seed_ompl(job.seed)
        from phyrogen_core.export import read_puzzle_dir

        from .problem import chain_path, problem_for_chain

        loaded = read_puzzle_dir(job.puzzle.path)
        problem = problem_for_chain(loaded.chain, loaded.goal)
        result = spec.plan(problem, job.time_limit, job.seed, job.progress_interval)
        path = chain_path(problem, result.path) if result.solved else ()
        return RunRecord(
            spec.title, job.puzzle.name, job.run, job.seed, job.time_limit, result.solved, result.status,
            result.time, result.first_solution_time, result.action_cost,
            result.length if result.solved else None, result.iterations, result.rejected,
            tuple((p.time, p.best_cost, p.iterations) for p in result.progress), path, loaded.joint_order,
            time.perf_counter() - started, None, result.best_solution_time)
    except Exception as exc:  # a crashed run is data, not the end of the benchmark
        return RunRecord(spec.title, job.puzzle.name, job.run, job.seed, job.time_limit, False, "Crash",
                         time.perf_counter() - started, None, None, None, 0, 0, (), (), (),
                         time.perf_counter() - started, f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=4)}")


_PRELOAD = ["numpy", "ompl.base", "ompl.geometric", "phyrogen_core", "phyrogen_core.export", "solver._kernels",
            "solver.planning", "solver.la_rrt", "solver.lbt_rrt", "solver.ompl_planners"]


def make_jobs(puzzles: Sequence[PuzzleFolder], planners: Sequence[str], profile: Profile,
              base_seed: int = 0) -> list[RunJob]:
    for name in planners:
        get_planner(name)
    return [RunJob(planner, puzzle, run, run_seed(planner, puzzle.name, run, base_seed),
                   profile.time_limit(puzzle.generator), profile.progress_interval)
            for puzzle in puzzles for run in range(profile.runs) for planner in planners]


def run_all(jobs: Sequence[RunJob], workers: int = 2,
            on_done: Callable[[RunRecord], None] | None = None) -> Iterator[RunRecord]:
    """Run every job in a fresh process (one per job), yielding records as they finish."""
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    with fresh_process_pool(workers, len(jobs), _PRELOAD) as pool:
        for record in pool.imap_unordered(_run_job, jobs):
            if on_done is not None:
                on_done(record)
            yield record


# -- OMPL benchmark log --------------------------------------------------------
def _value(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "inf" if isinstance(v, float) and math.isinf(v) else ""
    if isinstance(v, bool):
        return "1" if v else "0"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_log(path: Path, experiment: str, records: Sequence[RunRecord], planner_titles: Sequence[str],
              time_limit: float, runs: int, base_seed: int, total_seconds: float, setup: str) -> None:
    """Write OMPL's benchmark log for one experiment (one puzzle, several planners)."""
    if any(c.isspace() for c in experiment):
        raise ValueError(f"experiment name {experiment!r} must not contain white space (OMPL logs split on it)")
    from importlib.metadata import version

    lines = [
        f"OMPL version {version('ompl')}",
        f"Experiment {experiment}",
        f"Running on {platform.node() or 'unknown'}",
        f"Starting at {datetime.now(UTC).strftime('%Y-%b-%d %H:%M:%S')}",
        "<<<|", setup.rstrip("\n"), "|>>>",
        "<<<|", f"{platform.machine()} {platform.processor() or ''} {os.cpu_count()} cores".strip(), "|>>>",
        f"{base_seed} is the random seed",
        f"{time_limit:g} seconds per run",
        "0 MB per run",
        f"{runs} runs per planner",
        f"{total_seconds:.3f} seconds spent to collect the data",
        "1 enum types",
        "status|" + "|".join(STATUS_NAMES),
        f"{len(planner_titles)} planners",
    ]
    for title in planner_titles:
        mine = sorted((r for r in records if r.planner == title), key=lambda r: r.run)
        lines += [title, "1 common properties", f"time_limit REAL = {time_limit:g}",
                  f"{len(RUN_PROPERTIES)} properties for each run"]
        lines += [f"{name} {kind}" for name, kind in RUN_PROPERTIES]
        lines.append(f"{len(mine)} runs")
        for r in mine:
            values = [r.time, r.solved, STATUS_NAMES.index(r.status), r.length, r.action_cost,
                      r.first_solution_time, r.iterations, r.seed, r.rejected]
            lines.append("".join(_value(v) + "; " for v in values))
        lines.append(f"{len(PROGRESS_PROPERTIES)} progress properties for each run")
        lines += [f"{name} {kind}" for name, kind in PROGRESS_PROPERTIES]
        lines.append(f"{len(mine)} runs")
        for r in mine:
            lines.append("".join(",".join(_value(v) for v in sample) + ",;" for sample in r.progress))
        lines.append(".")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def build_database(db_path: Path, logs: Iterable[Path]) -> None:
    """The SQLite database of the logs, built by OMPL's own reader (Planner Arena's format)."""
    from ompl.tools import computeViews, readBenchmarkLog

    with contextlib.redirect_stdout(io.StringIO()):  # the reader prints a line per log and planner
        readBenchmarkLog(str(db_path), [str(p) for p in logs], False)
        computeViews(str(db_path), False)


# -- best solutions -----------------------------------------------------------
def solution_json(record: RunRecord, factors: Mapping[str, Sequence[int]]) -> dict:
    """The saved form of a best path: joint order, path and the object moved by each action."""
    from .actions import action_sequence

    return {
        "format": "phyrogen-solution",
        "format_version": 1,
        "puzzle": record.puzzle,
        "planner": record.planner,
        "seed": record.seed,
        "run": record.run,
        "time_limit": record.time_limit,
        "found_after": record.best_solution_time,
        "action_cost": record.action_cost,
        "object_sequence": action_sequence(record.path, factors),
        "joint_order": list(record.joint_order),
        "path": [list(s) for s in record.path],
    }


def save_best_solution(puzzle: PuzzleFolder, records: Sequence[RunRecord],
                       planner_title: str = "LA-RRT") -> Path | None:
    """Write the lowest-cost path of ``planner_title`` on ``puzzle`` to its folder (atomically)."""
    from phyrogen_core.export import read_puzzle_dir

    solved = [r for r in records if r.planner == planner_title and r.puzzle == puzzle.name and r.solved]
    if not solved:
        return None
    best = min(solved, key=lambda r: (r.action_cost, r.length, r.run))
    chain = read_puzzle_dir(puzzle.path).chain
    return write_file_atomic(puzzle.best_solution, json.dumps(solution_json(best, chain.factors), indent=1).encode())


# -- the whole benchmark ----------------------------------------------------------
@dataclass(frozen=True)
class BenchmarkOutput:
    folder: Path
    database: Path
    logs: tuple[Path, ...]
    records: tuple[RunRecord, ...] = field(repr=False)
    wall_seconds: float = 0.0


def run_benchmark(puzzles: Sequence[PuzzleFolder], planners: Sequence[str], profile: Profile, out: Path,
                  workers: int = 2, base_seed: int = 0, save_solutions: bool = True, plots: bool = True,
                  progress: bool = True) -> BenchmarkOutput:
    """Run the benchmark and write ``out``: ``logs/<puzzle>.log``, ``benchmark.db``,
    ``summary.md``, ``fig4.png`` (atomically: the folder appears only when complete)."""
    from tqdm import tqdm

    jobs = make_jobs(puzzles, planners, profile, base_seed)
    started = time.perf_counter()
    records: list[RunRecord] = []
    bar = tqdm(total=len(jobs), unit="run", disable=not progress)
    try:
        for record in run_all(jobs, workers):
            records.append(record)
            bar.update(1)
            bar.set_postfix_str(f"{record.planner} {record.puzzle} {'ok' if record.solved else record.status}")
    finally:
        bar.close()
    wall = time.perf_counter() - started
    titles = [PLANNERS[p].title for p in planners]
    out = Path(out)
    setup = (f"PhyRoGen benchmark, profile {profile.name}: {profile.runs} runs per planner and puzzle; "
             f"planners {', '.join(titles)}")
    with atomic_directory(out) as folder:
        (folder / "logs").mkdir()
        logs = []
        for puzzle in puzzles:
            mine = [r for r in records if r.puzzle == puzzle.name]
            log = folder / "logs" / f"{puzzle.name}.log"
            write_log(log, puzzle.name, mine, titles, profile.time_limit(puzzle.generator), profile.runs,
                      base_seed, sum(r.wall for r in mine), setup)
            logs.append(log)
        build_database(folder / "benchmark.db", logs)
        crashed = [r for r in records if r.error]
        if crashed:
            (folder / "errors.txt").write_text(
                "\n\n".join(f"{r.planner} {r.puzzle} run {r.run} seed {r.seed}:\n{r.error}" for r in crashed),
                encoding="utf-8")
        if plots:
            from .plots import plot_fig4, summary_markdown, summary_rows

            rows = summary_rows(folder / "benchmark.db")
            (folder / "summary.md").write_text(summary_markdown(rows, profile, wall, workers), encoding="utf-8")
            plot_fig4(folder / "benchmark.db", folder / "fig4.png")
    if save_solutions:
        for puzzle in puzzles:
            save_best_solution(puzzle, records)
    return BenchmarkOutput(out, out / "benchmark.db", tuple(out / "logs" / p.name for p in logs),
                           tuple(records), wall)


def estimate_seconds(puzzles: Sequence[PuzzleFolder], planners: Sequence[str], profile: Profile,
                     workers: int, overhead: float) -> float:
    """Wall-clock seconds a benchmark takes: every run lasts its time limit plus ``overhead``
    (process start, loading, final checks; measure it on a sample)."""
    total = sum(profile.time_limit(p.generator) + overhead for p in puzzles) * profile.runs * len(planners)
    return total / workers
