"""The panel's long operations as jobs in subprocesses (blender_addon.jobs): progress, cancel, outcome.

The first test needs no Blender: a real ``phyrogen benchmark`` is started,
shows its progress, and Cancel ends its whole process group. The others
drive the panel's operations in the bpy wheel through the same functions its
modal operator calls from its timer (``begin``, ``advance``, ``cancel_running``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from blender_support import FakeLayout, private_blender_home

from blender_addon.jobs import Job, group_alive, phyrogen_command
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.record import PuzzleRecord
from solver.planning.problem import verify_certificate

TIMEOUT = 300.0  # a hung job fails the test instead of hanging it; no result depends on it


def _generate(out: Path, generator: str = "simple_slider", seed: int = 2) -> Path:
    result = Job("Generate", phyrogen_command("generate", "--generator", generator, "--seeds", str(seed),
                                              "--out", str(out), "--workers", "1", "--quiet")).wait()
    assert result.ok, result
    return PuzzleFolder.at(out, generator, f"{generator}_{seed}").path


def _until(condition, what: str):
    deadline = time.monotonic() + TIMEOUT
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"no {what} within {TIMEOUT} s")


def _long_benchmark(folder: Path, out: Path) -> list[str]:
    # Every run lasts its time limit (quick profile: 50 runs of 4 s on 2 workers): long enough to cancel.
    return phyrogen_command("benchmark", "--puzzles", str(folder), "--profile", "quick", "--out", str(out))


def test_job_shows_progress_and_cancel_ends_its_process_group(tmp_path):
    folder = _generate(tmp_path / "out")
    job = Job("Benchmark", _long_benchmark(folder, tmp_path / "bench"))
    fraction = _until(lambda: (job.progress()[0] or 0) > 0 and job.progress()[0], "progress")
    assert 0 < fraction < 1
    assert "%" in job.status_text() and "Esc" in job.status_text()
    job.cancel()
    assert "cancelling" in job.status_text()
    result = _until(job.poll, "end after cancel")
    assert result.cancelled and not result.ok and result.returncode in (130, 143, -15)
    assert not group_alive(job.pid)  # the command and every worker it started are gone
    # The contract: no half-written file; finished runs kept in the journal, each line whole.
    lines = (tmp_path / "bench" / "runs.jsonl").read_text().splitlines()
    assert all(json.loads(line)["record"]["puzzle"] == folder.name for line in lines)
    assert not [p for p in (tmp_path / "bench").rglob("*") if p.name.startswith(".") or p.suffix == ".tmp"]


def test_failed_job_reports_the_commands_error_line(tmp_path):
    result = Job("Re-plan", phyrogen_command("replan", str(tmp_path / "nowhere"))).wait()
    assert result.returncode == 2 and not result.cancelled
    assert "no such puzzle folder" in result.last_line


@pytest.fixture(scope="module")
def panel():
    private_blender_home()
    bpy = pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    from blender_addon import ui

    bpy.ops.wm.read_factory_settings(use_empty=True)
    ui.register()
    yield bpy, ui
    ui.unregister()


def _run(bpy, ui, operation: str) -> tuple[bool, str, list[str]]:
    """What the modal operator does: begin, then advance on every timer tick until the job ends."""
    job = ui.begin(bpy.context, operation)
    statuses = []
    outcome = _until(lambda: ui.advance(bpy.context) or statuses.append(bpy.context.scene.phyrogen.job_status),
                     f"end of {operation}")
    assert not group_alive(job.pid)
    return (*outcome, statuses)


def _drawn(bpy, ui) -> list[str]:
    log = []
    ui.draw_panel(FakeLayout(log), bpy.context.scene.phyrogen, phobos=False)
    return [text for kind, text in log if kind == "label"]


@pytest.mark.blender
@pytest.mark.slow
def test_panel_generate_edit_replan_benchmark_manipulate(panel, tmp_path):
    bpy, ui = panel
    settings = bpy.context.scene.phyrogen
    settings.generator, settings.seed, settings.output = "simple_slider", 2, str(tmp_path)
    ok, message, statuses = _run(bpy, ui, "generate")
    assert ok, message
    assert statuses and all(s.startswith("Generate simple_slider_2") for s in statuses)
    assert settings.result_state == "DONE" and "simple_slider_2: written to" in settings.result_message
    folder = tmp_path / "simple_slider" / "simple_slider_2"

    # An edit: a blocker moves along y (still clear of the others at the start). Re-plan exports the
    # scene as it is and certifies it anew; the export alone keeps the old certificate, marked unverified.
    bpy.data.objects["obj_01"].location.y -= 0.25
    ok, message, _ = _run(bpy, ui, "replan")
    assert ok, message
    assert "new certificate by" in settings.result_message
    loaded = read_puzzle_dir(folder)
    assert loaded.record.certificate_verified and loaded.record.provenance.replanned.queries > 0
    assert verify_certificate(loaded.chain, loaded.certificate, loaded.goal, start=loaded.start) == []
    from blender_addon.scene import read_chain

    assert read_chain(bpy.data.collections["simple_slider_2"]) == loaded.chain  # the scene shows the edit
    stored = PuzzleRecord.from_json(bpy.data.collections["simple_slider_2"]["phyrogen/metadata"])
    assert stored.certificate == loaded.certificate  # the new certificate is in the scene
    assert bpy.ops.phyrogen.validate() == {"FINISHED"}

    ok, message, statuses = _run(bpy, ui, "benchmark")
    assert ok, message
    assert any("%" in s for s in statuses)  # the progress bar's share of runs, as the status bar shows it
    summary = settings.result_details.splitlines()
    assert [line.split(":")[0] for line in summary] == ["LA-RRT", "LA-RRT+push (ours)", "RRT*", "LBT-RRT", "BIT*"]
    cells = json.loads((tmp_path / "benchmark" / "simple_slider_2" / "summary.json").read_text())["cells"]
    assert [f"{c['planner']}: {c['successes']}/{c['runs']}" for c in cells] == [
        line.split(" [")[0] for line in summary]  # the panel shows the benchmark's own numbers
    assert all(line in _drawn(bpy, ui) for line in summary)

    ok, message, _ = _run(bpy, ui, "manipulate")
    assert ok, message
    report = json.loads((tmp_path / "manipulation" / "simple_slider_2" / "report.json").read_text())
    assert ("succeeded" if report["success"] else "failed") in settings.result_message
    assert ui.manipulation_path(settings, "VIDEO").is_file()
    assert len(list(ui.manipulation_path(settings, "FRAMES").glob("*.png"))) == 4
    log = []
    ui.draw_panel(FakeLayout(log), settings, phobos=False)
    assert ("operator", "phyrogen.open_manipulation") in log and ("label", "Manipulate: done") in log


@pytest.mark.blender
@pytest.mark.slow
def test_panel_cancel_stops_the_job_and_says_so(panel, tmp_path):
    bpy, ui = panel
    settings = bpy.context.scene.phyrogen
    settings.generator, settings.seed, settings.output = "simple_slider", 3, str(tmp_path)
    assert bpy.ops.phyrogen.generate() == {"FINISHED"}  # from a script: the job is waited for
    operation = ui.Operation("Benchmark", lambda context: Job(
        "Benchmark", _long_benchmark(tmp_path / "simple_slider" / "simple_slider_3", tmp_path / "bench")),
        lambda context, result: ("finished", []))
    ui.OPERATIONS["long_benchmark"] = operation
    try:
        job = ui.begin(bpy.context, "long_benchmark")
        assert not bpy.ops.phyrogen.manipulate.poll()  # one job at a time
        _until(lambda: ui.advance(bpy.context) is None and "%" in settings.job_status, "progress")
        log = []
        ui.draw_panel(FakeLayout(log), settings, phobos=False)
        assert ("operator", "phyrogen.cancel_job") in log
        assert bpy.ops.phyrogen.cancel_job() == {"FINISHED"}
        ok, message = _until(lambda: ui.advance(bpy.context), "end after cancel")
    finally:
        del ui.OPERATIONS["long_benchmark"]
    assert not ok and message == "Benchmark cancelled"
    assert not group_alive(job.pid)
    assert settings.result_state == "CANCELLED" and "Benchmark: cancelled" in _drawn(bpy, ui)
    assert bpy.ops.phyrogen.manipulate.poll()
