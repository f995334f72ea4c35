"""Re-planning a puzzle folder as it is now (generated, or edited in Blender and exported): a new
solution certificate found by OMPL's RRT-Connect, for ``phyrogen replan`` and the Blender panel's Re-plan.

The search is RRT-Connect on our collision model with motions checked at fine
resolution (2 mm), so the path it returns is the certificate without repair;
where it finds nothing within its budget (narrow passages: a lockbox's slots),
LA-RRT with blocker pushes (the Maker's judge, :mod:`solver.planning.la_rrt`) gets the
same budget again. Budgets are counted in collision queries and OMPL's seed
generator, the goal sampler and LA-RRT are seeded from the puzzle's name and
``seed``: the same folder gives the same certificate on every machine. The path is
defragmented as generated certificates are and the dependency graph is read
off it. An edited puzzle's ``"certificate_verified": false`` goes away.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from phyrogen_core.actions import count_actions
from phyrogen_core.dependencies import dependency_shape
from phyrogen_core.export.reader import LoadedPuzzle
from phyrogen_core.folder import (
    METADATA_FILE,
    PuzzleFolder,
    Stage,
    owned_files,
    read_folder_file,
    require_self_contained,
    require_stage_folder,
    stage_directory,
    stage_entries,
)
from phyrogen_core.provenance import PlannerRun
from phyrogen_core.record import DependencyGraph
from phyrogen_core.seeding import stable_seed
from solver.planning.defragment import defragment_certificate
from solver.planning.la_rrt import la_rrt_within
from solver.planning.ompl_setup import rrt_connect, seed_ompl
from solver.planning.problem import (
    FINE_RESOLUTION,
    chain_dependency_graph,
    chain_path,
    problem_for_chain,
    verify_certificate,
)

REPLAN_BUDGET = 100_000
"""Collision queries RRT-Connect may spend by default (the audit's and the import's budget)."""
MAX_REPLAN_BUDGET = 100_000_000


class StartCollisionError(ValueError):
    """The puzzle's objects overlap in the start state: no path can start there."""


@dataclass(frozen=True)
class Replan:
    """A new certificate (empty when none was found within the budget) and what it took."""

    certificate: tuple[tuple[float, ...], ...]
    dependencies: tuple[tuple[str, str], ...]
    queries: int
    """Collision queries spent, by both planners when RRT-Connect found nothing."""
    budget: int
    seed: int
    planner: str = ""
    """``rrt_connect`` or ``la_rrt_push``: the planner that found the certificate."""

    @property
    def solved(self) -> bool:
        return bool(self.certificate)


def replan(loaded: LoadedPuzzle, budget: int = REPLAN_BUDGET, seed: int = 0) -> Replan:
    """A new certificate for the puzzle read from a folder: RRT-Connect within ``budget`` collision queries,
    else LA-RRT with pushes within as many again.

    Raises :class:`StartCollisionError` naming the overlapping objects when the
    start state collides, ValueError for a budget out of range.
    """
    if not 1 <= budget <= MAX_REPLAN_BUDGET:
        raise ValueError(f"budget must be 1 to {MAX_REPLAN_BUDGET} collision queries, got {budget!r}")
    chain, name = loaded.chain, loaded.name
    problem = problem_for_chain(chain, loaded.goal)
    if not problem.model.is_valid(problem.start):
        pairs = sorted(problem.model.colliding_objects(problem.start))
        shown = ", ".join(f"{a} and {b}" for a, b in pairs[:3]) + (f" and {len(pairs) - 3} more pairs"
                                                                  if len(pairs) > 3 else "")
        raise StartCollisionError(f"{name}: objects overlap at the start: {shown}; no path can start there")
    run_seed = stable_seed("replan", name, seed)
    seed_ompl(run_seed)
    result = rrt_connect(problem, budget, np.random.default_rng(run_seed), FINE_RESOLUTION)
    queries, planner, states = result.checks, "rrt_connect", result.path if result.solved else None
    if states is None:
        found, spent = la_rrt_within(problem, budget, np.random.default_rng(run_seed))
        queries, planner, states = queries + spent, "la_rrt_push", found.path if found.solved else None
    if states is None:
        return Replan((), (), queries, budget, run_seed)
    path = chain_path(problem, states)
    if verify_certificate(chain, path, loaded.goal, start=loaded.start):
        return Replan((), (), queries, budget, run_seed)
    certificate = tuple(tuple(float(v) for v in state)
                        for state in defragment_certificate(chain, loaded.goal, path))
    return Replan(certificate, chain_dependency_graph(chain, certificate), queries, budget, run_seed, planner)


def replanned_metadata(loaded: LoadedPuzzle, result: Replan) -> str:
    """``puzzle.json`` of the folder with the new certificate, its action count and dependency graph."""
    if not result.solved:
        raise ValueError(f"{loaded.name}: no new certificate to store")
    record = loaded.record
    shape = dependency_shape(result.dependencies, loaded.goal.target)
    return replace(
        record,
        certificate=result.certificate,
        certificate_actions=count_actions(result.certificate, loaded.chain.factors),
        dependency_graph=DependencyGraph(tuple(loaded.chain.factors), tuple((a, b) for a, b in result.dependencies),
                                         shape.depth, shape.branching),
        certificate_verified=True,
        provenance=replace(record.provenance,
                           replanned=PlannerRun(result.planner, result.budget, result.seed, result.queries)),
    ).to_json()


def write_replanned(folder: str | Path, loaded: LoadedPuzzle, result: Replan, notices: list[str] | None = None) -> Path:
    """Store the new certificate in the puzzle folder: its export stage swapped in atomically with the
    same URDF, SRDF and meshes and the new ``puzzle.json``; returns that file's path.

    Renders and solutions made for the old certificate move into ``stale/<n>/``
    (the folder contract, :func:`~phyrogen_core.folder.stage_directory`), and a
    line saying so is appended to ``notices``.
    """
    metadata = replanned_metadata(loaded, result)
    place = PuzzleFolder(Path(folder), loaded.name)
    check_replan_folder(place.path, place.name)
    # Only the export stage's own files are copied, each by the folder's reading rule; a user's
    # file beside them stays where it is (stage_directory carries it over, unread).
    kept = {path: read_folder_file(place.path / path, place.path)
            for path in owned_files(place.path, Stage.EXPORT, place.name) if path != METADATA_FILE}
    with stage_directory(place.path, Stage.EXPORT, place.name, notices) as temporary:
        (temporary / METADATA_FILE).write_text(metadata, encoding="utf-8")
        for path, data in kept.items():
            (temporary / path).parent.mkdir(parents=True, exist_ok=True)
            (temporary / path).write_bytes(data)
    return place.metadata


def check_replan_folder(folder: str | Path, name: str) -> None:
    """What :func:`write_replanned` needs of the puzzle folder, checked before any work: a real,
    writable folder (not a link), and every file of its export entries (``urdf/``, ``srdf/``,
    ``meshes/``) a regular file inside it, referenced or not: a link to a file elsewhere, a FIFO
    or a device there is bad input. Raises :class:`~phyrogen_core.folder.OutputError` or
    :class:`~phyrogen_core.folder.PuzzleFormatError`, one line naming the path."""
    require_stage_folder(folder, "puzzle folder")
    require_self_contained(folder, stage_entries(Stage.EXPORT, name))
