"""The audit asks the Maker's staged try too (solver/pipelines/audit.py audit_object): an object that plain moves
get past, where both searches of the audit's budget failed, is superfluous.

The puzzle is Continuous Space 4410009 made with the staged try taken out of the Maker's judge, so that it keeps
obj_03, which the searches missed (moving obj_02 and obj_01 aside solves it with obj_03 fixed; see
tests/test_staged_judge.py). The audit's budget here is small, so that its searches fail and only the staged try
can find the path: the control takes the staged try out of the audit too, and the object passes; a blocker that
geometry proves necessary passes with it. Work is bounded by budgets in queries, never seconds.
"""

from __future__ import annotations

import pytest

from manipulation.replay import PyBulletReferee
from phyrogen_core.export import read_puzzle_dir, write_puzzle
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.registry import get_generator
from solver.pipelines import audit as audit_module
from solver.pipelines.audit import audit_object, interlock_margin
from solver.pipelines.generation import generate_here
from solver.validation import judge as judge_module
from solver.validation.judge import Attempt
from solver.validation.staged import STAGED

BUDGET = 30
"""The audit's first-judge queries here (its second judge gets as many checks): too few for either search."""


def _never_solves(chain, goal, fixed, shrink) -> Attempt:
    return Attempt(tuple(fixed), shrink, False, judge=STAGED)


@pytest.fixture(scope="module")
def missed(tmp_path_factory):
    """(chain, goal, name, margin, urdf, objects proven necessary by geometry) of 4410009 as the searches alone
    left it."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(judge_module, "attempt_staged", _never_solves)
        puzzle = generate_here("continuous_space", 4410009, get_generator("continuous_space").parse_params({}))
    folder = write_puzzle(puzzle, tmp_path_factory.mktemp("missed"))
    loaded = read_puzzle_dir(folder)
    proven = sorted(name for name, how in puzzle.necessity.items() if how == "geometry")
    return (loaded.chain, loaded.goal, loaded.name, interlock_margin(loaded.record.parameters, folder),
            PuzzleFolder(folder, loaded.name).urdf, proven)


def test_the_staged_try_finds_the_missed_object(missed):
    chain, goal, name, margin, urdf, _ = missed
    assert margin == pytest.approx(0.01)
    found = audit_object(chain, goal, "obj_03", name, margin, BUDGET, urdf, PyBulletReferee())
    assert found.superfluous and found.solved_by == (STAGED,)
    assert found.robust_ok  # the referee's replay holds at the shrunk geometry it was planned for


def test_control_without_it_the_object_passes(missed, monkeypatch):
    chain, goal, name, margin, urdf, _ = missed
    monkeypatch.setattr(audit_module, "attempt_staged", _never_solves)
    assert not audit_object(chain, goal, "obj_03", name, margin, BUDGET, urdf, PyBulletReferee()).superfluous


def test_a_proven_blocker_passes_with_it(missed):
    chain, goal, name, margin, urdf, proven = missed
    assert proven
    for obj in proven:
        assert not audit_object(chain, goal, obj, name, margin, BUDGET, urdf, PyBulletReferee()).superfluous
