"""The ``phyrogen`` command line: thin wrappers over the library."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from phyrogen_core.folder import PuzzleFolder, find_in_paths, find_puzzle_folders
from phyrogen_core.registry import ParameterError, all_generators, describe_generators, paper_generators

EXIT_BAD_INPUT = 2


class UsageError(ValueError):
    pass


def parse_seeds(text: str) -> list[int]:
    """'3', '1-4' or '1,3,5-7' -> sorted seeds."""
    seeds: set[int] = set()
    try:
        for part in text.split(","):
            if "-" in part:
                low, high = (int(v) for v in part.split("-", 1))
                if high < low:
                    raise ValueError
                seeds.update(range(low, high + 1))
            else:
                seeds.add(int(part))
    except ValueError:
        raise UsageError(f"bad seed list {text!r} (examples: 3, 1-4, 1,3,5-7)") from None
    if not seeds or min(seeds) < 1:
        raise UsageError(f"seeds must be positive integers, got {text!r}")
    return sorted(seeds)


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
    for name in names:
        if name not in registry:
            raise UsageError(f"unknown generator {name!r} (known: {', '.join(registry)})")
    return names


def cmd_list(args) -> int:
    print(describe_generators())
    return 0


def cmd_generate(args) -> int:
    from solver.generation import Job, run_jobs

    names = _generators(args.generator)
    seeds = parse_seeds(args.seeds)
    overrides = parse_overrides(args.set or [])
    if overrides and len(names) > 1:
        raise UsageError("--set applies to one generator; name it with --generator")
    registry = all_generators()
    for name in names:  # fail fast on bad parameters, before any work
        spec = registry[name]
        params = spec.parse_params(overrides)
        for seed in seeds:
            spec.check(seed, params)
    jobs = [Job(name, seed, overrides) for name in names for seed in seeds]
    out = Path(args.out)
    started = time.perf_counter()
    reports = []
    progress = _progress(len(jobs), args.quiet)
    for report in run_jobs(jobs, out, args.workers):
        reports.append(report)
        progress.update(1)
    progress.close()
    wall = time.perf_counter() - started
    print(f"{'generator':18s} {'seed':>4s} {'objects':>7s} {'actions':>7s} {'time [s]':>8s}  result")
    for r in reports:
        result = r.folder if r.error is None else "FAILED: " + r.error.splitlines()[0]
        print(f"{r.generator:18s} {r.seed:4d} {r.objects:7d} {r.actions:7d} {r.seconds:8.2f}  {result}")
    failed = [r for r in reports if r.error]
    print(f"{len(reports) - len(failed)}/{len(reports)} puzzles in {wall:.1f} s wall time with {args.workers} workers")
    return 1 if failed else 0


def cmd_check(args) -> int:
    from phyrogen_core.export import read_puzzle_dir
    from solver.problem import verify_certificate

    loaded = read_puzzle_dir(Path(args.puzzle_dir))
    problems = verify_certificate(loaded.chain, loaded.certificate, loaded.goal, start=loaded.start)
    name = loaded.metadata.get("name", args.puzzle_dir)
    # An edited puzzle (the Blender panel's Export) keeps its old certificate, marked as not verified for it.
    edited = loaded.metadata.get("certificate_verified") is False
    note = " (found for the puzzle before it was edited)" if edited else ""
    if problems:
        print(f"{name}: INVALID{note}: " + "; ".join(problems))
        return 1
    print(f"{name}: certificate valid{note} ({len(loaded.certificate)} states, checked at fine resolution)")
    return 0


def cmd_manipulate(args) -> int:
    from manipulation.batch import manipulate_folders

    folders = [f.path if isinstance(f, PuzzleFolder) else f for f in find_in_paths(args.puzzle_dirs)]
    reports = manipulate_folders(folders, Path(args.out), video=not args.no_video,
                                 table=Path(args.table) if args.table else None, gui=args.gui, quiet=args.quiet)
    return 0 if all(r.success for r in reports) else 1


def cmd_render(args) -> int:
    from blender_addon.gallery import write_gallery
    from blender_addon.render_worker import parse_size
    from blender_addon.rendering import RenderError, render_puzzles
    from blender_addon.views import parse_views

    views = parse_views(args.views)
    if not args.gallery_only:
        size = parse_size(args.size)
        folders = [f.path for f in find_puzzle_folders(Path(args.out))]
        progress = _progress(len(folders), args.quiet)
        try:
            report = render_puzzles(folders, args.engine, size, views, args.workers,
                                    on_done=lambda _: progress.update(1))
        except RenderError as exc:
            print(f"phyrogen: render failed: {exc}", file=sys.stderr)
            return 1
        finally:
            progress.close()
        engines = sorted({r.engine for r in report.rendered})
        print(f"{len(report.rendered)} puzzles, {report.images} images ({size[0]}x{size[1]}, {', '.join(engines)}) "
              f"in {report.seconds:.1f} s: {report.seconds_per_image:.2f} s per image, with {args.workers} workers")
    print(f"gallery: {write_gallery(Path(args.out), views)}")
    return 0


def cmd_benchmark(args) -> int:
    from solver.benchmark import estimate_seconds, get_profile, run_benchmark
    from solver.planners import PLANNERS

    generators = None if args.generator == "all" else _generators(args.generator)
    planners = list(PLANNERS) if args.planners == "all" else [p.strip() for p in args.planners.split(",")]
    for name in planners:
        if name not in PLANNERS:
            raise UsageError(f"unknown planner {name!r} (known: {', '.join(PLANNERS)})")
    profile = get_profile(args.profile, args.runs, args.time_limit)
    puzzles = find_puzzle_folders(Path(args.puzzles), generators)
    estimate = estimate_seconds(puzzles, planners, profile, args.workers, overhead=1.0)
    print(f"{len(puzzles)} puzzles x {len(planners)} planners x {profile.runs} runs, profile {profile.name}: "
          f"about {estimate / 3600:.1f} h on {args.workers} workers", file=sys.stderr)
    if args.dry_run:
        return 0
    result = run_benchmark(puzzles, planners, profile, Path(args.out), args.workers, args.seed,
                           save_solutions=not args.no_solutions, progress=not args.quiet)
    print((Path(args.out) / "summary.md").read_text(encoding="utf-8"))
    print(f"database: {result.database}  figure: {Path(args.out) / 'fig4.png'}")
    crashed = sum(1 for r in result.records if r.error)
    return 1 if crashed else 0


def _progress(total: int, quiet: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="puzzle", disable=quiet or total < 2, file=sys.stderr)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="phyrogen", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list the registered generators and their parameters").set_defaults(func=cmd_list)
    gen = sub.add_parser("generate", help="generate certified puzzles")
    gen.add_argument("--generator", default="all", help="a name, comma-separated names, or 'all' (the paper's six)")
    gen.add_argument("--seed", "--seeds", dest="seeds", default="1-4", help="seed, range or list (default 1-4)")
    gen.add_argument("--set", action="append", metavar="KEY=VALUE", help="generator parameter override")
    gen.add_argument("--out", default="output", help="output folder (default: output)")
    gen.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    gen.add_argument("--quiet", action="store_true", help="no progress bar")
    gen.set_defaults(func=cmd_generate)
    check = sub.add_parser("check", help="re-validate an exported puzzle folder")
    check.add_argument("puzzle_dir")
    check.set_defaults(func=cmd_check)
    bench = sub.add_parser("benchmark", help="benchmark planners on puzzle folders (OMPL logs, database, plots)")
    bench.add_argument("--puzzles", default="output", help="folder of puzzle folders (default: output)")
    bench.add_argument("--generator", default="all", help="generators to include (default: all found)")
    bench.add_argument("--planners", default="all", help="comma-separated: la_rrt,rrt_star,lbt_rrt,bit_star")
    bench.add_argument("--profile", default="quick", help="paper (100 runs, the paper's limits) or quick")
    bench.add_argument("--runs", type=int, help="runs per planner and puzzle (overrides the profile)")
    bench.add_argument("--time-limit", type=float, help="seconds per run for every puzzle (overrides the profile)")
    bench.add_argument("--seed", type=int, default=0, help="base seed of every run's seed (default 0)")
    bench.add_argument("--out", default="output/benchmark", help="output folder (default: output/benchmark)")
    bench.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    bench.add_argument("--no-solutions", action="store_true", help="do not save LA-RRT's best path per puzzle")
    bench.add_argument("--dry-run", action="store_true", help="print the job count and time estimate only")
    bench.add_argument("--quiet", action="store_true", help="no progress bar")
    bench.set_defaults(func=cmd_benchmark)
    manipulate = sub.add_parser("manipulate", help="execute puzzles' solutions with a mobile KUKA iiwa in PyBullet")
    manipulate.add_argument("puzzle_dirs", nargs="+", metavar="PUZZLE_DIR",
                            help="puzzle folder(s), or a folder of generated puzzles (all of them)")
    manipulate.add_argument("--out", default="output/manipulation", help="output folder (default: output/manipulation)")
    manipulate.add_argument("--no-video", action="store_true", help="frames and report only")
    manipulate.add_argument("--table", metavar="FILE", help="also write a Markdown summary table here")
    manipulate.add_argument("--gui", action="store_true", help="show the simulation in a PyBullet window")
    manipulate.add_argument("--quiet", action="store_true", help="no progress bar")
    manipulate.set_defaults(func=cmd_manipulate)
    render = sub.add_parser("render", help="render every puzzle folder under --out and write <out>/index.html")
    render.add_argument("--out", default="output", help="output folder holding the puzzles (default: output)")
    render.add_argument("--engine", default="auto", choices=("auto", "workbench", "cycles"),
                        help="auto: Workbench, Cycles (CPU) where Workbench cannot run (default)")
    render.add_argument("--size", default="480x360", help="image size WIDTHxHEIGHT (default 480x360)")
    render.add_argument("--views", default="top,oblique,oblique_back",
                        help="comma-separated views: top, oblique, oblique_back, side")
    render.add_argument("--workers", type=int, default=1, help="render processes (default 1)")
    render.add_argument("--gallery-only", action="store_true", help="only (re)write index.html")
    render.add_argument("--quiet", action="store_true", help="no progress bar")
    render.set_defaults(func=cmd_render)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (UsageError, ParameterError, ValueError, FileNotFoundError) as exc:
        print(f"phyrogen: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("phyrogen: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
