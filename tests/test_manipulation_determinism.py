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


@pytest.fixture(scope="module")
def forward(two_puzzles, tmp_path_factory):
    """The two puzzles in one batch, first then second, and the BIT* planners the reaching module made
    meanwhile: a run both tests compare against (each of the others is a run of its own)."""
    import manipulation.reaching as reaching
    from manipulation.batch import manipulate_folders

    calls = []
    real = reaching.og

    def counting(si):
        calls.append(si)
        return real.BITstar(si)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(reaching, "og", SimpleNamespace(BITstar=counting, PathSimplifier=real.PathSimplifier))
        reports = manipulate_folders(two_puzzles, tmp_path_factory.mktemp("ab"), video=False, quiet=True)
    return reports, calls


@pytest.mark.slow
def test_a_batch_gives_each_puzzle_the_same_report_in_either_order(two_puzzles, forward, tmp_path):
    from manipulation.batch import manipulate_folders

    first, second = two_puzzles
    reports, bit_star_calls = forward
    # Random draws were made: with one OMPL seed per batch (before), these two reports differed.
    assert bit_star_calls
    backward = manipulate_folders([second, first], tmp_path / "ba", video=False, quiet=True)
    by_name = {r.puzzle: _without_timings(r) for r in backward}
    assert sorted(by_name) == sorted(r.puzzle for r in reports)
    for report in reports:
        assert _without_timings(report) == by_name[report.puzzle], report.puzzle


@pytest.mark.slow
def test_a_puzzle_alone_reports_as_in_a_batch(two_puzzles, forward, tmp_path):
    from manipulation.batch import manipulate_folders

    _, second = two_puzzles
    reports, _ = forward
    (alone,) = manipulate_folders([second], tmp_path / "alone", video=False, quiet=True)
    assert reports[1].puzzle == alone.puzzle
    assert _without_timings(alone) == _without_timings(reports[1])
