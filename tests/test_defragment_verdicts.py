"""The defragmenter keeps each motion's verdict and checks new motions with the skipping kernel
(solver/planning/defragment.py, Defragmenter._motions_free): its paths must be those of a defragmenter
that checks every motion of every candidate with CollisionModel.check_motion. Fresh seeds 9960201-9960206."""

from __future__ import annotations

import numpy as np
import pytest

from solver.pipelines.generation import generate_here
from solver.planning.defragment import Defragmenter
from solver.planning.problem import DEFAULT_RESOLUTION, problem_factors, problem_for_chain


def _plain(self: Defragmenter, states: np.ndarray) -> bool:
    """The reference: every motion checked on its own, in order, nothing kept."""
    check = self.model.check_motion
    return all(check(a, b, self.steps) for a, b in zip(states[:-1], states[1:], strict=True))


def _defragmented(puzzle, motions_free=None) -> np.ndarray:
    problem = problem_for_chain(puzzle.planning_chain, puzzle.goal)
    order = problem.model.joint_order
    columns = [puzzle.joint_order.index(name) for name in order]
    # The certificate with a detour per action: a staircase of many moves for the operators to clean up.
    path = np.asarray(puzzle.certificate, dtype=float)[:, columns]
    path = np.concatenate([path[:1], np.repeat(path[1:], 2, axis=0)])
    defragmenter = Defragmenter(problem, problem_factors(problem), problem.model.motion_steps(DEFAULT_RESOLUTION))
    if motions_free is not None:
        defragmenter._motions_free = motions_free.__get__(defragmenter)
    return defragmenter.run(path)


@pytest.mark.parametrize("generator, seed", [("rooms", 9960201), ("rooms", 9960202), ("lockbox_random", 9960203),
                                             ("lockbox_random", 9960204), ("continuous_space", 9960205),
                                             ("grid_world", 9960206)])
def test_kept_verdicts_give_the_paths_of_plain_checks(generator, seed):
    puzzle = generate_here(generator, seed, None)
    kept = _defragmented(puzzle)
    assert np.array_equal(kept, _defragmented(puzzle, _plain))
    # Negative control: a check that lets every motion through gives another path (the comparison can fail).
    assert not np.array_equal(kept, _defragmented(puzzle, lambda self, states: True))
