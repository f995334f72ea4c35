"""What the dataset benchmarks (``benchmarks/dataset_speed.py``, ``scripts/bench_dataset.py``) make: the
generators, each with the settings that keep sizes where the paper ties them to the seed, so that fresh
seeds make puzzles of the sizes measured before."""

from __future__ import annotations

SIZE_SETTINGS: dict[str, list[str]] = {"grid_world": [], "simple_slider": ["n_objects=4"], "lockbox_random": [],
                                       "rooms": [], "continuous_space": [], "move_n_times": ["n=3"]}
"""Each generator's ``KEY=VALUE`` overrides."""


def plan(puzzles: dict[str, int]) -> dict[str, tuple[int, list[str]]]:
    """Every generator of :data:`SIZE_SETTINGS`, in its order: (its puzzles at ``--scale 1``, its settings)."""
    return {generator: (puzzles[generator], settings) for generator, settings in SIZE_SETTINGS.items()}
