"""Same generator, parameters and seed give byte-identical output, in separate processes."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from phyrogen_core.registry import paper_generators
from solver.pipelines.generation import Job, run_jobs

pytestmark = pytest.mark.slow


def digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_regenerating_gives_byte_identical_folders(paper_reports, tmp_path):
    seeds = (1, 3)
    jobs = [Job(name, seed) for name in paper_generators() for seed in seeds]
    again = {(r.generator, r.seed): r for r in run_jobs(jobs, tmp_path, workers=2)}
    compared = 0
    for report in paper_reports:
        if report.seed not in seeds:
            continue
        second = again[(report.generator, report.seed)]
        assert second.error is None, second.error
        assert digest(Path(report.folder)) == digest(Path(second.folder)), f"{report.generator} {report.seed}"
        compared += 1
    assert compared == len(paper_generators()) * len(seeds)
