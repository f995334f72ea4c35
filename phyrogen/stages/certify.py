"""The certify stage: one seeded planner run on a puzzle folder (the solve stage, ``solver.planning.solve``), its
path checked at fine resolution as ``phyrogen check`` checks a certificate; nothing is written."""

from __future__ import annotations

from dataclasses import fields

from phyrogen.options import MAX_BENCHMARK_SEED
from phyrogen.stage_checks import check_within
from phyrogen_core.stage_records.certify import CertifyRequest, CertifyResult, PlannerRun


def run(request: CertifyRequest) -> CertifyResult:
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.problem import verify_certificate
    from solver.planning.solve import solve

    check_within("seed", request.seed, 0, MAX_BENCHMARK_SEED)
    loaded = read_puzzle_dir(request.folder)
    found = solve(loaded, request.planner, request.budget_checks, request.run, request.seed)
    problems = verify_certificate(loaded.chain, found.path, loaded.goal, start=loaded.start) if found.solved else ()
    run_fields = {field.name: getattr(found, field.name) for field in fields(PlannerRun)}
    return CertifyResult(**run_fields, problems=tuple(problems))
