"""The stages (phyrogen.stages): each job is one function run(request) -> result over the typed, versioned
records of phyrogen_core.stage_records, reachable from the Python API; each record's one strict reader refuses
malformed data with one line naming the field, beside a valid control that it reads back unchanged."""

from __future__ import annotations

import importlib
import inspect
import json
import math

import pytest

import phyrogen
from phyrogen_core.stage_records.audit import AuditedPuzzle, AuditRequest, AuditResult
from phyrogen_core.stage_records.base import RecordError, StageRequest, StageResult
from phyrogen_core.stage_records.benchmark import BenchmarkRequest, BenchmarkResult
from phyrogen_core.stage_records.certify import CertifyRequest, CertifyResult
from phyrogen_core.stage_records.check import CheckRequest, CheckResult
from phyrogen_core.stage_records.dataset import DatasetRequest, DatasetResult
from phyrogen_core.stage_records.export import ExportRequest, ExportResult
from phyrogen_core.stage_records.generate import GeneratedPuzzle, GenerateRequest, GenerateResult
from phyrogen_core.stage_records.import_urdf import ImportRequest, ImportResult
from phyrogen_core.stage_records.manipulate import ManipulateRequest, ManipulateResult, ManipulationOutcome
from phyrogen_core.stage_records.render import RenderRequest, RenderResult
from phyrogen_core.stage_records.replan import ReplanRequest, ReplanResult

SUMMARY = {"format": "phyrogen-benchmark-summary", "version": 2,
           "cells": [{"puzzle": "rooms_7", "planner": "BIT*", "runs": 3, "successes": 2, "ends": {"solved": 2},
                      "time_to_first": {"median": 0.42, "low": 0.1, "high": None}}]}
OUTCOME = ManipulationOutcome("rooms_7", "/tmp/m/rooms_7", "rooms", 7, 0.5, "certificate", 1, True, True, 4, 1, 1.5,
                              20.0, 30.0, 0.0, 0.001, "ok", ({"solution": "certificate", "actions": 4},), None)
VALID = [
    CheckRequest("out/rooms/rooms_7"),
    CheckResult(puzzle="rooms_7", folder="out/rooms/rooms_7", states=17, edited=False, problems=()),
    GenerateRequest("rooms", seeds="3-5", overrides=("n_objects=3",)),
    GenerateResult(puzzles=(GeneratedPuzzle("rooms", 3, 3, 5, 1.25, "out/rooms/rooms_3", None),
                            GeneratedPuzzle("rooms", 4, 0, 0, 0.5, None, "GenerationError: no room")),
                   ok=1, failed=1, wall_seconds=2.0),
    CertifyRequest("out/rooms/rooms_7", 100000, "la_rrt", run=2),
    CertifyResult("rooms_7", "la_rrt", "LA-RRT", 2, 100000, True, 100205, "budget", ("a", "b"),
                  ((0.0, 0.0), (0.5, -0.25)), 1, problems=()),
    ReplanRequest("out/rooms/rooms_7", 5000, 3),
    ReplanResult(puzzle="rooms_7", folder="out/rooms/rooms_7", solved=True, budget=5000, seed=3, planner="RRT-Connect",
                 queries=812, states=17, dependencies=3, notices=()),
    ExportRequest(("out",)),
    ExportResult(files=("out/rooms/rooms_7/mjcf/rooms_7.xml",)),
    ImportRequest("drawer.urdf", goal=(0.25,), target="drawer_joint"),
    ImportResult(puzzle="drawer", solved=True, folder="out/imported/drawer", budget=100000, seed=0, movable=2, static=1,
                 joints=2, goal_source="goal link", target="drawer", queries=420, states=9, actions=2,
                 notes=("a note",), notices=()),
    BenchmarkRequest(planners="la_rrt", budget_checks=20000, until="first"),
    BenchmarkResult(out="out/b", database="out/b/benchmark.db", results_page="out/b/results.html", crashed=0,
                    unsaved_solutions=(), summary=SUMMARY),
    ManipulateRequest(("out/rooms/rooms_7",), scale=0.5),
    ManipulateResult(out="out/m", reports=(OUTCOME,)),
    AuditRequest("out", budget=1000),
    AuditResult(puzzles=(AuditedPuzzle("rooms_7", "rooms", 7, False, ("box",), ("rooms_7: box is superfluous",)),),
                wall_seconds=3.5, report_json="out/audit/audit.json", report_markdown="out/audit/audit.md"),
    RenderRequest(size="64x48", engine="workbench", animation=False),
    RenderResult(puzzles=2, images=6, width=64, height=48, engines=("workbench",), seconds=4.0, animations=0,
                 animation_seconds=0.0, gallery="out/index.html", error=None),
    DatasetRequest("rooms,grid_world", "out/data", count=100, overrides=("n_objects=3:5",), sweep="zip"),
    DatasetResult(entries=200, ok=198, failed=2, generated=50, reused=150, seconds=120.5, puzzles_per_hour=1493.8,
                  manifest="out/data/manifest.parquet"),
]
"""A valid record of every stage's request and result."""


def _first_field(record, kind: type) -> str | None:
    return next((name for name, value in record.to_dict().items() if type(value) is kind
                 and name not in ("version", "exit_code", "request", "command")), None)


def _malformed(record) -> list[tuple[str, str, str]]:
    """(what, JSON text, what the one line must say) for ``record``: each a break of one rule."""
    data = record.to_dict()
    envelope = type(record).ENVELOPE
    field = next(name for name in data if name not in (envelope, "version", "exit_code"))
    other = "audit" if type(record).STAGE != "audit" else "check"
    cases = [
        ("missing key", {k: v for k, v in data.items() if k != field}, f"missing key {field!r}"),
        ("unknown key", {**data, "colour": "red"}, "unknown key 'colour'"),
        ("another version", {**data, "version": 2}, "this reader reads version 1"),
        ("no version", {k: v for k, v in data.items() if k != "version"}, "missing key 'version'"),
        ("another stage", {**data, envelope: other}, f"{envelope!r} is {other!r}"),
        ("a list", [data], "expected one JSON object, got a list"),
    ]
    text_field = _first_field(record, str)
    if text_field is not None:
        cases.append(("a number for text", {**data, text_field: 7}, f"{text_field!r}: expected"))
    number_field = _first_field(record, int)
    if number_field is not None:
        cases.append(("a bool for a number", {**data, number_field: True}, f"{number_field!r}: expected an integer"))
    texts = [(what, json.dumps(value), expected) for what, value, expected in cases]
    float_field = _first_field(record, float)
    if float_field is not None:
        texts.append(("NaN", json.dumps({**data, float_field: math.nan}), "non-finite number NaN"))
        texts.append(("1e400", json.dumps(data).replace(json.dumps(data[float_field]), "1e400", 1),
                      "non-finite number 1e400"))
    texts.append(("not JSON", json.dumps(data)[:-3], "not JSON"))
    if isinstance(record, StageResult):
        wrong = {**data, "exit_code": 1 - record.exit_code}
        texts.append(("an exit code the result does not give", json.dumps(wrong), "'exit_code' is"))
    return texts


CASES = [pytest.param(record, what, text, expected, id=f"{type(record).__name__}-{what}")
         for record in VALID for what, text, expected in _malformed(record)]


@pytest.mark.parametrize(("record", "what", "text", "expected"), CASES)
def test_each_reader_refuses_malformed_data_in_one_line(record, what, text, expected):
    with pytest.raises(RecordError) as caught:
        type(record).from_json(text)
    message = str(caught.value)
    assert expected in message and "\n" not in message, (what, message)
    assert message.startswith(type(record).label()), message  # it names the record it was reading


@pytest.mark.parametrize("record", VALID, ids=lambda r: type(r).__name__)
def test_the_valid_controls_are_read_back_unchanged(record):
    # The negative control of the test above: the same reader takes the unbroken record.
    text = record.to_json()
    assert type(record).from_json(text) == record
    assert json.loads(text)["version"] == type(record).VERSION


@pytest.mark.parametrize(("make", "expected"), [
    (lambda: GenerateRequest(seeds=5), "GenerateRequest: 'seeds': expected a string, got the number 5"),
    (lambda: GenerateRequest(workers=2.0), "'workers': expected an integer"),
    (lambda: BenchmarkRequest(until="never"), "'until': expected one of 'limit', 'first'"),
    (lambda: BenchmarkRequest(time_limit=math.inf), "'time_limit': the non-finite number inf"),
    (lambda: ImportRequest("a.urdf", goal=(0.1, math.nan)), "'goal[1]': the non-finite number nan"),
    (lambda: ExportRequest(()), "'folders' names no folder"),
    (lambda: CertifyResult("p", "la_rrt", "LA-RRT", 0, 10, True, 10, "solved", ("a",), ((0.0, 1.0),), 1, problems=()),
     "a path of one value per joint"),
    (lambda: ReplanResult(puzzle="p", folder="f", solved=True, budget=10, seed=0, planner=None, queries=None,
                          states=None, dependencies=None, notices=()), "'planner': expected a value"),
    (lambda: GenerateResult(puzzles=(), ok=-1, failed=0, wall_seconds=1.0), "'ok' is -1, expected a count"),
    (lambda: DatasetResult(entries=10, ok=9, failed=0, generated=10, reused=0, seconds=1.0, puzzles_per_hour=1.0,
                           manifest="m"), "must each add up to 'entries' 10"),
    (lambda: BenchmarkResult(out="o", database="d", results_page="r", crashed=0, unsaved_solutions=(),
                             summary={"cells": [{"puzzle": "p"}]}), "cells[0]: missing key 'planner'"),
])
def test_a_record_made_in_python_is_checked_as_one_read_from_data(make, expected):
    with pytest.raises(RecordError) as caught:
        make()
    assert expected in str(caught.value)
    # Control: the defaults alone make valid requests.
    assert GenerateRequest().seeds == "1-4" and BenchmarkRequest().until == "limit"


def test_every_stage_is_run_request_to_result_from_the_python_api():
    assert set(phyrogen.STAGES) == {"check", "generate", "certify", "replan", "export", "import_urdf", "benchmark",
                                    "manipulate", "audit", "render", "dataset"}
    for module_name, request_name in phyrogen.STAGES.items():
        module = importlib.import_module(f"phyrogen.stages.{module_name}")
        signature = inspect.signature(module.run)
        request = next(iter(signature.parameters.values()))
        assert request.annotation == request_name, module_name
        result_name = request_name.removesuffix("Request") + "Result"
        assert signature.return_annotation == result_name, module_name
        # The API re-exports both records, and they are the core's (the panel's) types.
        request_type, result_type = getattr(phyrogen, request_name), getattr(phyrogen, result_name)
        assert issubclass(request_type, StageRequest) and issubclass(result_type, StageResult)
        assert request_type.__module__.startswith("phyrogen_core.stage_records.")
        assert {request_type, result_type} <= {type(record) for record in VALID}  # the reader tests cover both
    with pytest.raises(TypeError, match="no stage's request"):
        phyrogen.run(CheckResult(puzzle="p", folder="f", states=1, edited=False, problems=()))  # a result is no request


@pytest.mark.parametrize(("request_", "expected"), [
    (BenchmarkRequest(time_limit=-1.0, puzzles="/nonexistent"), "time_limit must be above 0 and at most 86400"),
    (BenchmarkRequest(runs=10_001, puzzles="/nonexistent"), "runs must be in 1..10000, got 10001"),
    (ReplanRequest("/nonexistent", budget=0), "budget must be in 1..100000000 collision queries, got 0"),
    (ManipulateRequest(("/nonexistent",), scale=2.5), "scale must be in 0.05..2 scene metres"),
    (ImportRequest("/nonexistent.urdf", seed=-1), "seed must be in 0..2147483646, got -1"),
    (GenerateRequest(workers=0), "workers must be a whole number in 1.."),
    (AuditRequest("/nonexistent", budget=0), "budget must be a whole number of collision queries"),
], ids=lambda r: type(r).__name__ if not isinstance(r, str) else "")
def test_a_stage_keeps_a_python_request_in_the_command_lines_bounds(request_, expected):
    # The command line's option types keep these in bounds; a request built in Python meets the same bounds
    # in its stage, before the (missing) folder is even looked at.
    with pytest.raises(ValueError, match="^" + expected.replace(".", r"\.")):
        phyrogen.run(request_)
    # Control: within the bounds the same request goes on, to the missing folder.
    if isinstance(request_, BenchmarkRequest):
        with pytest.raises(FileNotFoundError, match="nonexistent"):
            phyrogen.run(BenchmarkRequest(time_limit=1.0, runs=2, puzzles="/nonexistent"))


@pytest.mark.parametrize("request_", [
    CheckRequest("{tmp}/missing"), CertifyRequest("{tmp}/missing", 1000), ExportRequest(("{tmp}/missing",)),
    ReplanRequest("{tmp}/missing"),
    ImportRequest("{tmp}/missing.urdf", out="{tmp}/out"), BenchmarkRequest(puzzles="{tmp}/missing", out="{tmp}/b"),
    ManipulateRequest(("{tmp}/missing",), out="{tmp}/m"), AuditRequest("{tmp}/missing", out="{tmp}/a"),
    GenerateRequest("no_such_generator", out="{tmp}/out"), RenderRequest(out="{tmp}/missing"),
    DatasetRequest("no_such_generator", "{tmp}/data", count=3),
], ids=lambda r: type(r).__name__)
def test_each_stage_refuses_a_bad_request_before_any_work(request_, tmp_path):
    data = json.loads(request_.to_json().replace("{tmp}", str(tmp_path)))
    request_ = type(request_).from_dict(data)  # a request read from data runs as one made in Python
    with pytest.raises((ValueError, FileNotFoundError)) as caught:  # what the command line answers with exit 2
        phyrogen.run(request_)
    message = str(caught.value)
    assert "\n" not in message and ("missing" in message or "no_such_generator" in message), message
    assert not any(p.name == "puzzle.json" for p in tmp_path.rglob("*"))


@pytest.mark.slow
def test_the_stages_chain_from_python(tmp_path):
    # generate -> check -> export -> certify -> replan through phyrogen.run, each result read back from its JSON.
    made = phyrogen.run(GenerateRequest("simple_slider", seeds="41", overrides=("n_objects=2",), out=str(tmp_path),
                                        workers=1))
    assert isinstance(made, GenerateResult) and (made.ok, made.failed, made.exit_code) == (1, 0, 0)
    (row,) = made.puzzles
    checked = phyrogen.run(CheckRequest(row.folder))
    assert checked.valid and checked.states > 1 and checked.exit_code == 0
    (mjcf,) = phyrogen.run(ExportRequest((row.folder,))).files
    assert mjcf.endswith("simple_slider_41.xml")
    files = {p: p.read_bytes() for p in sorted(tmp_path.rglob("*")) if p.is_file()}
    certified = phyrogen.run(CertifyRequest(row.folder, 100_000, "la_rrt"))  # in memory: the folder stays as it is
    assert certified.certified and certified.exit_code == 0 and len(certified.path) >= 2
    assert certified.path[-1] != certified.path[0]
    assert {p: p.read_bytes() for p in sorted(tmp_path.rglob("*")) if p.is_file()} == files
    assert phyrogen.run(CertifyRequest(row.folder, 100_000, "la_rrt")) == certified  # seeded: the same path
    starved = phyrogen.run(CertifyRequest(row.folder, 1, "la_rrt"))  # control: one check solves nothing
    assert not starved.solved and starved.path == () and starved.exit_code == 1
    replanned = phyrogen.run(ReplanRequest(row.folder))
    assert replanned.solved and replanned.states == phyrogen.run(CheckRequest(row.folder)).states
    for result in (made, checked, certified, replanned):
        assert type(result).from_json(result.to_json()) == result
    # Negative control: a certificate cut to its two ends runs through a blocker, and the stage says so.
    record = json.loads((tmp_path / "simple_slider" / "simple_slider_41" / "puzzle.json").read_text())
    record["certificate"] = [record["certificate"][0], record["certificate"][-1]]
    (tmp_path / "simple_slider" / "simple_slider_41" / "puzzle.json").write_text(json.dumps(record))
    broken = phyrogen.run(CheckRequest(row.folder))
    assert not broken.valid and broken.exit_code == 1


def test_the_manipulation_outcome_holds_exactly_the_executors_report_and_its_folder():
    # The manipulate stage reads each report (manipulation.execution_records.ManipulationReport, which the core
    # may not import) into its record strictly: a field added there must be added here, or every run would end
    # in the record's refusal; this says so in a test first.
    import dataclasses

    from manipulation.execution_records import ManipulationReport

    report = {field.name for field in dataclasses.fields(ManipulationReport)}
    assert {field.name for field in dataclasses.fields(ManipulationOutcome)} == report | {"folder"}
    # Control: a report with one more field is refused in one line naming it.
    with pytest.raises(RecordError, match="unknown key 'grip_force'"):
        ManipulationOutcome.from_dict({**OUTCOME.to_dict(), "grip_force": 1.0})
