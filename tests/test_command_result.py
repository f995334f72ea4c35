"""The readers of the commands' ``--json`` results (phyrogen_core.command_result): a result of the shape the
command line prints is read into its record; a malformed one is refused with one line naming the field.

The shapes below are those ``phyrogen generate|replan|benchmark|manipulate --json`` print (the keys the
command line writes, extra ones included); tests/test_blender_cli_json.py reads real output of generate
and replan with the same readers, tests/test_blender_panel_jobs.py that of benchmark and manipulate.
"""

from __future__ import annotations

import copy
import json

import pytest

from phyrogen_core.command_result import (
    CommandResultError,
    read_benchmark_result,
    read_generate_result,
    read_manipulate_result,
    read_replan_result,
)

GENERATE = {"command": "generate", "version": 1, "exit_code": 0, "failed": 0, "ok": 1, "wall_seconds": 4.2,
            "puzzles": [{"actions": 5, "error": None, "folder": "/tmp/out/grid_world/grid_world_31",
                         "generator": "grid_world", "objects": 4, "seconds": 3.917, "seed": 31}]}
REPLAN = {"budget": 2000000, "command": "replan", "version": 1, "dependencies": 3, "exit_code": 0,
          "folder": "/tmp/out/rooms/rooms_7", "notices": [], "planner": "RRT-Connect", "puzzle": "rooms_7",
          "queries": 1234, "seed": 0, "solved": True, "states": 17}
CELL = {"puzzle": "rooms_7", "planner": "LA-RRT (ours)", "runs": 3, "clock_ended": 0, "complete": True,
        "ends": {"solved": 2, "budget": 1}, "machine_dependent": False, "successes": 2, "rate": 0.667,
        "rate_low": 0.2, "rate_high": 0.94, "interval": "wilson", "solved_all": False, "solved_any": True,
        "time_to_first": {"median": 0.42, "low": 0.1, "high": None, "samples": 3},
        "checks_to_first": None, "final_cost": None}
BENCHMARK = {"command": "benchmark", "version": 1, "crashed": 0, "database": "/tmp/b/benchmark.db", "exit_code": 0,
             "out": "/tmp/b", "results_page": "/tmp/b/results.html", "unsaved_solutions": [],
             "summary": {"format": "phyrogen-benchmark-summary", "version": 2, "complete": True,
                         "machine_dependent": False,
                         "cells": [CELL, {**CELL, "planner": "BIT*", "successes": 0, "time_to_first": None}]}}
MANIPULATE = {"command": "manipulate", "version": 1, "exit_code": 1, "out": "/tmp/m",
              "reports": [{"puzzle": "rooms_7", "generator": "rooms", "seed": 7, "scale": 0.5,
                           "solution": "certificate", "solutions_tried": 1, "actions": 4, "regrasps": 1,
                           "planning_seconds": 1.5, "execution_seconds": 20, "simulated_seconds": 30.0,
                           "success": False, "target_at_goal": False, "max_penetration": 0.001,
                           "message": "unplanned contact", "attempts": [], "contact": None,
                           "benchmark_seconds": 0.0, "folder": "/tmp/m/rooms_7"}]}

READERS = {"generate": (read_generate_result, GENERATE), "replan": (read_replan_result, REPLAN),
           "benchmark": (read_benchmark_result, BENCHMARK), "manipulate": (read_manipulate_result, MANIPULATE)}


def test_each_result_of_the_commands_shape_is_read_into_its_record():
    generated = read_generate_result(json.dumps(GENERATE))
    (puzzle,) = generated.puzzles
    assert (puzzle.generator, puzzle.seed, puzzle.objects, puzzle.actions) == ("grid_world", 31, 4, 5)
    assert puzzle.folder.endswith("grid_world_31") and puzzle.error is None and generated.ok == 1
    replanned = read_replan_result(json.dumps(REPLAN))
    assert (replanned.puzzle, replanned.planner, replanned.states, replanned.queries) == ("rooms_7", "RRT-Connect",
                                                                                           17, 1234)
    benchmark = read_benchmark_result(json.dumps(BENCHMARK))
    assert [(c.planner, c.successes, c.runs, c.time_to_first) for c in benchmark.cells] == [
        ("LA-RRT (ours)", 2, 3, 0.42), ("BIT*", 0, 3, None)]
    (report,) = read_manipulate_result(json.dumps(MANIPULATE)).reports
    assert (report.success, report.regrasps, report.execution_seconds, report.folder) == (False, 1, 20.0,
                                                                                          "/tmp/m/rooms_7")
    assert isinstance(report.execution_seconds, float)
    # A failed generation and an unsolved re-plan are results too (their rows say so).
    failed = copy.deepcopy(GENERATE)
    failed["puzzles"][0].update(folder=None, error="ParameterError: gap too large")
    failed.update(ok=0, failed=1, exit_code=1)
    assert read_generate_result(json.dumps(failed)).puzzles[0].error.startswith("ParameterError")
    unsolved = {**REPLAN, "solved": False, "exit_code": 1, "planner": None, "queries": None, "states": None,
                "dependencies": None}
    assert read_replan_result(json.dumps(unsolved)).states is None


def _without(data: dict, path: tuple) -> dict:
    data = copy.deepcopy(data)
    target = data
    for key in path[:-1]:
        target = target[key]
    del target[path[-1]]
    return data


def _with(data: dict, path: tuple, value) -> dict:
    data = copy.deepcopy(data)
    target = data
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return data


MALFORMED = [
    # (command, text, what the one line must say)
    ("generate", json.dumps(_without(GENERATE, ("puzzles", 0, "objects"))), "puzzles[0]: missing key 'objects'"),
    ("generate", json.dumps(_with(GENERATE, ("puzzles", 0, "seed"), "31")), "'seed': expected an integer"),
    ("generate", json.dumps(_with(GENERATE, ("puzzles", 0, "actions"), True)), "'actions': expected an integer"),
    ("generate", json.dumps(_with(GENERATE, ("puzzles", 0, "seconds"), float("nan"))), "non-finite number NaN"),
    ("generate", json.dumps(_with(GENERATE, ("puzzles", 0), [1, 2])), "puzzles[0]: expected an object"),
    ("generate", json.dumps(_with(GENERATE, ("puzzles",), {})), "'puzzles': expected a list"),
    ("generate", json.dumps(_with(GENERATE, ("failed",), -1)), "'failed' is -1"),
    ("replan", json.dumps(_without(REPLAN, ("states",))), "missing key 'states'"),
    ("replan", json.dumps(_with(REPLAN, ("solved",), 1)), "'solved': expected true or false"),
    ("replan", json.dumps(_with(REPLAN, ("planner",), None)), "'planner': expected a value, got null"),
    ("benchmark", json.dumps(_without(BENCHMARK, ("summary", "cells", 1, "runs"))), "cells[1]: missing key 'runs'"),
    ("benchmark", json.dumps(_with(BENCHMARK, ("summary", "cells", 0, "time_to_first", "median"), "fast")),
     "time_to_first: 'median': expected a number"),
    ("benchmark", json.dumps(BENCHMARK).replace("0.42", "1e400"), "non-finite number 1e400"),
    ("benchmark", json.dumps(_with(BENCHMARK, ("summary", "cells", 0, "time_to_first", "median"), float("inf"))),
     "non-finite number Infinity"),
    ("benchmark", json.dumps(_with(BENCHMARK, ("summary",), None)), "'summary': expected an object, got null"),
    ("manipulate", json.dumps(_without(MANIPULATE, ("reports", 0, "folder"))), "reports[0]: missing key 'folder'"),
    ("manipulate", json.dumps(_with(MANIPULATE, ("reports", 0, "success"), "yes")), "'success': expected true"),
    ("manipulate", json.dumps(_with(MANIPULATE, ("reports", 0, "planning_seconds"), -float("inf"))),
     "non-finite number -Infinity"),
    # Not an object, not JSON, another command's result, no command at all.
    ("generate", json.dumps([GENERATE]), "expected one JSON object, got a list"),
    ("replan", "null", "expected one JSON object, got null"),
    ("manipulate", '"done"', "expected one JSON object, got the string 'done'"),
    ("benchmark", "", "not JSON"),
    ("benchmark", json.dumps(BENCHMARK)[:-5], "not JSON"),
    ("replan", "Traceback (most recent call last):\n  ...", "not JSON"),
    ("replan", json.dumps({**GENERATE}), "'command' is 'generate', not 'replan'"),
    ("manipulate", json.dumps(_without(MANIPULATE, ("command",))), "'command' is None, not 'manipulate'"),
]


@pytest.mark.parametrize(("command", "text", "expected"), MALFORMED)
def test_a_malformed_result_is_one_clear_error(command, text, expected):
    reader, _ = READERS[command]
    with pytest.raises(CommandResultError) as caught:
        reader(text)
    message = str(caught.value)
    assert message.startswith(f"{command} --json result") and expected in message, message
    assert "\n" not in message
    assert isinstance(caught.value, ValueError)  # what the panel reports as a failed job, not a traceback


def test_the_controls_of_the_malformed_results_are_read():
    # Negative control of the test above: each reader takes its own valid result, so a refusal there is
    # the malformed field's doing.
    for command, (reader, valid) in READERS.items():
        assert reader(json.dumps(valid)) is not None, command
