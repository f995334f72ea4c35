"""``--json`` on the commands the Blender panel runs: stdout is one JSON object, the rest goes to stderr.

The panel (``blender_addon/job_operators.py``) reads its results from these objects, never from the printed tables.
Benchmark's and Manipulate's objects are read by the panel's own tests (tests/test_blender_panel_jobs.py).
"""

from __future__ import annotations

import json
import subprocess
import sys

from phyrogen_core.command_result import read_generate_result, read_replan_result
from phyrogen_core.export import read_puzzle_dir

SEED = 23
"""A Simple Slider seed no other test uses."""


def phyrogen(*arguments: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "phyrogen", *arguments], capture_output=True, text=True,
                          timeout=600)


def test_generate_and_replan_print_one_json_object(tmp_path):
    run = phyrogen("generate", "--generator", "simple_slider", "--seeds", str(SEED), "--out", str(tmp_path),
                   "--workers", "1", "--set", "gap=0.1", "--json")
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)  # the whole of stdout: one object
    assert result["command"] == "generate" and result["exit_code"] == 0 and (result["ok"], result["failed"]) == (1, 0)
    (row,) = result["puzzles"]
    folder = tmp_path / "simple_slider" / f"simple_slider_{SEED}"
    assert row["folder"] == str(folder) and row["error"] is None and row["seed"] == SEED
    loaded = read_puzzle_dir(folder)
    assert row["objects"] == len(loaded.chain.object_names) and row["actions"] == loaded.record.certificate_actions
    assert "generator" in run.stderr and "seed" in run.stderr  # the human table went to stderr
    (puzzle,) = read_generate_result(run.stdout).puzzles  # the panel's reader takes the real output
    assert (puzzle.folder, puzzle.objects, puzzle.seed) == (str(folder), row["objects"], SEED)

    run = phyrogen("replan", str(folder), "--json")
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    replanned = read_puzzle_dir(folder).record
    assert result["solved"] is True and result["puzzle"] == f"simple_slider_{SEED}"
    assert result["states"] == len(replanned.certificate)
    assert result["planner"] in ("RRT-Connect", "LA-RRT+push") and result["queries"] > 0
    assert read_replan_result(run.stdout).states == len(replanned.certificate)


def test_bad_input_with_json_prints_nothing_on_stdout(tmp_path):
    run = phyrogen("generate", "--generator", "simple_slider", "--seeds", "1", "--set", "gap=7",
                   "--out", str(tmp_path), "--json")
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.count("\n") == 1 and "gap" in run.stderr
    run = phyrogen("replan", str(tmp_path / "missing"), "--json")
    assert run.returncode == 2 and run.stdout == "" and "missing" in run.stderr

