"""Benchmark planners x puzzles x runs; OMPL benchmark logs, the SQLite database, plots, best solutions.

Each run (planner, puzzle, run index) is planned in its own fresh worker
process (no run profits from another's warm caches) with a seed
derived from (base seed, planner, puzzle, run): the same runs give the same
random draws in any order, on any number of workers. Goal states come from
the shared goal sampler (:mod:`solver.planning.goal_sampling`) with a goal seed
derived from (base seed, puzzle, run) only: run ``r`` of every planner sees
the same goal states. A run lasts its time limit, or, with ``until_first``
(``phyrogen benchmark --until first``), ends at its first solution that
holds at fine resolution: success within the time limit and the time to
the first solution are then measured without paying for the rest of the
limit, and the action cost is the first solution's. Results are written in
OMPL's benchmark log format, one log per puzzle (an *experiment*), then
turned into one SQLite database with ``ompl.tools.readBenchmarkLog`` and
``computeViews`` (Planner Arena opens it). The best solution per puzzle of
the LA-RRT entries (the paper's and ours, those registered with ``saves_solution``)
is saved into the puzzle's folder for the manipulation stage
(:attr:`~phyrogen_core.folder.PuzzleFolder.best_solution`).

Everything is checked before the first run (:func:`plan_benchmark`): every
puzzle is read strictly and its planning problem built, the output folder
and, when solutions are saved, each puzzle's ``solutions/`` must be
writable; bad input raises ValueError (one line) and nothing is written.

A benchmark resumes. Every finished run is appended to ``<out>/runs.jsonl``
(one JSON line, fsynced) under a key of everything that decides its result:
planner and its version (:attr:`~solver.planning.registry.PlannerSpec.version`: it
changes with the planner's code or settings), puzzle name and a digest of
the puzzle's files, run index, seed, goal seed, time limit, progress
interval, until-first mode and OMPL version. Running the same benchmark
again reuses the runs whose key matches and runs only the rest; an edited or
regenerated puzzle has another digest, so its old runs are not reused. A
torn last line (the process killed mid-write) is ignored and cut off. The
journal stays when the benchmark completes: it is the raw record of every
run (paths included), and a later benchmark into the same folder with more
runs, planners or puzzles reuses what it holds; delete it to run everything
again. The other outputs (``logs/``, ``benchmark.db``, ``errors.txt``,
``summary.md``, ``summary.json``, ``fig4.png``, ``results.html``; :data:`OUTPUT_ENTRIES`) are built in a
temporary folder inside ``out`` once all runs are done and each is swapped
in with a rename; any other entry of ``out`` is left alone, and so is a user's
file in ``logs/`` that is not a benchmark log (:func:`is_benchmark_log`; a user's file where a
puzzle's log goes is refused). A link at one of these names, or a file
of theirs in a folder no benchmark wrote, is refused before any run
(:func:`check_output_folder`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from phyrogen_core.folder import OutputError, PuzzleFolder, PuzzleFormatError, carry_others, require_stage_folder
from solver.benchmark.jobs import RunJob, RunRecord, make_jobs, run_all
from solver.benchmark.journal import JOURNAL, Journal, _fsync_dir, puzzle_digest, read_journal, run_key
from solver.benchmark.ompl_log import build_database, is_benchmark_log, write_log
from solver.benchmark.profiles import Budget, Profile, budget_for, check_time_limit, check_workers
from solver.benchmark.solutions import save_best_solution
from solver.planning.registry import PLANNERS, get_planner, solution_planners

OUTPUT_ENTRIES = ("logs", "benchmark.db", "errors.txt", "summary.md", "summary.json", "fig4.png", "results.html")
"""The entries of the output folder that a finished benchmark writes, replacing the old ones (an entry
it does not produce this time, say ``errors.txt``, is removed); every other entry is left alone."""
_STAGING_PREFIX = ".benchmark-staging."
DATABASE_TABLES = ("experiments", "runs")
"""Tables every benchmark database has (OMPL's schema): what tells a benchmark's ``benchmark.db`` from another file."""

def check_output_folder(out: Path) -> None:
    """What a benchmark would replace in its output folder ``out``, checked before any run.

    The journal and :data:`OUTPUT_ENTRIES` must be of their kind (``logs`` a folder, the rest
    regular files), none a symbolic link: replacing a link deletes it, and appending to a linked
    journal writes outside the folder. An output entry is replaced only in a folder a benchmark
    wrote, one whose ``runs.jsonl`` is a journal (empty, or with a run in it) or whose
    ``benchmark.db`` is a benchmark database: a user's own ``summary.md`` or ``results.html`` in
    another folder is refused, not overwritten. Raises :class:`~phyrogen_core.folder.OutputError`,
    one line naming the path."""
    out = Path(out)
    if not out.is_dir():
        return
    present = [name for name in (JOURNAL, *OUTPUT_ENTRIES) if os.path.lexists(out / name)]
    for name in present:
        path = out / name
        if path.is_symlink():
            raise OutputError(f"{path} is a symbolic link; a benchmark replaces only its own files in its output "
                              "folder: move the link, or choose another --out")
        if name == "logs" and not path.is_dir():
            raise OutputError(f"{path} is not a folder; a benchmark writes its logs there: move it, or choose "
                              "another --out")
        if name != "logs" and not path.is_file():
            raise OutputError(f"{path} is not a regular file; a benchmark replaces it with its own: move it, or "
                              "choose another --out")
    if JOURNAL in present and not _is_journal(out / JOURNAL):
        raise OutputError(f"{out / JOURNAL} is not a benchmark journal (no line of it is a run); move it, or "
                          "choose another --out")
    outputs = [name for name in present if name != JOURNAL]
    if outputs and JOURNAL not in present and not _is_benchmark_database(out / "benchmark.db"):
        raise OutputError(f"{out / outputs[0]} was not written by phyrogen benchmark ({out} holds no {JOURNAL} "
                          "and no benchmark database); move it, or choose another --out")


def _is_journal(path: Path) -> bool:
    try:
        if os.stat(path).st_size == 0:
            return True  # a benchmark stopped before its first run finished
    except OSError:
        return False
    return bool(read_journal(path))


def _is_benchmark_database(path: Path) -> bool:
    import sqlite3

    if path.is_symlink() or not path.is_file():
        return False
    try:
        with contextlib.closing(sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True)) as db:
            tables = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
    except sqlite3.Error:
        return False
    return all(table in tables for table in DATABASE_TABLES)

# -- the whole benchmark ----------------------------------------------------------
@dataclass(frozen=True)
class BenchmarkOutput:
    folder: Path
    database: Path
    logs: tuple[Path, ...]
    records: tuple[RunRecord, ...] = field(repr=False)
    wall_seconds: float = 0.0
    reused: int = 0  # runs taken from the journal instead of run again
    unsaved_solutions: tuple[str, ...] = ()  # one line per puzzle whose best solution could not be saved


@dataclass(frozen=True)
class BenchmarkPlan:
    """A checked benchmark: its jobs, and which of them the output folder's journal already holds."""

    puzzles: tuple[PuzzleFolder, ...]
    planners: tuple[str, ...]
    profile: Profile
    out: Path
    workers: int
    base_seed: int
    save_solutions: bool
    jobs: tuple[RunJob, ...]
    until_first: bool = field(default=False, kw_only=True)
    budget_checks: Budget = field(default=None, kw_only=True)  # collision checks per run (None: seconds)
    budget_cpu: float | None = field(default=None, kw_only=True)  # CPU seconds per run (machine-dependent)
    keys: tuple[str, ...] = field(repr=False)  # the journal key of each job
    done: Mapping[str, RunRecord] = field(repr=False)  # journaled runs of this benchmark, by key
    digests: Mapping[str, str] = field(repr=False)  # puzzle name -> puzzle_digest

    @property
    def journal(self) -> Path:
        return self.out / JOURNAL

    @property
    def todo(self) -> list[RunJob]:
        return [job for job, key in zip(self.jobs, self.keys, strict=True) if key not in self.done]

    def estimate_seconds(self, overhead: float) -> float:
        """Wall-clock seconds the runs still to do take (see :func:`estimate_seconds`); a budgeted run
        its budget's CPU seconds, or its checks at :data:`ESTIMATED_CHECKS_PER_SECOND` (a rough guide:
        planners and puzzles differ several times), not its backstop."""
        return sum(_job_seconds(job) + overhead for job in self.todo) / self.workers


ESTIMATED_CHECKS_PER_SECOND = 500_000
"""Checks (motions by their length) a planner spends per CPU second, for estimates only: on Move N
Times 2, 0.7-6.3 million a CPU second over the five entries (docs/benchmark/README.md, "Charging the work")."""


def _job_seconds(job: RunJob) -> float:
    if job.budget_cpu is not None:
        return min(job.budget_cpu, job.time_limit)
    if job.budget_checks is not None:
        return min(job.budget_checks / ESTIMATED_CHECKS_PER_SECOND, job.time_limit)
    return job.time_limit


def _ompl_version() -> str:
    from importlib.metadata import version

    return version("ompl")


def plan_benchmark(puzzles: Sequence[PuzzleFolder], planners: Sequence[str], profile: Profile, out: Path,
                   workers: int = 2, base_seed: int = 0, save_solutions: bool = True,
                   until_first: bool = False, budget_checks: Budget = None,
                   budget_cpu: float | None = None) -> BenchmarkPlan:
    """Check everything a benchmark needs, before any run and without writing anything.

    Raises ValueError (:class:`~phyrogen_core.folder.PuzzleFormatError`,
    :class:`~phyrogen_core.folder.OutputError`), one line naming the file, when
    a puzzle cannot be read strictly or its planning problem cannot be built,
    two puzzles share a name, a planner is unknown, ``workers`` is not a whole
    number of at least 1, the output folder cannot be written, or (saving
    solutions) a puzzle's ``solutions/`` cannot be written, or ``budget_checks`` is not a whole
    number in 1..:data:`~solver.planning.anytime.MAX_BUDGET_CHECKS`. Reads the journal
    of ``out`` to find the runs already done. ``until_first``: every run stops at its first
    solution (see the module docstring). ``budget_checks``: every run ends after that many
    collision checks, its time limit only a backstop (the same result on any machine); a mapping
    gives each generator its own (:func:`solver.benchmark.paper_budgets.paper_budgets`), and a
    puzzle of a generator it lacks is refused. ``budget_cpu``: every run ends after that many CPU
    seconds instead (machine-dependent; not with ``budget_checks``).
    """
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.anytime import check_budget_checks, check_budget_cpu
    from solver.planning.problem import problem_for_chain

    check_workers(workers)
    for budget in (budget_checks.values() if isinstance(budget_checks, Mapping) else (budget_checks,)):
        check_budget_checks(budget)
    check_budget_cpu(budget_cpu)
    if budget_checks is not None and budget_cpu is not None:
        raise ValueError("a benchmark has one budget: in collision checks or in CPU seconds, not both")
    if isinstance(base_seed, bool) or not isinstance(base_seed, int):
        raise ValueError(f"base seed must be a whole number, got {base_seed!r}")
    planners = tuple(planners)
    if not planners:
        raise ValueError("no planners to benchmark")
    for name in planners:
        get_planner(name)
        if planners.count(name) > 1:
            raise ValueError(f"planner {name!r} is named twice")
    puzzles = tuple(puzzles)
    if not puzzles:
        raise ValueError("no puzzles to benchmark")
    out = Path(out)
    # A linked --out would take every entry a benchmark replaces (and the journal it appends to) elsewhere.
    require_stage_folder(out, "benchmark output folder")
    check_output_folder(out)  # a user's summary.md or a link there is refused, not replaced
    seen: dict[str, PuzzleFolder] = {}
    digests: dict[str, str] = {}
    for puzzle in puzzles:
        where = puzzle.metadata
        if any(c.isspace() for c in puzzle.name):
            raise PuzzleFormatError(f"{where}: puzzle name {puzzle.name!r} contains white space, which OMPL's "
                                    "benchmark log cannot hold")
        if puzzle.name in seen:
            raise ValueError(f"{seen[puzzle.name].path} and {puzzle.path} are both puzzle {puzzle.name!r}; "
                             "a benchmark tells puzzles apart by name, so give it one of them")
        seen[puzzle.name] = puzzle
        loaded = read_puzzle_dir(puzzle.path)
        try:
            problem_for_chain(loaded.chain, loaded.goal)
            check_time_limit(profile.time_limit(puzzle.generator))
            budget_for(budget_checks, puzzle.generator)
        except ValueError as exc:
            raise PuzzleFormatError(f"{where}: {exc}") from None
        digests[puzzle.name] = puzzle_digest(puzzle)
        log = out / "logs" / f"{puzzle.name}.log"
        if os.path.lexists(log) and not is_benchmark_log(log):
            raise OutputError(f"{log} is not a benchmark log, and the benchmark writes puzzle {puzzle.name!r}'s "
                              "log there: move it, or choose another --out")
        if save_solutions and any(name in planners for name in solution_planners()):
            try:
                # A linked solutions/ (or puzzle folder) would take the solution outside the puzzle.
                require_stage_folder(puzzle.solutions, "solutions folder", root=puzzle.path)
            except OutputError as exc:
                raise OutputError(f"{exc} (or do not save solutions: --no-solutions)") from None
    jobs = tuple(make_jobs(puzzles, planners, profile, base_seed, until_first, budget_checks, budget_cpu))
    ompl = _ompl_version()
    keys = tuple(run_key(job, digests[job.puzzle.name], ompl) for job in jobs)
    journaled = read_journal(out / JOURNAL) if out.is_dir() else {}
    # A crashed run is kept in the journal as a record, but run again: its cause may be fixed by now.
    done = {key: journaled[key] for key in keys if key in journaled and journaled[key].error is None}
    return BenchmarkPlan(puzzles, planners, profile, out, workers, base_seed, save_solutions, jobs, keys,
                         done, digests, until_first=bool(until_first), budget_checks=budget_checks,
                         budget_cpu=None if budget_cpu is None else float(budget_cpu))


def run_benchmark(puzzles: Sequence[PuzzleFolder], planners: Sequence[str], profile: Profile, out: Path,
                  workers: int = 2, base_seed: int = 0, save_solutions: bool = True, plots: bool = True,
                  progress: bool = True, on_done: Callable[[RunRecord], None] | None = None,
                  until_first: bool = False, budget_checks: Budget = None,
                  budget_cpu: float | None = None) -> BenchmarkOutput:
    """Check the input (:func:`plan_benchmark`), then run what the journal does not hold and write
    ``out``: ``logs/<puzzle>.log``, ``benchmark.db``, ``summary.md``, ``fig4.png``, ``errors.txt``
    (when runs crashed), next to the journal ``runs.jsonl``."""
    plan = plan_benchmark(puzzles, planners, profile, out, workers, base_seed, save_solutions, until_first,
                          budget_checks, budget_cpu)
    return run_plan(plan, plots=plots, progress=progress, on_done=on_done)


def run_plan(plan: BenchmarkPlan, plots: bool = True, progress: bool = True,
             on_done: Callable[[RunRecord], None] | None = None, ray: str | None = None) -> BenchmarkOutput:
    """Run the plan's remaining jobs, each journaled as it finishes (then ``on_done`` is called),
    and write the outputs once all are done; ``ray`` as in :func:`run_all`. Interrupted
    (KeyboardInterrupt, any exception), it keeps every journaled run and writes no output: the
    same plan, made again, resumes."""
    from tqdm import tqdm

    plan.out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    records = dict(plan.done)
    key_of = {(j.planner, j.puzzle.name, j.run): k for j, k in zip(plan.jobs, plan.keys, strict=True)}
    with Journal(plan.journal) as journal:
        _remove_stale_staging(plan.out)  # the lock is ours: no other benchmark is writing into this folder
        todo = plan.todo
        if todo:
            bar = tqdm(total=len(plan.jobs), initial=len(plan.done), unit="run", disable=not progress)
            try:
                for record in run_all(todo, plan.workers, ray=ray):
                    key = key_of[(_planner_id(record.planner), record.puzzle, record.run)]
                    journal.append(key, record)
                    records[key] = record
                    bar.update(1)
                    bar.set_postfix_str(f"{record.planner} {record.puzzle} "
                                        f"{'ok' if record.solved else record.status}")
                    if on_done is not None:
                        on_done(record)
            finally:
                bar.close()
        wall = time.perf_counter() - started
        ordered = tuple(records[key] for key in plan.keys)
        _publish(plan, ordered, wall, plots)
    unsaved = []
    if plan.save_solutions:
        for puzzle in plan.puzzles:
            try:
                if puzzle_digest(puzzle) != plan.digests[puzzle.name]:
                    unsaved.append(f"{puzzle.path}: changed while the benchmark ran; its best solution "
                                   "is not saved (run the benchmark again)")
                    continue
                save_best_solution(puzzle, ordered)
            except (OSError, ValueError) as exc:
                unsaved.append(f"{puzzle.path}: best solution not saved: {exc}")
    logs = tuple(plan.out / "logs" / f"{p.name}.log" for p in plan.puzzles)
    return BenchmarkOutput(plan.out, plan.out / "benchmark.db", logs, ordered, wall, len(plan.done), tuple(unsaved))


def _planner_id(title: str) -> str:
    # A worker that could not load a registered planner reports it under its name.
    return next((name for name, spec in PLANNERS.items() if spec.title == title), title)


def _remove_stale_staging(out: Path) -> None:
    for entry in out.iterdir():
        if entry.name.startswith(_STAGING_PREFIX) and entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry, ignore_errors=True)


def _publish(plan: BenchmarkPlan, records: Sequence[RunRecord], wall: float, plots: bool) -> None:
    """Write the outputs into a temporary folder inside ``out``, then rename each into place."""
    profile = plan.profile
    titles = [PLANNERS[p].title for p in plan.planners]
    versions = {PLANNERS[p].title: PLANNERS[p].version for p in plan.planners}
    mode = "each run stops at its first solution (--until first)" if plan.until_first else \
        "each run lasts its time limit (--until limit)"
    if plan.budget_checks is not None:
        budgets = plan.budget_checks if isinstance(plan.budget_checks, Mapping) else None
        mode += (f"; a budget of {plan.budget_checks} collision checks per run" if budgets is None else
                 "; a budget of collision checks per run for each generator (" +
                 ", ".join(f"{g} {n}" for g, n in budgets.items()) + ")") + \
            " (a motion charged by its length), the time limit a wall-clock backstop"
    if plan.budget_cpu is not None:
        mode += (f"; a budget of {plan.budget_cpu:g} CPU seconds per run (machine-dependent), the time limit a "
                 "wall-clock backstop")
    setup = (f"PhyRoGen benchmark, profile {profile.name}: {profile.runs} runs per planner and puzzle, {mode}; "
             f"planners {', '.join(titles)}")
    staging = Path(tempfile.mkdtemp(prefix=_STAGING_PREFIX, dir=plan.out))
    try:
        (staging / "logs").mkdir()
        logs = []
        for puzzle in plan.puzzles:
            mine = [r for r in records if r.puzzle == puzzle.name]
            log = staging / "logs" / f"{puzzle.name}.log"
            write_log(log, puzzle.name, mine, titles, profile.time_limit(puzzle.generator), profile.runs,
                      plan.base_seed, sum(r.wall for r in mine), setup, plan.until_first, versions,
                      budget_for(plan.budget_checks, puzzle.generator), plan.budget_cpu)
            logs.append(log)
        build_database(staging / "benchmark.db", logs)
        crashed = [r for r in records if r.error]
        if crashed:
            (staging / "errors.txt").write_text(
                "\n\n".join(f"{r.planner} {r.puzzle} run {r.run} seed {r.seed}:\n{r.error}" for r in crashed),
                encoding="utf-8")
        if plots:
            from solver.benchmark.plots import plot_fig4, summary_json, summary_markdown, summary_rows

            rows = summary_rows(staging / "benchmark.db")
            (staging / "summary.json").write_text(summary_json(rows), encoding="utf-8")
            (staging / "summary.md").write_text(
                summary_markdown(rows, profile, wall, plan.workers, reused=len(plan.done),
                                 until_first=plan.until_first), encoding="utf-8")
            plot_fig4(staging / "benchmark.db", staging / "fig4.png", until_first=plan.until_first)
            from solver.benchmark.results_page import write_results_page

            write_results_page(staging)
        # Only the benchmark's own logs are replaced in logs/: a user's notes there, even a .log of
        # theirs, go into the new folder.
        carry_others(plan.out / "logs", staging / "logs",
                     lambda path: "/" not in path and is_benchmark_log(plan.out / "logs" / path))
        for name in OUTPUT_ENTRIES:
            new, final = staging / name, plan.out / name
            # A folder cannot be renamed over an existing one: move the old entry out of the way first.
            if os.path.lexists(final) and (not new.exists() or new.is_dir() or final.is_dir() or final.is_symlink()):
                os.replace(final, staging / f"{name}.old")
            if new.exists():
                os.replace(new, final)
        _fsync_dir(plan.out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def estimate_seconds(puzzles: Sequence[PuzzleFolder], planners: Sequence[str], profile: Profile,
                     workers: int, overhead: float) -> float:
    """Wall-clock seconds a benchmark takes: every run lasts its time limit plus ``overhead``
    (process start, loading, final checks; measure it on a sample). Runs that stop at their first
    solution (``until_first``) take at most this."""
    check_workers(workers)
    total = sum(profile.time_limit(p.generator) + overhead for p in puzzles) * profile.runs * len(planners)
    return total / workers
