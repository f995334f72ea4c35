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
    lines = [{"verdict": {"generator": "move_n_times", "size": 7, "budget_checks": budget, "hard": hard,
                          "charge": script.CHARGE}} for budget, hard in ((200_000, True), (560_000, False))]
    # A verdict of the old unit (a motion counted once; no "charge" in the line) at the same budget.
    lines.append({"verdict": {"generator": "move_n_times", "size": 8, "budget_checks": 560_000, "hard": True}})
    log.write_text("".join(json.dumps(line) + "\n" for line in lines))
    done = script._verdicts(log)
    assert done[("move_n_times", 7, 560_000, script.CHARGE)]["hard"] is False
    assert done[("move_n_times", 7, 200_000, script.CHARGE)]["hard"] is True
    assert ("move_n_times", 7, 1_000, script.CHARGE) not in done
    assert ("move_n_times", 8, 560_000, script.CHARGE) not in done  # not reused: another unit
    assert ("move_n_times", 8, 560_000, "per-motion") in done


def test_the_table_reports_every_entry_on_every_generator_and_counts_clock_ended_runs_apart(tmp_path):
    from solver.benchmark.jobs import RunRecord
    from solver.benchmark.journal import journal_line
    from solver.planning.registry import get_planner

    script = _script()
    bench = tmp_path / "bench"
    (bench / "rooms").mkdir(parents=True)
    budget = script.paper_budget_checks("rooms")
    lines = []
    for k, planner in enumerate(script.ENTRIES):
        title = get_planner(planner).title
        for run, (solved, end, checks) in enumerate(((True, "solved", 1000 + k), (False, "budget", budget),
                                                     (False, "clock", budget // 9))):
            record = RunRecord(title, "rooms_90001", run, 10 * k + run, 600.0, solved,
                               "Exact solution" if solved else "Timeout", 1.0, 0.5 if solved else None,
                               3 if solved else None, 1.0 if solved else None, 10, 0, (), checks=checks,
                               cpu_time=2.0, end=end)
            key = json.dumps({"planner": planner, "puzzle": "rooms_90001", "run": run, "seed": 10 * k + run})
            lines.append(journal_line(key, record))
    (bench / "rooms" / "runs.jsonl").write_bytes(b"".join(lines))
    rows, cpu, warnings = script.table_rows(bench, {})
    body = rows[2:]
    assert len(body) == len(script.KNOBS) * len(script.ENTRIES)  # every entry on every generator
    assert {row.split(" | ")[0].strip("| ") for row in body} == set(script.KNOBS)
    rooms = [row for row in body if row.startswith("| rooms |")]
    assert [row.split(" | ")[3] for row in rooms] == [get_planner(p).title for p in script.ENTRIES]
    for row in rooms:  # the clock-ended run is left out of the rate and named
        assert "| 1 / 2 |" in row and "clock 1" in row and "(incomplete)" in row and "(not a hard size)" in row
    assert len([w for w in warnings if "clock" in w]) == len(script.ENTRIES) and cpu == 2.0 * 3 * 5
    # Control: the other generators were not measured here, and say so.
    assert all("not measured" in row for row in body if not row.startswith("| rooms |"))


def test_search_start_sizes():
    script = _script()
    assert list(script._sizes("move_n_times", script._starts("move_n_times=7")))[:2] == [7, 8]
    assert list(script._sizes("move_n_times", {}))[0] == script.KNOBS["move_n_times"].start
    assert list(script._sizes("grid_world", script._starts("grid_world=9,rooms=5")))[:2] == [9, 11]
    for bad in ("nope=3", "move_n_times=x", "move_n_times"):
        with pytest.raises(SystemExit) as stopped:
            script._starts(bad)
        assert stopped.value.code == 2
