"""The generate stage: certified puzzles for generators and seeds (or a named suite), in worker processes."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

from phyrogen.difficulty_options import difficulty_settings
from phyrogen.stage_checks import check_generation, check_workers
from phyrogen.usage import UsageError, generator_names, parse_overrides, parse_seeds
from phyrogen_core.stage_records.generate import GeneratedPuzzle, GenerateRequest, GenerateResult

CHECK_EVERY_SEED_UP_TO = 10_000
"""Longer seed lists are checked up front at the ends of each range only (each job again in its worker)."""


def run(request: GenerateRequest, *, on_start: Callable[[int], None] | None = None,
        on_puzzle: Callable[[GeneratedPuzzle, tuple[str, ...]], None] | None = None,
        on_running: Callable[[list[str]], None] | None = None) -> GenerateResult:
    """Generate the puzzles of ``request`` into its ``out``. Once the request is checked, ``on_start`` gets
    the number of puzzles; ``on_puzzle`` gets each one's row and notices as soon as it (and every row before
    it) is done; ``on_running`` the names of the puzzles running, at least once a second."""
    from solver.pipelines.generation import Job, run_jobs

    seeds = parse_seeds(request.seeds)
    difficulty = difficulty_settings(request)
    check_workers(request.workers)
    names, overrides_of = _requested(request)
    count = sum(len(r) for r in seeds)
    # Seed-dependent sizes (n = seed, n_objects = seed + 1) only grow with the seed, so a range's two ends
    # stand for it.
    checked = [seed for r in seeds for seed in (r if count <= CHECK_EVERY_SEED_UP_TO else (r[0], r[-1]))]
    for name in names:  # fail fast on bad parameters, before any work
        check_generation(name, overrides_of[name], checked)
    out = _check_output(request.out, names, seeds, request.mjcf)
    # Jobs are made as the workers take them: a run of a hundred million seeds starts at once, in little memory.
    jobs = (Job(name, seed, overrides_of[name], mjcf=request.mjcf, difficulty=difficulty)
            for name in names for r in seeds for seed in r)
    if on_start is not None:
        on_start(count * len(names))

    def running(jobs: list) -> None:
        if on_running is not None:
            on_running([f"{job.generator}_{job.seed}" for job in jobs])

    started = time.perf_counter()
    done = failed = 0
    rows: list[GeneratedPuzzle] = []
    for report in run_jobs(jobs, out, request.workers, on_running=running):
        row = _row(report)
        if request.keep_rows:
            rows.append(row)
        if on_puzzle is not None:
            on_puzzle(row, report.notices)
        done += 1
        failed += report.error is not None
    return GenerateResult(puzzles=tuple(rows), ok=done - failed, failed=failed,
                          wall_seconds=round(time.perf_counter() - started, 3))


def _row(report) -> GeneratedPuzzle:
    return GeneratedPuzzle(report.generator, report.seed, report.objects, report.actions, round(report.seconds, 3),
                           None if report.error else str(report.folder),
                           None if report.error is None else report.error.splitlines()[0])


def _requested(request: GenerateRequest) -> tuple[list[str], dict[str, dict]]:
    """The generators asked for (by name or suite) and each one's parameter overrides."""
    if request.suite is not None:
        from phyrogen_core.suites import get_suite

        if request.generators is not None or request.overrides:
            raise UsageError("--suite names its generators and their parameters; give no --generator or --set with it")
        suite = get_suite(request.suite)
        return [entry.generator for entry in suite], {entry.generator: dict(entry.overrides) for entry in suite}
    names = generator_names("all" if request.generators is None else request.generators)  # '' is refused, not all
    overrides = parse_overrides(list(request.overrides))
    if overrides and len(names) > 1:
        raise UsageError("--set applies to one generator; name it with --generator")
    return names, {name: overrides for name in names}


def _puzzle_folders_present(parent: Path, generator: str, seeds: tuple[range, ...]) -> list[Path]:
    """The entries of ``parent`` (a generator's folder of an output root) at the paths of the
    puzzle folders of ``seeds``, whatever they are: found by listing ``parent`` once, so that the
    cost grows with what is there, not with the number of seeds."""
    try:
        with os.scandir(parent) as entries:
            present = sorted(entry.name for entry in entries)
    except (FileNotFoundError, NotADirectoryError):
        return []
    prefix = f"{generator}_"
    found = []
    for entry in present:
        number = entry[len(prefix):] if entry.startswith(prefix) else ""
        if number.isdigit() and f"{prefix}{int(number)}" == entry and any(int(number) in r for r in seeds):
            found.append(parent / entry)
    return found


def _check_output(text: str, names: list[str], seeds: tuple[range, ...], mjcf: bool) -> Path:
    """``out``, checked writable with every generator's folder, and every puzzle folder of the request
    already there a real folder (and without a user's MJCF file of the name with ``mjcf``)."""
    from phyrogen_core.folder import OutputError, require_writable_dir

    out = require_writable_dir(text)  # an unusable --out is found before any puzzle is made
    for name in names:
        require_writable_dir(out / name)
        for folder in _puzzle_folders_present(out / name, name, seeds):
            # A link would take the puzzle elsewhere, a user's file there would be found only once the
            # puzzle is made: both refused, not swapped away.
            if folder.is_symlink() or not folder.is_dir():
                what = "a symbolic link" if folder.is_symlink() else "a file, not a folder"
                raise OutputError(f"puzzle folder {folder} is {what}; a stage writes only into real folders "
                                  "(move it away or choose another --out)")
            if mjcf:  # a user's mjcf/<name>.xml there is refused, not overwritten
                from phyrogen_core.export.mjcf import check_mjcf_target

                check_mjcf_target(folder, folder.name)
    return out
