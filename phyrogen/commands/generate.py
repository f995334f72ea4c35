"""``phyrogen generate``: certified puzzles for generators and seeds (or a named suite), in worker processes;
a row per puzzle as it is done."""

from __future__ import annotations

import sys

from phyrogen.difficulty_options import add_difficulty_options
from phyrogen.json_output import add_json_option
from phyrogen.options import add_quiet_option, add_workers_option, path_option
from phyrogen.progress import progress_bar, show_running
from phyrogen.stages import generate
from phyrogen_core.stage_records.generate import GenerateRequest


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
    request = GenerateRequest(args.generator, args.suite, args.seeds, tuple(args.set or ()), args.out, args.workers,
                              args.mjcf, args.difficulty, args.difficulty_runs, args.difficulty_checks,
                              keep_rows=args.json)
    progress = None

    def on_start(total: int) -> None:
        nonlocal progress
        progress = progress_bar(total, args.quiet)
        progress.write(f"{'generator':18s} {'seed':>4s} {'objects':>7s} {'actions':>7s} {'time [s]':>8s}  result",
                       file=sys.stdout)

    def on_puzzle(row, notices: tuple[str, ...]) -> None:
        result = row.folder if row.error is None else "FAILED: " + row.error
        progress.write(f"{row.generator:18s} {row.seed:4d} {row.objects:7d} {row.actions:7d} {row.seconds:8.2f}  "
                       f"{result}", file=sys.stdout)
        sys.stdout.flush()
        for notice in notices:
            progress.write(f"phyrogen: note: {notice}", file=sys.stderr)
        progress.update(1)

    try:
        result = generate.run(request, on_start=on_start, on_puzzle=on_puzzle,
                              on_running=lambda names: show_running(progress, names))
    finally:
        if progress is not None:
            progress.close()
    done = result.ok + result.failed
    print(f"{result.ok}/{done} puzzles in {result.wall_seconds:.1f} s wall time with {args.workers} workers")
    args.json_result = result
    return result.exit_code
