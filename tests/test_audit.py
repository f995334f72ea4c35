"""``phyrogen audit``: passes a generated puzzle, names a superfluous object, catches a penetrating
certificate, refuses bad input with one line and exit code 2, and gives the same report twice."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from manipulation.replay import PENETRATION_TOLERANCE, PyBulletReferee
from phyrogen.cli import build_parser, main
from phyrogen_core.export import read_puzzle_dir, write_puzzle
from phyrogen_core.geometry import Pose
from phyrogen_core.puzzle import Puzzle
from solver.pipelines.audit import (
    DEFAULT_BUDGET,
    MARKDOWN_MARKER,
    MAX_BUDGET,
    REPORT_FORMAT,
    AuditSettings,
    CertificateAudit,
    PuzzleAudit,
    PuzzleToAudit,
    Replay,
    report_data,
    report_markdown,
)
from solver.pipelines.generation import Job, run_jobs
from solver.validation.judge import NO_GOAL_STATE, NO_PATH

BUDGET = "3000"
"""Queries per attempt in these tests: a simple slider with one object too many is solved in far
fewer; the necessary objects stay unsolved at any budget."""


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> dict[int, Puzzle]:
    """Simple Slider seeds 5 and 6 (not the paper's 1-4), generated once for this module."""
    out = tmp_path_factory.mktemp("generated")
    reports = list(run_jobs([Job("simple_slider", 5), Job("simple_slider", 6)], out_root=out, workers=1))
    assert all(r.error is None for r in reports), [r.error for r in reports]
    return {r.seed: r.puzzle for r in reports}


def _export(puzzle: Puzzle, root: Path) -> Path:
    return write_puzzle(puzzle, root)


def _audit(folder: Path, out: Path, *extra: str) -> int:
    return main(["audit", str(folder), "--budget", BUDGET, "--out", str(out), "--quiet", *extra])


def _report(out: Path) -> dict:
    return json.loads((out / "audit.json").read_text())


def test_a_generated_puzzle_passes(generated, tmp_path, capsys):
    folder = _export(generated[5], tmp_path / "puzzles")
    out = tmp_path / "audit"
    assert _audit(folder, out) == 0
    stdout = capsys.readouterr().out
    row = next(line for line in stdout.splitlines() if line.startswith("simple_slider"))
    assert row.split()[:4] == ["simple_slider", "5", "6", "6"] and row.endswith("ok")
    report = _report(out)
    assert report["format"] == REPORT_FORMAT and report["failed"] == 0
    (puzzle,) = report["puzzles"]
    assert puzzle["ok"] and puzzle["superfluous"] == []
    assert [o["name"] for o in puzzle["objects"]] == ["obj_01", "obj_02", "obj_03", "obj_04", "obj_05"]
    assert all(not o["superfluous"] and o["path"] == [] for o in puzzle["objects"])
    # Both judges ran on every object, and each necessary one says why (goal region empty or no path).
    assert report["settings"]["judges"] == ["la_rrt_push", "la_rrt_paper"]
    for o in puzzle["objects"]:
        assert o["solved_by"] == [] and o["necessity"] in (NO_GOAL_STATE, NO_PATH), o["necessity"]
        second = o["second_judge"]
        assert 0 < second["checks"] <= second["budget"] + 8 and second["budget"] == int(BUDGET)
        assert (second["goals"]["states"] == 0) == (o["necessity"] == NO_GOAL_STATE), second
    assert puzzle["certificate"]["replay"]["deepest_penetration"] <= PENETRATION_TOLERANCE
    assert puzzle["certificate"]["replay"]["states"] > 1000  # densified at 2 mm
    assert (out / "audit.md").read_text().splitlines()[0] == MARKDOWN_MARKER


def _with_a_superfluous_object(puzzle: Puzzle) -> Puzzle:
    """``puzzle`` plus a copy of its last slider 20 m away: it blocks nothing."""
    last = puzzle.objects[-1]
    x, y, z = last.pose.xyz
    extra = dataclasses.replace(last, name="obj_99", pose=Pose.planar(x + 20.0, y, z, last.pose.rpy[2]))
    grown = dataclasses.replace(puzzle, objects=(*puzzle.objects, extra))
    old = list(puzzle.joint_order)
    # The extra slider stays at its start (0) all along the certificate.
    certificate = tuple(tuple(state[old.index(j)] if j in old else 0.0 for j in grown.joint_order)
                        for state in puzzle.certificate)
    return dataclasses.replace(grown, certificate=certificate)


def test_a_superfluous_object_fails_the_audit_and_is_named_with_its_path(generated, tmp_path, capsys):
    folder = _export(_with_a_superfluous_object(generated[6]), tmp_path / "puzzles")
    out = tmp_path / "audit"
    assert _audit(folder, out, "--workers", "2") == 1
    stdout = capsys.readouterr().out
    assert "FAILED: obj_99" in stdout and "obj_99 is superfluous" in stdout
    first = (out / "audit.json").read_bytes()
    (puzzle,) = _report(out)["puzzles"]
    assert puzzle["superfluous"] == ["obj_99"] and not puzzle["ok"]
    assert [o["necessity"] for o in puzzle["objects"]].count("superfluous") == 1
    assert puzzle["certificate"]["replay_ok"], "the certificate itself is fine"
    found = next(o for o in puzzle["objects"] if o["name"] == "obj_99")
    assert "la_rrt_push" in found["solved_by"], found["solved_by"]
    loaded = read_puzzle_dir(folder)
    column = loaded.joint_order.index("obj_99")
    path = found["path"]
    assert path[0] == list(loaded.start) and all(state[column] == 0.0 for state in path)
    assert loaded.goal.is_reached(loaded.chain.state_dict(path[-1]))
    assert found["replay"]["states"] > len(path)
    # Planned with every shape shrunk by the margin: it must hold at that geometry in PyBullet.
    assert found["robust_ok"] is True and found["robust_threshold"] == pytest.approx(PENETRATION_TOLERANCE + 0.02)
    assert isinstance(found["exact_ok"], bool)
    # Same folder, same verdicts and paths, whatever the number of workers; the audit's own
    # report is replaced.
    assert _audit(folder, out, "--workers", "1") == 1
    assert (out / "audit.json").read_bytes() == first


def test_a_penetrating_certificate_fails(generated, tmp_path, capsys):
    folder = _export(generated[5], tmp_path / "puzzles")
    metadata = json.loads((folder / "puzzle.json").read_text())
    # Straight from start to end: the target slides through the sliders that block it.
    metadata["certificate"] = [metadata["certificate"][0], metadata["certificate"][-1]]
    (folder / "puzzle.json").write_text(json.dumps(metadata))
    loaded = read_puzzle_dir(folder)
    replay = PyBulletReferee().replay(folder / "urdf" / f"{loaded.name}.urdf", loaded.chain,
                                      loaded.certificate)
    assert replay.depth > 0.05 and len(replay.links) == 2

    out = tmp_path / "audit"
    assert _audit(folder, out) == 1
    assert "the certificate penetrates" in capsys.readouterr().out
    (puzzle,) = _report(out)["puzzles"]
    assert not puzzle["certificate"]["replay_ok"]
    assert puzzle["certificate"]["replay"]["deepest_penetration"] == pytest.approx(replay.depth)
    assert any("collides" in p for p in puzzle["certificate"]["problems"])  # our checker agrees


def _edit_metadata(folder: Path, edit) -> None:
    path = folder / "puzzle.json"
    path.write_text(edit(path.read_text()))


def _set_margin(value: str):
    return lambda text: text.replace('"interlock_margin": 0.01', f'"interlock_margin": {value}')


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("missing folder", "no such folder"),
        ("malformed puzzle.json", "malformed JSON"),
        ("non-finite margin", "must be finite"),
        ("margin too large", "interlock_margin = 0.5"),
        ("margin not a number", "interlock_margin = 'wide'"),
        ("budget zero", "--budget: must be a whole number in 1..10000000"),
        ("budget not a number", "--budget: must be a whole number"),
        ("out is a file", "is a file"),
        ("out holds a user's audit.md", "was not written by phyrogen audit"),
    ],
)
def test_bad_input_is_one_line_and_exit_code_2(case, message, generated, tmp_path, capsys):
    folder = _export(generated[5], tmp_path / "puzzles")
    out = tmp_path / "audit"
    budget = BUDGET
    if case == "missing folder":
        shutil.rmtree(folder)
    elif case == "malformed puzzle.json":
        _edit_metadata(folder, lambda text: text[:-20])
    elif case == "non-finite margin":
        _edit_metadata(folder, _set_margin("NaN"))
    elif case == "margin too large":
        _edit_metadata(folder, _set_margin("0.5"))
    elif case == "margin not a number":
        _edit_metadata(folder, _set_margin('"wide"'))
    elif case.startswith("budget"):
        budget = "0" if case == "budget zero" else "lots"
    elif case == "out is a file":
        out.write_text("mine")
    else:
        out.mkdir()
        (out / "audit.md").write_text("# my notes\n")
    capsys.readouterr()
    code = main(["audit", str(folder), "--budget", budget, "--out", str(out), "--quiet"])
    captured = capsys.readouterr()
    assert code == 2, captured
    assert len(captured.err.strip().splitlines()) == 1 and message in captured.err, captured.err
    assert captured.out == ""
    assert not (out / "audit.json").exists()
    if case == "out holds a user's audit.md":
        assert (out / "audit.md").read_text() == "# my notes\n"


def test_help_states_the_budget_constants():
    audit = build_parser()._subparsers._group_actions[0].choices["audit"]
    text = " ".join(audit.format_help().split())
    assert f"default {DEFAULT_BUDGET}" in text and f"at most {MAX_BUDGET}" in text


def test_a_report_cut_short_says_so():
    puzzle = PuzzleToAudit("f", "simple_slider_9", "simple_slider", 9, 0.01, 2, ("obj_01",), 2, ("obj_00", "obj_01"))
    audit = PuzzleAudit(puzzle, CertificateAudit((), Replay(0.0, 10), 1e-3), ())
    settings = AuditSettings(DEFAULT_BUDGET, "PyBullet", 0.002, 1e-3)
    assert report_data([audit], settings)["complete"] is True
    data = report_data([audit], settings, total=3)
    assert data["complete"] is False and data["puzzles_total"] == 3
    assert "Incomplete: the audit stopped after 1 of 3 puzzles" in report_markdown([audit], settings, total=3)
