"""The ``--json`` results of ``phyrogen generate``, ``replan``, ``benchmark`` and ``manipulate`` as typed
records, each with one strict reader.

A command run with ``--json`` prints exactly one JSON object on stdout (README, "For programs"). Its
reader here turns that text into a frozen record or raises :class:`CommandResultError`, one line that
names the command and the field: text that is no JSON, a value that is not an object, a result of
another command, a missing key, a value of the wrong type (a bool is no number), a non-finite number
(``NaN`` or ``Infinity`` anywhere in the text). Keys a record does not hold are ignored, so a command
may add keys to its result without breaking its readers; the ones a record holds are required.

The Blender panel reads its jobs' results through these readers (``blender_addon.job_operators``);
the command line's writer can build the same records.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TypeVar

from .stage_records.base import RecordError
from .stage_records.generate import GeneratedPuzzle, GenerateResult
from .stage_records.replan import ReplanResult

__all__ = ["BenchmarkCell", "BenchmarkResult", "CommandResultError", "GenerateResult", "GeneratedPuzzle",
           "ManipulateResult", "ManipulationOutcome", "ReplanResult", "read_benchmark_result",
           "read_generate_result", "read_manipulate_result", "read_replan_result"]

_T = TypeVar("_T")


CommandResultError = RecordError
"""A command's ``--json`` result that its reader refuses; the message is one line."""


def read_generate_result(text: str) -> GenerateResult:
    """The record of ``phyrogen generate --json``'s stdout; :class:`CommandResultError` when it is not one."""
    return GenerateResult.from_json(text)


def read_replan_result(text: str) -> ReplanResult:
    """The record of ``phyrogen replan --json``'s stdout; :class:`CommandResultError` when it is not one."""
    return ReplanResult.from_json(text)


@dataclass(frozen=True)
class BenchmarkCell:
    """One puzzle and planner of a benchmark's summary (``summary.json``'s ``cells``)."""

    puzzle: str
    planner: str
    runs: int
    successes: int
    time_to_first: float | None
    """Median seconds to a first solution over all runs; None when not within the budget (or no estimate)."""


@dataclass(frozen=True)
class BenchmarkResult:
    """``phyrogen benchmark --json``: the output's paths and the summary's cells."""

    out: str
    database: str
    results_page: str
    crashed: int
    cells: tuple[BenchmarkCell, ...]
    exit_code: int


@dataclass(frozen=True)
class ManipulationOutcome:
    """One puzzle's report of ``phyrogen manipulate --json`` (its ``report.json``, with its ``folder``)."""

    puzzle: str
    folder: str
    solution: str
    """Which solution the numbers are of."""
    success: bool
    actions: int
    regrasps: int
    planning_seconds: float
    execution_seconds: float
    message: str


@dataclass(frozen=True)
class ManipulateResult:
    """``phyrogen manipulate --json``."""

    out: str
    reports: tuple[ManipulationOutcome, ...]
    exit_code: int


# -- the readers -----------------------------------------------------------------------------------


def read_benchmark_result(text: str) -> BenchmarkResult:
    """The record of ``phyrogen benchmark --json``'s stdout; :class:`CommandResultError` when it is not one."""
    data = _result(text, "benchmark")
    label = "benchmark --json result"
    summary = _field(data, "summary", dict, label)
    cells = tuple(_record(cell, f"{label}: summary.cells[{index}]", _benchmark_cell)
                  for index, cell in enumerate(_field(summary, "cells", list, f"{label}: summary")))
    return BenchmarkResult(_field(data, "out", str, label), _field(data, "database", str, label),
                           _field(data, "results_page", str, label), _count(data, "crashed", label), cells,
                           _field(data, "exit_code", int, label))


def read_manipulate_result(text: str) -> ManipulateResult:
    """The record of ``phyrogen manipulate --json``'s stdout; :class:`CommandResultError` when it is not one."""
    data = _result(text, "manipulate")
    label = "manipulate --json result"
    reports = tuple(_record(report, f"{label}: reports[{index}]", _manipulation_outcome)
                    for index, report in enumerate(_field(data, "reports", list, label)))
    return ManipulateResult(_field(data, "out", str, label), reports, _field(data, "exit_code", int, label))


def _benchmark_cell(cell: Mapping, label: str) -> BenchmarkCell:
    estimate = _optional(cell, "time_to_first", dict, label)
    median = None if estimate is None else _optional(estimate, "median", float, f"{label}: time_to_first")
    return BenchmarkCell(_field(cell, "puzzle", str, label), _field(cell, "planner", str, label),
                         _count(cell, "runs", label), _count(cell, "successes", label), median)


def _manipulation_outcome(report: Mapping, label: str) -> ManipulationOutcome:
    return ManipulationOutcome(_field(report, "puzzle", str, label), _field(report, "folder", str, label),
                               _field(report, "solution", str, label), _field(report, "success", bool, label),
                               _count(report, "actions", label), _count(report, "regrasps", label),
                               _field(report, "planning_seconds", float, label),
                               _field(report, "execution_seconds", float, label),
                               _field(report, "message", str, label))


# -- strict fields ---------------------------------------------------------------------------------


def _refuse_constant(name: str) -> None:
    raise CommandResultError(f"the non-finite number {name}")


def _finite_float(text: str) -> float:
    value = float(text)  # 1e400 is read as infinity
    if not math.isfinite(value):
        _refuse_constant(text)
    return value


def _result(text: str, command: str) -> Mapping:
    """The parsed object of ``command``'s result: JSON, an object, of that command, no non-finite number."""
    label = f"{command} --json result"
    if not isinstance(text, str):
        raise CommandResultError(f"{label}: expected the command's stdout as text, got {type(text).__name__}")
    try:
        data = json.loads(text, parse_constant=_refuse_constant, parse_float=_finite_float)
    except CommandResultError as exc:
        raise CommandResultError(f"{label}: {exc} (JSON has no such number)") from None
    except ValueError as exc:
        shown = text.strip()[-120:]
        raise CommandResultError(f"{label}: not JSON ({exc.msg} at character {exc.pos}; stdout ends {shown!r})"
                                 ) from None
    if not isinstance(data, dict):
        raise CommandResultError(f"{label}: expected one JSON object, got {_kind(data)}")
    if data.get("command") != command:
        raise CommandResultError(f"{label}: 'command' is {data.get('command')!r}, not {command!r}")
    return data


def _record(value, label: str, make: Callable[[Mapping, str], _T]) -> _T:
    if not isinstance(value, dict):
        raise CommandResultError(f"{label}: expected an object, got {_kind(value)}")
    return make(value, label)


def _field(data: Mapping, key: str, kind: type, label: str):
    if key not in data:
        raise CommandResultError(f"{label}: missing key {key!r}")
    return _typed(data[key], kind, f"{label}: {key!r}")


def _optional(data: Mapping, key: str, kind: type, label: str):
    """A key that must be there, whose value may be null."""
    if key not in data:
        raise CommandResultError(f"{label}: missing key {key!r}")
    return None if data[key] is None else _typed(data[key], kind, f"{label}: {key!r}")


def _count(data: Mapping, key: str, label: str) -> int:
    value = _field(data, key, int, label)
    if value < 0:
        raise CommandResultError(f"{label}: {key!r} is {value}, expected a count (0 or more)")
    return value


_KIND_NAMES = {str: "a string", int: "an integer", float: "a number", bool: "true or false", list: "a list",
               dict: "an object"}


def _typed(value, kind: type, label: str):
    # JSON's true and false are Python ints too: a bool is accepted only where one is asked for.
    is_bool = isinstance(value, bool)
    if kind is float and not is_bool and isinstance(value, int | float):
        if not math.isfinite(value):  # reached only by a parsed object handed on; the text cannot hold one
            raise CommandResultError(f"{label}: the non-finite number {value}")
        return float(value)
    if kind is bool and is_bool or kind not in (bool, float) and isinstance(value, kind) and not is_bool:
        return value
    raise CommandResultError(f"{label}: expected {_KIND_NAMES[kind]}, got {_kind(value)}")


def _kind(value) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{str(value).lower()}"
    if isinstance(value, str):
        return f"the string {value[:40]!r}"
    if isinstance(value, int | float):
        return f"the number {value}"
    return {list: "a list", dict: "an object"}.get(type(value), type(value).__name__)
