"""The best-solution file has one record and one strict reader: each malformed file gets one clear error.

The control beside every broken file is the same file unbroken, which reads; the benchmark's own
writer's output reads back into the record and out again byte for byte.
"""

from __future__ import annotations

import json
import os
from types import SimpleNamespace

import numpy as np
import pytest

from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.folder_layout import BEST_SOLUTION
from phyrogen_core.folder_reads import MAX_FILE_BYTES
from phyrogen_core.sizes import MAX_CERTIFICATE_STATES
from phyrogen_core.solution_file import SolutionFile, read_solution_file

ORDER = ["j_b", "j_a", "j_c"]


def valid() -> dict:
    return {"format": "phyrogen-solution", "format_version": 1, "puzzle": "p_17", "planner": "LA-RRT", "seed": 4,
            "run": 2, "time_limit": 10.0, "found_after": 0.25, "action_cost": 2, "object_sequence": ["a", "b"],
            "joint_order": list(ORDER), "path": [[0.0, 0.5, -1.0], [0.25, 0.5, -1.0], [0.25, 0.0, 2.0]]}


def write(folder, text: str):
    file = folder / BEST_SOLUTION
    file.parent.mkdir(parents=True, exist_ok=True)
    file.write_text(text)
    return file


def error_of(folder, file) -> str:
    with pytest.raises(PuzzleFormatError) as caught:
        read_solution_file(file, folder)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(str(file)), message
    return message


def test_a_valid_file_reads_and_gives_its_path_in_the_puzzles_joint_order(tmp_path):
    file = write(tmp_path, json.dumps(valid()))
    solution = read_solution_file(file, tmp_path)
    assert solution.joint_order == tuple(ORDER) and solution.run_name == "LA-RRT run 2"
    path = solution.path_in(["j_a", "j_b", "j_c"], "here")
    assert path.tolist() == [[0.5, 0.0, -1.0], [0.5, 0.25, -1.0], [0.0, 0.25, 2.0]]
    assert solution.to_json() == valid()
    with pytest.raises(PuzzleFormatError, match="does not match the puzzle's joints"):
        solution.path_in(["j_a", "j_b", "j_d"], "here")  # negative control: another puzzle's joints


def test_only_joint_order_and_path_are_required(tmp_path):
    data = {"joint_order": ORDER, "path": valid()["path"]}
    solution = read_solution_file(write(tmp_path, json.dumps(data)), tmp_path)
    assert solution.planner is None and solution.run_name == "LA-RRT"


def _broken(name: str) -> tuple[str, str]:
    """(file text, what the error must say) of the valid file broken one way."""
    data = valid()
    if name == "non-finite number":
        return json.dumps(data).replace("0.25, 0.5", "NaN, 0.5", 1), "path[1][0] is nan"
    if name == "huge number":
        data["path"][2][2] = 1e300
        return json.dumps(data), "path[2][2] = 1e+300 must be a finite number within"
    if name == "short row":
        data["path"][1] = [0.25, 0.5]
        return json.dumps(data), "path[1] must be a list of 3 numbers"
    if name == "one state":
        data["path"] = data["path"][:1]
        return json.dumps(data), "path must be a list of at least 2 states"
    if name == "too many states":
        data["path"] = [[0.0, 0.0, 0.0]] * (MAX_CERTIFICATE_STATES + 1)
        bound = MAX_CERTIFICATE_STATES
        return json.dumps(data), f"path holds {bound + 1} states, more than the {bound} accepted"
    if name == "missing key":
        del data["path"]
        return json.dumps(data), "expected an object with 'joint_order' and 'path'"
    if name == "unknown key":
        data["comment"] = "mine"
        return json.dumps(data), "unknown key 'comment'"
    if name == "another format":
        data["format_version"] = 2
        return json.dumps(data), "format_version 2 is not supported"
    if name == "repeated joint":
        data["joint_order"] = ["j_a", "j_a", "j_c"]
        return json.dumps(data), "joint_order ['j_a', 'j_a', 'j_c'] must be a list of distinct joint names"
    if name == "planner not a name":
        data["planner"] = 5
        return json.dumps(data), "planner = 5 must be a printable string"
    if name == "not JSON":
        return json.dumps(data)[:-2], "malformed JSON"
    raise AssertionError(name)


BROKEN = ("non-finite number", "huge number", "short row", "one state", "too many states", "missing key",
          "unknown key", "another format", "repeated joint", "planner not a name", "not JSON")


@pytest.mark.parametrize("name", BROKEN)
def test_each_malformed_file_gets_one_clear_error(tmp_path, name):
    text, says = _broken(name)
    message = error_of(tmp_path, write(tmp_path, text))
    assert says in message, message


def test_a_file_leading_out_of_the_puzzle_folder_is_refused(tmp_path):
    folder, elsewhere = tmp_path / "puzzle", tmp_path / "elsewhere.json"
    elsewhere.write_text(json.dumps(valid()))
    file = folder / BEST_SOLUTION
    file.parent.mkdir(parents=True)
    os.symlink(elsewhere, file)
    assert "outside the puzzle folder" in error_of(folder, file)
    os.unlink(file)
    os.link(elsewhere, file)  # control: the same bytes inside the folder read
    assert read_solution_file(file, folder).run == 2


def test_an_oversized_file_is_refused_before_it_is_read(tmp_path):
    file = write(tmp_path, json.dumps(valid()))
    with open(file, "r+b") as handle:
        handle.truncate(MAX_FILE_BYTES + 1)  # sparse: nothing is written, the size is all that is asked
    assert "more than the 16 MiB" in error_of(tmp_path, file)


def test_the_benchmarks_writer_output_reads_back_byte_for_byte(tmp_path):
    """What ``solver.benchmark.solutions.solution_json`` writes today is exactly this format: the record
    reads it and writes the same bytes, so the writer can move onto the record unchanged."""
    from phyrogen_core.export import read_puzzle_dir, write_puzzle
    from solver.benchmark.solutions import solution_json
    from solver.pipelines.generation import generate_puzzle

    loaded = read_puzzle_dir(write_puzzle(generate_puzzle("grid_world", 917), tmp_path / "out"))
    record = SimpleNamespace(puzzle=loaded.name, planner="LA-RRT", seed=917, run=3, time_limit=40.0,
                             best_solution_time=1.5, action_cost=4,
                             path=tuple(tuple(float(v) for v in s) for s in loaded.certificate),
                             joint_order=tuple(loaded.joint_order))
    written = json.dumps(solution_json(record, loaded.chain.factors), indent=1)
    solution = SolutionFile.from_data(json.loads(written), "written")
    assert json.dumps(solution.to_json(), indent=1) == written
    assert np.array_equal(solution.path_in(loaded.joint_order, "written"), np.asarray(loaded.certificate))
