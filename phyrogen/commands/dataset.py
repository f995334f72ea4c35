"""``phyrogen dataset``: a sharded, resumable dataset with a Parquet manifest (docs/datasets.md); with
``--stats DIR``, a description of one."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from phyrogen.difficulty_options import add_difficulty_options, difficulty_settings
from phyrogen.options import add_quiet_option, add_workers_option, path_option, whole_number
from phyrogen.progress import progress_bar, show_running
from phyrogen.ray_options import add_ray_option, check_ray, ray_connection
from phyrogen.usage import UsageError, generator_names, parse_seeds
from phyrogen_core.registry import MAX_SEED

if TYPE_CHECKING:
    from solver.pipelines.dataset.manifest_row import ManifestRow


def add_parser(sub) -> None:
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
    add_workers_option(data)
    add_ray_option(data, "puzzles")
    data.add_argument("--stats", type=path_option, metavar="DIR",
                      help="print counts, distinct puzzles and difficulty histograms of the dataset DIR; "
                           "plots into DIR/plots/")
    add_quiet_option(data)
    data.set_defaults(func=run)


def run(args) -> int:
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
    names = generator_names(args.generator)
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
    progress = progress_bar(request.size, args.quiet)

    def on_running(running: list) -> None:
        show_running(progress, [task.name for task in running])

    def show_row(row: ManifestRow, made_now: bool) -> None:
        if made_now and not row.ok:
            progress.write(f"{row.generator} {row.seed}: FAILED: {row.error.splitlines()[0]}",
                           file=sys.stdout)
        progress.update(1)

    def show_shard(shard: int, rows: list) -> None:
        ok = sum(row.ok for row in rows)
        progress.write(f"{shard_name(shard)}: {ok}/{len(rows)} puzzles ok; rows in parts/{shard_name(shard)}.parquet",
                       file=sys.stdout)
        sys.stdout.flush()

    backend = local_backend if args.ray is None else ray_backend(args.ray)
    try:
        with ray_connection(args.ray, args.workers):  # (an unreachable cluster is refused before anything is written)
            result = build_dataset(request, root, args.workers, backend=backend, on_row=show_row,
                                   on_skip=progress.update, on_shard=show_shard, on_running=on_running)
    finally:
        progress.close()
    rate = f" ({result.puzzles_per_hour:.0f} puzzles/hour)" if result.generated else ""
    print(f"{result.ok}/{result.entries} puzzles ok, {result.failed} failed; {result.generated} made now, "
          f"{result.reused} found done; {result.seconds:.1f} s wall time with {args.workers} workers{rate}")
    print(f"manifest: {result.manifest}")
    return 0


def dataset_count_option(text: str) -> int:
    from solver.pipelines.dataset.request import MAX_ENTRIES  # here, not at the top: the parser stays quick to build

    return whole_number(text, 1, MAX_ENTRIES, " puzzles")


def dataset_start_option(text: str) -> int:
    return whole_number(text, 1, MAX_SEED)


def shard_size_option(text: str) -> int:
    from solver.pipelines.dataset.request import MAX_SHARD_SIZE

    return whole_number(text, 1, MAX_SHARD_SIZE, " puzzle folders per shard")
