"""The worked example of docs/adding-a-generator.md, docs/examples/two_sliders.py, as a generator.

It is loaded into a copy of the registry (so ``phyrogen list`` still shows
the six built-in generators) and must pass what every registered generator
passes, then generate a certified puzzle with the real validator in which
fixing any blocker leaves the target stuck.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
import test_registry

from phyrogen_core.registry import all_generators, get_generator, paper_generators, registry_copy
from solver.parallel.pool import fresh_process_pool

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "examples" / "two_sliders.py"
NAME = "two_sliders"


def load_example() -> None:
    """Run the example module, which registers its generator in the registry in use."""
    spec = importlib.util.spec_from_file_location("two_sliders_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses and type hints look their module up by name
    spec.loader.exec_module(module)


@pytest.fixture()
def with_example():
    with registry_copy():
        load_example()
        yield get_generator(NAME)


def test_the_example_is_listed_after_the_papers_six_only_in_the_copy(with_example):
    assert list(all_generators())[-1] == NAME and not with_example.paper
    assert NAME not in paper_generators()
    assert with_example.difficulty_parameters() == ("gap",)


def test_the_real_registry_does_not_have_the_example():
    assert NAME not in all_generators()


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_the_example_passes_what_every_generator_passes(with_example, seed):
    test_registry.test_docstring_has_the_fixed_sections(NAME)
    test_registry.test_every_parameter_is_documented_and_every_knob_named_in_the_docstring(NAME)
    test_registry.test_every_benchmark_profile_has_a_time_limit(NAME)
    test_registry.test_names_roles_colours_handles_floor_free_start_and_goal(NAME, seed)


def _generate_and_fix_each_blocker(seed: int) -> tuple[list[str], list[tuple[str, str]], dict[str, bool]]:
    """In a fresh process (OMPL's RNG is seeded once per process): generate the example's
    puzzle with the real validator, check its certificate, and try to solve it again with
    each blocker fixed, at 10x the budget the generation's own necessity check had."""
    import numpy as np

    from solver.pipelines.generation import generate_here
    from solver.planning.problem import verify_certificate
    from solver.validation.judge import JUDGE_BUDGET, attempt_fixed

    with registry_copy():
        load_example()
        puzzle = generate_here(NAME, seed)
        maker_input = get_generator(NAME).build(seed, puzzle.parameters)
    problems = verify_certificate(puzzle.planning_chain, puzzle.certificate, puzzle.goal)
    budget = int(10 * JUDGE_BUDGET * maker_input.fixed_budget_scale)
    solved_with_fixed = {}
    for blocker in puzzle.objects[1:]:
        attempt = attempt_fixed(puzzle.planning_chain, puzzle.goal, [blocker.name], maker_input.interlock_margin,
                                budget, np.random.default_rng(seed))
        solved_with_fixed[blocker.name] = attempt.solved
    return problems, list(puzzle.dependencies), solved_with_fixed


@pytest.mark.parametrize("seed", [1, 2])
def test_the_example_generates_a_certified_puzzle_that_needs_its_blocker(seed):
    # A fresh process: generating is deterministic only in a process that has not planned before.
    with fresh_process_pool(1, 1, []) as pool:
        ((problems, dependencies, solved_with_fixed),) = pool.imap(_generate_and_fix_each_blocker, [seed])
    assert problems == []
    assert dependencies == [("obj_01", "obj_00")]
    assert solved_with_fixed == {"obj_01": False}
