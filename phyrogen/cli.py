"""The ``phyrogen`` command line: thin wrappers over the library."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import json
import math
import os
import signal
import sys
import threading
import time
import traceback
from pathlib import Path

from phyrogen_core.folder import PuzzleFolder, find_in_paths, find_puzzle_folders
from phyrogen_core.registry import (
    MAX_SEED,
    ParameterError,
    all_generators,
    describe_generators,
    merge_seed_spans,
    paper_generators,
)

EXIT_BAD_INPUT = 2


class UsageError(ValueError):
    pass



def parse_seeds(text: str) -> tuple[range, ...]:
    """'3', '1-4' or '1,3,5-7' -> the seeds as sorted, disjoint ranges.

    Ranges, not numbers: '1-100000000' takes no more memory than '1-4'.
    """
    spans = []
    try:
        for part in text.split(","):
            low, dash, high = part.partition("-")
            spans.append((int(low), int(high) if dash else int(low)))
            if spans[-1][1] < spans[-1][0]:
                raise ValueError
    except ValueError:
        raise UsageError(f"bad seed list {text!r} (examples: 3, 1-4, 1,3,5-7)") from None
    spans.sort()
    if spans[0][0] < 1:
        raise UsageError(f"seeds must be positive integers, got {text!r}")
    if max(high for _, high in spans) > MAX_SEED:
        raise UsageError(f"seeds must be at most {MAX_SEED}, got {text!r}")
    return tuple(range(low, high + 1) for low, high in merge_seed_spans(spans))


def parse_overrides(items: list[str]) -> dict[str, str]:
    overrides = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise UsageError(f"bad --set {item!r}: expected key=value")
        overrides[key.strip()] = value.strip()
    return overrides


def _generators(text: str) -> list[str]:
    registry = all_generators()
    if text == "all":
        return list(paper_generators())
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:  # '' or ',': a request for nothing is a mistake, not a run that does nothing
        raise UsageError(f"no generator named in {text!r} (known: {', '.join(registry)}, or 'all')")
    for name in names:
        if name not in registry:
            raise UsageError(f"unknown generator {name!r} (known: {', '.join(registry)})")
    return names


def cmd_list(args) -> int:
    print(describe_generators())
    return 0


CHECK_EVERY_SEED_UP_TO = 10_000
"""Longer seed lists are checked up front at the ends of each range only (each job again in its worker)."""


def cmd_generate(args) -> int:
    from phyrogen_core.folder import OutputError, require_writable_dir
    from solver.pipelines.generation import Job, run_jobs

    seeds = parse_seeds(args.seeds)
    difficulty = difficulty_settings(args)
    if args.suite is not None:
        from phyrogen_core.suites import get_suite

        if args.generator is not None or args.set:
            raise UsageError("--suite names its generators and their parameters; give no --generator or --set with it")
        suite = get_suite(args.suite)
        names = [entry.generator for entry in suite]
        overrides_of = {entry.generator: dict(entry.overrides) for entry in suite}
    else:
        names = _generators("all" if args.generator is None else args.generator)  # '' is refused, not all
        overrides = parse_overrides(args.set or [])
        if overrides and len(names) > 1:
            raise UsageError("--set applies to one generator; name it with --generator")
        overrides_of = {name: overrides for name in names}
    registry = all_generators()
    count = sum(len(r) for r in seeds)
    for name in names:  # fail fast on bad parameters, before any work
        spec = registry[name]
        params = spec.parse_params(overrides_of[name])
        # Seed-dependent sizes (n = seed, n_objects = seed + 1) only grow with the seed, so
        # a range's two ends stand for it.
        for r in seeds:
            for seed in r if count <= CHECK_EVERY_SEED_UP_TO else (r[0], r[-1]):
                spec.check(seed, params)
    out = require_writable_dir(args.out)  # an unusable --out is found before any puzzle is made
    for name in names:
        require_writable_dir(out / name)
        for folder in _puzzle_folders_present(out / name, name, seeds):
            # A link would take the puzzle elsewhere, a user's file there would be found only once the
            # puzzle is made: both refused, not swapped away.
            if folder.is_symlink() or not folder.is_dir():
                what = "a symbolic link" if folder.is_symlink() else "a file, not a folder"
                raise OutputError(f"puzzle folder {folder} is {what}; a stage writes only into real folders "
                                  "(move it away or choose another --out)")
            if args.mjcf:  # a user's mjcf/<name>.xml there is refused, not overwritten
                from phyrogen_core.export.mjcf import check_mjcf_target

                check_mjcf_target(folder, folder.name)
    # Jobs are made as the workers take them and each row is printed as soon as it (and every
    # row before it) is done: a run of a hundred million seeds starts at once, in little memory.
    jobs = (Job(name, seed, overrides_of[name], mjcf=args.mjcf, difficulty=difficulty)
            for name in names for r in seeds for seed in r)
    progress = _progress(count * len(names), args.quiet)

    def show_running(running: list) -> None:
        if progress.disable:
            return
        shown = [f"{job.generator}_{job.seed}" for job in running[:3]]
        text = "running " + ", ".join(shown) + (f" and {len(running) - 3} more" if len(running) > 3 else "")
        # Once a second at least, so that the elapsed time moves while a long puzzle runs.
        since = time.time() - progress.last_print_t
        if since >= 1.0 or (text != progress.postfix and since >= progress.mininterval):
            progress.set_postfix_str(text)

    started = time.perf_counter()
    done = failed = 0
    rows: list[dict] = []  # only with --json
    try:
        progress.write(f"{'generator':18s} {'seed':>4s} {'objects':>7s} {'actions':>7s} {'time [s]':>8s}  result",
                       file=sys.stdout)
        for r in run_jobs(jobs, out, args.workers, on_running=show_running):
            if args.json:
                rows.append({"generator": r.generator, "seed": r.seed, "objects": r.objects, "actions": r.actions,
                             "seconds": round(r.seconds, 3), "folder": None if r.error else str(r.folder),
                             "error": None if r.error is None else r.error.splitlines()[0]})
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


def cmd_dataset(args) -> int:
    """Make or resume a dataset (docs/datasets.md); with ``--stats DIR``, describe one. Exit 0 once
    every entry has its manifest row: failed seeds are rows too, counted in the last line."""
    if args.stats is not None:
        given = [flag for flag, value in (("--generator", args.generator), ("--seeds", args.seeds),
                                          ("--count", args.count), ("--set", args.set), ("--out", args.out),
                                          ("--mjcf", args.mjcf)) if value]
        if given:
            raise UsageError(f"--stats reads a finished or unfinished dataset; it takes no {given[0]}")
        from solver.pipelines.dataset import dataset_stats, plot_stats

        stats = dataset_stats(Path(args.stats))
        print(stats.text(), end="")
        print(f"plots: {plot_stats(stats)}")
        return 0
    from phyrogen_core.folder import shard_name
    from solver.pipelines.dataset import build_dataset, check_dataset_root, local_backend, make_request, ray_backend

    if args.generator is None or args.out is None:
        raise UsageError("dataset needs --generator and --out (or --stats DIR to describe a dataset)")
    if (args.seeds is None) == (args.count is None):
        raise UsageError("give the seeds either with --seeds (e.g. 1-1000) or with --count N [--start S]")
    if args.seeds is not None and args.start is not None:
        raise UsageError("--start goes with --count; --seeds lists the seeds itself")
    names = _generators(args.generator)
    if args.seeds is not None:
        seeds = parse_seeds(args.seeds)
    else:
        start = 1 if args.start is None else args.start
        if start + args.count - 1 > MAX_SEED:
            raise UsageError(f"--start {start} --count {args.count} goes past the largest seed {MAX_SEED}")
        seeds = (range(start, start + args.count),)
    # Everything is checked before the first file is written: the request, every entry's size
    # (feasible for its generator), and the folder (writable; empty, or this request's dataset).
    request = make_request(names, seeds, args.set or [], args.sweep, args.shard_size, args.mjcf,
                           difficulty_settings(args))
    root = check_dataset_root(request, Path(args.out))
    check_ray(args.ray)  # an unreachable cluster is bad input, refused before the progress bar shows
    progress = _progress(request.size, args.quiet)

    def show_running(running: list) -> None:
        if progress.disable:
            return
        shown = [task.name for task in running[:3]]
        text = "running " + ", ".join(shown) + (f" and {len(running) - 3} more" if len(running) > 3 else "")
        since = time.time() - progress.last_print_t
        if since >= 1.0 or (text != progress.postfix and since >= progress.mininterval):
            progress.set_postfix_str(text)

    def show_row(row: dict, made_now: bool) -> None:
        if made_now and row["status"] != "ok":
            progress.write(f"{row['generator']} {row['seed']}: FAILED: {row['error'].splitlines()[0]}",
                           file=sys.stdout)
        progress.update(1)

    def show_shard(shard: int, rows: list) -> None:
        ok = sum(row["status"] == "ok" for row in rows)
        progress.write(f"{shard_name(shard)}: {ok}/{len(rows)} puzzles ok; rows in parts/{shard_name(shard)}.parquet",
                       file=sys.stdout)
        sys.stdout.flush()

    backend = local_backend if args.ray is None else ray_backend(args.ray)
    try:
        with ray_connection(args.ray, args.workers):  # (an unreachable cluster is refused before anything is written)
            result = build_dataset(request, root, args.workers, backend=backend, on_row=show_row,
                                   on_skip=progress.update, on_shard=show_shard, on_running=show_running)
    finally:
        progress.close()
    rate = f" ({result.puzzles_per_hour:.0f} puzzles/hour)" if result.generated else ""
    print(f"{result.ok}/{result.entries} puzzles ok, {result.failed} failed; {result.generated} made now, "
          f"{result.reused} found done; {result.seconds:.1f} s wall time with {args.workers} workers{rate}")
    print(f"manifest: {result.manifest}")
    return 0


def dataset_count_option(text: str) -> int:
    from solver.pipelines.dataset.request import MAX_ENTRIES  # here, not at the top: the parser stays quick to build

    return _whole_number(text, 1, MAX_ENTRIES, " puzzles")


def dataset_start_option(text: str) -> int:
    return _whole_number(text, 1, MAX_SEED)


def shard_size_option(text: str) -> int:
    from solver.pipelines.dataset.request import MAX_SHARD_SIZE

    return _whole_number(text, 1, MAX_SHARD_SIZE, " puzzle folders per shard")


def cmd_check(args) -> int:
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.problem import verify_certificate

    loaded = read_puzzle_dir(Path(args.puzzle_dir))
    problems = verify_certificate(loaded.chain, loaded.certificate, loaded.goal, start=loaded.start)
    name = loaded.name
    # An edited puzzle (the Blender panel's Export) keeps its old certificate, marked as not verified for it.
    edited = not loaded.record.certificate_verified
    note = " (found for the puzzle before it was edited)" if edited else ""
    if problems:
        print(f"{name}: INVALID{note}: " + "; ".join(problems))
        return 1
    print(f"{name}: certificate valid{note} ({len(loaded.certificate)} states, checked at fine resolution)")
    return 0


def cmd_replan(args) -> int:
    from phyrogen_core.export import read_puzzle_dir
    from solver.pipelines.replanning import REPLAN_BUDGET, check_replan_folder, replan, write_replanned

    folder = Path(args.puzzle_dir)
    loaded = read_puzzle_dir(folder)  # bad input is found before any work
    check_replan_folder(folder, loaded.name)
    name = loaded.name
    result = replan(loaded, REPLAN_BUDGET if args.budget is None else args.budget, args.seed)
    args.json_result = {"command": "replan", "puzzle": name, "folder": str(folder), "solved": result.solved,
                        "budget": result.budget, "seed": args.seed}
    if not result.solved:
        print(f"phyrogen: error: {name}: not solved by RRT-Connect nor LA-RRT within {result.budget} collision "
              f"queries each (seed {args.seed}); the folder is unchanged (a larger --budget may solve it)",
              file=sys.stderr)
        return 1
    notices: list[str] = []
    write_replanned(folder, loaded, result, notices)
    for notice in notices:
        print(f"phyrogen: note: {notice}", file=sys.stderr)
    planner = {"rrt_connect": "RRT-Connect", "la_rrt_push": "LA-RRT+push"}[result.planner]
    args.json_result.update(planner=planner, queries=result.queries, states=len(result.certificate),
                            dependencies=len(result.dependencies), notices=notices)
    print(f"{name}: new certificate by {planner} in {result.queries} collision queries: "
          f"{len(result.certificate)} states, {len(result.dependencies)} dependencies")
    return 0


def replan_budget_option(text: str) -> int:
    from solver.pipelines.replanning import MAX_REPLAN_BUDGET

    return _whole_number(text, 1, MAX_REPLAN_BUDGET, " collision queries")


def cmd_export(args) -> int:
    from phyrogen_core.export import chain_to_mjcf, read_puzzle_dir, write_mjcf
    from phyrogen_core.export.mjcf import check_mjcf_target

    # Every folder is read, converted and checked writable before the first file is written:
    # bad input (a missing folder, a malformed puzzle) leaves every folder as it was.
    folders = [f.path if isinstance(f, PuzzleFolder) else Path(f) for f in find_in_paths(args.puzzle_dirs)]
    puzzles = []
    for folder in folders:
        loaded = read_puzzle_dir(folder)
        chain_to_mjcf(loaded.chain, loaded.certificate)
        check_mjcf_target(folder, loaded.name)  # a link, or a user's file of the name, is refused
        puzzles.append((folder, loaded))
    for folder, loaded in puzzles:
        print(write_mjcf(folder, loaded.chain, loaded.name, loaded.certificate))
    return 0


def cmd_import(args) -> int:
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.folder import require_writable_dir
    from phyrogen_core.urdf_import import import_urdf
    from solver.pipelines.importing import IMPORT_BUDGET, certify_imported, versions

    out = require_writable_dir(args.out)  # an unusable --out is found before any work
    imported = import_urdf(args.urdf, target=args.target, goal=args.goal, name=args.name)
    for note in imported.notes:
        print(f"phyrogen: note: {note}", file=sys.stderr)
    puzzle = imported.puzzle
    result = certify_imported(puzzle, IMPORT_BUDGET if args.budget is None else args.budget, args.seed)
    if result.puzzle is None:
        print(f"phyrogen: error: {puzzle.name}: not solved by LA-RRT within {result.budget} collision queries "
              f"(seed {args.seed}); nothing written (a larger --budget may solve it, or the goal is wrong)",
              file=sys.stderr)
        return 1
    notices: list[str] = []
    folder = write_puzzle(result.puzzle, out, versions(), notices)
    for notice in notices:
        print(f"phyrogen: note: {notice}", file=sys.stderr)
    static = len(imported.objects) - imported.movable
    print(f"{folder}: {imported.movable} movable and {static} static objects, {len(puzzle.joint_order)} joints, "
          f"goal from the {imported.goal_source} (target {puzzle.goal.target}); certified by LA-RRT in "
          f"{result.queries} collision queries: {len(result.puzzle.certificate)} states, {result.actions} actions")
    return 0


def goal_values_option(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"must be comma-separated finite numbers (joint values), got {text!r}")
    return values


def import_budget_option(text: str) -> int:
    from solver.pipelines.importing import MAX_IMPORT_BUDGET

    return _whole_number(text, 1, MAX_IMPORT_BUDGET, " collision queries")


def cmd_audit(args) -> int:
    from tqdm import tqdm

    from manipulation.replay import PyBulletReferee
    from solver.pipelines.audit import (
        DEFAULT_BUDGET,
        TABLE_HEADER,
        AuditSettings,
        check_report_folder,
        plan_audit,
        run_audit,
        second_budget,
        table_row,
        task_count,
        write_reports,
    )

    budget = DEFAULT_BUDGET if args.budget is None else args.budget
    # Every puzzle is read and the report folder checked before the first attempt starts.
    puzzles = plan_audit(find_puzzle_folders(Path(args.dir)))
    out = check_report_folder(args.out)
    referee = PyBulletReferee()
    settings = AuditSettings(budget, referee.name, referee.resolution, referee.tolerance)
    if not args.quiet:
        print(f"auditing {len(puzzles)} puzzles: two judges per object, LA-RRT with pushes ({budget} collision "
              f"queries) and the paper's LA-RRT ({second_budget(budget)} checks, goal sampling included); "
              f"certificates replayed in "
              f"{referee.name} every {referee.resolution * 1000:g} mm, penetration threshold "
              f"{referee.tolerance * 1000:g} mm", file=sys.stderr)
    progress = tqdm(total=task_count(puzzles), unit="check", disable=args.quiet, file=sys.stderr)
    audits = []
    started = time.perf_counter()
    try:
        progress.write(TABLE_HEADER, file=sys.stdout)
        for audit in run_audit(puzzles, referee, budget, args.workers, on_task_done=lambda: progress.update(1)):
            progress.write(table_row(audit), file=sys.stdout)
            sys.stdout.flush()
            audits.append(audit)
    finally:
        progress.close()
        if audits:  # interrupted, the report still holds the puzzles finished, marked incomplete
            reports = write_reports(out, audits, settings, total=len(puzzles))
    for audit in audits:
        for line in audit.failures():
            print("  " + line.splitlines()[0])
    failed = sum(not a.ok for a in audits)
    print(f"{len(audits) - failed}/{len(audits)} puzzles pass the audit in {time.perf_counter() - started:.1f} s "
          f"wall time with {args.workers} workers; report: {reports[0]}, {reports[1]}")
    return 1 if failed else 0


def cmd_manipulate(args) -> int:
    from manipulation.batch import manipulate_folders

    folders = [f.path if isinstance(f, PuzzleFolder) else f for f in find_in_paths(args.puzzle_dirs)]
    runs = benchmark_runs(Path(args.benchmark), folders) if args.benchmark else None
    from manipulation.execution import ExecutionSettings

    reports = manipulate_folders(folders, Path(args.out), video=not args.no_video,
                                 table=Path(args.table) if args.table else None, gui=args.gui, quiet=args.quiet,
                                 settings=ExecutionSettings(scale=args.scale), runs=runs)
    args.json_result = {"command": "manipulate", "out": str(Path(args.out)),
                        "reports": [{**dataclasses.asdict(r), "folder": str(Path(args.out) / r.puzzle)}
                                    for r in reports]}
    return 0 if all(r.success for r in reports) else 1


MAX_SCENE_SCALE = 2.0
MIN_SCENE_SCALE = 0.05
"""``manipulate --scale``: below it every object's 5 cm knob is under 2.5 mm wide, less than the
gripper closes on (docs/manipulation/README.md#physical-scale); 1e-300 made the physics fail."""


def scene_scale_option(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and MIN_SCENE_SCALE <= value <= MAX_SCENE_SCALE):
        raise argparse.ArgumentTypeError(f"must be a number from {MIN_SCENE_SCALE:g} to {MAX_SCENE_SCALE:g} (scene "
                                         f"metres per puzzle metre), got {text!r}")
    return value


def benchmark_runs(benchmark: Path, folders: list[Path]) -> dict[Path, list]:
    """Per puzzle folder, the solved LA-RRT runs of ``benchmark``'s journal on that very puzzle (its
    name and the digest of its files), for the manipulation stage. Glue here, at the top: the
    journal's reader lives in the solver beside OMPL, which manipulation may not import."""
    from manipulation.solution import BenchmarkRun
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.folder import OutputError
    from solver.benchmark.runner import JOURNAL, puzzle_digest, read_journal
    from solver.planning.registry import LA_RRT_PLANNERS

    journal = benchmark / JOURNAL
    if not os.path.lexists(journal):
        raise OutputError(f"benchmark folder {benchmark} has no {JOURNAL}; name the folder a benchmark wrote "
                          "(its --out)")
    records = [(json.loads(key), record) for key, record in read_journal(journal).items()]
    out: dict[Path, list] = {}
    for folder in folders:
        name = read_puzzle_dir(folder).name
        digest = puzzle_digest(PuzzleFolder(Path(folder), name))
        out[Path(folder)] = [BenchmarkRun(r.planner, r.run, tuple(r.joint_order), tuple(r.path))
                             for key, r in records
                             if key.get("planner") in LA_RRT_PLANNERS and r.solved and len(r.path) >= 2
                             and r.puzzle == name and key.get("puzzle_sha256") == digest]
    return out


def cmd_render(args) -> int:
    from blender_addon.gallery import check_gallery_target, write_gallery
    from blender_addon.render_worker import parse_size
    from blender_addon.rendering import RenderError, check_render_folders, render_puzzles
    from blender_addon.views import parse_views
    from phyrogen_core.folder import require_writable_dir

    views = parse_views(args.views)
    size = None if args.gallery_only else parse_size(args.size)
    if args.blender is not None:
        _use_blender_binary(args.blender)
    out = require_writable_dir(args.out, "render output folder")  # index.html goes there
    check_gallery_target(out)  # a user's own index.html is refused before any render
    try:
        found = [f.path for f in find_puzzle_folders(out)]
    except FileNotFoundError:
        if not args.gallery_only:
            raise
        found = []  # an empty gallery
    # Every folder is read and checked before any Blender starts (and before the progress bar):
    # a broken one is bad input naming the folder, not a failed render worker.
    folders = check_render_folders(found, writable=size is not None)
    if size is not None:
        progress = _progress(len(folders), args.quiet)
        try:
            report = render_puzzles(folders, args.engine, size, views, args.workers,
                                    on_done=lambda _: progress.update(1), animation=not args.no_animation)
        except RenderError as exc:
            print(f"phyrogen: render failed: {exc}", file=sys.stderr)
            return 1
        finally:
            progress.close()
        engines = sorted({r.engine for r in report.rendered})
        print(f"{len(report.rendered)} puzzles, {report.images} images ({size[0]}x{size[1]}, {', '.join(engines)}) "
              f"in {report.seconds:.1f} s: {report.seconds_per_image:.2f} s per image, with {args.workers} workers")
        if report.animations:
            print(f"{report.animations} solution animations, {report.animation_seconds / report.animations:.1f} s "
                  "each (worker time, included above)")
    print(f"gallery: {write_gallery(Path(args.out), views)}")
    return 0


def _use_blender_binary(text: str) -> None:
    """``render --blender PATH``: the render workers run in that Blender binary, whose version then writes
    the ``.blend`` files (blender_addon.environment.render_worker_command)."""
    import shutil

    from blender_addon.environment import BLENDER_VARIABLE

    found = shutil.which(text)
    if found is None:
        raise UsageError(f"--blender {text!r}: no such executable")
    os.environ[BLENDER_VARIABLE] = str(Path(found).resolve())


def cmd_benchmark(args) -> int:
    if args.report is not None:
        return benchmark_report(Path(args.report))
    from solver.benchmark.runner import backstop_profile, get_profile, plan_benchmark, run_plan
    from solver.planning.registry import select_planners

    generators = None if args.generator == "all" else _generators(args.generator)
    try:
        planners = select_planners(args.planners)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    profile = get_profile(args.profile, args.runs, args.time_limit)
    budget_checks = args.budget_checks
    if args.budget_from_paper:
        from solver.benchmark.paper_budgets import paper_budgets

        if args.budget_checks is not None:
            raise UsageError("--budget-from-paper sets each generator's check budget; give no --budget-checks with it")
        budget_checks = paper_budgets()
    if args.budget_cpu is not None and budget_checks is not None:
        raise UsageError("--budget-cpu gives every run a budget in CPU seconds; give no check budget with it")
    if (budget_checks is not None or args.budget_cpu is not None) and args.time_limit is None:
        # The budget ends a run; the clock, derived from the budget, only a hang (a tight one: --time-limit).
        profile = backstop_profile(profile, budget_checks, args.budget_cpu)
    puzzles = find_puzzle_folders(Path(args.puzzles), generators)
    # Every puzzle is read and every output path checked here, before the first run.
    until_first = args.until == "first"
    plan = plan_benchmark(puzzles, planners, profile, Path(args.out), args.workers, args.seed,
                          save_solutions=not args.no_solutions, until_first=until_first,
                          budget_checks=budget_checks, budget_cpu=args.budget_cpu)
    check_ray(args.ray)  # an unreachable cluster is bad input, refused before any line of progress
    estimate = plan.estimate_seconds(overhead=1.0)
    print(f"{len(puzzles)} puzzles x {len(planners)} planners x {profile.runs} runs, profile {profile.name}: "
          f"{'at most ' if until_first else ''}about {estimate / 3600:.1f} h on {args.workers} workers",
          file=sys.stderr)
    if plan.done:
        print(f"resuming: {len(plan.done)} of {len(plan.jobs)} runs already done (journal {plan.journal}; "
              "delete it to run them again)", file=sys.stderr)
    if args.dry_run:
        return 0
    with ray_connection(args.ray, args.workers):
        result = run_plan(plan, progress=not args.quiet, ray=args.ray)
    print((Path(args.out) / "summary.md").read_text(encoding="utf-8"))
    print(f"database: {result.database}  figure: {Path(args.out) / 'fig4.png'}  "
          f"results page: {Path(args.out) / 'results.html'}")
    for line in result.unsaved_solutions:
        print(f"phyrogen: warning: {line}", file=sys.stderr)
    crashed = sum(1 for r in result.records if r.error)
    args.json_result = {"command": "benchmark", "out": str(Path(args.out)), "database": str(result.database),
                        "results_page": str(Path(args.out) / "results.html"), "crashed": crashed,
                        "unsaved_solutions": list(result.unsaved_solutions),
                        "summary": json.loads((Path(args.out) / "summary.json").read_text(encoding="utf-8"))}
    return 1 if crashed or result.unsaved_solutions else 0


def benchmark_report(folder: Path) -> int:
    """``phyrogen benchmark --report DIR``: the results page of a finished benchmark, made again from
    its database; a missing or broken database is bad input (exit 2, nothing written)."""
    from solver.benchmark.results_page import write_results_page

    print(f"results page: {write_results_page(folder)}")
    return 0


def _progress(total: int, quiet: bool):
    """A progress bar on stderr (none when ``quiet``), also for a single puzzle: it may take long."""
    from tqdm import tqdm

    return tqdm(total=total, unit="puzzle", disable=quiet, file=sys.stderr)


# -- numeric options: refused while the command line is read, before any work --------------
WORKERS_PER_CORE = 4
"""``--workers`` may ask for at most this many processes per usable core: more only contend for
cores and memory (each worker holds OMPL, numpy and the compiled collision kernels), and in a
benchmark they would distort the timed runs."""
MAX_RUNS = 10_000
"""``benchmark --runs``: the paper's protocol takes 100 runs per planner and puzzle."""
MAX_TIME_LIMIT = 24 * 3600.0
"""``benchmark --time-limit`` in seconds: a day per run; the paper's longest limit is 600 s."""
MAX_BENCHMARK_SEED = 2**31 - 2
"""``benchmark --seed``: OMPL's seed range (see ``phyrogen_core.seeding.stable_seed``), from 0 (the default)."""


def max_workers() -> int:
    """The largest ``--workers``: :data:`WORKERS_PER_CORE` times the cores this process may use."""
    import os

    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return WORKERS_PER_CORE * max(1, cores)


def _whole_number(text: str, low: int, high: int, why: str = "") -> int:
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must be a whole number in {low}..{high}{why}, got {text!r}")
    return value


def ray_connection(address: str | None, workers: int):
    """The Ray cluster of ``--ray`` (:func:`solver.parallel.ray_pool.ray_instance`); nothing without it."""
    if address is None:
        return contextlib.nullcontext()
    from solver.parallel.ray_pool import ray_instance

    return ray_instance(address, workers)


def check_ray(address: str | None) -> None:
    """Refuse a ``--ray`` that :func:`ray_connection` would refuse, without starting anything."""
    if address is not None:
        from solver.parallel.ray_pool import check_ray_address

        check_ray_address(address)


def add_ray_option(parser, what: str) -> None:
    parser.add_argument("--ray", nargs="?", const="local", metavar="ADDRESS",
                        help=f"make the {what} as Ray tasks: alone, on a local Ray instance with --workers CPUs; "
                             "with an address (auto, HOST:PORT, ray://HOST:PORT), on that cluster, whose nodes "
                             "must see the puzzle folders at the same paths (docs/datasets.md#ray)")


def add_difficulty_options(parser) -> None:
    parser.add_argument("--difficulty", action="store_true",
                        help="measure each puzzle's difficulty (BIT*'s success rate and median checks to a first "
                             "solution over seeded runs within a check budget) and write it into puzzle.json")
    parser.add_argument("--difficulty-runs", type=difficulty_runs_option, metavar="K",
                        help="runs per puzzle with --difficulty (default 8)")
    parser.add_argument("--difficulty-checks", type=budget_checks_option, metavar="N",
                        help="collision checks per run with --difficulty (default 20000)")


def difficulty_runs_option(text: str) -> int:
    from solver.benchmark.difficulty import MAX_RUNS as MAX_DIFFICULTY_RUNS

    return _whole_number(text, 1, MAX_DIFFICULTY_RUNS)


def difficulty_settings(args):
    """The --difficulty settings, or None without --difficulty (then the other two may not be given)."""
    if not args.difficulty:
        if args.difficulty_runs is not None or args.difficulty_checks is not None:
            raise UsageError("--difficulty-runs and --difficulty-checks go with --difficulty")
        return None
    from solver.benchmark.difficulty import DEFAULT_BUDGET_CHECKS, DEFAULT_RUNS, DifficultySettings

    return DifficultySettings(args.difficulty_runs or DEFAULT_RUNS, args.difficulty_checks or DEFAULT_BUDGET_CHECKS)


def workers_option(text: str) -> int:
    return _whole_number(text, 1, max_workers(), f" ({WORKERS_PER_CORE} per usable core)")


def runs_option(text: str) -> int:
    return _whole_number(text, 1, MAX_RUNS)


def benchmark_seed_option(text: str) -> int:
    return _whole_number(text, 0, MAX_BENCHMARK_SEED, " (OMPL's seed range)")


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


def budget_checks_option(text: str) -> int:
    from solver.planning.anytime import MAX_BUDGET_CHECKS

    return _whole_number(text, 1, MAX_BUDGET_CHECKS, " collision checks")


def audit_budget_option(text: str) -> int:
    from solver.pipelines.audit import MAX_BUDGET  # here, not at the top: the parser stays quick to build

    return _whole_number(text, 1, MAX_BUDGET, " collision queries")


def path_option(text: str) -> str:
    """A path given on the command line, as given, unless it is empty: ``Path("")`` is ``"."``, so an
    empty ``--out`` would write into the working directory and an empty reader path read it."""
    if not text:
        raise argparse.ArgumentTypeError("must name a file or folder, got ''")
    return text


def image_size_option(text: str) -> str:
    """The text itself, once :func:`blender_addon.render_worker.parse_size` accepts it."""
    from blender_addon.render_worker import parse_size

    try:
        parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


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


class _Parser(argparse.ArgumentParser):
    """argparse, but a bad argument is one line (the contract), not the usage and then the message."""

    def error(self, message: str):
        raise UsageError(f"{message} (see {self.prog} --help)")


def add_json_option(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--json", action="store_true",
                        help=f"for programs: stdout is one JSON object ({what}); what is printed otherwise goes "
                             "to stderr")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="phyrogen", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the registered generators and their parameters").set_defaults(func=cmd_list)
    gen = sub.add_parser("generate", help="generate certified puzzles")
    gen.add_argument("--generator", help="a name, comma-separated names, or 'all' (the paper's six; the default)")
    gen.add_argument("--suite", help="every generator of a named suite, with its parameters: hard "
                                     "(phyrogen_core/suites.py)")
    gen.add_argument("--seed", "--seeds", dest="seeds", default="1-4", help="seed, range or list (default 1-4)")
    gen.add_argument("--set", action="append", metavar="KEY=VALUE", help="generator parameter override")
    gen.add_argument("--out", type=path_option, default="output", help="output folder (default: output)")
    gen.add_argument("--workers", type=workers_option, default=2,
                     help="worker processes (default 2; at most 4 per usable core)")
    gen.add_argument("--mjcf", action="store_true", help="also write each puzzle's MJCF: <folder>/mjcf/<name>.xml")
    add_difficulty_options(gen)
    gen.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_option(gen, "one object per puzzle: generator, seed, objects, actions, seconds, folder, error")
    gen.set_defaults(func=cmd_generate)
    data = sub.add_parser("dataset", help="generate a sharded, resumable dataset with a Parquet manifest "
                                          "(docs/datasets.md); --stats DIR describes one")
    data.add_argument("--generator", help="a name, comma-separated names, or 'all' (the paper's six)")
    data.add_argument("--seed", "--seeds", dest="seeds", help="seed, range or list, e.g. 1-1000 (or use --count)")
    data.add_argument("--count", type=dataset_count_option, help="how many seeds per generator, from --start")
    data.add_argument("--start", type=dataset_start_option, help="the first seed with --count (default 1)")
    data.add_argument("--set", action="append", metavar="KEY=VALUE",
                      help="a parameter for every puzzle, or a sweep: KEY=LOW:HIGH[:STEP] or KEY=A,B,C")
    data.add_argument("--sweep", choices=("cross", "zip"), default="cross",
                      help="cross (default): seed s gets combination s mod K of all swept values' K combinations "
                           "(first --set slowest); zip: each swept parameter cycles on its own (value s mod n)")
    data.add_argument("--out", type=path_option,
                      help="the dataset's folder: new, empty, or this request's dataset (then resumed)")
    data.add_argument("--shard-size", type=shard_size_option, default=1000,
                      help="puzzle folders per shard (default 1000)")
    data.add_argument("--mjcf", action="store_true", help="also write each puzzle's MJCF: <folder>/mjcf/<name>.xml")
    add_difficulty_options(data)
    data.add_argument("--workers", type=workers_option, default=2,
                      help="worker processes (default 2; at most 4 per usable core)")
    add_ray_option(data, "puzzles")
    data.add_argument("--stats", type=path_option, metavar="DIR",
                      help="print counts, distinct puzzles and difficulty histograms of the dataset DIR; "
                           "plots into DIR/plots/")
    data.add_argument("--quiet", action="store_true", help="no progress bar")
    data.set_defaults(func=cmd_dataset)
    check = sub.add_parser("check", help="re-validate an exported puzzle folder")
    check.add_argument("puzzle_dir", type=path_option)
    check.set_defaults(func=cmd_check)
    replan = sub.add_parser("replan", help="find a new certificate for a puzzle folder as it is now (e.g. edited "
                                           "in Blender) with OMPL's RRT-Connect (else LA-RRT) and store it in "
                                           "puzzle.json")
    replan.add_argument("puzzle_dir", type=path_option)
    replan.add_argument("--budget", type=replan_budget_option,
                        help="collision queries each planner may spend (default 100000)")
    replan.add_argument("--seed", type=benchmark_seed_option, default=0, help="seed of the search (default 0)")
    add_json_option(replan, "solved, planner, queries, states, dependencies")
    replan.set_defaults(func=cmd_replan)
    export = sub.add_parser("export", help="write other formats into puzzle folders: mjcf -> <folder>/mjcf/<name>.xml")
    export.add_argument("puzzle_dirs", type=path_option, nargs="+", metavar="PUZZLE_DIR",
                        help="puzzle folder(s), or a folder of generated puzzles (all of them)")
    export.add_argument("--format", required=True, choices=("mjcf",), help="mjcf: MuJoCo (docs/interop.md)")
    export.set_defaults(func=cmd_export)
    imp = sub.add_parser("import", help="import a planar puzzle from a URDF file as a certified puzzle folder "
                                        "(docs/import.md)")
    imp.add_argument("urdf", type=path_option, metavar="URDF",
                     help="the URDF file; meshes: STL (binary or ASCII) or OBJ")
    imp.add_argument("--out", type=path_option, default="output",
                     help="output folder; the puzzle goes to OUT/imported/NAME (default: output)")
    imp.add_argument("--name", help="the puzzle's name (default: the URDF's robot name)")
    imp.add_argument("--target", help="the target: a URDF joint or link (default: the object that fits the link "
                                      "named 'goal')")
    imp.add_argument("--goal", type=goal_values_option, metavar="VALUE[,VALUE...]",
                     help="the target's goal in URDF joint values: one for a joint, one per joint (from the world "
                          "outwards) for a link; needs --target (default: read from the link named 'goal')")
    imp.add_argument("--budget", type=import_budget_option,
                     help="collision queries LA-RRT may spend to certify the puzzle (default 100000)")
    imp.add_argument("--seed", type=benchmark_seed_option, default=0, help="seed of the certifying search (default 0)")
    imp.set_defaults(func=cmd_import)
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
    bench.add_argument("--workers", type=workers_option, default=2,
                       help="worker processes (default 2; at most 4 per usable core)")
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
    bench.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_option(bench, "summary.json's content under 'summary', and the output's paths")
    bench.set_defaults(func=cmd_benchmark)
    manipulate = sub.add_parser("manipulate", help="execute puzzles' solutions with a mobile KUKA iiwa in PyBullet")
    manipulate.add_argument("puzzle_dirs", type=path_option, nargs="+", metavar="PUZZLE_DIR",
                            help="puzzle folder(s), or a folder of generated puzzles (all of them)")
    manipulate.add_argument("--out", type=path_option, default="output/manipulation",
                            help="output folder (default: output/manipulation)")
    manipulate.add_argument("--no-video", action="store_true", help="frames and report only")
    manipulate.add_argument("--table", type=path_option, metavar="FILE",
                            help="also write a Markdown summary table here")
    manipulate.add_argument("--scale", type=scene_scale_option,
                            help="scene metres per puzzle metre, 0.05..2, for every puzzle (default: each generator's "
                                 "physical scale, docs/manipulation/README.md#physical-scale)")
    manipulate.add_argument("--gui", action="store_true", help="show the simulation in a PyBullet window")
    manipulate.add_argument("--quiet", action="store_true", help="no progress bar")
    manipulate.add_argument("--benchmark", type=path_option, metavar="DIR",
                            help="a benchmark's output folder: every least-cost LA-RRT solution in its journal is "
                                 "tried, then the certificate (default: the puzzle's best solution, then the "
                                 "certificate)")
    add_json_option(manipulate, "each puzzle's report.json and its output folder")
    manipulate.set_defaults(func=cmd_manipulate)
    audit = sub.add_parser("audit", help="re-check exported puzzles: certificate replayed in PyBullet, every "
                                         "object tried as superfluous with a large budget")
    audit.add_argument("dir", type=path_option, metavar="DIR",
                       help="a puzzle folder, or a folder of generated puzzles (all of them)")
    audit.add_argument("--budget", type=audit_budget_option,
                       help="collision queries per attempt with an object fixed (default 100000, 25 x the Maker's "
                            "judge budget; at most 10000000); the second judge gets as many collision checks")
    audit.add_argument("--out", type=path_option, default="output/audit",
                       help="folder for audit.json (found paths included) and audit.md; replaces only files an "
                            "earlier audit wrote (default: output/audit)")
    audit.add_argument("--workers", type=workers_option, default=2,
                       help="worker processes (default 2; at most 4 per usable core)")
    audit.add_argument("--quiet", action="store_true", help="no progress bar")
    audit.set_defaults(func=cmd_audit)
    render = sub.add_parser("render", help="render every puzzle folder under --out and write <out>/index.html")
    render.add_argument("--out", type=path_option, default="output",
                        help="output folder holding the puzzles (default: output)")
    render.add_argument("--engine", default="auto", choices=("auto", "workbench", "cycles"),
                        help="auto: Workbench, Cycles (CPU) where Workbench cannot run (default)")
    render.add_argument("--size", type=image_size_option, default="520x390",
                        help="image size WIDTHxHEIGHT, each side 16..8192 (default 520x390)")
    render.add_argument("--views", default="top,oblique,oblique_back",
                        help="comma-separated views: top, oblique, oblique_back, side")
    render.add_argument("--workers", type=workers_option, default=1,
                        help="render processes (default 1; at most 4 per usable core)")
    render.add_argument("--no-animation", action="store_true",
                        help="no solution animation (images/<name>_solution.webp, about 3-4 s per puzzle)")
    render.add_argument("--blender", metavar="PATH",
                        help="render and save each .blend with this Blender binary (e.g. blender, Blender 3.4+), "
                             "so that the .blend opens in that version; default: the bpy module, Blender 4.5, "
                             "whose .blend files Blender 3.x cannot open")
    render.add_argument("--gallery-only", action="store_true", help="only (re)write index.html")
    render.add_argument("--quiet", action="store_true", help="no progress bar")
    render.set_defaults(func=cmd_render)
    # Before or after the command: 'phyrogen --debug generate ...' and 'phyrogen generate ... --debug'.
    debug_help = "print the traceback of an unexpected error"
    parser.add_argument("--debug", action="store_true", help=debug_help)
    for command in sub.choices.values():
        command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=debug_help)
    return parser


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM: raised where the command is, so that every ``with`` and ``finally`` on
    the way out cleans up (workers stopped, temporary folders removed)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


_interrupted: int | None = None  # the signal that stopped the command


COMPILED_INIT = frozenset({"ExtensionFileLoader.create_module", "ExtensionFileLoader.exec_module"})
"""importlib's calls that run a compiled module's initialisation (OMPL's, Numba's, PyBullet's)."""
RETRY_SECONDS = 0.01
"""How soon a signal held back during a compiled module's initialisation is sent again."""


def _in_compiled_init(frame) -> bool:
    """Whether ``frame`` runs inside the initialisation of a compiled module: Python code that the
    module's C++ calls (OMPL's builds hundreds of enums), or that C++ itself."""
    while frame is not None:
        if frame.f_code.co_qualname in COMPILED_INIT:
            return True
        frame = frame.f_back
    return False


def _interrupt(signum, frame) -> None:
    global _interrupted
    if _in_compiled_init(frame):
        # Raised here, the exception would cross the module's C++ on its way out: OMPL's aborts the
        # process ("terminate called after throwing an instance of 'nanobind::python_error'") or
        # swallows it. The signal comes again a moment later, until the import has returned.
        threading.Timer(RETRY_SECONDS, os.kill, (os.getpid(), signum)).start()
        return
    # Only the first signal counts: a second one would cut the clean-up short.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _interrupted = signum
    raise Interrupted(signum)


def _redeliver(fallback, unraisable) -> None:
    # Raised inside a finalizer (a __del__, a weakref callback), Interrupted cannot propagate:
    # Python would print "Exception ignored" and the command would go on. Send the signal again,
    # to arrive a moment later, outside the finalizer.
    if isinstance(unraisable.exc_value, Interrupted) and threading.current_thread() is threading.main_thread():
        signum = unraisable.exc_value.signum
        signal.signal(signum, _interrupt)
        threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
    else:
        fallback(unraisable)


def _run_for_json(args) -> int:
    """``--json``: the command's own stdout goes to stderr, then its result (``args.json_result``, set by the
    command) is printed as one JSON object. Bad input raises before, so its stdout stays empty."""
    args.json_result = None
    with contextlib.redirect_stdout(sys.stderr):
        code = args.func(args)
    if args.json_result is not None:
        print(json.dumps({**args.json_result, "exit_code": code}, sort_keys=True))
    return code


def main(argv: list[str] | None = None) -> int:
    """Run a command. Bad input: one line on stderr, exit 2. Interrupted (SIGINT, SIGTERM): one
    line, exit 130 or 143, nothing left running. Anything else: one line (the traceback with
    ``--debug``), exit 1."""
    global _interrupted
    from phyrogen_core.folder import OutputError

    _interrupted = None
    previous = {}
    previous_hook = sys.unraisablehook
    if threading.current_thread() is threading.main_thread():
        previous = {signum: signal.signal(signum, _interrupt) for signum in (signal.SIGINT, signal.SIGTERM)}
        sys.unraisablehook = functools.partial(_redeliver, previous_hook)
    debug = False
    try:
        args = build_parser().parse_args(argv)
        debug = args.debug
        if getattr(args, "json", False):
            code = _run_for_json(args)
        else:
            code = args.func(args)
        if _interrupted is not None:  # dropped in a finalizer, and the command ended before it came again
            raise Interrupted(_interrupted)
        return code
    except (UsageError, ParameterError, OutputError, ValueError, FileNotFoundError) as exc:
        if debug:
            traceback.print_exc()
        print(f"phyrogen: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # The reader of stdout went away (``phyrogen generate | head``): the workers were stopped on
        # the way here; end quietly as a program killed by SIGPIPE would, and let the interpreter's
        # final flush of stdout go nowhere.
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except KeyboardInterrupt as exc:
        for signum in previous:  # also a signal that _redeliver sent again
            signal.signal(signum, signal.SIG_IGN)
        print("phyrogen: interrupted", file=sys.stderr)
        return 128 + getattr(exc, "signum", signal.SIGINT)
    except Exception as exc:
        if debug:
            traceback.print_exc()
        else:
            message = (str(exc).splitlines() or [""])[0]
            print(f"phyrogen: error: {type(exc).__name__}: {message} (run with --debug for the traceback)",
                  file=sys.stderr)
        return 1
    finally:
        # A caller in the same process gets its handlers back. Run as the program (no argv), the
        # command keeps them until the process ends: a second Ctrl-C arriving as it exits must
        # still count as ignored, not end it by the signal.
        if argv is not None and previous:
            sys.unraisablehook = previous_hook
            for signum, handler in previous.items():
                if handler is not None:
                    signal.signal(signum, handler)


if __name__ == "__main__":
    sys.exit(main())
