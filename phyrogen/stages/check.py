"""The check stage: a puzzle folder's certificate checked again at fine resolution."""

from __future__ import annotations

from phyrogen.stage_checks import certificate_problems
from phyrogen_core.stage_records.check import CheckRequest, CheckResult


def run(request: CheckRequest) -> CheckResult:
    from phyrogen_core.export import read_puzzle_dir

    loaded = read_puzzle_dir(request.folder)
    # An edited puzzle (the Blender panel's Export) keeps its old certificate, marked as not verified for it.
    return CheckResult(puzzle=loaded.name, folder=request.folder, states=len(loaded.certificate),
                       edited=not loaded.record.certificate_verified, problems=tuple(certificate_problems(loaded)))
