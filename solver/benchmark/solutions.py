"""The best solution per puzzle of the LA-RRT entries, saved into the puzzle's folder as the typed
best-solution file (:class:`~phyrogen_core.solution_file.SolutionFile`) for the manipulation stage."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

from phyrogen_core.folder import PuzzleFolder, write_file_atomic
from phyrogen_core.solution_file import SolutionFile
from solver.benchmark.jobs import RunRecord
from solver.planning.registry import PLANNERS, solution_planners


def solution_record(record: RunRecord, factors: Mapping[str, Sequence[int]]) -> SolutionFile:
    """The best-solution file of a run's path: joint order, path and the object moved by each action."""
    from phyrogen_core.actions import action_sequence

    return SolutionFile(tuple(record.joint_order), tuple(tuple(state) for state in record.path),
                        puzzle=record.puzzle, planner=record.planner, seed=record.seed, run=record.run,
                        time_limit=record.time_limit, found_after=record.best_solution_time,
                        action_cost=record.action_cost,
                        object_sequence=tuple(action_sequence(record.path, factors)))


def solution_json(record: RunRecord, factors: Mapping[str, Sequence[int]]) -> dict:
    """The saved form of a best path (:func:`solution_record` as JSON)."""
    return solution_record(record, factors).to_json()


def save_best_solution(puzzle: PuzzleFolder, records: Sequence[RunRecord],
                       planner_titles: Sequence[str] | str | None = None) -> Path | None:
    """Write the lowest-cost path on ``puzzle`` of the planners titled ``planner_titles`` (default:
    the entries registered with ``saves_solution``, the LA-RRT ones) to its folder (atomically)."""
    from phyrogen_core.export import read_puzzle_dir

    if planner_titles is None:
        planner_titles = [PLANNERS[name].title for name in solution_planners()]
    elif isinstance(planner_titles, str):
        planner_titles = [planner_titles]
    solved = [r for r in records if r.planner in planner_titles and r.puzzle == puzzle.name and r.solved]
    if not solved:
        return None
    best = min(solved, key=lambda r: (r.action_cost, r.length, r.run))
    record = solution_record(best, read_puzzle_dir(puzzle.path).chain.factors)
    return write_file_atomic(puzzle.best_solution, json.dumps(record.to_json(), indent=1).encode())
