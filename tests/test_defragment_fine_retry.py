"""defragment_certificate defragments again with motions checked at 2 mm when its 2 cm result fails the
2 mm certificate check (solver/planning/defragment.py), and only then: a certificate whose 2 cm result
holds is defragmented once, so its bytes are those of the 2 cm pass. Seed 6120348's raw certificate
(Move N Times n = 3, fixed in tests/test_routed_legs.py) is such a clipping case."""

from __future__ import annotations

import numpy as np
import pytest
from test_routed_legs import _SEED_6120348_RAW, _seed_6120348

import solver.planning.defragment as defragment_module
from phyrogen_core.actions import count_actions
from solver.planning.problem import (
    DEFAULT_RESOLUTION,
    FINE_RESOLUTION,
    chain_path,
    problem_for_chain,
    verify_certificate,
)


@pytest.fixture(scope="module")
def puzzle():
    return _seed_6120348()


def _one_pass(puzzle, certificate, resolution):
    """The defragmenter alone, motions checked at ``resolution``, in the chain's joint order."""
    problem = problem_for_chain(puzzle.chain, puzzle.goal)
    columns = [puzzle.chain.joint_order.index(name) for name in problem.model.joint_order]
    path = np.asarray(certificate, dtype=float)[:, columns]
    defragmenter = defragment_module.Defragmenter(problem, defragment_module.problem_factors(problem),
                                                  problem.model.motion_steps(resolution))
    return chain_path(problem, defragmenter.run(path))


def _counting_passes(monkeypatch) -> list[float]:
    """The motion step (metres) of every Defragmenter defragment_certificate builds."""
    resolutions: list[float] = []

    class Counting(defragment_module.Defragmenter):
        def __init__(self, problem, factors, steps, *args, **kwargs):
            for resolution in (DEFAULT_RESOLUTION, FINE_RESOLUTION):
                if np.array_equal(steps, problem.model.motion_steps(resolution)):
                    resolutions.append(resolution)
            super().__init__(problem, factors, steps, *args, **kwargs)

    monkeypatch.setattr(defragment_module, "Defragmenter", Counting)
    return resolutions


def test_a_clipping_2_cm_result_is_defragmented_again_at_2_mm(puzzle, monkeypatch):
    # The control: the 2 cm pass alone gives a path the 2 mm check refuses (the raw path was kept).
    coarse = _one_pass(puzzle, _SEED_6120348_RAW, DEFAULT_RESOLUTION)
    assert verify_certificate(puzzle.chain, coarse, puzzle.goal) != []
    passes = _counting_passes(monkeypatch)
    clean = defragment_module.defragment_certificate(puzzle.chain, puzzle.goal, _SEED_6120348_RAW)
    assert passes == [DEFAULT_RESOLUTION, FINE_RESOLUTION]
    assert verify_certificate(puzzle.chain, clean, puzzle.goal) == []
    assert count_actions(clean, puzzle.chain.factors) == 6 < count_actions(_SEED_6120348_RAW, puzzle.chain.factors)


def test_a_holding_2_cm_result_is_kept_without_a_second_pass(puzzle, monkeypatch):
    # The 6 actions the 2 mm pass found: the 2 cm pass keeps a path the 2 mm check accepts.
    six = defragment_module.defragment_certificate(puzzle.chain, puzzle.goal, _SEED_6120348_RAW)
    coarse = _one_pass(puzzle, six, DEFAULT_RESOLUTION)
    assert verify_certificate(puzzle.chain, coarse, puzzle.goal) == []
    passes = _counting_passes(monkeypatch)
    clean = defragment_module.defragment_certificate(puzzle.chain, puzzle.goal, six)
    assert passes == [DEFAULT_RESOLUTION]
    assert np.array_equal(np.asarray(clean), coarse)


def test_a_fine_call_makes_one_pass(puzzle, monkeypatch):
    passes = _counting_passes(monkeypatch)
    defragment_module.defragment_certificate(puzzle.chain, puzzle.goal, _SEED_6120348_RAW, FINE_RESOLUTION)
    assert passes == [FINE_RESOLUTION]
