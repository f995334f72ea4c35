"""Nothing a user made is deleted, and no stage writes or reads through a link out of its folder.

Each stage replaces only files of its own exact names (:func:`phyrogen_core.folder.stage_owns`):
a user's file beside them, even inside ``urdf/``, ``images/`` or ``mjcf/``, stays where it is, and
only the stage's own earlier outputs move into ``stale/``. A file at one of a stage's own names
that the stage did not write (a user's ``index.html``, ``mjcf/<name>.xml``) is refused up front.
Every folder a stage writes into is a real folder inside the puzzle (or dataset) folder, and every
file it copies a regular file inside it: otherwise exit 2, one line naming the path, nothing
written, before any work. Each test has its negative control beside it: the stage's own files are
still replaced, moved or removed, and a clean folder still passes.
"""

from __future__ import annotations

import json
import os
import stat
from dataclasses import replace
from pathlib import Path

import pytest
from hostile_support import PARAMETERS, hostile_puzzle, refused, snapshot

from phyrogen.cli import main
from phyrogen_core.atomic_writes import OutputError, atomic_directory
from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import read_puzzle_dir, write_mjcf, write_puzzle
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.folder_ownership import Stage

USER = b"a user's own file"


@pytest.fixture
def place(tmp_path) -> PuzzleFolder:
    """The hostile puzzle's folder under ``tmp_path/out``: hostile/hostile_1."""
    return PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path / "out"))


@pytest.fixture
def no_work(monkeypatch):
    """The commands' work (planning, Blender workers, simulation, benchmark runs) fails the test if it starts."""
    import blender_addon.rendering
    import manipulation.batch
    import solver.benchmark.runner
    import solver.pipelines.generation
    import solver.pipelines.replanning

    def started(*args, **kwargs):
        raise AssertionError("work started before the input was checked")

    monkeypatch.setattr(solver.pipelines.generation, "run_jobs", started)

    monkeypatch.setattr(solver.pipelines.replanning, "replan", started)
    monkeypatch.setattr(blender_addon.rendering, "_run_workers", started)
    monkeypatch.setattr(manipulation.batch, "execute_puzzle", started)
    monkeypatch.setattr(solver.benchmark.runner, "run_plan", started)


def put(path: Path, data: bytes = USER) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


# -- A. a user's files inside a stage's folders ----------------------------------------------------
USER_FILES = ("urdf/MY_URDF_NOTES.txt", "urdf/my_robot.urdf", "srdf/mine.srdf", "meshes/my_part.obj",
              "meshes/sub/deeper.txt", "images/notes.txt", "solutions/my_path.json", "mjcf/my_scene_with_robot.xml",
              "phobos/MY_PHOBOS_NOTES.txt", "phobos/urdf/notes.txt", "phobos/meshes/my_mesh.obj")


@pytest.mark.parametrize("rendered", [False, True], ids=["alone", "with renders"])
def test_regenerating_a_changed_puzzle_keeps_a_users_files_inside_its_folders(place, tmp_path, rendered):
    for path in USER_FILES:
        put(place.path / path, USER + path.encode())
    if rendered:
        put(place.images / "hostile_1_00.png", b"render")
        put(place.best_solution, b"{}")
        put(place.path / "phobos" / "urdf" / "hostile_1.urdf", b"Phobos's URDF")
        put(place.path / "phobos" / "meshes" / "obj" / "obj_00.obj", b"Phobos's mesh")
    old_urdf = place.urdf.read_bytes()
    notices: list[str] = []
    write_puzzle(replace(hostile_puzzle(), parameters={**PARAMETERS, "size": 2.0}), tmp_path / "out", None, notices)
    for path in USER_FILES:  # where they were, as they were: not deleted, not moved
        assert (place.path / path).read_bytes() == USER + path.encode(), path
    stale = place.path / "stale" / "1"
    if rendered:  # negative control: the stage's own earlier outputs do move, and only they
        from phyrogen_core.folder_ownership import stage_owns

        assert (stale / "images" / "hostile_1_00.png").read_bytes() == b"render"
        assert (stale / "urdf" / "hostile_1.urdf").read_bytes() == old_urdf
        assert not (place.images / "hostile_1_00.png").exists() and not place.best_solution.exists()
        moved = sorted(p.relative_to(stale).as_posix() for p in stale.rglob("*") if p.is_file())
        assert (stale / "phobos" / "urdf" / "hostile_1.urdf").read_bytes() == b"Phobos's URDF"
        assert not (place.path / "phobos" / "meshes" / "obj").exists()
        assert all(stage_owns(Stage.EXPORT, place.name, p) or p in (
            "images/hostile_1_00.png", "solutions/la_rrt_best.json", "phobos/urdf/hostile_1.urdf",
            "phobos/meshes/obj/obj_00.obj") for p in moved), moved
        assert "solutions/la_rrt_best.json" in moved and any(p.startswith("meshes/") for p in moved)
        assert len(notices) == 1
    else:
        assert notices == [] and not (place.path / "stale").exists()
    assert read_puzzle_dir(place.path).record.parameters["size"] == 2.0


def test_a_stage_still_replaces_and_removes_its_own_files(place, tmp_path):
    """Negative control: an own mesh the new puzzle no longer has goes; a user's file in meshes/ stays."""
    from phyrogen_core.folder_ownership import stage_owns

    put(place.meshes / "my_part.obj")
    own = sorted(p.name for p in place.meshes.glob("*_*_*_*.obj"))
    assert own and all(stage_owns(Stage.EXPORT, place.name, f"meshes/{name}") for name in own)
    put(place.meshes / "gone_visual_9_9.obj", b"an old export's piece")  # the stage's own name pattern
    write_puzzle(hostile_puzzle(), tmp_path / "out")
    assert not (place.meshes / "gone_visual_9_9.obj").exists()
    assert (place.meshes / "my_part.obj").read_bytes() == USER
    assert sorted(p.name for p in place.meshes.glob("*_*_*_*.obj")) == own


def test_export_with_phobos_replaces_only_phobos_files(tmp_path):
    """The folder rule Export with Phobos swaps its folder in by (``blender_addon.phobos``): Phobos's
    URDF and OBJ meshes are replaced, an old mesh it no longer writes goes, a user's file stays."""
    from phyrogen_core.folder_ownership import phobos_owns
    from phyrogen_core.stage_writes import owned_directory

    final = tmp_path / "phobos"
    for path in ("urdf/hostile_1.urdf", "meshes/obj/obj_00.obj", "meshes/obj/gone.obj"):
        put(final / path, b"an earlier export")
    for path in ("notes.txt", "urdf/notes.txt", "meshes/my_mesh.obj", "renders/view.png"):
        put(final / path)
    with owned_directory(final, phobos_owns) as temporary:
        put(temporary / "urdf" / "hostile_1.urdf", b"new")
        put(temporary / "meshes" / "obj" / "obj_00.obj", b"new")
    assert snapshot(final) == {"meshes": None, "meshes/my_mesh.obj": USER, "meshes/obj": None,
                               "meshes/obj/obj_00.obj": b"new", "notes.txt": USER, "renders": None,
                               "renders/view.png": USER, "urdf": None, "urdf/hostile_1.urdf": b"new",
                               "urdf/notes.txt": USER}


def test_replan_keeps_a_users_files_in_place_and_moves_only_old_renders(place, capsys):
    put(place.path / "MY_NOTES.txt")
    put(place.path / "notes" / "day1.txt")
    put(place.path / "urdf" / "MY_URDF_NOTES.txt")
    put(place.images / "MY_NOTES.txt")  # beside the renders, in the folders that move
    put(place.solutions / "notes" / "day2.txt")
    put(place.images / "hostile_1_00.png", b"made for the old certificate")
    assert main(["replan", str(place.path)]) == 0
    assert "moved to" in capsys.readouterr().err
    kept = ("MY_NOTES.txt", "notes/day1.txt", "urdf/MY_URDF_NOTES.txt", "images/MY_NOTES.txt",
            "solutions/notes/day2.txt")
    for path in kept:
        assert (place.path / path).read_bytes() == USER, path
    stale = place.path / "stale" / "1"
    assert not any(stale.rglob("MY_NOTES.txt")) and not any(stale.rglob("notes"))
    # Negative control: the render made for the old certificate did move.
    assert (stale / "images" / "hostile_1_00.png").read_bytes() == b"made for the old certificate"


def test_dataset_removes_only_its_own_temporaries(tmp_path, capsys):
    root = tmp_path / "data"
    argv = ["dataset", "--generator", "grid_world", "--seeds", "9100-9101", "--set", "n_objects=2", "--out",
            str(root), "--workers", "1", "--quiet"]
    assert main(argv) == 0
    shard = root / "shard-00000"
    users = [put(root / ".my_notes.tmp"), put(root / ".thesis_draft.tmp.tex"),
             put(root / ".notes.abcdefgh.tmp"),  # our pattern, but no entry of ours
             put(root / "parts" / ".my.parquet.tmp"), put(shard / "grid_world" / ".my_notes.tmp"),
             put(shard / "grid_world" / ".draft.abcdefgh.tmp")]
    leftovers = [put(root / ".manifest.parquet.k1ll3d00.tmp", b"PAR1"),
                 put(root / ".dataset.json.k1ll3d00.tmp", b"{"),
                 put(root / "parts" / ".shard-00000.parquet.k1ll3d00.tmp", b"PAR1"),
                 put(shard / "grid_world" / ".grid_world_9100.k1ll3d00.tmp" / "urdf" / "x.urdf", b"<rob").parent.parent]
    assert main(argv) == 0  # resumed: finds everything done, cleans up
    capsys.readouterr()
    for path in users:
        assert path.read_bytes() == USER, path
    for path in leftovers:  # negative control: what a killed writer of ours left is removed
        assert not os.path.lexists(path), path


@pytest.fixture(scope="module")
def mjcf_dataset(tmp_path_factory) -> tuple[list[str], Path]:
    """A dataset of two puzzles with their MJCF (its command, its root), made once; tests use copies."""
    root = tmp_path_factory.mktemp("mjcf_dataset") / "data"
    argv = ["dataset", "--generator", "grid_world", "--seeds", "9200-9201", "--set", "n_objects=2", "--mjcf",
            "--out", str(root), "--workers", "1", "--quiet"]
    assert main(argv) == 0
    return argv, root


def _users_mjcf(folder: Path, outside: Path) -> tuple[Path, str]:
    put(folder / "mjcf" / f"{folder.name}.xml", b"<mujoco>a user's scene</mujoco>")
    return folder / "mjcf" / f"{folder.name}.xml", "was not written by phyrogen export"


def _linked_mjcf(folder: Path, outside: Path) -> tuple[Path, str]:
    for child in (folder / "mjcf").iterdir():
        child.unlink()
    (folder / "mjcf").rmdir()
    (folder / "mjcf").symlink_to(outside, target_is_directory=True)
    return folder / "mjcf", "symbolic link"


def _linked_puzzle_folder(folder: Path, outside: Path) -> tuple[Path, str]:
    folder.rename(outside / folder.name)
    folder.symlink_to(outside / folder.name, target_is_directory=True)
    return folder, "symbolic link"


def _fifo_in_puzzle_folder(folder: Path, outside: Path) -> tuple[Path, str]:
    os.mkfifo(folder / "notes.fifo")
    return folder / "notes.fifo", "FIFO"


def _link_out_of_puzzle_folder(folder: Path, outside: Path) -> tuple[Path, str]:
    put(outside / "notes.txt", b"a user's notes")
    (folder / "notes.txt").symlink_to(outside / "notes.txt")
    return folder / "notes.txt", "outside"


@pytest.mark.parametrize("damage", [_users_mjcf, _linked_mjcf, _linked_puzzle_folder, _fifo_in_puzzle_folder,
                                    _link_out_of_puzzle_folder],
                         ids=lambda f: f.__name__.strip("_"))
def test_dataset_mjcf_refuses_what_its_writers_would_meet_before_any_work(damage, mjcf_dataset, tmp_path, capsys,
                                                                          monkeypatch):
    """An unfinished shard (its part and the manifest gone, as when killed): its existing puzzle
    folders are checked up front, as ``generate --mjcf`` checks its own; the refusal came from a
    worker after the puzzle was made again, or (a user's MJCF) not at all, the file moved to stale/."""
    import shutil

    import solver.pipelines.dataset

    argv, made = mjcf_dataset
    root = tmp_path / "data"
    shutil.copytree(made, root, symlinks=True)
    shutil.rmtree(root / "parts")
    (root / "manifest.parquet").unlink()
    outside = tmp_path / "outside"
    outside.mkdir()
    folder = root / "shard-00000" / "grid_world" / "grid_world_9200"
    path, fragment = damage(folder, outside)
    argv = [*argv[:argv.index("--out") + 1], str(root), *argv[argv.index("--out") + 2:]]
    with monkeypatch.context() as patch:
        def started(*args, **kwargs):
            raise AssertionError("the dataset started before its folders were checked")

        patch.setattr(solver.pipelines.dataset, "build_dataset", started)
        refused(argv, capsys, tmp_path, str(path), fragment)
    # The control: the shard undamaged resumes (the puzzles found done), with the MJCF in place.
    shutil.rmtree(root)
    shutil.copytree(made, root, symlinks=True)
    shutil.rmtree(root / "parts")
    assert main(argv) == 0
    capsys.readouterr()
    assert (root / "shard-00000" / "grid_world" / "grid_world_9201" / "mjcf" / "grid_world_9201.xml").is_file()


@pytest.mark.parametrize("name, entry", [(".manifest.parquet.k1ll3d00.tmp", "manifest.parquet"),
                                         (".grid_world_7.abcd_123.tmp.old3", "grid_world_7"),
                                         (".difficulty.png.x1y2z3w4.tmp.png", "difficulty.png"),
                                         (".index.x1y2z3w4.html.tmp", "index"),
                                         (".my_notes.tmp", None), (".thesis_draft.tmp.tex", None),
                                         ("notes.abcdefgh.tmp", None), (".a.b.tmp", None)])
def test_temporary_names_follow_one_exact_pattern(name, entry):
    from phyrogen_core.atomic_writes import temporary_entry

    assert temporary_entry(name) == entry


def gallery(out: Path) -> Path:
    return out / "index.html"


def test_render_refuses_a_users_own_index_html_before_any_work(place, tmp_path, capsys, no_work):
    out = tmp_path / "out"
    put(gallery(out), b"<html>my own page</html>")
    for argv in (["render", "--out", str(out), "--quiet"], ["render", "--out", str(out), "--gallery-only"]):
        refused(argv, capsys, tmp_path, str(gallery(out)), "not written by phyrogen render")
    link = tmp_path / "elsewhere.html"
    put(link, b"<html>elsewhere</html>")
    gallery(out).unlink()
    gallery(out).symlink_to(link)
    refused(["render", "--out", str(out), "--gallery-only"], capsys, tmp_path, str(gallery(out)), "a link")


def test_render_rewrites_a_gallery_it_wrote(place, tmp_path, capsys):
    """Negative control: the page phyrogen render wrote is replaced, twice over."""
    out = tmp_path / "out"
    for _ in range(2):
        assert main(["render", "--out", str(out), "--gallery-only"]) == 0
    assert b"hostile_1" in gallery(out).read_bytes()
    # A page of an earlier version (no marker yet) begins exactly so, and is replaced too.
    put(gallery(out), b'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
                      b"<title>PhyRoGen puzzles</title>\n<style>old</style>")
    assert main(["render", "--out", str(out), "--gallery-only"]) == 0
    assert b"phyrogen render gallery" in gallery(out).read_bytes()
    capsys.readouterr()


def test_export_mjcf_keeps_a_users_files_and_refuses_one_of_its_name(place, tmp_path, capsys):
    put(place.path / "mjcf" / "my_scene_with_robot.xml")
    assert main(["export", str(place.path), "--format", "mjcf"]) == 0
    ours = place.path / "mjcf" / "hostile_1.xml"
    assert (place.path / "mjcf" / "my_scene_with_robot.xml").read_bytes() == USER
    assert ours.read_bytes().startswith(b'<?xml version="1.0"?>\n<mujoco model=')
    assert main(["export", str(place.path), "--format", "mjcf"]) == 0  # negative control: its own file
    capsys.readouterr()
    ours.write_bytes(b'<mujoco model="mine"><worldbody/></mujoco>\n')  # the user's own scene, of our name
    refused(["export", str(place.path), "--format", "mjcf"], capsys, tmp_path, str(ours), "not written by")


def test_generate_with_mjcf_refuses_a_users_file_of_its_name_before_any_work(tmp_path, capsys, no_work):
    out = tmp_path / "gen"
    mine = put(out / "simple_slider" / "simple_slider_2" / "mjcf" / "simple_slider_2.xml")
    argv = ["generate", "--generator", "simple_slider", "--seeds", "1-3", "--mjcf", "--out", str(out), "--quiet"]
    refused(argv, capsys, tmp_path, str(mine), "not written by")
    # Negative control: without --mjcf the file is none of generate's business, and the work starts (the stub).
    assert main(argv[:5] + argv[6:]) == 1 and "work started" in capsys.readouterr().err
    assert mine.read_bytes() == USER


def test_an_output_folder_shared_with_a_user_keeps_the_users_files(tmp_path):
    """``owned_directory``, as manipulate (``manipulation.outputs.owns_output``) and render use it."""
    from manipulation.outputs import owns_output
    from phyrogen_core.stage_writes import owned_directory

    final = tmp_path / "runs" / "hostile_1"
    put(final / "my_analysis.md")
    put(final / "frames" / "my_sketch.png")
    put(final / "frames" / "frame_9.png", b"an old run's frame")
    put(final / "report.json", b"old report")
    with owned_directory(final, lambda path: owns_output("hostile_1", path)) as folder:
        put(folder / "report.json", b"new report")
        put(folder / "frames" / "frame_1.png", b"new frame")
    assert (final / "my_analysis.md").read_bytes() == USER and (final / "frames" / "my_sketch.png").read_bytes() == USER
    # Negative control: the stage's own files are replaced, and its old ones it did not write again go.
    assert (final / "report.json").read_bytes() == b"new report" and not (final / "frames" / "frame_9.png").exists()
    # The plain atomic_directory replaces the folder whole: what owned_directory is there to prevent.
    with atomic_directory(final) as folder:
        put(folder / "report.json", b"whole")
    assert not (final / "my_analysis.md").exists()


# -- B. links and special files -------------------------------------------------------------------
def _outside_file(tmp_path: Path) -> Path:
    return put(tmp_path / "secret.txt", b"outside the puzzle folder")


def _unreferenced_link_outside(place, tmp_path):
    (place.path / "urdf" / "extra.urdf").symlink_to(_outside_file(tmp_path))
    return str(place.path / "urdf" / "extra.urdf"), "outside the puzzle folder"


def _unreferenced_fifo(place, tmp_path):
    os.mkfifo(place.meshes / "pipe.obj")
    return str(place.meshes / "pipe.obj"), "is a FIFO"


def _link_to_dev_zero(place, tmp_path):
    (place.path / "srdf" / "zero.srdf").symlink_to("/dev/zero")
    return str(place.path / "srdf" / "zero.srdf"), "/dev/zero"


def _linked_meshes_folder(place, tmp_path):
    outside = tmp_path / "meshes_elsewhere"
    place.meshes.rename(outside)
    place.meshes.symlink_to(outside, target_is_directory=True)
    return str(place.path), "outside the puzzle folder"  # found by the reader already, naming the URDF


@pytest.mark.parametrize("damage", [_unreferenced_link_outside, _unreferenced_fifo, _link_to_dev_zero,
                                    _linked_meshes_folder], ids=lambda f: f.__name__.strip("_"))
def test_replan_refuses_links_out_and_special_files_before_any_work(place, tmp_path, capsys, no_work, damage):
    path, fragment = damage(place, tmp_path)
    refused(["replan", str(place.path)], capsys, tmp_path, path, fragment)


def _root_link_outside(place, tmp_path):
    (place.path / "my_notes.txt").symlink_to(_outside_file(tmp_path))
    return str(place.path / "my_notes.txt"), "outside the puzzle folder"


def _root_link_to_folder_outside(place, tmp_path):
    (tmp_path / "elsewhere").mkdir()
    (place.path / "library").symlink_to(tmp_path / "elsewhere", target_is_directory=True)
    return str(place.path / "library"), "outside the puzzle folder"


def _root_fifo(place, tmp_path):
    os.mkfifo(place.path / "pipe")
    return str(place.path / "pipe"), "is a FIFO"


def _root_link_to_dev_zero(place, tmp_path):
    (place.path / "zero").symlink_to("/dev/zero")
    return str(place.path / "zero"), "/dev/zero"


def _nested_fifo(place, tmp_path):
    (place.path / "notes" / "deep").mkdir(parents=True)
    os.mkfifo(place.path / "notes" / "deep" / "pipe")
    return str(place.path / "notes" / "deep" / "pipe"), "is a FIFO"


def _reading_commands(place: PuzzleFolder, tmp_path: Path) -> list[list[str]]:
    """Every command that reads a puzzle folder, pointed at ``place`` (or the folder of puzzles holding it)."""
    out = str(place.path.parent.parent)
    return [["check", str(place.path)], ["replan", str(place.path)], ["export", str(place.path), "--format", "mjcf"],
            ["benchmark", "--puzzles", out, "--out", str(tmp_path / "bench"), "--planners", "la_rrt",
             "--budget-checks", "100", "--time-limit", "5", "--dry-run"],
            ["manipulate", str(place.path), "--out", str(tmp_path / "runs"), "--quiet"],
            ["audit", out, "--out", str(tmp_path / "audit"), "--quiet"],
            ["render", "--out", out, "--quiet"]]


@pytest.mark.parametrize("damage", [_root_link_outside, _root_link_to_folder_outside, _root_fifo,
                                    _root_link_to_dev_zero, _nested_fifo], ids=lambda f: f.__name__.strip("_"))
def test_every_reader_refuses_an_unreferenced_link_out_or_special_file_up_front(place, tmp_path, capsys, no_work,
                                                                                damage):
    """A path that leaves the puzzle folder is bad input wherever it appears: an entry that
    puzzle.json does not reference, at the root or deeper, is refused by every command that reads
    the folder, before any work, naming it; nothing is written."""
    path, fragment = damage(place, tmp_path)
    for argv in _reading_commands(place, tmp_path):
        refused(argv, capsys, tmp_path, path, fragment)


def test_links_that_stay_inside_the_folder_pass_every_reader(place, tmp_path, capsys):
    """Negative control: root-level links to a file and to a folder inside the puzzle folder (and a
    dangling one that would stay inside) are no escape; the folder reads and checks as before."""
    put(place.path / "library" / "notes.txt")
    (place.path / "notes.txt").symlink_to(Path("library") / "notes.txt")
    (place.path / "shelf").symlink_to("library", target_is_directory=True)
    (place.path / "later.txt").symlink_to("not_written_yet.txt")
    assert read_puzzle_dir(place.path).name == place.name
    assert PuzzleFolder.open(place.path).name == place.name
    from phyrogen.cli import main

    assert main(["check", str(place.path)]) == 0
    capsys.readouterr()


def test_replan_follows_links_inside_the_folder(place, tmp_path):
    """Negative control: a link to a file inside the puzzle folder is no escape."""
    from solver.pipelines.replanning import check_replan_folder

    put(place.path / "library" / "notes.txt")
    (place.path / "urdf" / "notes.txt").symlink_to(Path("..") / "library" / "notes.txt")
    check_replan_folder(place.path, place.name)


def test_dataset_stats_refuses_files_outside_the_dataset_and_a_folder_that_is_no_dataset(tmp_path, capsys):
    import pyarrow.parquet as pq

    from solver.pipelines.dataset.manifest import schema

    root = tmp_path / "data"
    put(root / "dataset.json", json.dumps({"generators": ["grid_world"]}).encode())
    pq.write_table(schema().empty_table(), tmp_path / "elsewhere.parquet")
    (root / "manifest.parquet").symlink_to(tmp_path / "elsewhere.parquet")
    refused(["dataset", "--stats", str(root)], capsys, tmp_path, str(root / "manifest.parquet"), "outside")
    (root / "manifest.parquet").unlink()
    (root / "plots").symlink_to(tmp_path, target_is_directory=True)
    refused(["dataset", "--stats", str(root)], capsys, tmp_path, str(root / "plots"), "symbolic link")
    (root / "plots").unlink()
    for not_a_request in (b"[]", b"{}", b"not json"):
        put(root / "dataset.json", not_a_request)
        refused(["dataset", "--stats", str(root)], capsys, tmp_path, str(root / "dataset.json"))
    # Negative control: the same folder as a dataset (its own, empty manifest) is described, with plots.
    put(root / "dataset.json", json.dumps({"generators": ["grid_world"]}).encode())
    pq.write_table(schema().empty_table(), root / "manifest.parquet")
    assert main(["dataset", "--stats", str(root)]) == 0
    assert (root / "plots" / "difficulty.png").is_file()
    capsys.readouterr()


def test_benchmark_refuses_a_solutions_folder_leading_outside(place, tmp_path, capsys, no_work):
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    place.solutions.symlink_to(outside, target_is_directory=True)
    argv = ["benchmark", "--puzzles", str(place.path), "--out", str(tmp_path / "bench"), "--planners", "la_rrt",
            "--budget-checks", "100", "--time-limit", "5", "--dry-run"]
    refused(argv, capsys, tmp_path, str(place.solutions), "symbolic link")
    place.solutions.unlink()
    assert main(argv) == 0  # negative control: a real solutions folder (or none) passes
    capsys.readouterr()


def _linked_puzzle(place: PuzzleFolder, tmp_path: Path) -> Path:
    """``tmp_path/linked/hostile/hostile_1``, a link to the real puzzle folder."""
    link = tmp_path / "linked" / "hostile" / "hostile_1"
    link.parent.mkdir(parents=True)
    link.symlink_to(place.path, target_is_directory=True)
    return link


def test_a_linked_puzzle_folder_is_refused_by_every_stage_that_writes_into_it(place, tmp_path, capsys, no_work):
    link = _linked_puzzle(place, tmp_path)
    assert read_puzzle_dir(link).name == "hostile_1"  # reading through it is fine
    refused(["replan", str(link)], capsys, tmp_path, str(link), "symbolic link")
    refused(["export", str(link), "--format", "mjcf"], capsys, tmp_path, str(link), "symbolic link")
    refused(["render", "--out", str(tmp_path / "linked"), "--quiet"], capsys, tmp_path, str(link), "symbolic link")
    with pytest.raises(OutputError, match="symbolic link"):  # the swap itself refuses, should a caller not check
        write_puzzle(hostile_puzzle(), tmp_path / "linked")
    out = tmp_path / "gen"
    (out / "simple_slider").mkdir(parents=True)
    (out / "simple_slider" / "simple_slider_2").symlink_to(place.path, target_is_directory=True)
    refused(["generate", "--generator", "simple_slider", "--seeds", "1-3", "--out", str(out), "--quiet"], capsys,
            tmp_path, str(out / "simple_slider" / "simple_slider_2"), "symbolic link")


def test_linked_images_and_mjcf_folders_are_refused(place, tmp_path, capsys, no_work):
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    chain = read_puzzle_dir(place.path).chain
    place.images.symlink_to(outside, target_is_directory=True)
    refused(["render", "--out", str(tmp_path / "out"), "--quiet"], capsys, tmp_path, str(place.images),
            "symbolic link")
    place.images.unlink()
    (place.path / "mjcf").symlink_to(outside, target_is_directory=True)
    refused(["export", str(place.path), "--format", "mjcf"], capsys, tmp_path, str(place.path / "mjcf"),
            "symbolic link")
    with pytest.raises(OutputError, match="symbolic link"):  # the writer refuses too, should a caller not read
        write_mjcf(place.path, chain, place.name)


def test_a_linked_manipulation_output_folder_is_refused(place, tmp_path, capsys, no_work):
    runs = tmp_path / "runs"
    runs.mkdir()
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    (runs / "hostile_1").symlink_to(outside, target_is_directory=True)
    refused(["manipulate", str(place.path), "--out", str(runs), "--quiet"], capsys, tmp_path,
            str(runs / "hostile_1"), "symbolic link")


@pytest.mark.blender
@pytest.mark.slow
def test_a_render_keeps_a_users_files_in_images_and_drops_its_own_old_ones(place):
    """The render worker (one Blender process, one small view) through ``owned_directory``."""
    pytest.importorskip("bpy", reason="the bpy wheel is not installed (pip install -e .[blender])")
    from blender_addon.rendering import render_puzzles

    put(place.images / "my_annotated_view.png")
    put(place.images / "hostile_1_05.png", b"a view an earlier render made")  # the render's own name
    render_puzzles([place.path], size=(64, 48), views=("top",), animation=False)
    assert (place.images / "my_annotated_view.png").read_bytes() == USER
    # Negative control: the stage's own files are replaced; its old one it did not make again is gone.
    assert sorted(p.name for p in place.images.iterdir()) == ["hostile_1_00.png", "my_annotated_view.png"]


def test_a_users_fifo_is_kept_where_hard_links_fail(place, tmp_path, monkeypatch):
    """Carried over without a hard link (``os.link`` refused), a FIFO of the user's is made anew
    in the new folder, not opened (which would block) and not left behind; a regular file is copied."""
    os.mkfifo(place.path / "urdf" / "pipe", 0o640)
    put(place.path / "urdf" / "notes.txt")

    def no_hard_links(*args, **kwargs):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_hard_links)
    write_puzzle(replace(hostile_puzzle(), parameters={**PARAMETERS, "size": 2.0}), tmp_path / "out")
    pipe = os.lstat(place.path / "urdf" / "pipe")
    assert stat.S_ISFIFO(pipe.st_mode) and stat.S_IMODE(pipe.st_mode) == 0o640
    assert (place.path / "urdf" / "notes.txt").read_bytes() == USER
    assert json.loads(place.metadata.read_text())["parameters"]["size"] == 2.0  # control: the new puzzle is there
    # Kept, not deleted, by the writer; a reader refuses the folder while it holds the FIFO.
    with pytest.raises(PuzzleFormatError, match="urdf/pipe is a FIFO"):
        read_puzzle_dir(place.path)
