"""Shared fixtures: the paper's 24 puzzles, generated once per test session."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def paper_reports(tmp_path_factory):
    """Reports (with puzzles and folders) of the six generators x seeds 1-4."""
    from phyrogen_core.registry import paper_generators
    from solver.pipelines.generation import Job, run_jobs

    out = tmp_path_factory.mktemp("paper")
    jobs = [Job(name, seed) for name in paper_generators() for seed in range(1, 5)]
    reports = list(run_jobs(jobs, out, workers=2))
    failed = [f"{r.generator} {r.seed}: {r.error}" for r in reports if r.error]
    assert not failed, "generation failed:\n" + "\n".join(failed)
    return reports
