"""Manipulation runs are deterministic: a puzzle's report is the same alone or in a batch, in any order."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import pytest

TIMING_FIELDS = ("planning_seconds", "execution_seconds", "benchmark_seconds")
"""Wall-clock measurements: the only report fields allowed to differ between equal runs."""


def _without_timings(report) -> dict:
    data = dataclasses.asdict(report)
    for name in TIMING_FIELDS:
        data.pop(name)
    for attempt in data.get("attempts", ()):
        for name in TIMING_FIELDS:
            attempt.pop(name, None)
    return data


@pytest.fixture(scope="module")
def two_puzzles(tmp_path_factory):
    """Two small puzzles of fresh seeds (not the paper's), written as folders. Both need BIT*
    (not every motion is a straight line): smaller Simple Sliders and Grid Worlds never call it,
    and then the order could not matter."""
    from phyrogen_core.export import write_puzzle
    from solver.pipelines.generation import generate_puzzle

    out = tmp_path_factory.mktemp("determinism")
    return [write_puzzle(generate_puzzle("move_n_times", 731, {"n": 2}), out),
            write_puzzle(generate_puzzle("grid_world", 733), out)]


@pytest.fixture
def bit_star_calls(monkeypatch):
    """Counts the BIT* planners made by the reaching module."""
    import manipulation.reaching as reaching

    calls = []
    real = reaching.og

    def counting(si):
        calls.append(si)
        return real.BITstar(si)

    monkeypatch.setattr(reaching, "og", SimpleNamespace(BITstar=counting, PathSimplifier=real.PathSimplifier))
    return calls


@pytest.mark.slow
def test_a_batch_gives_each_puzzle_the_same_report_in_either_order(two_puzzles, bit_star_calls, tmp_path):
    from manipulation.batch import manipulate_folders

    first, second = two_puzzles
    forward = manipulate_folders([first, second], tmp_path / "ab", video=False, quiet=True)
    # Random draws were made: with one OMPL seed per batch (before), these two reports differed.
    assert bit_star_calls
    backward = manipulate_folders([second, first], tmp_path / "ba", video=False, quiet=True)
    by_name = {r.puzzle: _without_timings(r) for r in backward}
    assert sorted(by_name) == sorted(r.puzzle for r in forward)
    for report in forward:
        assert _without_timings(report) == by_name[report.puzzle], report.puzzle


@pytest.mark.slow
def test_a_puzzle_alone_reports_as_in_a_batch(two_puzzles, tmp_path):
    from manipulation.batch import manipulate_folders

    first, second = two_puzzles
    (alone,) = manipulate_folders([second], tmp_path / "alone", video=False, quiet=True)
    batch = manipulate_folders([first, second], tmp_path / "batch", video=False, quiet=True)
    assert _without_timings(alone) == _without_timings(batch[1])
