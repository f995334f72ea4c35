"""Wall time to generate and validate the paper's 24 puzzles (no rendering, no export).

    python benchmarks/generation_speed.py [--workers 2]

Prints per-puzzle times and the total against the paper's reported 127 s
(on 4 cores, mostly without validation).
"""

from __future__ import annotations

import argparse
import time

from phyrogen_core.registry import paper_generators
from solver.pipelines.generation import Job, run_jobs

PAPER_SECONDS = 127.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    jobs = [Job(name, seed) for name in paper_generators() for seed in range(1, 5)]
    started = time.perf_counter()
    reports = list(run_jobs(jobs, None, args.workers))
    wall = time.perf_counter() - started
    for r in reports:
        print(f"{r.generator:18s} {r.seed:2d} {r.seconds:7.2f} s  {'ok' if r.error is None else r.error}")
    by_generator = {}
    for r in reports:
        by_generator[r.generator] = by_generator.get(r.generator, 0.0) + r.seconds
    for name, seconds in by_generator.items():
        print(f"  {name:18s} {seconds:7.2f} s (sum of 4 seeds)")
    print(f"24 puzzles: {wall:.1f} s wall time on {args.workers} workers; "
          f"paper: {PAPER_SECONDS:.0f} s on 4 cores -> {PAPER_SECONDS / wall:.1f}x")


if __name__ == "__main__":
    main()
