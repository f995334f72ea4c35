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
import fcntl
import hashlib
import io
import json
import math
import os
import platform
import shutil
import stat
import tempfile
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from phyrogen_core.folder import (
    OutputError,
    PuzzleFolder,
    PuzzleFormatError,
    carry_others,
    read_folder_file,
    require_stage_folder,
    write_file_atomic,
)
from phyrogen_core.registry import benchmark_time_limits
from solver.parallel.tasks import task_pool
from solver.planning.anytime import END_REASONS
from solver.planning.goal_sampling import goal_seed
from solver.planning.registry import PLANNERS, get_planner, load_planner_source, run_seed, solution_planners

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
    ("collision checks", "INTEGER"),
    ("cpu time", "REAL"),
    ("checks to first solution", "INTEGER"),
    ("end reason", "ENUM"),
)
PROGRESS_PROPERTIES = (("time", "REAL"), ("best cost", "REAL"), ("iterations", "INTEGER"))
ENUMS = (("status", STATUS_NAMES), ("end reason", END_REASONS))
"""The logs' enum types: OMPL's status, and why a run ended (:data:`~solver.planning.anytime.END_REASONS`)."""


@dataclass(frozen=True)
class Profile:
    """How much to run: runs per (planner, puzzle) and seconds per run for each generator."""

    name: str
    runs: int
    time_limits: Mapping[str, float]
    progress_interval: float
    default_time_limit: float | None = None  # for a generator missing from time_limits (one limit for all)

    def time_limit(self, generator: str) -> float:
        if generator in self.time_limits:
            return self.time_limits[generator]
        if self.default_time_limit is not None:
            return self.default_time_limit
        raise ValueError(f"profile {self.name!r} has no time limit for generator {generator!r}; "
                         f"it has: {', '.join(self.time_limits)} (or give one limit for all: --time-limit)")


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
        if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
            raise ValueError(f"runs must be a whole number of at least 1, got {runs!r}")
        profile = Profile(profile.name, runs, profile.time_limits, profile.progress_interval)
    if time_limit is not None:
        check_time_limit(time_limit)
        limit = float(time_limit)
        # The one limit holds for every generator, registered or not (a hand-made puzzle's too).
        profile = Profile(f"{profile.name}-{limit:g}s", profile.runs, {g: limit for g in profile.time_limits},
                          min(profile.progress_interval, limit / 20), default_time_limit=limit)
    return profile


def backstop_profile(profile: Profile, budget_checks: Budget = None, budget_cpu: float | None = None) -> Profile:
    """``profile`` with each generator's time limit replaced by the wall-clock backstop of its budget
    (:func:`solver.benchmark.difficulty.backstop_seconds`, :func:`~solver.benchmark.difficulty.cpu_backstop_seconds`):
    so wide that the budget, not the clock, ends a run on any machine under any load; a tighter one
    is an explicit choice (``--time-limit``). Without a budget, ``profile`` itself. (At the paper's
    limits themselves, the clock ended 31 of 34 unsolved runs on a loaded 2-core machine.)"""
    from solver.benchmark.difficulty import backstop_seconds, cpu_backstop_seconds

    if budget_checks is None and budget_cpu is None:
        return profile
    if budget_cpu is not None:
        limits = {g: cpu_backstop_seconds(budget_cpu) for g in profile.time_limits}
        default = cpu_backstop_seconds(budget_cpu)
    elif isinstance(budget_checks, int):
        limits = {g: backstop_seconds(budget_checks) for g in profile.time_limits}
        default = backstop_seconds(budget_checks)
    else:
        limits = {g: backstop_seconds(budget_checks[g]) for g in profile.time_limits if g in budget_checks}
        default = None
    return Profile(f"{profile.name}-backstop", profile.runs, limits, profile.progress_interval,
                   default_time_limit=default)


def check_time_limit(seconds: object) -> None:
    """Raise ValueError unless ``seconds`` is a positive, finite number (an infinite run never ends)."""
    if isinstance(seconds, bool) or not isinstance(seconds, int | float) or not (0 < seconds < math.inf):
        raise ValueError(f"time limit must be a positive, finite number of seconds, got {seconds!r}")


def check_workers(workers: object) -> None:
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a whole number of at least 1, got {workers!r}")


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
        if spec.uses_ompl_rng:
            from solver.planning.ompl_setup import seed_ompl

            seed_ompl(job.seed)
        from phyrogen_core.export import read_puzzle_dir
        from solver.planning.problem import chain_path, problem_for_chain

        loaded = read_puzzle_dir(job.puzzle.path)
        problem = problem_for_chain(loaded.chain, loaded.goal)
        result = spec.plan(problem, job.time_limit, job.seed, job.progress_interval, job.until_first, job.goal_seed,
                           job.budget_checks, job.budget_cpu)
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


Budget = int | Mapping[str, int] | None
"""A check budget per run: one for every puzzle, one per generator (``--budget-from-paper``,
:mod:`solver.benchmark.paper_budgets`), or None (runs end on their time limit)."""


def budget_for(budget: Budget, generator: str) -> int | None:
    """The check budget of a run on ``generator``'s puzzles; ValueError when a per-generator budget
    has none for it."""
    if budget is None or isinstance(budget, int):
        return budget
    try:
        return budget[generator]
    except KeyError:
        raise ValueError(f"no check budget for generator {generator!r}; the budgets are for: "
                         f"{', '.join(budget)}") from None


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
              time_limit: float, runs: int, base_seed: int, total_seconds: float, setup: str,
              until_first: bool = False, versions: Mapping[str, str] | None = None,
              budget_checks: int | None = None, budget_cpu: float | None = None) -> None:
    """Write OMPL's benchmark log for one experiment (one puzzle, several planners). Each planner's
    common properties hold the time limit, whether runs stopped at their first solution
    (``until_first``) and, when given, its version (``versions``: title -> version) and the runs'
    budget (``budget_checks``, or ``budget_cpu`` with ``machine_dependent``); each run's ``end reason``
    says what ended it."""
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
        f"{len(ENUMS)} enum types",
        *("|".join((name, *values)) for name, values in ENUMS),
        f"{len(planner_titles)} planners",
    ]
    for title in planner_titles:
        mine = sorted((r for r in records if r.planner == title), key=lambda r: r.run)
        common = [f"time_limit REAL = {time_limit:g}", f"until_first BOOLEAN = {int(bool(until_first))}"]
        if versions and title in versions:
            common.append(f"version STRING = {versions[title]}")
        if budget_checks is not None:
            common.append(f"budget_checks INTEGER = {budget_checks}")
        if budget_cpu is not None:
            common += [f"budget_cpu REAL = {budget_cpu!r}", "machine_dependent BOOLEAN = 1"]
        lines += [title, f"{len(common)} common properties", *common, f"{len(RUN_PROPERTIES)} properties for each run"]
        lines += [f"{name} {kind}" for name, kind in RUN_PROPERTIES]
        lines.append(f"{len(mine)} runs")
        for r in mine:
            values = [r.time, r.solved, STATUS_NAMES.index(r.status), r.length, r.action_cost,
                      r.first_solution_time, r.iterations, r.seed, r.rejected, r.checks, r.cpu_time,
                      r.first_solution_checks, None if r.end is None else END_REASONS.index(r.end)]
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
    from phyrogen_core.actions import action_sequence

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
                       planner_titles: Sequence[str] | str | None = None) -> Path | None:
    """Write the lowest-cost path on ``puzzle`` of the planners titled ``planner_titles`` (default:
    the entries registered with ``saves_solution``, the LA-RRT ones) to its folder (atomically)."""
    from phyrogen_core.export import read_puzzle_dir

    if planner_titles is None:
        planner_titles = [PLANNERS[name].title for name in solution_planners()]
    elif isinstance(planner_titles, str):
        planner_titles = [planner_titles]
    solved = [r for r in records if r.planner in planner_titles and r.puzzle == puzzle.name and r.solved]
    if not solved:
        return None
    best = min(solved, key=lambda r: (r.action_cost, r.length, r.run))
    chain = read_puzzle_dir(puzzle.path).chain
    return write_file_atomic(puzzle.best_solution, json.dumps(solution_json(best, chain.factors), indent=1).encode())


# -- the journal of finished runs ------------------------------------------------
JOURNAL = "runs.jsonl"
"""The journal of finished runs in the output folder: one JSON object a line, ``{"key": ..., "record": ...}``."""
JOURNAL_FORMAT = 2
"""2: keys name the planner's version, the goal seed and the until-first mode (format 1 keys match none)."""
OUTPUT_ENTRIES = ("logs", "benchmark.db", "errors.txt", "summary.md", "summary.json", "fig4.png", "results.html")
"""The entries of the output folder that a finished benchmark writes, replacing the old ones (an entry
it does not produce this time, say ``errors.txt``, is removed); every other entry is left alone."""
_STAGING_PREFIX = ".benchmark-staging."
DATABASE_TABLES = ("experiments", "runs")
"""Tables every benchmark database has (OMPL's schema): what tells a benchmark's ``benchmark.db`` from another file."""


def is_benchmark_log(path: Path) -> bool:
    """Whether ``path`` is a log a benchmark wrote: a regular file ``<name>.log`` that opens as
    :func:`write_log` opens it (``OMPL version ...``, then ``Experiment <name>``). A user's
    ``my_analysis.log`` in ``logs/``, or a benchmark log they copied under another name, is not one."""
    path = Path(path)
    if path.suffix != ".log" or path.is_symlink() or not path.is_file():
        return False
    try:
        with open(path, "rb") as file:
            head = file.read(4096).split(b"\n")
    except OSError:
        return False
    return len(head) > 2 and head[0].startswith(b"OMPL version ") and \
        head[1] == f"Experiment {path.stem}".encode()


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


def puzzle_digest(puzzle: PuzzleFolder) -> str:
    """SHA-256 over every file the planners read of ``puzzle``: ``puzzle.json``, the URDF, its meshes.

    Run the strict reader first: this function trusts the URDF to parse.
    """
    import xml.etree.ElementTree as ET

    name = PuzzleFolder.open(puzzle.path).name
    urdf = PuzzleFolder(puzzle.path, name).urdf
    urdf_bytes = read_folder_file(urdf, puzzle.path)
    meshes = sorted({m.get("filename", "") for m in ET.fromstring(urdf_bytes).iter("mesh")})
    digest = hashlib.sha256()
    for path in [puzzle.metadata, urdf] + [urdf.parent / m for m in meshes]:
        label = os.path.relpath(path, puzzle.path).encode()
        data = urdf_bytes if path == urdf else read_folder_file(path, puzzle.path)
        # Lengths first, so that no two different sets of files can hash the same stream.
        digest.update(len(label).to_bytes(8, "little") + label + len(data).to_bytes(8, "little") + data)
    return digest.hexdigest()


def run_key(job: RunJob, digest: str, ompl_version: str) -> str:
    """Everything a run's result depends on, as canonical JSON: equal keys, interchangeable runs.

    The planner's version changes with its code or settings (and the goal sampler's), so a run
    recorded before such a change is not reused under the same planner name."""
    return json.dumps({"planner": job.planner, "planner_version": get_planner(job.planner).version,
                       "puzzle": job.puzzle.name, "puzzle_sha256": digest,
                       "run": job.run, "seed": job.seed, "goal_seed": job.goal_seed, "time_limit": job.time_limit,
                       "progress_interval": job.progress_interval, "until": "first" if job.until_first else "limit",
                       "ompl": ompl_version, "format": JOURNAL_FORMAT,
                       # Only when set, so that the keys of runs without a budget are what they were.
                       **({} if job.budget_checks is None else {"budget_checks": job.budget_checks}),
                       **({} if job.budget_cpu is None else {"budget_cpu": job.budget_cpu})},
                      sort_keys=True)


def _finite_or_none(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None  # strict JSON has no infinity; only progress costs are infinite ("no solution yet")
    if isinstance(value, list | tuple):
        return [_finite_or_none(v) for v in value]
    return value


def journal_line(key: str, record: RunRecord) -> bytes:
    data = {"key": json.loads(key), "record": {k: _finite_or_none(v) for k, v in asdict(record).items()}}
    return (json.dumps(data, sort_keys=True, allow_nan=False) + "\n").encode()


_RECORD_TYPES = {
    "planner": str, "puzzle": str, "run": int, "seed": int, "time_limit": float, "solved": bool, "status": str,
    "time": float, "first_solution_time": float | None, "action_cost": int | None, "length": float | None,
    "iterations": int, "rejected": int, "wall": float, "error": str | None, "best_solution_time": float | None,
    "checks": int | None, "cpu_time": float | None, "first_solution_checks": int | None, "end": str | None,
}
_ADDED_FIELDS = {"checks", "cpu_time", "first_solution_checks", "end"}
"""RunRecord fields added after journals were first written: a record without them reads as None."""


def _fits(value: object, kind) -> bool:
    kinds = (kind,) if isinstance(kind, type) else kind.__args__
    if isinstance(value, bool) or value is None:
        return type(value) in kinds
    if isinstance(value, int):
        return int in kinds or float in kinds  # JSON may write a whole float as an integer
    return isinstance(value, kinds)


def parse_journal_line(line: bytes) -> tuple[str, RunRecord] | None:
    """(key, record) of one journal line, or None when the line is torn, foreign or malformed."""
    try:
        data = json.loads(line)
        key, raw = data["key"], data["record"]
        fields = set(RunRecord.__dataclass_fields__)
        if not isinstance(key, dict) or not isinstance(raw, dict) or not fields - _ADDED_FIELDS <= set(raw) <= fields:
            return None
        raw = {name: None for name in _ADDED_FIELDS} | raw
        if not all(_fits(raw[name], kind) for name, kind in _RECORD_TYPES.items()) \
                or raw["status"] not in STATUS_NAMES or raw["end"] not in (None, *END_REASONS):
            return None
        progress = tuple((float(t), math.inf if c is None else float(c), int(i)) for t, c, i in raw["progress"])
        path = tuple(tuple(float(v) for v in state) for state in raw["path"])
        joint_order = tuple(raw["joint_order"])
        if not all(isinstance(n, str) for n in joint_order):
            return None
        record = RunRecord(**{**raw, "progress": progress, "path": path, "joint_order": joint_order})
        spec = PLANNERS.get(key.get("planner"))
        if spec is None or (spec.title, key.get("puzzle"), key.get("run"), key.get("seed")) != (
                record.planner, record.puzzle, record.run, record.seed):
            return None
        return json.dumps(key, sort_keys=True), record
    except (ValueError, TypeError, KeyError, AttributeError, RecursionError):
        return None


def read_journal(path: Path) -> dict[str, RunRecord]:
    """The runs recorded in a journal, by key (the last one of a key wins); {} when there is none.

    Lines that do not parse are skipped: a torn last line, left by a process killed mid-write,
    costs that one run and nothing else.
    """
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return {}
    except OSError as exc:
        raise OutputError(f"journal {path} cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise OutputError(f"journal {path} is not a regular file; remove it or choose another output folder")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise OutputError(f"journal {path} cannot be read: {exc.strerror or exc}") from None
    runs: dict[str, RunRecord] = {}
    for line in raw.split(b"\n"):
        parsed = parse_journal_line(line) if line.strip() else None
        if parsed is not None:
            runs[parsed[0]] = parsed[1]
    return runs


class Journal:
    """The output folder's journal, open for appending and locked against a second benchmark."""

    def __init__(self, path: Path):
        self.path = Path(path)
        # O_NOFOLLOW: a link there would take the journal outside the folder (refused up front as well).
        self._fd = os.open(self.path, os.O_RDWR | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
        try:
            try:
                fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise OutputError(f"{self.path.parent} is in use by another benchmark (its {JOURNAL} is "
                                  "locked); wait for it or choose another output folder") from None
            self._cut_torn_tail()
            os.fsync(self._fd)
            _fsync_dir(self.path.parent)
        except BaseException:
            os.close(self._fd)
            raise

    def _cut_torn_tail(self) -> None:
        # Appending after a torn line would glue the next record onto it; cut the torn part off.
        size = os.fstat(self._fd).st_size
        end = size
        while end > 0:
            start = max(0, end - 65536)
            chunk = os.pread(self._fd, end - start, start)
            newline = chunk.rfind(b"\n")
            if newline >= 0:
                end = start + newline + 1
                break
            end = start
        if end != size:
            os.ftruncate(self._fd, end)

    def append(self, key: str, record: RunRecord) -> None:
        data = memoryview(journal_line(key, record))
        while data:
            data = data[os.write(self._fd, data):]
        os.fsync(self._fd)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)  # releases the lock
            self._fd = -1

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


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
