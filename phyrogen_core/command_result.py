"""The ``--json`` results of ``phyrogen generate``, ``replan``, ``benchmark`` and ``manipulate``: the stages'
result records (:mod:`phyrogen_core.stage_records`), each read by one strict reader.

A command run with ``--json`` prints exactly one JSON object on stdout (README, "For programs"): its stage's
result record (``to_json``), which holds the command's name, the record's version and the exit code. Its
reader here turns that text back into the same record or raises :class:`CommandResultError`, one line that
names the command and the field: text that is no JSON, a value that is not an object, a result of another
command or version, a missing or unknown key, a value of the wrong type (a bool is no number), a
non-finite number (``NaN`` or ``Infinity`` anywhere in the text), an exit code the result does not give.

The Blender panel reads its jobs' results through these readers (``blender_addon.job_operators``).
"""

from __future__ import annotations

from .stage_records.base import RecordError
from .stage_records.benchmark import BenchmarkCell, BenchmarkResult
from .stage_records.generate import GeneratedPuzzle, GenerateResult
from .stage_records.manipulate import ManipulateResult, ManipulationOutcome
from .stage_records.replan import ReplanResult

__all__ = ["BenchmarkCell", "BenchmarkResult", "CommandResultError", "GenerateResult", "GeneratedPuzzle",
           "ManipulateResult", "ManipulationOutcome", "ReplanResult", "read_benchmark_result",
           "read_generate_result", "read_manipulate_result", "read_replan_result"]

CommandResultError = RecordError
"""A command's ``--json`` result that its reader refuses; the message is one line."""


def read_generate_result(text: str) -> GenerateResult:
    """The record of ``phyrogen generate --json``'s stdout; :class:`CommandResultError` when it is not one."""
    return GenerateResult.from_json(text)


def read_replan_result(text: str) -> ReplanResult:
    """The record of ``phyrogen replan --json``'s stdout; :class:`CommandResultError` when it is not one."""
    return ReplanResult.from_json(text)


def read_benchmark_result(text: str) -> BenchmarkResult:
    """The record of ``phyrogen benchmark --json``'s stdout; :class:`CommandResultError` when it is not one."""
    return BenchmarkResult.from_json(text)


def read_manipulate_result(text: str) -> ManipulateResult:
    """The record of ``phyrogen manipulate --json``'s stdout; :class:`CommandResultError` when it is not one."""
    return ManipulateResult.from_json(text)
