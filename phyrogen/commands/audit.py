"""``phyrogen audit``: exported puzzles checked again: certificate replayed in PyBullet, every object tried as
superfluous with a large budget."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from phyrogen.options import add_quiet_option, add_workers_option, path_option, whole_number
from phyrogen_core.folder import find_puzzle_folders


def add_parser(sub) -> None:
    audit = sub.add_parser("audit", help="re-check exported puzzles: certificate replayed in PyBullet, every "
                                         "object tried as superfluous with a large budget")
    audit.add_argument("dir", type=path_option, metavar="DIR",
                       help="a puzzle folder, or a folder of generated puzzles (all of them)")
    audit.add_argument("--budget", type=audit_budget_option,
                       help="collision queries per attempt with an object fixed (default 100000, 25 x the Maker's "
                            "judge budget; at most 10000000); the second judge gets as many collision checks")
    audit.add_argument("--out", type=path_option, default="output/audit",
                       help="folder for audit.json (found paths included) and audit.md; replaces only files an "
                            "earlier audit wrote (default: output/audit)")
    add_workers_option(audit)
    add_quiet_option(audit)
    audit.set_defaults(func=run)


def run(args) -> int:
    from tqdm import tqdm

    from manipulation.replay import PyBulletReferee
    from solver.pipelines.audit import (
        DEFAULT_BUDGET,
        TABLE_HEADER,
        AuditSettings,
        check_report_folder,
        plan_audit,
        run_audit,
        second_budget,
        table_row,
        task_count,
        write_reports,
    )

    budget = DEFAULT_BUDGET if args.budget is None else args.budget
    # Every puzzle is read and the report folder checked before the first attempt starts.
    puzzles = plan_audit(find_puzzle_folders(Path(args.dir)))
    out = check_report_folder(args.out)
    referee = PyBulletReferee()
    settings = AuditSettings(budget, referee.name, referee.resolution, referee.tolerance)
    if not args.quiet:
        print(f"auditing {len(puzzles)} puzzles: two judges per object, LA-RRT with pushes ({budget} collision "
              f"queries) and the paper's LA-RRT ({second_budget(budget)} checks, goal sampling included); "
              f"certificates replayed in "
              f"{referee.name} every {referee.resolution * 1000:g} mm, penetration threshold "
              f"{referee.tolerance * 1000:g} mm", file=sys.stderr)
    progress = tqdm(total=task_count(puzzles), unit="check", disable=args.quiet, file=sys.stderr)
    audits = []
    started = time.perf_counter()
    try:
        progress.write(TABLE_HEADER, file=sys.stdout)
        for audit in run_audit(puzzles, referee, budget, args.workers, on_task_done=lambda: progress.update(1)):
            progress.write(table_row(audit), file=sys.stdout)
            sys.stdout.flush()
            audits.append(audit)
    finally:
        progress.close()
        if audits:  # interrupted, the report still holds the puzzles finished, marked incomplete
            reports = write_reports(out, audits, settings, total=len(puzzles))
    for audit in audits:
        for line in audit.failures():
            print("  " + line.splitlines()[0])
    failed = sum(not a.ok for a in audits)
    print(f"{len(audits) - failed}/{len(audits)} puzzles pass the audit in {time.perf_counter() - started:.1f} s "
          f"wall time with {args.workers} workers; report: {reports[0]}, {reports[1]}")
    return 1 if failed else 0


def audit_budget_option(text: str) -> int:
    from solver.pipelines.audit import MAX_BUDGET  # here, not at the top: the parser stays quick to build

    return whole_number(text, 1, MAX_BUDGET, " collision queries")
