"""The dataset stage: a sharded, resumable dataset with a Parquet manifest (docs/datasets.md)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from phyrogen.difficulty_options import difficulty_settings
from phyrogen.ray_options import check_ray, ray_connection
from phyrogen.stage_checks import check_workers
from phyrogen.usage import UsageError, generator_names, parse_seeds
from phyrogen_core.registry import MAX_SEED
from phyrogen_core.stage_records.dataset import DatasetRequest, DatasetResult


def run(request: DatasetRequest, *, on_start: Callable[[int], None] | None = None,
        on_row: Callable[[object, bool], None] | None = None, on_skip: Callable[[int], None] | None = None,
        on_shard: Callable[[int, list], None] | None = None,
        on_running: Callable[[list[str]], None] | None = None) -> DatasetResult:
    """Make or resume the dataset. Once everything is checked, ``on_start`` gets the number of entries; then
    ``on_row(row, made_now)`` each entry's manifest row (:class:`solver.pipelines.dataset.ManifestRow`),
    ``on_skip(count)`` the entries of each complete shard skipped, ``on_shard(shard, rows)`` each shard
    this run completes, ``on_running`` the names of the puzzles being made."""
    from solver.pipelines.dataset import build_dataset, check_dataset_root, local_backend, make_request, ray_backend

    if (request.seeds is None) == (request.count is None):
        raise UsageError("give the seeds either with --seeds (e.g. 1-1000) or with --count N [--start S]")
    if request.seeds is not None and request.start is not None:
        raise UsageError("--start goes with --count; --seeds lists the seeds itself")
    check_workers(request.workers)
    names = generator_names(request.generators)
    if request.seeds is not None:
        seeds = parse_seeds(request.seeds)
    else:
        start = 1 if request.start is None else request.start
        if start + request.count - 1 > MAX_SEED:
            raise UsageError(f"--start {start} --count {request.count} goes past the largest seed {MAX_SEED}")
        seeds = (range(start, start + request.count),)
    # Everything is checked before the first file is written: the request, every entry's size
    # (feasible for its generator), and the folder (writable; empty, or this request's dataset).
    made = make_request(names, seeds, list(request.overrides), request.sweep, request.shard_size, request.mjcf,
                        difficulty_settings(request))
    root = check_dataset_root(made, Path(request.out))
    check_ray(request.ray)  # an unreachable cluster is bad input, refused before the progress bar shows
    if on_start is not None:
        on_start(made.size)

    def running(tasks: list) -> None:
        if on_running is not None:
            on_running([task.name for task in tasks])

    backend = local_backend if request.ray is None else ray_backend(request.ray)
    with ray_connection(request.ray, request.workers):  # (an unreachable cluster is refused before anything is written)
        built = build_dataset(made, root, request.workers, backend=backend, on_row=on_row, on_skip=on_skip,
                              on_shard=on_shard, on_running=running)
    return DatasetResult(entries=built.entries, ok=built.ok, failed=built.failed, generated=built.generated,
                         reused=built.reused, seconds=built.seconds, puzzles_per_hour=built.puzzles_per_hour,
                         manifest=str(built.manifest))
