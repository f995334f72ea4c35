"""The panel's long operations as jobs in subprocesses (blender_addon.jobs): progress, cancel, outcome.

The first test needs no Blender: a real ``phyrogen benchmark`` is started,
shows its progress, and Cancel ends its whole process group. The others
drive the panel's operations in the bpy wheel through the same functions its
modal operator calls from its timer (``begin``, ``advance``, ``cancel_running``).
"""

from __future__ import annotations

import dataclasses
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
    # Nothing of the job is left: its workers may end a moment after the command on a busy machine.
    _until(lambda: not group_alive(job.pid), f"the processes of {operation} to end")
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
    made = read_puzzle_dir(tmp_path / "simple_slider" / "simple_slider_2")
    table = ui.result_table(settings)
    assert table.columns == ("Puzzle", "simple_slider_2")
    assert dict(table.rows)["Objects"] == str(len(made.chain.object_names))
    assert dict(table.rows)["Actions"] == str(made.record.certificate_actions)
    folder = tmp_path / "simple_slider" / "simple_slider_2"

    # An edit: a blocker moves along y (still clear of the others at the start). Re-plan exports the
    # scene as it is and certifies it anew; the export alone keeps the old certificate, marked unverified.
    bpy.data.objects["obj_01"].location.y -= 0.25
    ok, message, _ = _run(bpy, ui, "replan")
    assert ok, message
    assert "new certificate by" in settings.result_message
    loaded = read_puzzle_dir(folder)
    assert dict(ui.result_table(settings).rows)["States"] == str(len(loaded.certificate))  # from replan --json
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
    table = ui.result_table(settings)
    assert table.columns == ("Planner", "Solved", "Time")
    assert [row[0] for row in table.rows] == ["LA-RRT", "LA-RRT+push", "RRT*", "LBT-RRT", "BIT*"]
    cells = json.loads((tmp_path / "benchmark" / "simple_slider_2" / "summary.json").read_text())["cells"]
    # The panel shows the benchmark's own numbers (from its --json result, summary.json's content).
    assert [(c["planner"].removesuffix(" (ours)"), f"{c['successes']}/{c['runs']}") for c in cells] == [
        row[:2] for row in table.rows]
    log = []
    ui.draw_panel(FakeLayout(log), settings, phobos=False)
    assert ("list", "PHYROGEN_UL_results") in log and ("label", "Planner") in log

    ok, message, _ = _run(bpy, ui, "manipulate")
    assert ok, message
    report = json.loads((tmp_path / "manipulation" / "simple_slider_2" / "report.json").read_text())
    assert ("succeeded" if report["success"] else "failed") in settings.result_message
    assert ui.manipulation_path(settings, "VIDEO").is_file()
    assert len(list(ui.manipulation_path(settings, "FRAMES").glob("frame_*.png"))) == 4
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


@pytest.mark.blender
def test_parameters_are_passed_typed(panel):
    """Each generator's panel parameters reach ``phyrogen generate`` as text its registry reads back to the
    same values (a string as itself: ``ring``, not ``'ring'``)."""
    bpy, ui = panel
    from phyrogen_core.registry import all_generators

    assert [ui.override_text(v) for v in ("ring", 0.1, 7, True, False)] == ["ring", "0.1", "7", "true", "false"]
    for name, spec in all_generators().items():
        bpy.context.scene.phyrogen.generator = name
        _, params = ui.chosen_params(bpy.context.scene.phyrogen)
        command = ui.generate_command(name, 3, params, Path("out"))
        overrides = dict(a.removeprefix("--set=").split("=", 1) for a in command if a.startswith("--set="))
        assert spec.parse_params(overrides) == params, name
        assert not any(v.startswith(("'", '"')) for v in overrides.values()), overrides


@pytest.mark.blender
def test_a_button_whose_modules_are_missing_is_hidden_with_a_line(panel, monkeypatch):
    bpy, ui = panel
    settings = bpy.context.scene.phyrogen
    log = []
    ui.draw_panel(FakeLayout(log), settings, phobos=False)
    assert ("operator", "phyrogen.benchmark") in log  # control: everything is installed here
    monkeypatch.setitem(ui.OPERATIONS, "benchmark", dataclasses.replace(
        ui.OPERATIONS["benchmark"], needs=("matplotlib", "no_such_module_here")))
    log = []
    ui.draw_panel(FakeLayout(log), settings, phobos=False)
    assert ("operator", "phyrogen.benchmark") not in log
    assert ("label", "Benchmark needs no_such_module_here") in log
    with pytest.raises(RuntimeError, match="Benchmark needs no_such_module_here: install"):
        ui.begin(bpy.context, "benchmark")


def test_the_first_job_says_it_compiles_the_kernels(monkeypatch, tmp_path):
    from blender_addon import environment

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert not environment.collision_kernels_cached()
    job = Job("Generate x", ["sleep", "30"], note="compiling collision kernels (first run only: about 20 s of CPU)...")
    try:
        assert job.status_text().startswith("Generate x: compiling collision kernels (first run only")
    finally:
        job.cancel()
        _until(job.poll, "end")
    cache = tmp_path / "work" / "solver" / "collision"
    cache.mkdir(parents=True)
    (cache / "kernels.box_box-16.py311.nbi").write_bytes(b"")  # what numba writes once it compiled them
    assert environment.collision_kernels_cached()
