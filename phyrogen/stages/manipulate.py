"""The manipulate stage: puzzles' solutions executed by a mobile KUKA iiwa in PyBullet."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from phyrogen.stage_checks import check_within
from phyrogen_core.stage_records.base import RecordError
from phyrogen_core.stage_records.manipulate import ManipulateRequest, ManipulateResult, ManipulationOutcome

MAX_SCENE_SCALE = 2.0
MIN_SCENE_SCALE = 0.05
"""``scale``: below it every object's 5 cm knob is under 2.5 mm wide, less than the gripper closes on
(docs/manipulation/README.md#physical-scale); 1e-300 made the physics fail."""


def run(request: ManipulateRequest) -> ManipulateResult:
    """Execute every puzzle and write its outputs (frames, video, ``report.json``) under ``out``."""
    from manipulation.batch import manipulate_folders
    from manipulation.execution import ExecutionSettings
    from phyrogen_core.folder import PuzzleFolder, find_in_paths

    check_within("scale", request.scale, MIN_SCENE_SCALE, MAX_SCENE_SCALE, " scene metres per puzzle metre")
    folders = [f.path if isinstance(f, PuzzleFolder) else f for f in find_in_paths(list(request.folders))]
    runs = benchmark_runs(Path(request.benchmark), folders) if request.benchmark else None
    out = Path(request.out)
    reports = manipulate_folders(folders, out, video=request.video,
                                 table=Path(request.table) if request.table else None, gui=request.gui,
                                 quiet=not request.progress, settings=ExecutionSettings(scale=request.scale), runs=runs)
    return ManipulateResult(out=str(out), reports=tuple(_outcome(report, out) for report in reports))


def _outcome(report, out: Path) -> ManipulationOutcome:
    try:
        return ManipulationOutcome.from_dict({**dataclasses.asdict(report), "folder": str(out / report.puzzle)},
                                             f"{report.puzzle}'s report")
    except RecordError as exc:  # the executor's own numbers: a bug, not the user's bad input (exit 1, not 2)
        raise RuntimeError(str(exc)) from None


def benchmark_runs(benchmark: Path, folders: list[Path]) -> dict[Path, list]:
    """Per puzzle folder, the solved LA-RRT runs of ``benchmark``'s journal on that very puzzle (its
    name and the digest of its files), for the manipulation stage. Glue here, at the top: the
    journal's reader lives in the solver beside OMPL, which manipulation may not import."""
    import json

    from manipulation.solution import BenchmarkRun
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.folder import OutputError, PuzzleFolder
    from solver.benchmark.journal import JOURNAL, puzzle_digest, read_journal
    from solver.planning.registry import LA_RRT_PLANNERS

    journal = benchmark / JOURNAL
    if not os.path.lexists(journal):
        raise OutputError(f"benchmark folder {benchmark} has no {JOURNAL}; name the folder a benchmark wrote "
                          "(its --out)")
    records = [(json.loads(key), record) for key, record in read_journal(journal).items()]
    out: dict[Path, list] = {}
    for folder in folders:
        name = read_puzzle_dir(folder).name
        digest = puzzle_digest(PuzzleFolder(Path(folder), name))
        out[Path(folder)] = [BenchmarkRun(r.planner, r.run, tuple(r.joint_order), tuple(r.path))
                             for key, r in records
                             if key.get("planner") in LA_RRT_PLANNERS and r.solved and len(r.path) >= 2
                             and r.puzzle == name and key.get("puzzle_sha256") == digest]
    return out
