"""Bad output paths and broken puzzle folders, given to the commands that write (generate, render,
manipulate) or read (check): found before any work, exit 2, one stderr line naming the path,
nothing on stdout, nothing created, no traceback."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hostile_support import hostile_puzzle, refused, urdf_file

from phyrogen_core.export import write_puzzle

REPOSITORY = Path(__file__).resolve().parent.parent
AS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


@pytest.fixture
def puzzles(tmp_path) -> Path:
    """A folder of generated puzzles holding one valid puzzle, hostile/hostile_1."""
    write_puzzle(hostile_puzzle(), tmp_path / "puzzles")
    return tmp_path / "puzzles"


@pytest.fixture
def no_work(monkeypatch):
    """Every command's work (puzzle generation, Blender workers, simulation, the gallery) fails the
    test if it starts: the refusals below must come first."""
    import blender_addon.gallery
    import blender_addon.rendering
    import manipulation.batch
    import solver.pipelines.generation

    def started(*args, **kwargs):
        raise AssertionError("work started before the input was checked")

    monkeypatch.setattr(solver.pipelines.generation, "run_jobs", started)
    monkeypatch.setattr(blender_addon.rendering, "_run_workers", started)
    monkeypatch.setattr(blender_addon.gallery, "write_gallery", started)
    monkeypatch.setattr(manipulation.batch, "execute_puzzle", started)


def a_file(tmp_path: Path) -> tuple[Path, str]:
    path = tmp_path / "taken"
    path.write_text("a user's file")
    return path, "is a file"


def under_a_file(tmp_path: Path) -> tuple[Path, str]:
    return a_file(tmp_path)[0] / "out", "lies under"


def dangling_link(tmp_path: Path) -> tuple[Path, str]:
    path = tmp_path / "link"
    path.symlink_to(tmp_path / "nowhere" / "out")
    return path, "broken symbolic link"


def in_proc(tmp_path: Path) -> tuple[Path, str]:
    """Unwritable for root as well: procfs refuses new entries whatever the permission bits."""
    return Path("/proc/self/phyrogen-out"), "/proc/self"


def in_sys(tmp_path: Path) -> tuple[Path, str]:
    """Root passes the permission check (os.access) here; only trying to write finds the refusal."""
    if not os.path.isdir("/sys"):
        pytest.skip("no /sys on this system")
    return Path("/sys/phyrogen-out"), "/sys"


def read_only(tmp_path: Path) -> tuple[Path, str]:
    if AS_ROOT:
        pytest.skip("root writes into a folder without write permission; in_proc and in_sys cover unwritable "
                    "paths for root")
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o555)
    return folder / "out", "no permission"


BAD_OUTPUTS = [a_file, under_a_file, dangling_link, in_proc, in_sys, read_only]


def commands(puzzles: Path, out: Path) -> dict[str, list[str]]:
    return {
        "generate": ["generate", "--generator", "simple_slider", "--seeds", "1", "--out", str(out), "--quiet"],
        "render": ["render", "--out", str(out), "--quiet"],
        "render --gallery-only": ["render", "--out", str(out), "--gallery-only"],
        "manipulate": ["manipulate", str(puzzles / "hostile" / "hostile_1"), "--out", str(out), "--quiet"],
    }


@pytest.mark.parametrize("command", ["generate", "render", "render --gallery-only", "manipulate"])
@pytest.mark.parametrize("bad", BAD_OUTPUTS, ids=lambda f: f.__name__)
def test_an_unusable_output_folder_is_refused_up_front(command, bad, tmp_path, puzzles, capsys, no_work):
    out, what = bad(tmp_path)
    refused(commands(puzzles, out)[command], capsys, tmp_path, str(out), what)


@pytest.mark.parametrize("bad", [a_file, under_a_file, dangling_link, in_proc])
def test_check_of_a_path_that_is_no_puzzle_folder_is_refused(bad, tmp_path, capsys):
    path, _ = bad(tmp_path)
    refused(["check", str(path)], capsys, tmp_path, str(path))


def test_a_summary_table_that_cannot_be_written_is_refused_before_any_simulation(tmp_path, puzzles, capsys,
                                                                                 no_work):
    base = ["manipulate", str(puzzles), "--out", str(tmp_path / "runs"), "--no-video", "--quiet", "--table"]
    taken, _ = a_file(tmp_path)
    refused(base + [str(taken / "table.md")], capsys, tmp_path, str(taken), "is a file")
    refused(base + [str(taken / "deeper" / "table.md")], capsys, tmp_path, str(taken), "lies under")
    (tmp_path / "a_folder").mkdir()
    refused(base + [str(tmp_path / "a_folder")], capsys, tmp_path, str(tmp_path / "a_folder"), "is a folder")
    refused(base + ["/proc/self/table.md"], capsys, tmp_path, "/proc/self")


def test_a_file_where_a_puzzles_manipulation_output_goes_is_refused(tmp_path, puzzles, capsys, no_work):
    runs = tmp_path / "runs"
    runs.mkdir()
    (runs / "hostile_1").write_text("not the output folder")
    refused(["manipulate", str(puzzles), "--out", str(runs), "--quiet"], capsys, tmp_path,
            str(runs / "hostile_1"), "not a folder")


def test_a_file_where_a_generators_folder_goes_is_refused_before_any_puzzle(tmp_path, capsys, no_work):
    out = tmp_path / "out"
    out.mkdir()
    (out / "grid_world").write_text("a user's notes")
    refused(["generate", "--generator", "simple_slider,grid_world", "--seeds", "2", "--out", str(out), "--quiet"],
            capsys, tmp_path, str(out / "grid_world"), "is a file")
    assert (out / "grid_world").read_text() == "a user's notes"


# -- broken puzzle folders ---------------------------------------------------------------
def broken_json(folder: Path) -> str:
    (folder / "puzzle.json").write_text("{ not json")
    return "puzzle.json: malformed JSON"


def missing_urdf(folder: Path) -> str:
    urdf_file(folder).unlink()
    return f"{urdf_file(folder)}: URDF file is missing"


def skewed_axis(folder: Path) -> str:
    """The URDF's axis breaks the model's own rule: its message names the joint once, not twice."""
    urdf = urdf_file(folder)
    text = urdf.read_text()
    urdf.write_text(text.replace('<axis xyz="1 0 0"/>', '<axis xyz="1 1 0"/>', 1))
    return "hostile_1.urdf: joint 'obj_00': axis (1.0, 1.0, 0.0) is not a unit vector"


def inverted_limit(folder: Path) -> str:
    urdf = urdf_file(folder)
    urdf.write_text(urdf.read_text().replace('lower="0" upper="1"', 'lower="2" upper="1"', 1))
    return "joint 'obj_00' <limit>: lower=2.0 exceeds upper=1.0"


def goal_of_another_joint(folder: Path) -> str:
    data = json.loads((folder / "puzzle.json").read_text())
    data["goal"]["values"] = {"no_such_joint": 1.0}
    (folder / "puzzle.json").write_text(json.dumps(data))
    return "no_such_joint"


BROKEN = [broken_json, missing_urdf, skewed_axis, inverted_limit, goal_of_another_joint]


@pytest.mark.parametrize("command", ["check", "render", "render --gallery-only", "manipulate"])
@pytest.mark.parametrize("damage", BROKEN, ids=lambda f: f.__name__)
def test_a_broken_puzzle_folder_is_one_line_naming_it_before_any_work(command, damage, tmp_path, puzzles, capsys,
                                                                     no_work):
    folder = puzzles / "hostile" / "hostile_1"
    message = damage(folder)
    argv = {"check": ["check", str(folder)],
            "render": ["render", "--out", str(puzzles), "--quiet"],
            "render --gallery-only": ["render", "--out", str(puzzles), "--gallery-only"],
            "manipulate": ["manipulate", str(puzzles), "--out", str(tmp_path / "runs"), "--quiet"]}[command]
    err = refused(argv, capsys, tmp_path, str(folder), message)
    assert err.count("obj_00") <= 1, err


def test_a_broken_solution_is_refused_before_any_simulation(tmp_path, puzzles, capsys, no_work):
    solution = puzzles / "hostile" / "hostile_1" / "solutions" / "la_rrt_best.json"
    solution.parent.mkdir()
    solution.write_text('{"joint_order": [], "path": "not a path"}')
    refused(["manipulate", str(puzzles), "--out", str(tmp_path / "runs"), "--quiet"], capsys, tmp_path,
            str(solution))


@pytest.mark.parametrize("entry, what", [("images", "is not a folder"), ("hostile_1.blend", "is a folder")])
def test_render_outputs_blocked_by_the_wrong_kind_of_entry_are_refused(entry, what, tmp_path, puzzles, capsys,
                                                                      no_work):
    blocked = puzzles / "hostile" / "hostile_1" / entry
    if entry == "images":
        blocked.write_text("a file where the images go")
    else:
        blocked.mkdir()
    refused(["render", "--out", str(puzzles), "--quiet"], capsys, tmp_path, str(blocked), what)


def test_an_unwritable_puzzle_folder_is_refused_before_rendering(tmp_path, puzzles, capsys, no_work):
    if AS_ROOT:
        pytest.skip("root writes into a folder without write permission")
    folder = puzzles / "hostile" / "hostile_1"
    folder.chmod(0o555)
    try:
        refused(["render", "--out", str(puzzles), "--quiet"], capsys, tmp_path, str(folder), "no permission")
    finally:
        folder.chmod(0o755)


def test_manipulate_says_one_line_and_no_pybullet_banner(tmp_path, puzzles):
    """pybullet prints its build time from C on import; a fresh process shows whether it reaches stderr."""
    folder = puzzles / "hostile" / "hostile_1"
    broken_json(folder)
    result = subprocess.run([sys.executable, "-m", "phyrogen.cli", "manipulate", str(folder), "--out",
                             str(tmp_path / "runs")], capture_output=True, text=True, cwd=REPOSITORY, timeout=120)
    assert (result.returncode, result.stdout) == (2, "")
    assert result.stderr.startswith("phyrogen: error: ") and result.stderr.count("\n") == 1, result.stderr
    assert not (tmp_path / "runs").exists()


@pytest.mark.blender
def test_a_folder_broken_after_the_check_is_one_line_from_the_render_worker(tmp_path, puzzles):
    """Folders are checked before any worker starts; one broken in between still gets one line, not a traceback."""
    import importlib.util

    if importlib.util.find_spec("bpy") is None:
        pytest.skip("the bpy wheel is not installed (pip install -e .[blender])")
    folder = puzzles / "hostile" / "hostile_1"
    message = skewed_axis(folder)
    environment = {**os.environ, "BLENDER_USER_CONFIG": str(tmp_path / "config"),
                   "BLENDER_USER_RESOURCES": str(tmp_path / "resources")}
    result = subprocess.run([sys.executable, "-m", "blender_addon.render_worker", "--engine", "CYCLES", "--size",
                             "32x32", "--views", "top", str(folder)], capture_output=True, text=True,
                            cwd=REPOSITORY, env=environment, timeout=300)
    assert (result.returncode, result.stdout) == (2, "")
    lines = [line for line in result.stderr.splitlines() if line.startswith("render_worker: ")]
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in result.stderr, result.stderr
    assert sorted(os.listdir(folder)) == ["meshes", "puzzle.json", "srdf", "urdf"]


@pytest.mark.parametrize("scale", ["0", "-0.5", "nan", "inf", "2.5", "half"])
def test_a_scene_scale_that_is_no_positive_number_up_to_the_bound_is_refused(scale, tmp_path, puzzles, capsys,
                                                                             no_work):
    refused(["manipulate", str(puzzles), "--out", str(tmp_path / "runs"), "--quiet", "--scale", scale], capsys,
            tmp_path, "--scale", repr(scale))


def test_a_puzzle_wider_than_the_floor_the_base_drives_on_is_refused_before_any_simulation(tmp_path, puzzles,
                                                                                           no_work):
    from manipulation.batch import check_inputs
    from manipulation.execution import ExecutionSettings
    from manipulation.robot import RobotSpec

    folder = puzzles / "hostile" / "hostile_1"
    check_inputs([folder], tmp_path / "runs", settings=ExecutionSettings(scale=1.0))  # 9.8 m: it fits
    with pytest.raises(ValueError, match=r"'hostile_1' at scale 2 spans 19.6 m; the robot's base drives within 13.6 m"):
        check_inputs([folder], tmp_path / "runs", settings=ExecutionSettings(scale=2.0, robot=RobotSpec(base_range=8)))
