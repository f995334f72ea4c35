"""The import stage: a planar puzzle from a URDF file, certified by LA-RRT, as a puzzle folder (docs/import.md)."""

from __future__ import annotations

from collections.abc import Callable

from phyrogen.options import MAX_BENCHMARK_SEED
from phyrogen.stage_checks import check_within
from phyrogen_core.stage_records.import_urdf import ImportRequest, ImportResult


def run(request: ImportRequest, *, on_note: Callable[[str], None] | None = None) -> ImportResult:
    """Import and certify the URDF; written only when certified. ``on_note`` gets what the import assumed of
    the URDF as soon as it is read, before the certifying search."""
    from phyrogen_core.export import write_puzzle
    from phyrogen_core.folder import require_writable_dir
    from phyrogen_core.urdf_import import import_urdf
    from solver.pipelines.importing import IMPORT_BUDGET, MAX_IMPORT_BUDGET, certify_imported, versions

    check_within("budget", request.budget, 1, MAX_IMPORT_BUDGET, " collision queries")
    check_within("seed", request.seed, 0, MAX_BENCHMARK_SEED)
    out = require_writable_dir(request.out)  # an unusable out is found before any work
    goal = None if request.goal is None else list(request.goal)
    imported = import_urdf(request.urdf, target=request.target, goal=goal, name=request.name)
    for note in imported.notes:
        if on_note is not None:
            on_note(note)
    puzzle = imported.puzzle
    found = certify_imported(puzzle, IMPORT_BUDGET if request.budget is None else request.budget, request.seed)
    notices: list[str] = []
    folder = None if found.puzzle is None else str(write_puzzle(found.puzzle, out, versions(), notices))
    return ImportResult(puzzle=puzzle.name, solved=found.puzzle is not None, folder=folder, budget=found.budget,
                        seed=request.seed, movable=imported.movable, static=len(imported.objects) - imported.movable,
                        joints=len(puzzle.joint_order), goal_source=imported.goal_source, target=puzzle.goal.target,
                        queries=found.queries, states=0 if found.puzzle is None else len(found.puzzle.certificate),
                        actions=found.actions, notes=tuple(imported.notes), notices=tuple(notices))
