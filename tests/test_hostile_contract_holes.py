# ruff: noqa: F811  (the fixtures place and no_work come from test_hostile_user_files)
"""Five holes a probe of the command contract found, each closed (issue 39, items 2-6):

- a resumed ``dataset`` removed a shard's ``.records/`` folder whole, a user's file in it included;
- a file over 16 MiB that ``puzzle.json`` does not reference passed every reader, although such
  files are bad input wherever they appear in a puzzle folder (the renders' own images and
  ``.blend`` aside, whose size ``render --size`` bounds);
- ``--out ""`` (``Path("")`` is the working directory) wrote into the working directory;
- ``generate`` made a puzzle whose folder's path was a user's file, then failed (exit 1);
- ``manipulate --table FIFO`` simulated, wrote its report, then blocked forever on the FIFO.

Each refusal is bad input found before any work: exit 2, one stderr line naming the path or value,
nothing written. Each test has its negative control beside it.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hostile_support import refused
from test_hostile_user_files import USER, _reading_commands, no_work, place, put  # noqa: F401

from phyrogen.cli import main
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.folder_reads import MAX_FILE_BYTES


def sparse(path: Path, size: int) -> Path:
    """A file of ``size`` bytes that takes no disk space (a hole)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as handle:
        handle.truncate(size)
    return path


# -- 2. a resumed dataset and a user's file in .records/ --------------------------------------------
def test_a_resumed_dataset_keeps_a_users_file_in_its_records_folder(tmp_path, capsys):
    root = tmp_path / "data"
    argv = ["dataset", "--generator", "grid_world", "--seeds", "9310-9312", "--set", "n_objects=2",
            "--shard-size", "2", "--out", str(root), "--workers", "1", "--quiet"]
    assert main(argv) == 0
    records = [root / "shard-00000" / ".records", root / "shard-00001" / ".records"]
    assert not any(os.path.lexists(folder) for folder in records)  # a complete shard's records are gone
    users = [put(folder / "my_notes.txt") for folder in records]
    # Records of this stage's own names, as a run killed before its part file was written leaves them.
    own = [put(records[0] / "grid_world_9310.json", b"{}"), put(records[1] / "grid_world_9312.json", b"{}")]
    (root / "parts" / "shard-00001.parquet").unlink()  # shard 1 incomplete again: resumed, then finished
    assert main(argv) == 0  # shard 0 skipped as complete, shard 1 finished
    capsys.readouterr()
    for path in users:
        assert path.read_bytes() == USER, path
    for path in own:  # negative control: the records of its own entries are removed
        assert not os.path.lexists(path), path
    # Negative control: a records folder holding nothing of a user's goes, as before.
    put(records[0] / "grid_world_9311.json", b"{}")
    users[0].unlink()
    assert main(argv) == 0
    capsys.readouterr()
    assert not os.path.lexists(records[0]) and users[1].read_bytes() == USER


# -- 3. a file over 16 MiB anywhere in a puzzle folder ----------------------------------------------
@pytest.mark.parametrize("where", ["notes/big.bin", "urdf/extra.urdf", "images/my_render.png", "big_video.mp4",
                                   "stale/1/urdf/hostile_1.urdf", "stale/1/images/notes.png"])
def test_every_reader_refuses_an_unreferenced_file_over_16_mib_up_front(place, tmp_path, capsys, no_work, where):
    big = sparse(place.path / where, MAX_FILE_BYTES + 1)
    for argv in _reading_commands(place, tmp_path):
        refused(argv, capsys, tmp_path, str(big), f"{MAX_FILE_BYTES + 1} bytes", "16 MiB")


def test_a_renders_own_large_files_and_a_file_of_16_mib_pass_every_reader(place, tmp_path, capsys):
    """Negative control: a file of exactly 16 MiB is within the bound; the render stage's own
    images, animation and ``.blend`` (an 8192 x 8192 render is tens of MiB), in the folder or in a
    ``stale/<n>/`` snapshot of it, are no reader's input."""
    sparse(place.path / "notes" / "exactly.bin", MAX_FILE_BYTES)
    for where in ("images/hostile_1_00.png", "images/hostile_1_solution.webp", "hostile_1.blend",
                  "stale/1/images/hostile_1_02.png", "stale/2/hostile_1.blend"):
        sparse(place.path / where, 4 * MAX_FILE_BYTES)
    assert PuzzleFolder.open(place.path).name == "hostile_1"
    assert main(["check", str(place.path)]) == 0
    assert main(["export", str(place.path), "--format", "mjcf"]) == 0
    capsys.readouterr()


# -- 4. an empty path ----------------------------------------------------------------------------
def _empty_path_commands(puzzles: Path, place: PuzzleFolder, tmp_path: Path) -> dict[str, list[str]]:
    urdf = str(place.urdf)
    return {
        "generate --out": ["generate", "--generator", "simple_slider", "--seeds", "1", "--out", ""],
        "dataset --out": ["dataset", "--generator", "grid_world", "--count", "1", "--out", ""],
        "dataset --stats": ["dataset", "--stats", ""],
        "benchmark --out": ["benchmark", "--puzzles", str(puzzles), "--out", "", "--dry-run"],
        "benchmark --puzzles": ["benchmark", "--puzzles", "", "--out", str(tmp_path / "bench"), "--dry-run"],
        "benchmark --report": ["benchmark", "--report", ""],
        "audit --out": ["audit", str(puzzles), "--out", "", "--quiet"],
        "audit DIR": ["audit", "", "--out", str(tmp_path / "audit"), "--quiet"],
        "manipulate --out": ["manipulate", str(place.path), "--out", "", "--quiet"],
        "manipulate --table": ["manipulate", str(place.path), "--out", str(tmp_path / "runs"), "--table", ""],
        "manipulate --benchmark": ["manipulate", str(place.path), "--out", str(tmp_path / "runs"), "--benchmark", ""],
        "manipulate PUZZLE_DIR": ["manipulate", "", "--out", str(tmp_path / "runs")],
        "import --out": ["import", urdf, "--out", ""],
        "import URDF": ["import", "", "--out", str(tmp_path / "imported")],
        "render --out": ["render", "--out", "", "--quiet"],
        "check": ["check", ""],
        "replan": ["replan", ""],
        "export": ["export", "", "--format", "mjcf"],
    }


@pytest.mark.parametrize("command", list(_empty_path_commands(Path(), PuzzleFolder(Path(), "x"), Path())))
def test_an_empty_path_is_refused_not_taken_for_the_working_directory(command, place, tmp_path, capsys, no_work,
                                                                      monkeypatch):
    work = tmp_path / "work"  # the working directory: an empty --out would write here
    work.mkdir()
    monkeypatch.chdir(work)
    argv = _empty_path_commands(place.path.parent.parent, place, tmp_path)[command]
    refused(argv, capsys, tmp_path, "''", "must name a file or folder")
    assert not any(work.iterdir())


# -- 5. generate and a user's file where a puzzle folder goes -------------------------------------
@pytest.mark.parametrize("seeds, taken", [("1-3", 2), ("1-20000", 15_000)], ids=["few seeds", "many seeds"])
def test_generate_refuses_a_users_file_at_a_puzzle_folders_path_before_any_work(seeds, taken, tmp_path, capsys,
                                                                                 no_work):
    out = tmp_path / "out"
    users = put(out / "simple_slider" / f"simple_slider_{taken}")
    put(out / "simple_slider" / "simple_slider_99999")  # not a requested seed: no puzzle goes there
    put(out / "simple_slider" / f"simple_slider_0{taken}")  # not the name of seed {taken}'s folder
    refused(["generate", "--generator", "simple_slider", "--set", "n_objects=2", "--seeds", seeds, "--out", str(out),
             "--quiet"], capsys,
            tmp_path, str(users), "is a file")
    assert users.read_bytes() == USER


def test_generate_passes_folders_and_files_that_are_no_requested_puzzle(tmp_path, capsys):
    """Negative control: a user's files at the paths of seeds not asked for, an earlier puzzle's
    folder, and a name that only looks like a seed's are no obstacle; the puzzles are made."""
    out = tmp_path / "out"
    put(out / "simple_slider" / "simple_slider_7")
    put(out / "simple_slider" / "simple_slider_02")
    assert main(["generate", "--generator", "simple_slider", "--set", "n_objects=2", "--seeds", "2-3", "--out",
                 str(out), "--workers", "1", "--quiet"]) == 0
    assert main(["generate", "--generator", "simple_slider", "--set", "n_objects=2", "--seeds", "3", "--out",
                 str(out), "--workers", "1", "--quiet"]) == 0  # its own folder: made again
    capsys.readouterr()
    assert (out / "simple_slider" / "simple_slider_2" / "puzzle.json").is_file()
    assert (out / "simple_slider" / "simple_slider_7").read_bytes() == USER


# -- 6. manipulate --table and a FIFO ------------------------------------------------------------
def test_manipulate_refuses_a_fifo_as_its_summary_table_before_any_simulation(place, tmp_path, capsys, no_work):
    fifo = tmp_path / "table.md"
    os.mkfifo(fifo)
    refused(["manipulate", str(place.path), "--out", str(tmp_path / "runs"), "--no-video", "--quiet", "--table",
             str(fifo)], capsys, tmp_path, str(fifo), "FIFO")
    (tmp_path / "link.md").symlink_to(fifo)
    refused(["manipulate", str(place.path), "--out", str(tmp_path / "runs"), "--no-video", "--quiet", "--table",
             str(tmp_path / "link.md")], capsys, tmp_path, str(tmp_path / "link.md"), "FIFO")


def test_the_summary_table_is_written_whole_through_a_users_link(tmp_path, monkeypatch):
    """Negative control: a regular file (here behind a user's link, which stays a link) takes the table."""
    import manipulation.batch

    target = put(tmp_path / "tables" / "table.md", b"an older table")
    link = tmp_path / "table.md"
    link.symlink_to(target)
    monkeypatch.setattr(manipulation.batch, "check_inputs", lambda *args, **kwargs: None)
    monkeypatch.setattr(manipulation.batch, "summary_table", lambda reports: "| puzzle |\n")
    assert manipulation.batch.manipulate_folders([], tmp_path / "runs", table=link, quiet=True) == []
    assert link.is_symlink() and target.read_text() == "| puzzle |\n"
    assert [p.name for p in target.parent.iterdir()] == ["table.md"]  # no temporary left
