"""The Maker checks a search's "necessary" verdict against the solution it then finds: a solution that,
cleaned, keeps the new object at its creation pose solves the puzzle with that object fixed, so the
object is superfluous and the candidate is drawn again (a budgeted judge can miss such a path: seen on
Continuous Space seed 111428518, n_objects 5, branching 0, where the audit then found obj_04
superfluous). Seeds are drawn fresh each run; a geometric proof is never second-guessed."""

from __future__ import annotations

import random

import numpy as np
import pytest

from phyrogen_core.maker import BY_GEOMETRY, BY_SEARCH, Necessary, SolveResult, make
from phyrogen_core.objects import build_chain
from phyrogen_core.registry import get_generator

GENERATOR, SIZE = "simple_slider", {"n_objects": 3}


class Scripted:
    """Every candidate necessary by ``how`` and solvable; ``clean`` returns the solution with the newest
    object's joints at 0 (held still) on the candidates whose number is in ``still``."""

    def __init__(self, how: str, still: set[int], with_clean: bool = True):
        self.how, self.still, self.asked, self.cleaned = how, still, 0, 0
        if not with_clean:
            self.clean = None

    def necessity(self, objects, goal, fixed, margin, *, budget_scale=1.0):
        self.asked += 1
        return Necessary(margin, self.how)

    def solve(self, objects, goal, *, budget_scale=1.0):
        order = build_chain(tuple(objects)).joint_order
        return SolveResult(True, (tuple(0.0 for _ in order), tuple(0.1 for _ in order)))

    def clean(self, objects, goal, path):
        self.cleaned += 1
        path = np.array(path, dtype=float)
        if self.asked in self.still:
            newest = objects[-1].joint_names
            path[:, [i for i, j in enumerate(build_chain(tuple(objects)).joint_order) if j in newest]] = 0.0
        return tuple(map(tuple, path))


def _make(validator, seed):
    spec = get_generator(GENERATOR)
    params = spec.parse_params(SIZE)
    return make(spec.build(seed, params), seed, validator, GENERATOR)


@pytest.fixture
def seed():
    return random.SystemRandom().randrange(1, 50)  # Simple Slider's seeds that its size allows


def test_a_search_verdict_refuted_by_the_solution_draws_the_candidate_again(seed):
    refuted = Scripted(BY_SEARCH, still={2})
    result = _make(refuted, seed)
    plain = Scripted(BY_SEARCH, still=set())
    _make(plain, seed)
    # The second candidate was held still by its cleaned solution: one more question than the control.
    assert refuted.asked == plain.asked + 1, f"seed {seed}"
    assert len(result.objects) == len(_make(Scripted(BY_SEARCH, still=set()), seed).objects)


def test_a_geometric_proof_or_a_validator_without_clean_is_not_second_guessed(seed):
    proven = Scripted(BY_GEOMETRY, still={2})
    _make(proven, seed)
    assert proven.cleaned == 0, f"seed {seed}"
    no_clean = Scripted(BY_SEARCH, still={2}, with_clean=False)
    plain = Scripted(BY_SEARCH, still=set())
    _make(no_clean, seed)
    _make(plain, seed)
    assert no_clean.asked == plain.asked, f"seed {seed}"


@pytest.mark.slow
def test_the_continuous_space_puzzle_whose_judge_missed_has_every_blocker_moving():
    from phyrogen_core.export.metadata import puzzle_metadata
    from solver.pipelines.generation import generate_here

    spec = get_generator("continuous_space")
    puzzle = generate_here("continuous_space", 111428518, spec.parse_params({"n_objects": 5, "branching": 0}))
    certificate = np.array(puzzle.certificate)
    moved = {name for name, columns in puzzle.chain.factors.items() if np.any(certificate[:, list(columns)])}
    assert moved == set(puzzle.chain.factors), moved
    assert puzzle_metadata(puzzle)["dependency_graph"]["depth"] == 4
