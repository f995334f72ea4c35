"""The real Blender binary: the entry script in the background, and the add-on panel in the UI under Xvfb."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from blender_support import blender_environment, tool

from phyrogen_core.export import read_puzzle_dir
from solver.planning.problem import verify_certificate

REPOSITORY = Path(__file__).resolve().parent.parent
BLENDER = tool("blender")
pytestmark = [pytest.mark.blender, pytest.mark.slow]
needs_blender = pytest.mark.skipif(BLENDER is None,
                                   reason="the blender binary is not installed (apt-get install blender)")


@needs_blender
def test_generate_script_in_blender_background(tmp_path):
    result = subprocess.run(
        [BLENDER, "--background", "--factory-startup", "--python-exit-code", "1", "--python",
         str(REPOSITORY / "scripts" / "generate.py"), "--", "--generator", "simple_slider", "--seed", "2",
         "--out", str(tmp_path / "out")],
        capture_output=True, text=True, timeout=300, env=blender_environment(tmp_path))
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    folder = tmp_path / "out" / "simple_slider" / "simple_slider_2"
    assert "URDF from the scene equals the core's" in result.stdout
    assert (folder / "simple_slider_2.blend").is_file() and (folder / "urdf" / "simple_slider_2.urdf").is_file()


@needs_blender
def test_generate_script_started_wrongly_says_what_to_do(tmp_path):
    result = subprocess.run(
        [BLENDER, "--background", "--factory-startup", "--python-exit-code", "1", "--python",
         str(REPOSITORY / "scripts" / "generate.py"), "--generator", "simple_slider"],
        capture_output=True, text=True, timeout=120, env=blender_environment(tmp_path))
    assert result.returncode != 0
    assert "must follow '--'" in result.stdout + result.stderr


@needs_blender
def test_generate_script_help_lists_the_generators(tmp_path):
    from phyrogen_core.registry import all_generators

    result = subprocess.run(
        [BLENDER, "--background", "--factory-startup", "--python-exit-code", "1", "--python",
         str(REPOSITORY / "scripts" / "generate.py"), "--", "--help"],
        capture_output=True, text=True, timeout=120, env=blender_environment(tmp_path))
    assert "usage: blender --background --python scripts/generate.py" in result.stdout, result.stdout[-2000:]
    assert "usage: usage:" not in result.stdout
    assert all(name in result.stdout for name in all_generators())


def test_generate_script_under_plain_python(tmp_path):
    pytest.importorskip("bpy", reason="the bpy wheel is not installed")
    environment = blender_environment(tmp_path)
    environment["BLENDER_USER_RESOURCES"] = str(tmp_path / "resources")
    result = subprocess.run([sys.executable, str(REPOSITORY / "scripts" / "generate.py"), "--generator",
                             "move_n_times", "--seed", "1", "--out", str(tmp_path / "out")],
                            capture_output=True, text=True, timeout=300, env=environment)
    assert result.returncode == 0, result.stderr[-2000:]
    assert (tmp_path / "out" / "move_n_times" / "move_n_times_1" / "move_n_times_1.blend").is_file()


@needs_blender
@pytest.mark.skipif(tool("xvfb-run") is None or tool("xdotool") is None,
                    reason="xvfb-run and xdotool are needed for the UI check (apt-get install xvfb xauth xdotool)")
def test_panel_generate_replan_manipulate_clicks_in_the_real_ui(tmp_path):
    addon = tmp_path / "scripts" / "addons" / "phyrogen"
    shutil.copytree(REPOSITORY / "blender_addon", addon, ignore=shutil.ignore_patterns("__pycache__"))
    result_path, screenshot = tmp_path / "result.json", tmp_path / "panel.png"
    before, during = tmp_path / "panel-before.png", tmp_path / "panel-during.png"
    generated = tmp_path / "panel-generated.png"
    run = subprocess.run(
        ["xvfb-run", "-a", "-s", "-screen 0 1600x1200x24", BLENDER, "--factory-startup", "--python",
         str(REPOSITORY / "tests" / "blender_gui_check.py"), "--", str(result_path), str(screenshot), str(before),
         str(during), str(generated)],
        capture_output=True, text=True, timeout=400, env=blender_environment(tmp_path), cwd=tmp_path)
    assert result_path.is_file(), run.stdout[-3000:] + run.stderr[-3000:]
    result = json.loads(result_path.read_text())
    assert result["ok"], result
    assert {"base_link", "goal", "obj_00", "obj_01"} <= set(result["objects"])
    assert all(p.is_file() and p.stat().st_size > 10_000 for p in (screenshot, before, during, generated))
    assert result["during"].startswith("Manipulate simple_slider_1: ")  # the status line while it ran
    assert result["buttons_enabled_after"]
    # Generate framed the new puzzle: the view looks at the middle of its visual objects' bounds (the
    # default view looks at the origin from about 17 m, where the puzzle was small), from a few metres.
    # Blender's factory scene as it starts: Generate removed the untouched default cube, which hid the
    # puzzle at the origin, and said so; the camera and the light stay.
    assert result["objects_at_start"] == ["Camera", "Cube", "Light"]
    assert result["scene_after_generate"] == ["Camera", "Light"]
    generate = next(step for step in result["steps"] if step["step"] == "Generate")
    assert "default cube removed" in generate["message"]
    view = result["view_after_generate"]
    middle = [(lo + hi) / 2 for lo, hi in zip(view["low"], view["high"], strict=True)]
    assert max(abs(a - b) for a, b in zip(view["location"], middle, strict=True)) < 1e-3, view
    assert 1.0 < view["distance"] < 10.0, view
    # Each click ran its job in a subprocess: the UI's timers kept running meanwhile (not frozen),
    # with the job's progress in the status bar, and its outcome landed in the panel.
    assert [step["step"] for step in result["steps"]] == ["Generate", "Re-plan", "Manipulate"]
    for step in result["steps"]:
        assert step["state"] == "DONE" and step["ticks_while_running"] > 0, step
        assert any("Esc or right-click cancels" in status for status in step["statuses"]), step
    folder = Path(result["output"]) / "simple_slider" / "simple_slider_1"
    loaded = read_puzzle_dir(folder)  # the scene's edit, certified anew by Re-plan
    assert loaded.record.certificate_verified and loaded.record.provenance.replanned is not None
    assert verify_certificate(loaded.chain, loaded.certificate, loaded.goal, start=loaded.start) == []
    report = json.loads((Path(result["manipulation_output"]) / "report.json").read_text())
    assert result["panel"][:2] == ["Manipulate simple_slider_1", "DONE"]
    assert result["panel"][3] == "Execution\t" + ("succeeded" if report["success"] else "failed")  # the table
    assert result["panel"][2].startswith("simple_slider_1: execution " + ("succeeded" if report["success"]
                                                                          else "failed"))
    assert (Path(result["manipulation_output"]) / "simple_slider_1.mp4").is_file()
