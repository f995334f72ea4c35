"""The puzzle folder is a contract: one way to find folders, and a stage never deletes another stage's files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from blender_support import every_shape_puzzle, private_blender_home

from phyrogen_core.export import read_puzzle_dir, write_puzzle
from phyrogen_core.folder import PuzzleFolder, find_puzzle_folders
from phyrogen_core.folder_layout import BEST_SOLUTION
from phyrogen_core.folder_ownership import Stage, stage_entries


def tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_regenerated_puzzle_keeps_every_other_stage_and_user_file(tmp_path):
    folder = PuzzleFolder.open(write_puzzle(every_shape_puzzle(), tmp_path))
    others = {folder.images / "every_shape_1_00.png": b"png", folder.blend: b"blend",
              folder.best_solution: b"{}", folder.path / "notes" / "mine.txt": b"user", folder.path / ".hidden": b"h"}
    for path, data in others.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    before = tree(folder.path)
    write_puzzle(every_shape_puzzle(), tmp_path)
    assert tree(folder.path) == before
    assert [p.name for p in folder.path.parent.iterdir()] == [folder.path.name]  # no temporary folders left


def test_stages_own_disjoint_entries():
    owned = [set(stage_entries(stage, "p")) for stage in Stage]
    assert all(not (a & b) for i, a in enumerate(owned) for b in owned[i + 1:])
    folder = PuzzleFolder(Path("x"), "p")
    assert folder.best_solution == Path("x") / BEST_SOLUTION
    assert folder.best_solution.relative_to(folder.path).parts[0] in stage_entries(Stage.BENCHMARK, "p")
    assert {folder.blend.name, folder.images.name} <= set(stage_entries(Stage.RENDER, "p"))


def test_finding_folders_is_one_rule(tmp_path):
    for name in ("rooms/rooms_10", "rooms/rooms_9", "simple_slider/simple_slider_2", "rooms/.rooms_3.x.tmp"):
        (tmp_path / name).mkdir(parents=True)
        seed = int(name.rsplit("_")[-1].split(".")[0])
        (tmp_path / name / "puzzle.json").write_text(json.dumps({"name": Path(name).name, "seed": seed,
                                                                 "generator": Path(name).parent.name}))
    (tmp_path / "manipulation" / "rooms_9").mkdir(parents=True)  # another command's output: no puzzle.json
    found = find_puzzle_folders(tmp_path)
    # Registry order of generators, then the seed puzzle.json states (9 before 10), temporary folders skipped.
    names = [f.name for f in found]
    assert sorted(names, key=names.index) == names and set(names) == {"rooms_9", "rooms_10", "simple_slider_2"}
    assert names.index("rooms_9") < names.index("rooms_10")
    assert [f.name for f in find_puzzle_folders(tmp_path, ["rooms"])] == ["rooms_9", "rooms_10"]
    assert find_puzzle_folders(tmp_path / "rooms" / "rooms_9") == [found[names.index("rooms_9")]]
    with pytest.raises(FileNotFoundError, match="no puzzle folders"):
        find_puzzle_folders(tmp_path / "manipulation")
    with pytest.raises(FileNotFoundError, match="no such folder"):
        find_puzzle_folders(tmp_path / "missing")


@pytest.mark.slow
@pytest.mark.blender
def test_panel_export_after_render_and_benchmark_keeps_their_files(tmp_path):
    """Generate, render, benchmark; then the panel's Export, unedited and after an edit."""
    private_blender_home()
    bpy = pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    from blender_addon import ui
    from blender_addon.rendering import render_puzzles
    from blender_addon.scene import build_puzzle_folder, read_chain
    from manipulation.source import ShortBenchmark
    from solver.benchmark.profiles import get_profile
    from solver.benchmark.runner import run_benchmark
    from solver.pipelines.generation import generate_puzzle, versions

    root = tmp_path / "out"
    folder = PuzzleFolder.open(write_puzzle(generate_puzzle("simple_slider", 2), root, versions()))
    render_puzzles([folder.path], views=("top",))
    # The manipulation stage's short benchmark budget (a motion charged by its length), which solves Simple
    # Slider 2 in every run; the same on a loaded machine; the time limit is only a backstop against a hang.
    run_benchmark([folder], ["la_rrt"], get_profile("quick", runs=1, time_limit=300.0), tmp_path / "bench",
                  workers=1, plots=False, progress=False, budget_checks=ShortBenchmark().budget_checks)
    assert folder.images.is_dir() and folder.blend.is_file() and folder.best_solution.is_file()
    before = tree(folder.path)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    ui.register()
    try:
        built = build_puzzle_folder(folder.path, bpy.context.scene)
        settings = bpy.context.scene.phyrogen
        settings.output = str(root)
        settings.puzzle = built.collection.name
        assert bpy.ops.phyrogen.export_urdf() == {"FINISHED"}
        assert tree(folder.path) == before  # unedited: the same files, byte for byte, and nothing lost

        wall = next(obj for name, obj in built.links.items() if name.startswith("obj_01"))
        wall.location.y += 0.25
        assert bpy.ops.phyrogen.export_urdf() == {"FINISHED"}
        edited = read_chain(built.collection)
    finally:
        ui.unregister()
    after = tree(folder.path)
    # The edit made another puzzle: its renders and solution move into stale/1, beside the puzzle they show.
    moved = [k for k in before if k.startswith(("images/", "solutions/")) or k == folder.blend.name]
    assert moved and all(k not in after and after[f"stale/1/{k}"] == before[k] for k in moved)
    assert read_puzzle_dir(folder.path / "stale" / "1").record.to_json().encode() == before["puzzle.json"]
    assert after[f"urdf/{folder.name}.urdf"] != before[f"urdf/{folder.name}.urdf"]
    loaded = read_puzzle_dir(folder.path)  # metadata and URDF agree: the strict reader accepts them
    assert loaded.chain == edited
    assert loaded.record.certificate_verified is False
    limits = loaded.record.joint_limits
    assert {limit.joint: (limit.lower, limit.upper) for limit in limits} == {
        j.name: (j.lower, j.upper) for j in loaded.chain.active_joints}
