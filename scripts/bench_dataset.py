"""Dataset throughput: puzzles per hour per generator, by backend, in one run.

    .venv/bin/python scripts/bench_dataset.py [--workers 2] [--scale 1.0] [--generators grid_world,rooms]

Every generator's seeds (fresh ones each run, printed) are made three times, into throw-away
datasets, with the same number of workers:

- ``process per puzzle``: the local pool with batches of one, a fresh process for every puzzle
  (the baseline: how datasets were made before batches);
- ``local pool``: the default backend (cheap puzzles in batches of 8 per process);
- ``Ray``: the same batches as tasks on a local Ray instance with as many CPUs as workers (its
  start, about 4 s, is timed apart and not counted).

Rates count everything a dataset run does: generation, certification, writing each folder and
its record, the manifest. The three datasets must be byte-identical apart from timing columns;
the script checks that too.
"""

from __future__ import annotations

import argparse
import functools
import random
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.dataset_sizes import plan  # noqa: E402
from solver.parallel.ray_pool import LOCAL, ray_instance  # noqa: E402
from solver.pipelines.dataset import (  # noqa: E402
    TIMING_COLUMNS,
    build_dataset,
    local_backend,
    make_request,
    manifest_rows,
    ray_backend,
)

# Puzzles per generator at --scale 1 (about 20-40 s per backend on 2 cores), each with its size settings.
PLAN = plan({"grid_world": 600, "simple_slider": 300, "lockbox_random": 40, "rooms": 120, "continuous_space": 60,
             "move_n_times": 16})


def manifest_without_timing(root: Path) -> list[dict]:
    rows, _ = manifest_rows(root)
    return [{k: v for k, v in row.to_dict().items() if k not in TIMING_COLUMNS} for row in rows]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--scale", type=float, default=1.0, help="multiplies every generator's puzzle count")
    parser.add_argument("--generators", default=",".join(PLAN))
    args = parser.parse_args()
    scratch = Path(tempfile.mkdtemp(prefix="bench-dataset-"))
    rows = []
    try:
        ray_start = time.perf_counter()
        with ray_instance(LOCAL, args.workers):
            ray_start = time.perf_counter() - ray_start
            for generator in args.generators.split(","):
                count, settings = PLAN[generator]
                count = max(1, round(count * args.scale))
                first = random.SystemRandom().randrange(1_000_000, 9_000_000)
                request = make_request([generator], [(first, first + count - 1)], settings)
                rates, manifests = {}, {}
                for name, backend in (("process per puzzle", functools.partial(local_backend, batch_size=1)),
                                      ("local pool", local_backend), ("Ray", ray_backend(LOCAL))):
                    root = scratch / f"{generator}-{len(rates)}"
                    result = build_dataset(request, root, args.workers, backend=backend)
                    rates[name] = result.puzzles_per_hour
                    manifests[name] = manifest_without_timing(root)
                    shutil.rmtree(root)
                    print(f"{generator:17s} {name:19s} {count:4d} puzzles (seeds {first}-{first + count - 1}, "
                          f"{result.failed} failed): {result.seconds:6.1f} s, {result.puzzles_per_hour:8.0f} per hour",
                          flush=True)
                same = manifests["Ray"] == manifests["local pool"] == manifests["process per puzzle"]
                rows.append((generator, count, rates, same))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print(f"\nPuzzles per hour on {args.workers} workers (Ray's start, {ray_start:.1f} s, not counted):\n")
    print("| generator | puzzles | process per puzzle | local pool | Ray | local / per-puzzle | identical |")
    print("|---|---:|---:|---:|---:|---:|---|")
    for generator, count, rates, same in rows:
        base = rates["process per puzzle"]
        print(f"| {generator} | {count} | {base:,.0f} | {rates['local pool']:,.0f} | {rates['Ray']:,.0f} | "
              f"{rates['local pool'] / base:.2f}x | {'yes' if same else 'NO'} |")
    return 0 if all(same for *_, same in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
