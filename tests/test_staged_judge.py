"""The staged judge (solver/validation/staged.py): blockers moved one at a time until they collide, then the
target straight to its goal, asked only where every search at a rung failed.

The questions are the Maker's own, captured while Continuous Space puzzles are made with the staged judge
taken out of :func:`~solver.validation.judge.judge` (that capture is the negative control that the miss comes
back without it): 4410009, where LA-RRT missed obj_02 to -0.0205, obj_01 to 0.7995, the target to its goal with
obj_03 fixed at a shrink of 0.01, and fresh seeds on which no test was tuned. Every path the staged judge
returns is checked here again, state by state, at the fine resolution (not with the skipping check it used).
Work is bounded by the judges' budgets and the staged judge's node cap, never seconds.
"""

from __future__ import annotations

import numpy as np
import pytest

from phyrogen_core.maker import BY_GEOMETRY, BY_SEARCH
from phyrogen_core.objects import build_chain
from phyrogen_core.registry import get_generator
from solver.pipelines.generation import generate_here
from solver.planning.problem import FINE_RESOLUTION, densify, in_goal, problem_for_chain
from solver.validation import judge as judge_module
from solver.validation import validator as validator_module
from solver.validation.judge import Attempt, attempt_staged
from solver.validation.staged import STAGED, STAGED_MOVES

FRESH = (5530043, 5531010, 5531013, 5531034)
"""Fresh Continuous Space seeds (used by no other test) on which the searches alone record a verdict or a margin
the staged judge refutes: found by running it on 5530001-5530060 and 5531001-5531150, not tuned on."""


def _questions(seed: int, monkeypatch: pytest.MonkeyPatch, *, staged: bool) -> list[tuple]:
    """Every necessity question of the Maker on Continuous Space ``seed``: (objects, goal, fixed, margin,
    verdict), with the staged judge in the judge or taken out (``staged`` False: it never solves)."""
    asked: list[tuple] = []
    original = validator_module.OmplValidator.necessity

    def logged(self, objects, goal, fixed, margin, **kw):
        result = original(self, objects, goal, fixed, margin, **kw)
        asked.append((tuple(objects), goal, tuple(fixed), margin, self.verdicts[-1]))
        return result

    with monkeypatch.context() as patch:
        patch.setattr(validator_module.OmplValidator, "necessity", logged)
        if not staged:
            patch.setattr(judge_module, "attempt_staged",
                          lambda chain, goal, fixed, shrink: Attempt(tuple(fixed), shrink, False, judge=STAGED))
        spec = get_generator("continuous_space")
        generate_here("continuous_space", seed, spec.parse_params({}))
    return asked


def _valid_fine(objects, goal, fixed, shrink, path) -> bool:
    """``path`` (chain order) starts at the start, keeps ``fixed`` still, ends in the goal and every state of it,
    densified at :data:`FINE_RESOLUTION`, is collision-free with shapes shrunk by ``shrink``: plain state checks."""
    chain = build_chain(objects)
    problem = problem_for_chain(chain, goal, fixed=fixed, shrink=shrink)
    columns = [chain.joint_order.index(name) for name in problem.model.joint_order]
    locked = [k for k, name in enumerate(chain.joint_order) if name not in problem.model.joint_order]
    states = np.asarray(path, dtype=np.float64)
    if locked and np.any(states[:, locked] != states[0, locked]):
        return False
    states = states[:, columns]
    dense = densify(states, problem.model.motion_steps(FINE_RESOLUTION))
    return (np.array_equal(states[0], problem.start) and in_goal(problem, states[-1])
            and bool(np.all((dense >= problem.lower) & (dense <= problem.upper)))
            and bool(problem.model.check(dense).all()))


def _misses(asked) -> list[tuple]:
    """The necessary-by-search questions: (objects, goal, fixed, measured margin)."""
    return [(o, g, f, v.margin) for o, g, f, _m, v in asked if v.necessary and v.how == BY_SEARCH]


def test_4410009_miss_found_and_back_without_it(monkeypatch):
    without = _questions(4410009, monkeypatch, staged=False)
    missed = [q for q in _misses(without) if q[2] == ("obj_03",)]
    assert missed and missed[0][3] == pytest.approx(0.01)  # control: the searches alone record the miss
    objects, goal, fixed, shrink = missed[0]
    attempt = attempt_staged(build_chain(objects), goal, fixed, shrink)
    assert attempt.solved and attempt.judge == STAGED
    assert 2 <= len(attempt.path) - 1 <= STAGED_MOVES + 1
    assert _valid_fine(objects, goal, fixed, shrink, attempt.path)
    with_staged = _questions(4410009, monkeypatch, staged=True)
    # The same question (obj_03 fixed on the same draft) is now solved at the required margin by the staged judge.
    same = [v for o, _g, f, _m, v in with_staged if f == ("obj_03",) and o == objects]
    assert same and not same[0].necessary and same[0].witness.judge == STAGED
    assert same[0].reason == "solved by staged"


@pytest.mark.slow
def test_fresh_misses_found_every_path_valid(monkeypatch):
    found = tried = 0
    for seed in FRESH:
        for objects, goal, fixed, shrink in _misses(_questions(seed, monkeypatch, staged=False)):
            attempt = attempt_staged(build_chain(objects), goal, fixed, shrink)
            tried += 1
            if attempt.solved:
                found += 1
                assert _valid_fine(objects, goal, fixed, shrink, attempt.path)
                assert len(attempt.path) - 1 <= STAGED_MOVES + 1
    assert found >= len(FRESH)  # each of these seeds had a verdict or a margin the searches got wrong
    assert tried >= found


def test_geometry_proven_blockers_not_solved(monkeypatch):
    # The negative control: where a proof says the blocker blocks, the staged judge finds nothing (its paths are
    # checked before it returns them, so it cannot "solve" what no path solves).
    proven = []
    for seed in (4410009, *FRESH[:2]):
        proven += [(o, g, f, v.margin) for o, g, f, _m, v in _questions(seed, monkeypatch, staged=True)
                   if v.necessary and v.how == BY_GEOMETRY and g.target not in f]  # (a fixed target: no try)
    assert len(proven) >= 3
    for objects, goal, fixed, shrink in proven:
        attempt = attempt_staged(build_chain(objects), goal, fixed, shrink)
        assert not attempt.solved and attempt.path == ()
        assert attempt.queries > 0  # it did try


def test_necessity_kind_stays_the_searches(monkeypatch):
    # A necessary verdict after a failed staged try keeps its reason from the second judge's run, not the staged.
    kinds = 0
    for _o, _g, _f, _m, verdict in _questions(5531116, monkeypatch, staged=True):  # staged: 0.04 solved, 0.02 not
        if verdict.necessary and verdict.how != BY_GEOMETRY:
            kinds += 1
            assert verdict.attempts[-1].judge == STAGED and not verdict.attempts[-1].solved
            assert verdict._deciding.judge != STAGED
    assert kinds >= 1
