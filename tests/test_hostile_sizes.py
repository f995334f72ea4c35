"""Hostile input, sizes: every size is feasible within a stated bound or refused up front.

A size a generator accepts must generate within the bound stated in
``docs/generators.md#feasible-sizes`` (2 minutes of CPU time per puzzle);
anything larger is refused before any work, with one line naming the
parameter. The registry cases find each integer parameter's largest accepted
value by asking ``check`` (no generation), so a new generator's size knobs are
covered as soon as it is registered. The command line's numeric options
(``--workers``, ``--time-limit``, ``--runs``, ``--seed``, ``--size``) are
refused while the command line is read.
"""

from __future__ import annotations

import dataclasses
import random
import typing

import pytest

from phyrogen.cli import MAX_BENCHMARK_SEED, MAX_RUNS, MAX_TIME_LIMIT, build_parser, main, max_workers
from phyrogen_core.registry import ParameterError, all_generators, get_generator, paper_generators
from solver.pipelines.generation import generate_puzzle

HUGE = 10**6
"""Far beyond any feasible size: every integer parameter must be refused here (the binary search's ceiling)."""


def _int_parameters() -> list[tuple[str, str]]:
    cases = []
    for name, spec in all_generators().items():
        hints = typing.get_type_hints(spec.params)
        cases += [(name, f.name) for f in dataclasses.fields(spec.params) if hints[f.name] is int]
    return cases


INT_PARAMETERS = _int_parameters()


def _accepted(generator: str, seed: int, **values: int) -> bool:
    spec = get_generator(generator)
    try:
        spec.check(seed, dataclasses.replace(spec.default_params(), **values))
    except ParameterError:
        return False
    return True


def _largest_accepted(accepts: typing.Callable[[int], bool], low: int) -> int:
    """The largest value in [low, HUGE) that ``accepts`` takes, given it takes ``low`` and refuses HUGE;
    accepted values must form one range from ``low`` on."""
    high = HUGE
    while high - low > 1:
        middle = (low + high) // 2
        low, high = (middle, high) if accepts(middle) else (low, middle)
    return low


@pytest.fixture
def no_generation(monkeypatch):
    """Up front means before any worker starts: starting one fails the test."""
    import solver.pipelines.generation

    def refuse(*args, **kwargs):
        raise AssertionError("generation started for a size that should have been refused")

    monkeypatch.setattr(solver.pipelines.generation, "run_jobs", refuse)


def _cli(argv: list[str], capsys) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _assert_refused(code: int, err: str, *fragments: str) -> None:
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("phyrogen: error: "), err
    for fragment in fragments:
        assert fragment in err, (fragment, err)


# -- generator parameters ---------------------------------------------------------------
@pytest.mark.parametrize(("generator", "parameter"), INT_PARAMETERS, ids=[f"{g}.{p}" for g, p in INT_PARAMETERS])
def test_every_integer_parameter_has_an_upper_bound_refused_up_front(generator, parameter, tmp_path, capsys,
                                                                     no_generation):
    default = getattr(get_generator(generator).default_params(), parameter)
    assert _accepted(generator, 1, **{parameter: default})
    # No integer knob may accept every size: a million of anything cannot generate in 2 minutes.
    assert not _accepted(generator, 1, **{parameter: HUGE})
    largest = _largest_accepted(lambda v: _accepted(generator, 1, **{parameter: v}), default)
    out = tmp_path / "out"
    code, stdout, err = _cli(["generate", "--generator", generator, "--seeds", "1", "--set",
                              f"{parameter}={largest + 1}", "--out", str(out), "--quiet"], capsys)
    _assert_refused(code, err, parameter, str(largest + 1), generator)
    assert not out.exists()


SEED_SIZED = [name for name in all_generators() if not _accepted(name, HUGE)]
"""Generators whose default size grows with the seed, found by asking: seed 10^6 is refused."""


def test_the_seed_sized_generators_are_found():
    assert {"move_n_times", "simple_slider"} <= set(SEED_SIZED)  # n = Seed, Seed + 1 sliders


@pytest.mark.parametrize("generator", SEED_SIZED)
def test_sizes_taken_from_the_seed_are_bounded_too(generator, tmp_path, capsys, no_generation):
    largest = _largest_accepted(lambda seed: _accepted(generator, seed), 4)  # the paper's seeds 1-4 stay
    out = tmp_path / "out"
    code, _, err = _cli(["generate", "--generator", generator, "--seeds", f"1-{largest + 1}", "--out", str(out),
                         "--quiet"], capsys)
    _assert_refused(code, err, generator, f"seed {largest + 1}")
    assert not out.exists()


def test_the_papers_puzzles_stay_accepted():
    for name in paper_generators():
        assert all(_accepted(name, seed) for seed in range(1, 5)), name
        # The control: the same check refuses each paper generator a size (its first integer knob, huge).
        knob = next(parameter for generator, parameter in INT_PARAMETERS if generator == name)
        assert not _accepted(name, 1, **{knob: HUGE}), name


def test_all_generators_past_a_seed_sized_maximum_is_refused_before_any_work(tmp_path, capsys, no_generation):
    # The reported case was seeds 1-8 (0 of 48 puzzles in 10 minutes; now about a minute): Move N
    # Times' n = Seed stops at 20, so seed 21 refuses the whole request, not just its own puzzle.
    out = tmp_path / "out"
    code, stdout, err = _cli(["generate", "--generator", "all", "--seeds", "1-21", "--out", str(out)], capsys)
    _assert_refused(code, err, "seed 21")
    assert not out.exists() and stdout == ""


@pytest.mark.parametrize(("generator", "overrides", "fragment"), [
    ("move_n_times", {"n": 21}, "n must lie in 1..20"),  # 101 walls: past two-digit names
    ("simple_slider", {"n_objects": 51}, "n_objects must lie in 1..50"),
    ("grid_world", {"n_objects": 50}, "n_objects must lie in 1..25"),
    ("lockbox_random", {"n_objects": 50}, "n_objects must lie in 1..19"),
    ("continuous_space", {"n_objects": 50}, "n_objects must lie in 1..20"),
    ("rooms", {"n_rooms": 12, "doors": 0}, "n_rooms must lie in 1..6"),
    ("grid_world", {"branching": 73}, "branching must lie in 0..72"),
    ("continuous_space", {"branching": 19}, "branching must lie in 0..18"),
    ("rooms", {"scaling": 8.0}, "scaling must lie in [1, 4]"),  # 6 rooms, 6 doors: over 2 min at 8
    ("continuous_space", {"bar_length": 10.0}, "bar_length must lie in [1, 5]"),  # 20 bars: 85 s at 10
    ("continuous_space", {"bar_width": 0.01}, "bar_width"),
    ("rooms", {"wall_thickness": 1e-9}, "wall_thickness"),
])
def test_the_stated_maxima_and_their_reasons(generator, overrides, fragment):
    spec = get_generator(generator)
    with pytest.raises(ParameterError) as caught:
        spec.check(1, spec.parse_params(overrides))
    message = str(caught.value)
    assert "\n" not in message and fragment in message and message.startswith(f"generator {generator!r}")


@pytest.mark.parametrize(("generator", "overrides", "past"), [
    # The measured maxima (docs/generators.md#feasible-sizes), at the costliest geometry accepted, and
    # the size knob one step past its maximum.
    ("simple_slider", {"n_objects": 50, "gap": 1e-6}, {"n_objects": 51}),
    ("move_n_times", {"n": 20}, {"n": 21}),
    ("grid_world", {"n_objects": 25, "branching": 72, "clearance": 0.075, "allow_clockwise": False},
     {"n_objects": 26}),
    ("lockbox_random", {"n_objects": 19, "max_radius": 10.0}, {"n_objects": 20}),
    ("continuous_space", {"n_objects": 20, "bar_length": 5.0}, {"n_objects": 21}),
    ("rooms", {"n_rooms": 6, "doors": 6, "scaling": 4.0}, {"n_rooms": 7}),
])
def test_the_measured_maxima_are_accepted_and_one_more_is_refused(generator, overrides, past):
    spec = get_generator(generator)
    assert _accepted(generator, 1, **dataclasses.asdict(spec.parse_params(overrides)))
    # The control: one more of the size knob, the rest of the costliest geometry unchanged, is refused.
    (knob, value), = past.items()
    with pytest.raises(ParameterError, match=f"{knob} must lie in"):
        spec.check(1, spec.parse_params({**overrides, **past}))
    assert value == overrides[knob] + 1


@pytest.mark.parametrize(("generator", "seed", "overrides"), [
    # Seeds none of the measurements in docs/generators.md used. Move N Times' n = 20 is in
    # tests/test_move_n_times_scaling.py (slow, fresh seeds).
    pytest.param("simple_slider", 320, {"n_objects": 50}, marks=pytest.mark.slow),  # about 27 s
    ("simple_slider", 6, {}),  # Seed + 1 = 7 sliders
    ("move_n_times", 306, {"n": 8}),  # about 1.5 s
])
def test_the_largest_accepted_sizes_generate(generator, seed, overrides):
    from solver.planning.problem import verify_certificate

    spec = get_generator(generator)
    params = spec.parse_params(overrides)
    assert _accepted(generator, seed, **dataclasses.asdict(params))
    puzzle = generate_puzzle(generator, seed, params)
    assert puzzle.parameters == params and (puzzle.generator, puzzle.seed) == (generator, seed)
    if generator == "simple_slider":
        assert len(puzzle.objects) == overrides.get("n_objects", seed + 1)
    # A certified puzzle of that size: its certificate holds as `phyrogen check` checks one ...
    assert verify_certificate(puzzle.chain, puzzle.certificate, puzzle.goal) == []
    # ... and the same check refuses it cut short of the goal (the control).
    assert verify_certificate(puzzle.chain, puzzle.certificate[:-1], puzzle.goal) == [
        "certificate does not end in the goal"]


# -- command-line numbers ---------------------------------------------------------------
def _refused_option(argv: list[str], capsys) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.strip()


BAD_OPTIONS = [
    *[(command, "--workers", value) for command in ("generate", "benchmark", "render")
      for value in ("0", "-1", str(max_workers() + 1), "1000", "1.5", "nan", "two")],
    ("benchmark", "--time-limit", "inf"),
    ("benchmark", "--time-limit", "-inf"),
    ("benchmark", "--time-limit", "nan"),
    ("benchmark", "--time-limit", "1e309"),
    ("benchmark", "--time-limit", "0"),
    ("benchmark", "--time-limit", "-5"),
    ("benchmark", "--time-limit", str(MAX_TIME_LIMIT + 1)),
    ("benchmark", "--runs", "0"),
    ("benchmark", "--runs", "-3"),
    ("benchmark", "--runs", str(MAX_RUNS + 1)),
    ("benchmark", "--runs", "1e3"),
    ("benchmark", "--seed", "-1"),
    ("benchmark", "--seed", str(MAX_BENCHMARK_SEED + 1)),
    ("benchmark", "--seed", str(2**64)),
    ("benchmark", "--seed", "0.5"),
    ("render", "--size", "100000x100000"),
    ("render", "--size", "8193x360"),
    ("render", "--size", "480x15"),
    ("render", "--size", "0x0"),
    ("render", "--size", "-480x360"),
    ("render", "--size", "480x360x3"),
    ("render", "--size", "480"),
]


@pytest.mark.parametrize(("command", "option", "value"), BAD_OPTIONS)
def test_numeric_options_out_of_range_are_refused(command, option, value, capsys):
    line = _refused_option([command, f"{option}={value}"], capsys)
    assert f"argument {option}" in line and value in line, line


@pytest.mark.parametrize(("command", "option", "value", "parsed"), [
    ("generate", "--workers", "1", 1),
    ("generate", "--workers", str(max_workers()), max_workers()),
    ("render", "--workers", str(max_workers()), max_workers()),
    ("benchmark", "--time-limit", str(MAX_TIME_LIMIT), MAX_TIME_LIMIT),
    ("benchmark", "--time-limit", "0.05", 0.05),
    ("benchmark", "--runs", str(MAX_RUNS), MAX_RUNS),
    ("benchmark", "--seed", "0", 0),
    ("benchmark", "--seed", str(MAX_BENCHMARK_SEED), MAX_BENCHMARK_SEED),
    ("render", "--size", "16x8192", "16x8192"),
])
def test_numeric_options_at_their_bounds_are_accepted(command, option, value, parsed):
    args = build_parser().parse_args([command, f"{option}={value}"])
    assert getattr(args, option.lstrip("-").replace("-", "_")) == parsed


def test_the_workers_bound_follows_the_usable_cores():
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert max_workers() == 4 * cores


def test_a_refused_option_is_one_line_on_stderr(tmp_path, capsys):
    try:
        code = main(["generate", "--workers", "0", "--out", str(tmp_path / "out")])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "--workers" in err, err



def test_a_long_staircase_generates_on_every_fresh_seed():
    # The Maker used to walk into staircases with no way on: 6 of 60 seeds gave up at 7 sliders.
    first = random.SystemRandom().randrange(10**6, 10**9)
    spec = get_generator("simple_slider")
    for seed in range(first, first + 12):
        assert len(generate_puzzle("simple_slider", seed, spec.parse_params({"n_objects": 9})).objects) == 9, seed
