"""The audit stage: exported puzzles checked again: certificate replayed in PyBullet, every object tried as
superfluous with a large budget."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from phyrogen.stage_checks import check_workers
from phyrogen_core.stage_records.audit import AuditedPuzzle, AuditPlan, AuditRequest, AuditResult


def run(request: AuditRequest, *, on_start: Callable[[AuditPlan], None] | None = None,
        on_task_done: Callable[[], None] | None = None,
        on_puzzle: Callable[[AuditedPuzzle, str], None] | None = None) -> AuditResult:
    """Audit every puzzle and write ``audit.json`` and ``audit.md`` into ``out`` (interrupted, with the
    puzzles finished, marked incomplete). ``on_start`` gets the checked plan, ``on_task_done`` each attempt
    as it ends, ``on_puzzle`` each puzzle's record and its row of the audit's table as it is done."""
    from manipulation.replay import PyBulletReferee
    from phyrogen_core.folder import find_puzzle_folders
    from solver.pipelines.audit import (
        DEFAULT_BUDGET,
        AuditSettings,
        check_budget,
        check_report_folder,
        plan_audit,
        run_audit,
        second_budget,
        table_row,
        task_count,
        write_reports,
    )

    budget = DEFAULT_BUDGET if request.budget is None else check_budget(request.budget)
    check_workers(request.workers)
    # Every puzzle is read and the report folder checked before the first attempt starts.
    puzzles = plan_audit(find_puzzle_folders(Path(request.folder)))
    out = check_report_folder(request.out)
    referee = PyBulletReferee()
    settings = AuditSettings(budget, referee.name, referee.resolution, referee.tolerance)
    if on_start is not None:
        on_start(AuditPlan(len(puzzles), task_count(puzzles), budget, second_budget(budget), referee.name,
                           referee.resolution, referee.tolerance))
    audits = []
    started = time.perf_counter()
    reports = None
    try:
        for audit in run_audit(puzzles, referee, budget, request.workers, on_task_done=on_task_done or _nothing):
            audits.append(audit)
            if on_puzzle is not None:
                on_puzzle(_record(audit), table_row(audit))
    finally:
        if audits:  # interrupted, the report still holds the puzzles finished, marked incomplete
            reports = write_reports(out, audits, settings, total=len(puzzles))
    if reports is None:  # nothing to audit: the reports say so
        reports = write_reports(out, audits, settings, total=len(puzzles))
    return AuditResult(puzzles=tuple(_record(a) for a in audits), wall_seconds=round(time.perf_counter() - started, 3),
                       report_json=str(reports[0]), report_markdown=str(reports[1]))


def _nothing() -> None:
    pass


def _record(audit) -> AuditedPuzzle:
    p = audit.puzzle
    return AuditedPuzzle(p.name, p.generator, p.seed, audit.ok, tuple(audit.superfluous),
                         tuple(line.splitlines()[0] for line in audit.failures()))
