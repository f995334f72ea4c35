"""Generate certified puzzles, each in a fresh worker process.

Each puzzle seeds every random source it draws from at its start (numpy
Generators and OMPL's seed generator, from (generator, seed)), so the result
is the same in any process and any order. ``phyrogen generate`` still runs
each puzzle in a process of its own, forked from a server process that has
imported everything (a crash or a hang costs that puzzle only);
datasets run cheap puzzles in batches (:mod:`solver.pipelines.dataset.build`).
"""

from __future__ import annotations

import time
import traceback
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence, Sized
from dataclasses import dataclass, field, replace
from functools import cache, partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from phyrogen_core import __version__
from phyrogen_core.maker import GenerationError
from phyrogen_core.registry import ParameterError, get_generator
from phyrogen_core.seeding import stable_seed
from solver.parallel.pool import deferred_signals, fresh_process_pool

if TYPE_CHECKING:
    from phyrogen_core.puzzle import Puzzle
    from solver.benchmark.difficulty import DifficultySettings

_WORKER_STACK = ["solver.validation.validator", "solver.planning.defragment", "solver.planning.problem",
                 "solver.planning.ompl_setup", "solver.benchmark.difficulty"]
"""What a worker generates with: imported by the workers' server only (:data:`_PRELOAD`), never at this
module's top, so that the command's process, which only schedules the work, does not load the
compiled kernels' stack (about 0.3 CPU s of a dataset's start-up)."""
_PRELOAD = ["numpy", "ompl.base", "ompl.geometric", "phyrogen_core", "phyrogen_core.generators",
            "phyrogen_core.actions", "phyrogen_core.export", *_WORKER_STACK, "solver.pipelines._server_warmup"]


def ompl_seed(generator: str, seed: int) -> int:
    """The seed of OMPL's global RNG for puzzle ``seed`` of ``generator``."""
    return stable_seed("ompl", generator, seed)


def versions() -> dict[str, str]:
    """The versions written into every puzzle folder, looked up once per process (importlib.metadata
    reads and parses each package's METADATA: 2 ms a puzzle otherwise)."""
    return dict(_versions())


@cache
def _versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {"phyrogen": __version__}
    for package in ("numpy", "ompl"):
        try:
            out[package] = version(package)
        except PackageNotFoundError:
            pass
    return out


def warm_hint(generator: str, seed: int, params: Any, *, also: Sequence[str] = (), generate: bool = True,
              always: bool = False) -> str:
    """The text a fresh-process pool hands its server (:data:`solver.parallel.pool.SERVER_HINT`) for it to
    prepare the workers for puzzles of ``generator`` (and of the generators ``also``), before it forks any
    (:mod:`solver.pipelines._server_warmup`): it loads what those generators' puzzles loaded before
    (:mod:`solver.pipelines._warm_record`) or, with ``generate``, generates the puzzle ``seed`` of
    ``generator`` once and throws it away: the workers then start with what that generator's puzzles load on
    first use (its compiled kernels' signatures, above all), and nothing else. ``always``: generate it even
    when a record holds its signatures, for what the puzzle warms beyond them (see :func:`read_hint`)."""
    import base64
    import pickle

    return base64.b64encode(pickle.dumps((generator, seed, params, tuple(also), bool(generate),
                                          bool(generate and always)))).decode("ascii")


@dataclass(frozen=True)
class WarmHint:
    """A :func:`warm_hint` read back."""

    generator: str
    seed: int
    params: Any
    also: tuple[str, ...] = ()
    generate: bool = True
    always: bool = False
    """Generate the puzzle even after loading its generator's record: a worker's first puzzle costs about
    3 ms more after a server that only loaded signatures (Python's bytecode specialised and the caches filled
    by the server's puzzle are shared by every worker), which a request of many batches pays many times."""


def read_hint(hint: str) -> WarmHint:
    """The :func:`warm_hint` that made ``hint``; raises what reading a text that is none raises."""
    import base64
    import pickle

    generator, seed, params, also, generate, always = pickle.loads(base64.b64decode(hint.encode("ascii")))
    return WarmHint(str(generator), seed, params, tuple(str(name) for name in also), bool(generate), bool(always))


def generate_for_hint(hint: str) -> None:
    """Generate, in this process, the puzzle named by a :func:`warm_hint`, and discard it; it writes
    nothing. Raises what the hint's reading or the generation raises."""
    read = read_hint(hint)
    try:
        generate_here(read.generator, read.seed, read.params)
    except GenerationError:  # a failed seed: it has loaded what it needed on its way
        pass


def generate_here(generator: str, seed: int, params: Any = None, *, stats: dict[str, Any] | None = None) -> Puzzle:
    """Generate and certify one puzzle in THIS process.

    Deterministic in any process, after anything else (see the module docstring).
    ``stats``, when given, receives ``validation_checks``: the collision queries the Maker's
    validator spent (planning, necessity judging, certifying), a machine-independent cost.
    """
    from phyrogen_core.maker import make, rng_for
    from phyrogen_core.objects import build_chain
    from phyrogen_core.puzzle import Puzzle
    from solver.planning.defragment import defragment_certificate
    from solver.planning.ompl_setup import seed_ompl
    from solver.planning.problem import dependency_graph
    from solver.validation.validator import OmplValidator

    spec = get_generator(generator)
    params = spec.default_params() if params is None else params
    spec.check(seed, params)
    seed_ompl(ompl_seed(generator, seed))
    maker_input = spec.build(seed, params)
    validator = OmplValidator(rng_for(generator, seed, "validator"), routed=maker_input.routed_validation)
    validator.budget = int(validator.budget * maker_input.budget_scale)
    result = make(maker_input, seed, validator, generator)
    certificate = validator.certify(result.objects, result.goal, result.certificate)
    if certificate is None:
        raise GenerationError(f"generator {generator!r}, seed {seed}: no certificate holds at fine resolution")
    # Stored clean: a planner's path moves several objects per segment and counts many
    # more actions than the puzzle needs (Move N Times: 138 for 8).
    certificate = defragment_certificate(build_chain(result.objects), result.goal, certificate)
    dependencies = dependency_graph(result.objects, certificate, shrink=maker_input.interlock_margin)
    margins = {name: m for name, m in result.margins.items() if name != result.goal.target}
    necessity = {name: how for name, how in result.necessity.items() if name in margins}
    if stats is not None:
        stats["validation_checks"] = validator.checks
    return Puzzle(result.objects, result.goal, generator, seed, params, dependencies, certificate, margins,
                  necessity=necessity)


@dataclass(frozen=True)
class Job:
    generator: str
    seed: int
    overrides: Mapping[str, str] = field(default_factory=dict)
    params: Any = None  # a parameter dataclass instance; takes precedence over ``overrides``
    mjcf: bool = False  # also write the MJCF (``mjcf/<name>.xml``) into the folder
    difficulty: DifficultySettings | None = None  # measure it and write it into puzzle.json


@dataclass(frozen=True)
class Report:
    """What one job produced: a puzzle folder, or an error message."""

    generator: str
    seed: int
    objects: int = 0
    actions: int = 0
    seconds: float = 0.0
    folder: str | None = None
    error: str | None = None
    puzzle: Puzzle | None = None
    notices: tuple[str, ...] = ()  # e.g. a changed puzzle's old renders moved to stale/<n>/
    cpu_seconds: float = 0.0  # the worker's CPU time for the job (benchmarks/generation_speed.py)


def _run_job(job: Job, out_root: str | None) -> Report:
    from phyrogen_core.actions import count_actions
    from solver.benchmark.difficulty import measure_difficulty

    started = time.perf_counter()
    cpu = time.process_time()
    try:
        spec = get_generator(job.generator)
        params = job.params if job.params is not None else spec.parse_params(job.overrides)
        puzzle = generate_here(job.generator, job.seed, params)
        if job.difficulty is not None:
            puzzle = replace(puzzle, difficulty=measure_difficulty(puzzle.chain, puzzle.goal, puzzle.name,
                                                                   job.difficulty))
        folder = None
        notices: list[str] = []
        if out_root is not None:
            from phyrogen_core.export import write_mjcf, write_puzzle

            with deferred_signals():  # stopped while writing, a worker finishes the folder first
                folder = str(write_puzzle(puzzle, Path(out_root), versions(), notices))
                if job.mjcf:
                    write_mjcf(folder, puzzle.chain, puzzle.name, puzzle.certificate)
        chain = puzzle.planning_chain
        return Report(job.generator, job.seed, sum(o.is_movable for o in puzzle.objects),
                      count_actions(puzzle.certificate, chain.factors), time.perf_counter() - started,
                      folder, None, puzzle, tuple(notices), cpu_seconds=time.process_time() - cpu)
    except (ParameterError, GenerationError) as exc:
        return Report(job.generator, job.seed, seconds=time.perf_counter() - started, error=str(exc),
                      cpu_seconds=time.process_time() - cpu)
    except Exception as exc:  # a bug: keep the traceback for the report
        detail = traceback.format_exc(limit=6)
        return Report(job.generator, job.seed, seconds=time.perf_counter() - started,
                      error=f"{type(exc).__name__}: {exc}\n{detail}", cpu_seconds=time.process_time() - cpu)


def _cost_hint(job: Job) -> float:
    """The generator's validation budget scale for this job (1 when it cannot be told)."""
    try:
        spec = get_generator(job.generator)
        params = job.params if job.params is not None else spec.parse_params(job.overrides)
        return float(spec.build(job.seed, params).budget_scale)
    except Exception:  # the worker runs the job and reports what is wrong with it
        return 1.0


def _lost(job: Job, how: str) -> Report:
    return Report(job.generator, job.seed, error=f"the worker process ended ({how}) before it reported")


LOOKAHEAD = 64
"""Jobs read ahead of the oldest unreported one: the memory a run holds does not grow with its length."""


def _registered_by_caller(job: Job) -> bool:
    """Whether the job's generator (or its parameter class) comes from outside this project: then
    the caller's script registered it, and only running that script again gives a worker it."""
    try:
        spec = get_generator(job.generator)
    except ParameterError:
        return False  # the worker reports it
    modules = [spec.build.__module__, type(job.params).__module__ if job.params is not None else "phyrogen_core"]
    return any(module.partition(".")[0] != "phyrogen_core" for module in modules)


def run_jobs(jobs: Iterable[Job], out_root: Path | None = None, workers: int = 2,
             on_done: Callable[[Report], None] | None = None,
             on_running: Callable[[list[Job]], None] | None = None) -> Iterator[Report]:
    """Run jobs in fresh worker processes (one process per job), yielding their reports in the
    order of ``jobs``, which is read as the work goes on (it may be a long generator).

    ``on_running`` gets the jobs running, at least once a second and whenever they change.
    Leaving the loop early (an exception, Ctrl-C) stops the running jobs; the folders written
    so far stay, and none is left half-written.
    """
    tasks = len(jobs) if isinstance(jobs, Sized) else workers
    root = None if out_root is None else str(out_root)
    run_main = isinstance(jobs, Collection) and any(_registered_by_caller(job) for job in jobs)
    with fresh_process_pool(workers, tasks, _PRELOAD, run_main=run_main) as pool:
        # Among the jobs read ahead, those with the largest search budgets start first, so that
        # no long job is left running alone at the end. Each puzzle depends only on its job,
        # never on the order or the process it runs in.
        for report in pool.imap(partial(_run_job, out_root=root), jobs, lookahead=LOOKAHEAD,
                                priority=_cost_hint, on_lost=_lost, heartbeat=on_running):
            if on_done is not None:
                on_done(report)
            yield report


def generate_puzzle(generator: str, seed: int, params: Any = None) -> Puzzle:
    """One certified puzzle, generated deterministically in a fresh process.

    ``params`` is the generator's parameter dataclass, a mapping of
    ``key=value`` overrides, or None for the defaults.
    """
    job = Job(generator, seed, dict(params)) if isinstance(params, Mapping) else Job(generator, seed, {}, params)
    (report,) = list(run_jobs([job], workers=1))
    if report.error is not None or report.puzzle is None:
        raise GenerationError(report.error or "generation failed")
    return report.puzzle
