"""The benchmark journal's one strict reader (:meth:`solver.benchmark.journal.JournalEntry.from_line`):
a malformed line gets one clear error naming what is wrong, a valid line (the control) reads back."""

from __future__ import annotations

import json
import math

import pytest

from solver.benchmark.jobs import RunRecord
from solver.benchmark.journal import JournalEntry, JournalFormatError, read_journal

KEY = json.dumps({"planner": "lbt_rrt", "puzzle": "rooms_58", "run": 3, "seed": 8117, "time_limit": 7.5},
                 sort_keys=True)
RECORD = RunRecord("LBT-RRT", "rooms_58", 3, 8117, 7.5, True, "Exact solution", 2.25, 0.5, 4, 3.75, 91, 2,
                   ((0.0, math.inf, 0), (0.5, 6.0, 40), (2.0, 4.0, 91)), ((0.0, 0.1), (0.3, -0.2)), ("j0", "j1"),
                   wall=2.5, best_solution_time=2.0, checks=7000, cpu_time=2.1, first_solution_checks=3100,
                   end="budget")


def line_with(change) -> bytes:
    data = json.loads(JournalEntry(KEY, RECORD).to_line())
    change(data)
    return json.dumps(data).encode()


def error_of(line: bytes) -> str:
    with pytest.raises(JournalFormatError) as caught:
        JournalEntry.from_line(line)
    message = str(caught.value)
    assert "\n" not in message
    return message


def test_a_valid_line_reads_back_as_the_same_entry():
    line = JournalEntry(KEY, RECORD).to_line()
    assert line.endswith(b"\n") and b"Infinity" not in line  # "no solution yet" is written as null
    assert JournalEntry.from_line(line) == JournalEntry(KEY, RECORD)


def _delete(part, name):
    return lambda data: data[part].pop(name)


def _set(part, name, value):
    return lambda data: data[part].__setitem__(name, value)


@pytest.mark.parametrize(("line", "expected"), [
    (b'{"key": {"planner": "lbt_rrt"}, "record": {"planner": ', "not JSON"),  # torn mid-write
    (b"[1, 2]", "expected an object with 'key' and 'record'"),
    (line_with(lambda data: data.pop("record")), "no 'record'"),
    (line_with(_delete("record", "seed")), "record has no 'seed'"),
    (line_with(_set("record", "colour", "red")), "unknown field 'colour'"),
    (line_with(_set("record", "solved", "yes")), "record.solved = 'yes' must be bool"),
    (line_with(_set("record", "iterations", 9.5)), "record.iterations = 9.5 must be int"),
    (line_with(_set("record", "status", "Great")), "record.status 'Great' is none of OMPL's"),
    (line_with(_set("record", "path", [[0.0, "x"]])), "record.path[0][1] = 'x' must be float"),
    (line_with(_set("record", "progress", [[0.0, None]])), "record.progress[0] = [0.0, None] must be"),
    (line_with(_set("record", "joint_order", "j0j1")), "record.joint_order = 'j0j1' must be a list"),
    (line_with(_set("key", "planner", "no_such_planner")), "key.planner 'no_such_planner' is no registered"),
    (line_with(_set("key", "seed", 1)), "are not its key's"),
])
def test_a_malformed_line_gets_one_clear_error(line, expected):
    assert expected in error_of(line)


@pytest.mark.parametrize("number", ["NaN", "Infinity", "-Infinity", "1e400"])
def test_a_non_finite_number_is_refused(number):
    line = JournalEntry(KEY, RECORD).to_line().replace(b'"time": 2.25', b'"time": ' + number.encode())
    assert line != JournalEntry(KEY, RECORD).to_line()
    assert "not a finite number" in error_of(line)


def test_strict_reading_names_the_file_and_line_and_resuming_skips_it(tmp_path):
    good = JournalEntry(KEY, RECORD).to_line()
    other = JournalEntry(KEY.replace('"run": 3', '"run": 4'), RunRecord(**{**RECORD.__dict__, "run": 4}))
    journal = tmp_path / "runs.jsonl"
    journal.write_bytes(good + line_with(_set("record", "solved", "yes")) + b"\n" + other.to_line() + good[:30])
    assert len(read_journal(journal)) == 2  # a resumed benchmark runs the broken line's run again
    with pytest.raises(JournalFormatError, match=r"runs\.jsonl: line 2: record\.solved = 'yes' must be bool"):
        read_journal(journal, strict=True)
    # Control: a torn last line (no newline: killed mid-write) is not an error, even strictly.
    journal.write_bytes(good + other.to_line() + good[:30])
    assert len(read_journal(journal, strict=True)) == 2
