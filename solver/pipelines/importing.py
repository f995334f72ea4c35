"""Certifying an imported puzzle (:mod:`phyrogen_core.urdf_import`): our strongest planner finds the
solution certificate every puzzle folder carries.

LA-RRT with blocker pushes (the Maker's judge and the benchmark's
``la_rrt_push``) runs until its first solution or until a budget of
collision queries is spent, with a numpy RNG seeded from the puzzle's name:
the same URDF gives the same certificate on every machine, and an unsolved
puzzle is reported after a bounded search, never after a wall-clock guess.
The path is checked at fine resolution, defragmented as generated
certificates are, and the dependency graph is read off it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from phyrogen_core.actions import count_actions
from phyrogen_core.provenance import PlannerRun
from phyrogen_core.puzzle import Puzzle
from phyrogen_core.seeding import stable_seed
from solver.planning.defragment import defragment_certificate
from solver.planning.la_rrt import la_rrt_within
from solver.planning.problem import chain_path, dependency_graph, problem_for_chain, verify_certificate

IMPORT_BUDGET = 100_000
"""Collision queries LA-RRT may spend on an imported puzzle by default: the audit's budget, 25 times
the Maker's judge budget. The prototype's puzzles need 40 to 6 200 (docs/import.md)."""
MAX_IMPORT_BUDGET = 100_000_000


class StartCollisionError(ValueError):
    """The imported puzzle's objects overlap in their rest pose: no path can start there."""


@dataclass(frozen=True)
class Certification:
    """The certified puzzle (None when unsolved within the budget) and what it took."""

    puzzle: Puzzle | None
    queries: int
    budget: int
    seed: int

    @property
    def solved(self) -> bool:
        return self.puzzle is not None

    @property
    def actions(self) -> int:
        if self.puzzle is None:
            return 0
        return count_actions(self.puzzle.certificate, self.puzzle.planning_chain.factors)


def certify_imported(puzzle: Puzzle, budget: int = IMPORT_BUDGET, seed: int = 0) -> Certification:
    """``puzzle`` with a certificate and dependency graph, found by LA-RRT within ``budget`` collision
    queries (its RNG seeded from the puzzle's name and ``seed``).

    Raises :class:`StartCollisionError` naming the overlapping objects when
    the start state collides.
    """
    if not 1 <= budget <= MAX_IMPORT_BUDGET:
        raise ValueError(f"budget must be 1 to {MAX_IMPORT_BUDGET} collision queries, got {budget!r}")
    chain = puzzle.planning_chain
    problem = problem_for_chain(chain, puzzle.goal)
    if not problem.model.is_valid(problem.start):
        pairs = sorted(problem.model.colliding_objects(problem.start))
        shown = ", ".join(f"{a} and {b}" for a, b in pairs[:3])
        shown += f" and {len(pairs) - 3} more pairs" if len(pairs) > 3 else ""
        raise StartCollisionError(f"{puzzle.name}: objects overlap at the start: {shown}; no path can start there")
    run_seed = stable_seed("import", puzzle.name, seed)
    result, queries = la_rrt_within(problem, budget, np.random.default_rng(run_seed))
    if not result.solved:
        return Certification(None, queries, budget, run_seed)
    path = chain_path(problem, result.path)
    if verify_certificate(chain, path, puzzle.goal):  # LA-RRT keeps only paths valid at fine resolution
        return Certification(None, queries, budget, run_seed)
    certificate = defragment_certificate(chain, puzzle.goal, path)
    dependencies = dependency_graph(puzzle.objects, certificate)
    provenance = replace(puzzle.provenance, certified=PlannerRun("la_rrt_push", budget, run_seed, queries))
    certified = replace(puzzle, certificate=certificate, dependencies=dependencies, provenance=provenance)
    return Certification(certified, queries, budget, run_seed)


def versions() -> dict[str, str]:
    """The package versions an imported puzzle's ``puzzle.json`` records."""
    from phyrogen_core import __version__

    return {"phyrogen": __version__, "numpy": np.__version__}
