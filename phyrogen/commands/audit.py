"""``phyrogen audit``: exported puzzles checked again: certificate replayed in PyBullet, every object tried as
superfluous with a large budget."""

from __future__ import annotations

import sys

from phyrogen.options import add_quiet_option, add_workers_option, path_option, whole_number
from phyrogen.stages import audit
from phyrogen_core.stage_records.audit import AuditRequest


def add_parser(sub) -> None:
    parser = sub.add_parser("audit", help="re-check exported puzzles: certificate replayed in PyBullet, every "
                                          "object tried as superfluous with a large budget")
    parser.add_argument("dir", type=path_option, metavar="DIR",
                        help="a puzzle folder, or a folder of generated puzzles (all of them)")
    parser.add_argument("--budget", type=audit_budget_option,
                        help="collision queries per attempt with an object fixed (default 100000, 25 x the Maker's "
                             "judge budget; at most 10000000); the second judge gets as many collision checks")
    parser.add_argument("--out", type=path_option, default="output/audit",
                        help="folder for audit.json (found paths included) and audit.md; replaces only files an "
                             "earlier audit wrote (default: output/audit)")
    add_workers_option(parser)
    add_quiet_option(parser)
    parser.set_defaults(func=run)


def run(args) -> int:
    from tqdm import tqdm

    from solver.pipelines.audit import TABLE_HEADER

    progress = None

    def on_start(plan) -> None:
        nonlocal progress
        if not args.quiet:
            print(f"auditing {plan.puzzles} puzzles: two judges per object, LA-RRT with pushes ({plan.budget} "
                  f"collision queries) and the paper's LA-RRT ({plan.second_budget} checks, goal sampling included); "
                  f"certificates replayed in {plan.referee} every {plan.resolution * 1000:g} mm, penetration "
                  f"threshold {plan.tolerance * 1000:g} mm", file=sys.stderr)
        progress = tqdm(total=plan.tasks, unit="check", disable=args.quiet, file=sys.stderr)
        progress.write(TABLE_HEADER, file=sys.stdout)

    def on_puzzle(_, row: str) -> None:
        progress.write(row, file=sys.stdout)
        sys.stdout.flush()

    try:
        result = audit.run(AuditRequest(args.dir, args.budget, args.out, args.workers), on_start=on_start,
                           on_task_done=lambda: progress.update(1), on_puzzle=on_puzzle)
    finally:
        if progress is not None:
            progress.close()
    for puzzle in result.puzzles:
        for line in puzzle.failures:
            print("  " + line)
    passed = sum(p.ok for p in result.puzzles)
    print(f"{passed}/{len(result.puzzles)} puzzles pass the audit in {result.wall_seconds:.1f} s wall time with "
          f"{args.workers} workers; report: {result.report_json}, {result.report_markdown}")
    return result.exit_code


def audit_budget_option(text: str) -> int:
    from solver.pipelines.audit import MAX_BUDGET  # here, not at the top: the parser stays quick to build

    return whole_number(text, 1, MAX_BUDGET, " collision queries")
