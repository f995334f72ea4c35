"""``phyrogen replan``: a new certificate for a puzzle folder as it is now (the panel's Re-plan)."""

from __future__ import annotations

import json
import shutil

from phyrogen.cli import main
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.folder import PuzzleFolder
from solver.pipelines.generation import generate_puzzle, versions
from solver.planning.problem import verify_certificate


def _folder(root, generator="grid_world", seed=3) -> PuzzleFolder:
    from phyrogen_core.export import write_puzzle

    return PuzzleFolder.open(write_puzzle(generate_puzzle(generator, seed), root, versions()))


def test_replan_stores_a_valid_certificate_the_same_on_every_run(tmp_path, capsys):
    first, second = _folder(tmp_path / "a"), _folder(tmp_path / "b")
    (first.images).mkdir()
    (first.images / "grid_world_3_00.png").write_bytes(b"made for the old certificate")  # a render's name
    urdf = first.urdf.read_bytes()
    assert main(["replan", str(first.path)]) == 0
    assert main(["replan", str(second.path)]) == 0
    out = capsys.readouterr()
    assert out.out.count("grid_world_3: new certificate by") == 2
    loaded = read_puzzle_dir(first.path)
    assert verify_certificate(loaded.chain, loaded.certificate, loaded.goal, start=loaded.start) == []
    assert loaded.record.provenance.replanned.planner in ("rrt_connect", "la_rrt_push")
    assert first.metadata.read_bytes() == second.metadata.read_bytes()  # seeded: the same search everywhere
    assert first.urdf.read_bytes() == urdf  # the puzzle itself is unchanged
    # Renders made for the old certificate move aside with it (the folder contract), and the command says so.
    assert (first.path / "stale" / "1" / "images" / "grid_world_3_00.png").is_file() and not first.images.exists()
    assert "moved to" in out.err


def test_replan_certifies_an_edited_puzzle_again(tmp_path):
    folder = _folder(tmp_path, "simple_slider", 2)
    metadata = json.loads(folder.metadata.read_text())
    metadata["certificate_verified"] = False  # as the panel's Export leaves an edited puzzle
    folder.metadata.write_text(json.dumps(metadata))
    assert main(["replan", str(folder.path)]) == 0
    assert read_puzzle_dir(folder.path).record.certificate_verified


def test_replan_that_finds_nothing_leaves_the_folder_as_it_was(tmp_path, capsys):
    folder = _folder(tmp_path, "lockbox_random", 3)
    before = {p: p.read_bytes() for p in folder.path.rglob("*") if p.is_file()}
    assert main(["replan", str(folder.path), "--budget", "10"]) == 1
    assert "not solved by RRT-Connect nor LA-RRT within 10 collision queries" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in folder.path.rglob("*") if p.is_file()} == before


def test_replan_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    assert main(["replan", str(tmp_path / "missing")]) == 2
    assert "no such puzzle folder" in capsys.readouterr().err
    folder = _folder(tmp_path, "simple_slider", 1)
    assert main(["replan", str(folder.path), "--budget", "0"]) == 2
    shutil.rmtree(folder.path)
