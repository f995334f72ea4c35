"""``phyrogen dataset``: a sharded, resumable dataset with a Parquet manifest (docs/datasets.md); with
``--stats DIR``, a description of one."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

from phyrogen.difficulty_options import add_difficulty_options
from phyrogen.options import add_quiet_option, add_workers_option, path_option, whole_number
from phyrogen.progress import progress_bar, show_running
from phyrogen.ray_options import add_ray_option
from phyrogen.stages import dataset
from phyrogen.usage import UsageError
from phyrogen_core.registry import MAX_SEED
from phyrogen_core.stage_records.dataset import DatasetRequest

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

    if args.generator is None or args.out is None:
        raise UsageError("dataset needs --generator and --out (or --stats DIR to describe a dataset)")
    request = DatasetRequest(args.generator, args.out, args.seeds, args.count, args.start, tuple(args.set or ()),
                             args.sweep, args.shard_size, args.mjcf, args.difficulty, args.difficulty_runs,
                             args.difficulty_checks, args.workers, args.ray)
    progress = None

    def on_start(size: int) -> None:
        nonlocal progress
        progress = progress_bar(size, args.quiet)

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

    try:
        result = dataset.run(request, on_start=on_start, on_row=show_row, on_skip=lambda n: progress.update(n),
                             on_shard=show_shard, on_running=lambda names: show_running(progress, names))
    finally:
        if progress is not None:
            progress.close()
    rate = f" ({result.puzzles_per_hour:.0f} puzzles/hour)" if result.generated else ""
    print(f"{result.ok}/{result.entries} puzzles ok, {result.failed} failed; {result.generated} made now, "
          f"{result.reused} found done; {result.seconds:.1f} s wall time with {args.workers} workers{rate}")
    print(f"manifest: {result.manifest}")
    return result.exit_code


def dataset_count_option(text: str) -> int:
    from solver.pipelines.dataset.request import MAX_ENTRIES  # here, not at the top: the parser stays quick to build

    return whole_number(text, 1, MAX_ENTRIES, " puzzles")


def dataset_start_option(text: str) -> int:
    return whole_number(text, 1, MAX_SEED)


def shard_size_option(text: str) -> int:
    from solver.pipelines.dataset.request import MAX_SHARD_SIZE

    return whole_number(text, 1, MAX_SHARD_SIZE, " puzzle folders per shard")
