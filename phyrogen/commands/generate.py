"""``phyrogen generate``: certified puzzles for generators and seeds (or a named suite), in worker processes;
a row per puzzle as it is done."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from phyrogen.difficulty_options import add_difficulty_options, difficulty_settings
from phyrogen.json_output import add_json_option
from phyrogen.options import add_quiet_option, add_workers_option, path_option
from phyrogen.progress import progress_bar, show_running
from phyrogen.stage_checks import check_generation
from phyrogen.usage import UsageError, generator_names, parse_overrides, parse_seeds

CHECK_EVERY_SEED_UP_TO = 10_000
"""Longer seed lists are checked up front at the ends of each range only (each job again in its worker)."""


def add_parser(sub) -> None:
    gen = sub.add_parser("generate", help="generate certified puzzles")
    gen.add_argument("--generator", help="a name, comma-separated names, or 'all' (the paper's six; the default)")
    gen.add_argument("--suite", help="every generator of a named suite, with its parameters: hard "
                                     "(phyrogen_core/suites.py)")
    gen.add_argument("--seed", "--seeds", dest="seeds", default="1-4", help="seed, range or list (default 1-4)")
    gen.add_argument("--set", action="append", metavar="KEY=VALUE", help="generator parameter override")
    gen.add_argument("--out", type=path_option, default="output", help="output folder (default: output)")
    add_workers_option(gen)
    gen.add_argument("--mjcf", action="store_true", help="also write each puzzle's MJCF: <folder>/mjcf/<name>.xml")
    add_difficulty_options(gen)
    add_quiet_option(gen)
    add_json_option(gen, "one object per puzzle: generator, seed, objects, actions, seconds, folder, error")
    gen.set_defaults(func=run)


def run(args) -> int:
    from solver.pipelines.generation import Job, run_jobs

    seeds = parse_seeds(args.seeds)
    difficulty = difficulty_settings(args)
    names, overrides_of = _requested(args)
    count = sum(len(r) for r in seeds)
    # Seed-dependent sizes (n = seed, n_objects = seed + 1) only grow with the seed, so a range's two ends
    # stand for it.
    checked = [seed for r in seeds for seed in (r if count <= CHECK_EVERY_SEED_UP_TO else (r[0], r[-1]))]
    for name in names:  # fail fast on bad parameters, before any work
        check_generation(name, overrides_of[name], checked)
    out = _check_output(args.out, names, seeds, args.mjcf)
    # Jobs are made as the workers take them and each row is printed as soon as it (and every
    # row before it) is done: a run of a hundred million seeds starts at once, in little memory.
    jobs = (Job(name, seed, overrides_of[name], mjcf=args.mjcf, difficulty=difficulty)
            for name in names for r in seeds for seed in r)
    progress = progress_bar(count * len(names), args.quiet)

    def on_running(running: list) -> None:
        show_running(progress, [f"{job.generator}_{job.seed}" for job in running])

    started = time.perf_counter()
    done = failed = 0
    rows: list[dict] = []  # only with --json
    try:
        progress.write(f"{'generator':18s} {'seed':>4s} {'objects':>7s} {'actions':>7s} {'time [s]':>8s}  result",
                       file=sys.stdout)
        for r in run_jobs(jobs, out, args.workers, on_running=on_running):
            if args.json:
                rows.append(_json_row(r))
            result = r.folder if r.error is None else "FAILED: " + r.error.splitlines()[0]
            progress.write(f"{r.generator:18s} {r.seed:4d} {r.objects:7d} {r.actions:7d} {r.seconds:8.2f}  {result}",
                           file=sys.stdout)
            sys.stdout.flush()
            for notice in r.notices:
                progress.write(f"phyrogen: note: {notice}", file=sys.stderr)
            progress.update(1)
            done += 1
            failed += r.error is not None
    finally:
        progress.close()
    wall = time.perf_counter() - started
    print(f"{done - failed}/{done} puzzles in {wall:.1f} s wall time with {args.workers} workers")
    args.json_result = {"command": "generate", "puzzles": rows, "ok": done - failed, "failed": failed,
                        "wall_seconds": round(wall, 3)}
    return 1 if failed else 0


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


def _requested(args) -> tuple[list[str], dict[str, dict]]:
    """The generators asked for (by ``--generator`` or ``--suite``) and each one's parameter overrides."""
    if args.suite is not None:
        from phyrogen_core.suites import get_suite

        if args.generator is not None or args.set:
            raise UsageError("--suite names its generators and their parameters; give no --generator or --set with it")
        suite = get_suite(args.suite)
        return [entry.generator for entry in suite], {entry.generator: dict(entry.overrides) for entry in suite}
    names = generator_names("all" if args.generator is None else args.generator)  # '' is refused, not all
    overrides = parse_overrides(args.set or [])
    if overrides and len(names) > 1:
        raise UsageError("--set applies to one generator; name it with --generator")
    return names, {name: overrides for name in names}


def _check_output(text: str, names: list[str], seeds: tuple[range, ...], mjcf: bool) -> Path:
    """``--out``, checked writable with every generator's folder, and every puzzle folder of the request
    already there a real folder (and without a user's MJCF file of the name with ``--mjcf``)."""
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


def _json_row(r) -> dict:
    """A puzzle's row of ``--json``."""
    return {"generator": r.generator, "seed": r.seed, "objects": r.objects, "actions": r.actions,
            "seconds": round(r.seconds, 3), "folder": None if r.error else str(r.folder),
            "error": None if r.error is None else r.error.splitlines()[0]}
