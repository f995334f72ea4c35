"""The ``hard`` suite (phyrogen_core/suites.py) and the search rule of scripts/hard_suite.py.

The suite's evidence is docs/benchmark/hard-suite.md (a measurement, not a
test); here: every entry is a registered generator with valid parameters that
set one of its difficulty knobs, ``phyrogen generate --suite hard`` makes
exactly those puzzles, and the search's verdict rule decides as stated.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

from phyrogen_core.record import PuzzleRecord
from phyrogen_core.registry import ParameterError, get_generator
from phyrogen_core.suites import HARD_SUITE, SuiteEntry, get_suite

ROOT = Path(__file__).resolve().parent.parent
MEASURED_SEEDS = range(90001, 90011)  # docs/benchmark/hard-suite.md; no test generates them
TEST_SEED = 614_220_301  # fresh


@functools.cache
def _script():
    spec = importlib.util.spec_from_file_location("hard_suite_script", ROOT / "scripts" / "hard_suite.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up by name
    spec.loader.exec_module(module)
    return module


def _check(entry: SuiteEntry, seeds) -> None:
    spec = get_generator(entry.generator)
    params = entry.params()
    for seed in seeds:
        spec.check(seed, params)
    knobs = set(spec.difficulty_parameters())
    if not set(entry.overrides) <= knobs:
        raise ParameterError(f"{entry.generator}: {sorted(set(entry.overrides) - knobs)} are not difficulty knobs")


def test_the_hard_suite_is_registered_and_lists_each_generator_once():
    assert get_suite("hard") == HARD_SUITE and HARD_SUITE
    names = [entry.generator for entry in HARD_SUITE]
    assert len(names) == len(set(names))


@pytest.mark.parametrize("entry", HARD_SUITE, ids=lambda e: e.generator)
def test_every_entry_sets_valid_difficulty_knobs(entry):
    _check(entry, MEASURED_SEEDS)


@pytest.mark.parametrize("entry", [SuiteEntry("move_n_times", {"n": "99"}), SuiteEntry("rooms", {"gap": "1"}),
                                   SuiteEntry("rooms", {"wall_height": "0.5"})])
def test_the_entry_check_refuses_a_bad_entry(entry):
    # Negative control: an infeasible size, an unknown parameter, a parameter that is no difficulty knob.
    with pytest.raises(ParameterError):
        _check(entry, MEASURED_SEEDS)


@pytest.mark.parametrize(("outcomes", "total", "expected"), [
    ({"bit_star": [False, False, False], "rrt_star": [False, False, False]}, 4, True),
    ({"bit_star": [False, False], "rrt_star": [False, False, False]}, 4, None),  # BIT* could still reach 2 of 4
    ({"bit_star": [True, True], "rrt_star": [False]}, 4, False),  # half solved: not under 50 %
    ({"bit_star": [True, False, False], "rrt_star": [False, False, False]}, 4, None),  # 2 of 4 still possible
    ({"bit_star": [True, False, False, False], "rrt_star": [False, False, False]}, 4, True),
    ({"bit_star": [True, False, True], "rrt_star": [False, False, False]}, 4, False),
])
def test_the_search_verdict(outcomes, total, expected):
    assert _script().verdict(outcomes, total) is expected


@pytest.mark.slow
def test_generate_suite_hard_makes_each_generator_at_its_size(tmp_path):
    done = subprocess.run([sys.executable, "-m", "phyrogen", "generate", "--suite", "hard", "--seeds", str(TEST_SEED),
                           "--workers", "1", "--quiet", "--out", str(tmp_path)], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    for entry in HARD_SUITE:
        folder = tmp_path / entry.generator / f"{entry.generator}_{TEST_SEED}"
        record = PuzzleRecord.from_json((folder / "puzzle.json").read_bytes())
        assert {key: str(record.parameters[key]) for key in entry.overrides} == dict(entry.overrides)
    made = sorted(p.name for p in tmp_path.iterdir() if p.is_dir())
    assert made == sorted(entry.generator for entry in HARD_SUITE)


def test_the_search_resumes_only_verdicts_made_at_the_same_budget(tmp_path):
    # A size found hard at 10,000 checks a second is searched again at 28,000; its verdict at the same
    # budget is reused. Negative control: the other budget's verdict is not.
    script = _script()
    log = tmp_path / "search.jsonl"
    lines = [{"verdict": {"generator": "move_n_times", "size": 7, "budget_checks": budget, "hard": hard}}
             for budget, hard in ((200_000, True), (560_000, False))]
    log.write_text("".join(json.dumps(line) + "\n" for line in lines))
    done = script._verdicts(log)
    assert done[("move_n_times", 7, 560_000)]["hard"] is False
    assert done[("move_n_times", 7, 200_000)]["hard"] is True
    assert ("move_n_times", 7, 1_000) not in done


def test_search_start_sizes():
    script = _script()
    assert list(script._sizes("move_n_times", script._starts("move_n_times=7")))[:2] == [7, 8]
    assert list(script._sizes("move_n_times", {}))[0] == script.KNOBS["move_n_times"].start
    assert list(script._sizes("grid_world", script._starts("grid_world=9,rooms=5")))[:2] == [9, 11]
    for bad in ("nope=3", "move_n_times=x", "move_n_times"):
        with pytest.raises(SystemExit) as stopped:
            script._starts(bad)
        assert stopped.value.code == 2
