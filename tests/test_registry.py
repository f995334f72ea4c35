"""The generator registry, and what every registered generator guarantees.

The tests in the second half are parametrized over the registry itself, so a
new generator is covered as soon as it is registered. They run the Maker with
a validator that accepts every candidate (no planner): they check what the
generators build; the family suites check their mechanisms.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from maker_support import run

from phyrogen_core.chain import GREEN, RED, Role
from phyrogen_core.geometry import Box, ConvexPrism, Cylinder
from phyrogen_core.maker import MakerInput
from phyrogen_core.objects import build_chain
from phyrogen_core.registry import (
    BENCHMARK_PROFILES,
    GeneratorSpec,
    ParameterError,
    Registry,
    all_generators,
    benchmark_time_limits,
    describe_generators,
    get_generator,
    paper_generators,
    parameter,
    register,
    registry_copy,
)
from solver.collision.model import CollisionModel

GENERATORS = list(all_generators())
SECTIONS = ("Mechanism:", "Randomization:", "Goal:", "Difficulty parameters:", "Departures:")
SEEDS = (1, 2, 3, 4)


# -- the paper's six ----------------------------------------------------------------
def test_paper_generators_in_table_one_order():
    assert paper_generators() == ("simple_slider", "continuous_space", "grid_world", "lockbox_random",
                                  "move_n_times", "rooms")
    assert [get_generator(name).paper_row for name in paper_generators()] == [1, 2, 3, 4, 5, 6]
    # They are listed first, in that order.
    assert GENERATORS[:6] == list(paper_generators())


def test_paper_time_limits_are_the_papers():
    # Paper, Sec. V: Simple Sliders 40 s, Grid World 40 s, Continuous Space 20 s,
    # Lockbox Random 600 s, Move N Times 20 s, Rooms 60 s.
    paper = {"simple_slider": 40.0, "grid_world": 40.0, "continuous_space": 20.0, "lockbox_random": 600.0,
             "move_n_times": 20.0, "rooms": 60.0}
    limits = benchmark_time_limits("paper")
    assert {name: limits[name] for name in paper_generators()} == paper


def test_benchmark_profiles_read_their_limits_from_the_registry():
    from solver.benchmark.profiles import get_profile

    for profile in BENCHMARK_PROFILES:
        assert dict(get_profile(profile).time_limits) == benchmark_time_limits(profile)
    assert get_generator("move_n_times").time_limit("quick") == 20.0


# -- registering --------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class _Documented:
    count: int = parameter(2, "how many", difficulty=True)
    size: float = parameter(1.0, "how big")


@dataclasses.dataclass(frozen=True)
class _Undocumented:
    count: int = parameter(2, "how many")
    size: float = 1.0


def _build(seed, params) -> MakerInput:
    raise NotImplementedError


LIMITS = {"paper": 10.0, "quick": 1.0}


def test_parameter_docs_and_difficulty_knobs():
    spec = GeneratorSpec("toy", "Toy", _build, _Documented, "Toy: nothing.", None, LIMITS)
    assert spec.parameter_docs() == {"count": "how many", "size": "how big"}
    assert spec.difficulty_parameters() == ("count",)
    assert not spec.paper
    text = spec.describe()
    assert "toy: Toy (not in the paper)" in text and "* count=2" in text and "how big" in text


def test_a_parameter_without_doc_is_refused():
    with pytest.raises(ValueError, match="size"):
        GeneratorSpec("toy", "Toy", _build, _Undocumented, "", None, LIMITS)


@pytest.mark.parametrize("limits", [{}, {"paper": 10.0}, {"paper": 10.0, "quick": 0.0},
                                    {"paper": 1.0, "quick": 1.0, "huge": 9.0}])
def test_time_limits_must_cover_every_profile(limits):
    with pytest.raises(ValueError, match="time_limits"):
        GeneratorSpec("toy", "Toy", _build, _Documented, "", None, limits)


def test_names_and_paper_rows_are_unique():
    registry = Registry()
    registry.add(GeneratorSpec("toy", "Toy", _build, _Documented, "", 1, LIMITS))
    with pytest.raises(ValueError, match="twice"):
        registry.add(GeneratorSpec("toy", "Toy", _build, _Documented, "", None, LIMITS))
    with pytest.raises(ValueError, match="row 1"):
        registry.add(GeneratorSpec("other", "Other", _build, _Documented, "", 1, LIMITS))
    with pytest.raises(ParameterError, match="unknown generator 'nope'"):
        registry.get("nope")


@dataclasses.dataclass(frozen=True)
class _Checked:
    count: int = parameter(2, "how many")
    size: float = parameter(1.0, "how big")
    round: bool = parameter(False, "whether round")

    def validate(self, seed: int) -> None:
        if self.count > 3:
            raise ParameterError(f"count must lie in 1..3, got {self.count}")


@pytest.mark.parametrize(("raw", "shown"), [("nan", "'nan'"), ("-inf", "'-inf'"), ("1e999", "'1e999'"),
                                            (10**400, "100000"), (float("inf"), "inf")])
def test_a_float_parameter_must_be_finite_for_any_generator(raw, shown):
    # The rule lives in the registry, not in each generator's validate: a new generator gets it for free.
    spec = GeneratorSpec("toy", "Toy", _build, _Checked, "", None, LIMITS)
    with pytest.raises(ParameterError) as caught:
        spec.parse_params({"size": raw})
    message = str(caught.value)
    assert message.startswith("generator 'toy': parameter 'size' must be") and shown in message
    assert "\n" not in message and len(message) < 200  # a 400-digit value is shortened


@pytest.mark.parametrize("raw", [2**63, -(2**63), "9" * 30, 1e300])
def test_an_int_parameter_must_fit_64_bits(raw):
    spec = GeneratorSpec("toy", "Toy", _build, _Checked, "", None, LIMITS)
    with pytest.raises(ParameterError, match="generator 'toy': parameter 'count'"):
        spec.parse_params({"count": raw})
    assert spec.parse_params({"count": 2**63 - 1}).count == 2**63 - 1


@pytest.mark.parametrize(("field", "value", "fragment"), [
    ("size", float("nan"), "must be a finite number"), ("size", float("-inf"), "must be a finite number"),
    ("size", "1.0", "must be float"), ("size", True, "must be float"), ("count", 2.0, "must be int"),
    ("count", 2**64, "must be an integer within"),
    ("count", False, "must be int"), ("round", 1, "must be bool"),
])
def test_check_applies_the_same_rule_to_a_parameter_dataclass(field, value, fragment):
    spec = GeneratorSpec("toy", "Toy", _build, _Checked, "", None, LIMITS)
    spec.check(1, _Checked(count=3, size=2, round=True))  # an int is a fine float
    with pytest.raises(ParameterError, match=f"generator 'toy': parameter '{field}' {fragment}"):
        spec.check(1, dataclasses.replace(_Checked(), **{field: value}))


def test_check_names_the_generator_when_validate_refuses():
    spec = GeneratorSpec("toy", "Toy", _build, _Checked, "", None, LIMITS)
    with pytest.raises(ParameterError, match=r"^generator 'toy': count must lie in 1\.\.3, got 4$"):
        spec.check(1, _Checked(count=4))
    with pytest.raises(ParameterError, match="parameters must be a _Checked, got _Documented"):
        spec.check(1, _Documented())


def test_registering_into_a_copy_leaves_the_registry_as_it_was():
    before = all_generators()
    with registry_copy() as copy:
        register("toy", "Toy", _Documented, time_limits=LIMITS)(_build)
        assert "toy" in copy.all() and get_generator("toy").title == "Toy"
        assert "toy" not in paper_generators()
        assert list(all_generators())[-1] == "toy"  # after the paper's six
    assert all_generators() == before


def test_describe_lists_every_generator_and_parameter():
    text = describe_generators()
    for name, spec in all_generators().items():
        assert f"{name}: {spec.title}" in text
        for parameter_name in spec.parameter_docs():
            assert f"{parameter_name}=" in text
    assert "taken from the seed" in text  # n_objects = 0 / n = 0 say what they mean


# -- every registered generator ---------------------------------------------------------
@pytest.mark.parametrize("name", GENERATORS)
def test_docstring_has_the_fixed_sections(name):
    spec = get_generator(name)
    for section in SECTIONS:
        assert section in spec.doc, f"{name}: docstring lacks {section!r}"
    spec.check(1, spec.default_params())


@pytest.mark.parametrize("name", GENERATORS)
def test_every_parameter_is_documented_and_every_knob_named_in_the_docstring(name):
    spec = get_generator(name)
    fields = [f.name for f in dataclasses.fields(spec.params)]
    docs = spec.parameter_docs()
    assert list(docs) == fields
    assert all(docs[f].strip() for f in fields), f"{name}: undocumented parameters"
    assert spec.difficulty_parameters(), f"{name}: no difficulty knob"
    section = re.search(r"Difficulty parameters:(.*?)\n\s*\n", spec.doc, re.S)
    assert section is not None
    for knob in spec.difficulty_parameters():
        assert f"``{knob}``" in section.group(1), f"{name}: knob {knob!r} not in 'Difficulty parameters'"


@pytest.mark.parametrize("name", GENERATORS)
def test_every_benchmark_profile_has_a_time_limit(name):
    spec = get_generator(name)
    assert all(spec.time_limit(profile) > 0 for profile in BENCHMARK_PROFILES)


def _height(shape) -> float:
    if isinstance(shape, Box):
        return shape.size[2]
    return shape.length if isinstance(shape, Cylinder) else shape.height


@pytest.mark.parametrize("name", GENERATORS)
@pytest.mark.parametrize("seed", SEEDS)
def test_names_roles_colours_handles_floor_free_start_and_goal(name, seed):
    result = run(name, seed)
    movable = [o for o in result.objects if o.is_movable]
    fixed = [o for o in result.objects if not o.is_movable]
    assert [o.name for o in movable] == [f"obj_{i:02d}" for i in range(len(movable))]
    assert [o.name[:9] for o in fixed] == [f"fixed_{i:02d}_" for i in range(len(fixed))]
    assert result.goal.target == "obj_00"
    for index, obj in enumerate(movable):
        assert obj.role is (Role.TARGET if index == 0 else Role.BLOCKER)
        body = next(g for g in obj.collisions if g.name == "body")
        assert body.color == (GREEN if index == 0 else RED)
        # Handles are physical and carry one knob to grasp; hinges are visual only.
        for geometries in (obj.visuals, obj.collisions):
            assert [g.name for g in geometries].count("knob") == 1, f"{obj.name}: no single knob"
            assert any(g.name == "handle_shaft" for g in geometries)
        assert not any(g.name == "hinge" for g in obj.collisions), "hinges are visual only"
    assert all(o.role is Role.STATIC for o in fixed)
    for obj in result.objects:
        # Everything stands on the floor.
        lowest = min(obj.pose.xyz[2] + g.origin.xyz[2] - _height(g.shape) / 2
                     for g in obj.collisions if g.name == "body")
        assert lowest == pytest.approx(0.0, abs=1e-9), f"{obj.name} does not stand on the floor"
        for geometry in obj.collisions:
            assert isinstance(geometry.shape, Box | Cylinder | ConvexPrism)
            assert geometry.origin.is_planar
    chain = build_chain(result.objects)
    assert CollisionModel(chain).is_valid(np.zeros(len(chain.joint_order))), "objects overlap at the start"
    for joint, value in result.goal.values.items():
        assert chain.joint(joint).lower - 1e-12 <= value <= chain.joint(joint).upper + 1e-12


@pytest.mark.parametrize("name", GENERATORS)
def test_same_seed_same_puzzle_other_seed_other_puzzle(name):
    first, again, other = run(name, 3), run(name, 3), run(name, 4)
    assert first.objects == again.objects and first.goal == again.goal
    assert (first.objects, first.goal) != (other.objects, other.goal)


def test_the_built_ins_are_declared_as_entry_points_and_the_registry_imports_no_generator():
    """Built-in generators and planners are found the way outside plug-ins are: through the entry points
    pyproject.toml declares (and the installed metadata holds: run ``pip install -e . --no-deps`` after
    editing them); the registry module itself imports no generator, so the import circle is gone."""
    import ast
    import tomllib
    from importlib import metadata
    from pathlib import Path

    from solver.planning.registry import PLANNERS

    root = Path(__file__).resolve().parents[1]
    declared = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))["project"]["entry-points"]
    for group, registered in (("phyrogen.generators", paper_generators()), ("phyrogen.planners", tuple(PLANNERS))):
        assert set(declared[group]) == set(registered), group
        entries = metadata.entry_points(group=group)
        installed = {e.name: e.value for e in entries if e.dist.metadata["Name"] == "phyrogen"}
        assert installed == declared[group], f"{group}: the installed metadata is stale; pip install -e . --no-deps"
    tree = ast.parse((root / "phyrogen_core" / "registry.py").read_text(encoding="utf-8"))
    imported = {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    imported |= {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    assert not any("generators" in name for name in imported), imported
