"""The certify stage: one seeded planner run on a puzzle folder (the solve stage, ``solver.planning.solve``), its
path checked at fine resolution as ``phyrogen check`` checks a certificate; nothing is written."""

from __future__ import annotations

from phyrogen.options import MAX_BENCHMARK_SEED
from phyrogen.stage_checks import check_within
from phyrogen_core.stage_records.certify import CertifyRequest, CertifyResult


def run(request: CertifyRequest) -> CertifyResult:
    from phyrogen_core.export import read_puzzle_dir
    from solver.planning.problem import verify_certificate
    from solver.planning.solve import solve

    check_within("seed", request.seed, 0, MAX_BENCHMARK_SEED)
    loaded = read_puzzle_dir(request.folder)
    found = solve(loaded, request.planner, request.budget_checks, request.run, request.seed)
    problems = verify_certificate(loaded.chain, found.path, loaded.goal, start=loaded.start) if found.solved else ()
    return CertifyResult(found.puzzle, found.planner, found.title, found.run, found.budget_checks, found.solved,
                         found.checks, found.end, found.joint_order, found.path, found.action_cost, tuple(problems))
