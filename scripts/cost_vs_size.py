"""Generation cost against size for every generator: docs/cost_vs_size.png and a Markdown table.

    .venv/bin/python scripts/cost_vs_size.py [--seeds 3] [--workers 2] [--out docs/cost_vs_size.png]

Each generator is swept over its size knob (n_objects from 2 to 12 where the generator allows
it, Rooms' n_rooms 2-6 with 2 doors, Move N Times' n 1-12),
with --seeds fresh seeds per size (printed), each puzzle in a process of its own (batches of
one), as one dataset per generator. The cost of a puzzle is its generation time in its worker
(generation and certification, not export) and the collision queries its validation spent
(machine-independent). The plot shows the median and the range over the seeds.
"""

from __future__ import annotations

import argparse
import functools
import json
import random
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from solver.pipelines.dataset import build_dataset, local_backend, make_request, manifest_rows  # noqa: E402

SWEEPS = {  # generator: (size parameter, smallest, largest, other settings)
    "simple_slider": ("n_objects", 1, 12, []),
    "move_n_times": ("n", 1, 12, []),
    "rooms": ("n_rooms", 2, 6, ["doors=2"]),
    "grid_world": ("n_objects", 2, 12, []),
    "lockbox_random": ("n_objects", 2, 12, []),
    "continuous_space": ("n_objects", 2, 12, []),
}


def measure(generator: str, seeds_per_size: int, workers: int, scratch: Path) -> dict[int, list[tuple[float, int]]]:
    """size -> [(seconds, queries)] for the generator's sweep."""
    knob, low, high, settings = SWEEPS[generator]
    sizes = high - low + 1
    first = random.SystemRandom().randrange(1_000_000, 9_000_000)
    request = make_request([generator], [(first, first + sizes * seeds_per_size - 1)],
                           [f"{knob}={low}:{high}", *settings])
    print(f"{generator}: {knob} {low}..{high}, seeds {first}-{first + sizes * seeds_per_size - 1}", flush=True)
    root = scratch / generator
    build_dataset(request, root, workers, backend=functools.partial(local_backend, batch_size=1))
    costs: dict[int, list[tuple[float, int]]] = {}
    for row in manifest_rows(root)[0]:
        size = int(json.loads(row.parameters)[knob])
        if not row.ok:
            print(f"  {generator} seed {row.seed} ({knob} {size}) failed: {row.error.splitlines()[0]}")
            continue
        costs.setdefault(size, []).append((row.generation_seconds, row.validation_checks))
    shutil.rmtree(root)
    return costs


def plot(results: dict[str, dict[int, list[tuple[float, int]]]], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for generator, costs in results.items():
        sizes = sorted(costs)
        for axis, column in zip(axes, (0, 1), strict=True):
            values = [[c[column] for c in costs[s]] for s in sizes]
            medians = [statistics.median(v) for v in values]
            low = [m - min(v) for m, v in zip(medians, values, strict=True)]
            high = [max(v) - m for m, v in zip(medians, values, strict=True)]
            axis.errorbar(sizes, medians, yerr=[low, high], marker="o", capsize=3, label=generator)
    axes[0].set_ylabel("generation time per puzzle (s, one core)")
    axes[1].set_ylabel("collision queries per puzzle")
    for axis in axes:
        axis.set_yscale("log")
        axis.set_xlabel("size (n_objects; Rooms: n_rooms; Move N Times: n)")
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend()
    figure.suptitle("Generation cost against size (median, range over the seeds)")
    figure.tight_layout()
    figure.savefig(out, dpi=110)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=3, help="seeds per size")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--generators", default=",".join(SWEEPS))
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "cost_vs_size.png")
    args = parser.parse_args()
    scratch = Path(tempfile.mkdtemp(prefix="cost-vs-size-"))
    try:
        results = {g: measure(g, args.seeds, args.workers, scratch) for g in args.generators.split(",")}
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    plot(results, args.out)
    print(f"\nplot: {args.out}\n")
    print("| generator | size | median s | max s | median queries |")
    print("|---|---:|---:|---:|---:|")
    for generator, costs in results.items():
        for size in sorted(costs):
            seconds = [c[0] for c in costs[size]]
            queries = [c[1] for c in costs[size]]
            print(f"| {generator} | {size} | {statistics.median(seconds):.2f} | {max(seconds):.2f} | "
                  f"{statistics.median(queries):,.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
