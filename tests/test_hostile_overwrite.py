"""Writing over an existing puzzle folder: regenerating keeps what other stages and users made while
the puzzle is the same, moves the renders and solutions of a changed puzzle into ``stale/<n>/`` (with
the puzzle they show) and says so, and writers racing for one folder leave one writer's complete folder."""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import os
import threading
from dataclasses import replace
from pathlib import Path

import pytest
from hostile_support import PARAMETERS, hostile_puzzle

from phyrogen_core import atomic_writes
from phyrogen_core.atomic_writes import OutputError, atomic_directory
from phyrogen_core.chain import RED, Geometry
from phyrogen_core.export import read_puzzle_dir, write_export_files, write_puzzle
from phyrogen_core.export.metadata import record_for_chain
from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.folder_ownership import Stage, stage_entries
from phyrogen_core.geometry import Pose, slot_disc
from phyrogen_core.record import PuzzleRecord
from phyrogen_core.stage_writes import same_stage_entries, stage_directory


def tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def add_other_files(place: PuzzleFolder) -> dict[str, bytes]:
    """Renders, a solution and a user's files, as other stages and a user leave them; returns them by path."""
    files = {place.images / f"{place.name}_00.png": b"png 0", place.images / f"{place.name}_01.png": b"png 1",
             place.blend: b"blend", place.best_solution: b'{"path": []}',
             place.path / "notes" / "mine.txt": b"my notes", place.path / ".hidden": b"hidden",
             place.path / "README": b"about this puzzle"}
    for path, data in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    return {p.relative_to(place.path).as_posix(): data for p, data in files.items()}


USER_FILES = ("notes/mine.txt", ".hidden", "README")


def changed_parameters():
    return replace(hostile_puzzle(), parameters={**PARAMETERS, "size": 2.0})


def moved_wall():
    """Only the URDF changes: a fixed wall's pose is in no other file."""
    puzzle = hostile_puzzle()
    wall = puzzle.objects[3]
    moved = replace(wall, pose=Pose.planar(-5.0, 5.5, 0.25, 0.1))
    return replace(puzzle, objects=puzzle.objects[:3] + (moved,))


def reshaped_disc():
    """The slot disc's cut is a little wider: its meshes change, and the inertia in the URDF."""
    puzzle = hostile_puzzle()
    disc = puzzle.objects[1]
    wider = slot_disc(0.5, 0.31)
    visuals = (Geometry(wider, color=RED),) + disc.visuals[1:]
    return replace(puzzle, objects=(puzzle.objects[0], replace(disc, visuals=visuals,
                                                              collisions=(Geometry(wider, color=RED),)),
                                    *puzzle.objects[2:]))


def longer_certificate():
    puzzle = hostile_puzzle()
    start = puzzle.start
    return puzzle.with_certificate([start, (0.5,) + start[1:], (1.0,) + start[1:]])


CHANGES = {"parameters": changed_parameters, "urdf only": moved_wall, "meshes": reshaped_disc,
           "certificate": longer_certificate}


def test_every_change_is_a_change_and_versions_are_not(tmp_path):
    """The cases below each differ in the file they claim to, so the tests cover each kind of change."""
    base = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path / "base"))
    owned = stage_entries(Stage.EXPORT, base.name)
    differs = {}
    for label, make in CHANGES.items():
        other = write_puzzle(make(), tmp_path / label.replace(" ", "_"))
        assert not same_stage_entries(base.path, other, owned), label
        differs[label] = sorted(k for k, v in tree(other).items() if tree(base.path).get(k) != v)
    assert differs["urdf only"] == [f"urdf/{base.name}.urdf"]
    assert any(k.startswith("meshes/") for k in differs["meshes"])
    assert differs["parameters"] == differs["certificate"] == ["puzzle.json"]
    newer = write_puzzle(hostile_puzzle(), tmp_path / "newer", {"phyrogen": "99.0", "numpy": "9"})
    assert tree(newer) != tree(base.path) and same_stage_entries(base.path, newer, owned)


def test_regenerating_the_same_puzzle_keeps_every_other_file_byte_identical(tmp_path):
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path, {"phyrogen": "1.0"}))
    others = add_other_files(place)
    notices: list[str] = []
    write_puzzle(hostile_puzzle(), tmp_path, {"phyrogen": "2.0"}, notices)
    after = tree(place.path)
    assert {k: after.get(k) for k in others} == others
    assert json.loads(after["puzzle.json"])["versions"] == {"phyrogen": "2.0"}  # the new bookkeeping is written
    assert notices == [] and not (place.path / "stale").exists()
    assert os.listdir(place.path.parent) == [place.name]


@pytest.mark.parametrize("change", CHANGES)
def test_regenerating_a_changed_puzzle_moves_its_renders_and_solutions_to_stale(tmp_path, change):
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    old_export = tree(place.path)
    others = add_other_files(place)
    notices: list[str] = []
    write_puzzle(CHANGES[change](), tmp_path, None, notices)

    stale = place.path / "stale" / "1"
    assert notices == [f"{place.path}: puzzle changed; its previous {place.name}.blend, images, solutions moved "
                       f"to {stale}, with the puzzle they were made for"]
    after = tree(place.path)
    for user_file in USER_FILES:
        assert after[user_file] == others[user_file]
    assert not place.images.exists() and not place.blend.exists() and not place.solutions.exists()
    # The snapshot is the whole earlier puzzle folder (user files aside), byte for byte, and reads as one.
    expected = {**old_export, **{k: v for k, v in others.items() if k not in USER_FILES}}
    assert tree(stale) == expected
    fresh = write_puzzle(CHANGES[change](), tmp_path / "fresh")
    assert read_puzzle_dir(stale).chain == read_puzzle_dir(write_puzzle(hostile_puzzle(), tmp_path / "old")).chain
    assert {k: v for k, v in after.items() if k not in USER_FILES and not k.startswith("stale/")} == tree(fresh)


def test_every_later_change_gets_its_own_stale_folder_and_keeps_earlier_ones(tmp_path):
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    add_other_files(place)
    write_puzzle(changed_parameters(), tmp_path)
    first = tree(place.path / "stale")
    add_other_files(place)  # rendered and benchmarked again
    notices: list[str] = []
    write_puzzle(moved_wall(), tmp_path, None, notices)
    assert notices and notices[0].split(" moved to ")[1].startswith(str(place.path / "stale" / "2"))
    assert {k: v for k, v in tree(place.path / "stale").items() if k.startswith("1/")} == first
    assert json.loads((place.path / "stale" / "2" / "puzzle.json").read_text())["parameters"]["size"] == 2.0


def test_a_changed_puzzle_without_renders_or_solutions_is_simply_replaced(tmp_path):
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    (place.path / "notes.txt").write_text("mine")
    notices: list[str] = []
    write_puzzle(moved_wall(), tmp_path, None, notices)
    assert notices == [] and sorted(os.listdir(place.path)) == ["meshes", "notes.txt", "puzzle.json", "srdf", "urdf"]
    assert tree(place.path) == {**tree(write_puzzle(moved_wall(), tmp_path / "fresh")), "notes.txt": b"mine"}


def test_a_user_file_called_stale_is_left_alone(tmp_path):
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    add_other_files(place)
    (place.path / "stale").write_text("my file, not a folder")
    notices: list[str] = []
    write_puzzle(changed_parameters(), tmp_path, None, notices)
    assert (place.path / "stale").read_text() == "my file, not a folder"
    assert (place.path / "stale-1" / "images").is_dir() and str(place.path / "stale-1") in notices[0]


@pytest.mark.parametrize("entry", ["meshes", "urdf"])
def test_a_hand_edited_file_in_an_export_entry_counts_as_a_change_and_an_extra_one_stays(tmp_path, entry):
    """An export file edited by hand is a change (it moves to stale/ with the renders); a user's
    extra file beside it is no file of the export's, changes no puzzle and stays where it is."""
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    add_other_files(place)
    (place.path / entry / "extra.txt").write_text("dropped here by a user")
    notices: list[str] = []
    write_puzzle(hostile_puzzle(), tmp_path, None, notices)
    assert notices == [] and (place.path / entry / "extra.txt").read_text() == "dropped here by a user"

    edited = sorted(p for p in (place.path / entry).iterdir() if p.name != "extra.txt")[0]
    edited.write_bytes(edited.read_bytes() + b"# touched by hand\n")
    write_puzzle(hostile_puzzle(), tmp_path, None, notices)
    stale = place.path / "stale" / "1"
    assert len(notices) == 1 and (stale / "images").is_dir()
    assert (place.path / entry / "extra.txt").read_text() == "dropped here by a user"
    assert not (stale / entry / "extra.txt").exists()
    assert (stale / entry / edited.name).read_bytes().endswith(b"# touched by hand\n")


def test_an_unreadable_old_puzzle_json_counts_as_a_change(tmp_path):
    """When in doubt the renders move aside (nothing lost) rather than stay beside a puzzle they may not show."""
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    add_other_files(place)
    place.metadata.write_text("{ broken")
    write_puzzle(hostile_puzzle(), tmp_path)
    assert (place.path / "stale" / "1" / "puzzle.json").read_text() == "{ broken"
    assert not place.images.exists()


def test_a_failed_regeneration_moves_nothing(tmp_path):
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    add_other_files(place)
    before = tree(place.path)
    with pytest.raises(RuntimeError, match="interrupted"):
        with stage_directory(place.path, Stage.EXPORT, place.name) as temporary:
            write_export_files(PuzzleFolder(temporary, place.name), changed_parameters().chain, "{}")
            raise RuntimeError("interrupted")
    assert tree(place.path) == before and os.listdir(place.path.parent) == [place.name]


def export_like(place: PuzzleFolder, chain, metadata: str, notices: list[str]) -> None:
    """What the Blender panel's Export does (blender_addon.export.export_collection), without Blender."""
    with stage_directory(place.path, Stage.EXPORT, chain.name, notices) as temporary:
        write_export_files(PuzzleFolder(temporary, chain.name), chain, metadata)


def test_export_of_an_unedited_puzzle_keeps_everything_and_of_an_edited_one_moves_renders(tmp_path):
    place = PuzzleFolder.open(write_puzzle(hostile_puzzle(), tmp_path))
    others = add_other_files(place)
    before = tree(place.path)
    stored = place.metadata.read_text()
    notices: list[str] = []
    export_like(place, hostile_puzzle().chain, stored, notices)
    assert tree(place.path) == before and notices == []

    edited = moved_wall().chain
    metadata = record_for_chain(PuzzleRecord.from_json(stored), edited).to_json()
    export_like(place, edited, metadata, notices)
    assert len(notices) == 1 and "stale/1" in notices[0]
    assert read_puzzle_dir(place.path).record.certificate_verified is False
    assert {k: v for k, v in tree(place.path / "stale" / "1").items() if k in others} == {
        k: v for k, v in others.items() if k not in USER_FILES}
    assert all(tree(place.path)[k] == others[k] for k in USER_FILES)


# -- writers racing for one folder ------------------------------------------------------
def race_writer(final: str, writer: int, barrier) -> str | None:
    """One writer of a race: a complete, distinct export (every file names the writer), finished
    at the same instant as the others. Returns the error it met, if any."""
    try:
        with stage_directory(final, Stage.EXPORT, "p") as temporary:
            for entry in ("urdf", "srdf", "meshes"):
                (temporary / entry).mkdir()
                (temporary / entry / f"p.{entry}").write_text(f"writer {writer}")
            (temporary / "puzzle.json").write_text(json.dumps({"writer": writer}))
            barrier.wait()
    except Exception as exc:  # reported, not raised: the caller counts them
        return f"{type(exc).__name__}: {exc}"
    return None


def start_race(root: Path, race: int) -> Path:
    final = root / str(race) / "gen" / "p"
    (final / "images").mkdir(parents=True)
    (final / "images" / "p_00.png").write_text("render of the original")
    (final / "puzzle.json").write_text(json.dumps({"writer": "original"}))
    (final / "notes.txt").write_text("user")
    return final


def check_race(final: Path) -> None:
    """One writer's complete export, the user's file, the original render in stale/1 (moved once,
    by whichever writer came first), and no temporary or old folder left beside it."""
    writer = json.loads((final / "puzzle.json").read_text())["writer"]
    assert isinstance(writer, int)
    assert sorted(os.listdir(final)) == ["meshes", "notes.txt", "puzzle.json", "srdf", "stale", "urdf"]
    assert all((final / e / f"p.{e}").read_text() == f"writer {writer}" for e in ("urdf", "srdf", "meshes"))
    assert (final / "notes.txt").read_text() == "user"
    assert tree(final / "stale") == {"1/images/p_00.png": b"render of the original",
                                     "1/puzzle.json": b'{"writer": "original"}'}
    assert os.listdir(final.parent) == ["p"]


RACES, WRITERS = 40, 4


def on_threads(work, count: int) -> list:
    """``work(i)`` for i in range(count), each on its own thread, all at once; their results in order."""
    results = [None] * count

    def run(i: int) -> None:
        results[i] = work(i)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(count)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return results


def test_threads_racing_for_one_folder_leave_one_complete_folder(tmp_path):
    for race in range(RACES):
        final = start_race(tmp_path, race)
        barrier = threading.Barrier(WRITERS)
        errors = on_threads(lambda i, final=final, barrier=barrier: race_writer(str(final), i, barrier), WRITERS)
        assert errors == [None] * WRITERS
        check_race(final)


def test_processes_racing_for_one_folder_leave_one_complete_folder(tmp_path):
    context = multiprocessing.get_context("fork")
    with context.Manager() as manager, context.Pool(WRITERS) as pool:
        for race in range(12):
            final = start_race(tmp_path, race)
            barrier = manager.Barrier(WRITERS)
            errors = pool.starmap(race_writer, [(str(final), i, barrier) for i in range(WRITERS)])
            assert errors == [None] * WRITERS
            check_race(final)


def test_without_the_swap_lock_a_writer_moves_the_winner_aside_and_still_lands_whole(tmp_path, monkeypatch):
    """On a file system without flock, the rename onto another writer's folder fails (ENOTEMPTY) and
    is retried after moving that folder aside: still one writer's whole folder, and no exception."""
    monkeypatch.setattr(atomic_writes, "_swap_lock", lambda folder: contextlib.nullcontext())
    for race in range(RACES):
        final = tmp_path / str(race) / "out"
        barrier = threading.Barrier(WRITERS)

        def write(i: int, final=final, barrier=barrier) -> BaseException | None:
            try:
                with atomic_directory(final) as temporary:
                    for n in range(3):
                        (temporary / f"part{n}").write_text(str(i))
                    barrier.wait()
            except BaseException as exc:  # returned, for the assertion to show
                return exc
            return None

        assert on_threads(write, WRITERS) == [None] * WRITERS
        parts = {(final / f"part{n}").read_text() for n in range(3)}
        assert len(parts) == 1 and sorted(os.listdir(final)) == ["part0", "part1", "part2"]
        assert os.listdir(final.parent) == ["out"]


def test_a_file_in_the_way_is_one_output_error(tmp_path):
    (tmp_path / "gen").write_text("a file where the generator's folder goes")
    with pytest.raises(OutputError, match="gen.*not a folder|gen.*cannot be made"):
        with atomic_directory(tmp_path / "gen" / "p"):
            pass
    (tmp_path / "p").write_text("a file where the puzzle folder goes")
    with pytest.raises(OutputError, match="exists and is not a folder"):
        with atomic_directory(tmp_path / "p"):
            pass
    assert sorted(os.listdir(tmp_path)) == ["gen", "p"]
