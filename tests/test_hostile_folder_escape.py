"""Hostile input, class 3: a puzzle folder that reaches outside itself, or hands a reader something
other than a small regular file.

A puzzle folder is self-contained: every file a reader takes from it (``puzzle.json``, the URDF,
each OBJ mesh, the benchmark's solution) must, after symbolic links are resolved, lie inside the
folder, be a regular file (checked with ``os.stat`` before anything is opened: a FIFO would block,
``/dev/zero`` would never end) and hold at most ``MAX_FILE_BYTES`` (16 MiB). Mesh paths are
relative to the URDF (no absolute paths, no URLs). The puzzle's ``name``, which builds the URDF's
path, keeps one rule wherever a name meets a path (:func:`phyrogen_core.folder.name_problem`:
the reader, ``PuzzleFolder.open`` and ``PuzzleFolder.at``). Anything else is a
:class:`PuzzleFormatError` naming the file, one line; ``phyrogen check`` exits 2.

The cases apply every kind of escape to every file the reader opens: each mesh reference in the
URDF in turn, ``puzzle.json``, the URDF, the solution file. FIFO cases run the reader in a child
process whose ``open`` calls fail on the FIFO and which has 20 s to finish, so a regression
fails instead of hanging.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest
from hostile_support import (
    assert_cli_rejects,
    copy_folder,
    edit_json,
    format_error,
    hostile_puzzle,
    mesh_files,
    urdf_file,
    written,  # noqa: F401 (fixture)
)

from manipulation.solution import load_solution
from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.export import read_puzzle_dir
from phyrogen_core.folder import PuzzleFolder, find_puzzle_folders
from phyrogen_core.folder_layout import BEST_SOLUTION, MAX_NAME_LENGTH
from phyrogen_core.folder_reads import MAX_FILE_BYTES

REPOSITORY = Path(__file__).resolve().parents[1]
MESH_COUNT = 6
OUTSIDE = "outside the puzzle folder"


def _mesh_references(folder: Path) -> list[str]:
    text = urdf_file(folder).read_text()
    names = sorted({part.split('"')[0] for part in text.split('<mesh filename="')[1:]})
    assert len(names) == MESH_COUNT
    return names


def _point_mesh_at(folder: Path, reference: str, new: str) -> None:
    urdf = urdf_file(folder)
    text = urdf.read_text()
    assert text.count(f'filename="{reference}"') == 1
    urdf.write_text(text.replace(f'filename="{reference}"', f'filename="{new}"'))


def _outside_copy(folder: Path, reference: str) -> Path:
    """A valid copy of the mesh ``reference`` beside (outside) the puzzle folder."""
    target = folder.parent / "elsewhere" / Path(reference).name
    target.parent.mkdir(exist_ok=True)
    target.write_bytes((folder / "urdf" / reference).read_bytes())
    return target


def _socket_at(path: Path) -> socket.socket:
    """A listening UNIX socket at ``path`` (bound from its folder: socket paths are short)."""
    here = os.getcwd()
    os.chdir(path.parent)
    try:
        server = socket.socket(socket.AF_UNIX)
        server.bind(path.name)
    finally:
        os.chdir(here)
    return server


# -- mesh references ---------------------------------------------------------------------------
def _absolute(folder, reference):
    _point_mesh_at(folder, reference, str(_outside_copy(folder, reference)))
    return "must be a path relative to the URDF file"


def _file_url(folder, reference):
    _point_mesh_at(folder, reference, "file://" + str(_outside_copy(folder, reference)))
    return "must be a path relative to the URDF file"


def _package_url(folder, reference):
    _point_mesh_at(folder, reference, "package://puzzle/meshes/" + Path(reference).name)
    return "must be a path relative to the URDF file"


def _empty(folder, reference):
    _point_mesh_at(folder, reference, "")
    return "must be a path relative to the URDF file"


def _dot_dot(folder, reference):
    _outside_copy(folder, reference)
    _point_mesh_at(folder, reference, "../../elsewhere/" + Path(reference).name)
    return OUTSIDE


def _dot_dot_through_meshes(folder, reference):
    _outside_copy(folder, reference)
    _point_mesh_at(folder, reference, "../meshes/../../elsewhere/" + Path(reference).name)
    return OUTSIDE


def _symlink_outside(folder, reference):
    mesh = folder / "urdf" / reference
    outside = _outside_copy(folder, reference)
    mesh.unlink()
    mesh.symlink_to(outside)
    return OUTSIDE


def _symlink_dev_zero(folder, reference):
    mesh = folder / "urdf" / reference
    mesh.unlink()
    mesh.symlink_to("/dev/zero")
    return "resolves to /dev/zero"


def _meshes_folder_outside(folder, reference):
    meshes = folder / "meshes"
    outside = folder.parent / "elsewhere_meshes"
    meshes.rename(outside)
    meshes.symlink_to(outside, target_is_directory=True)
    return OUTSIDE


def _folder(folder, reference):
    mesh = folder / "urdf" / reference
    mesh.unlink()
    mesh.mkdir()
    return "is a folder, not a regular file"


def _oversize(folder, reference):
    mesh = folder / "urdf" / reference
    os.truncate(mesh, MAX_FILE_BYTES + 1)  # sparse: costs no disk
    return f"is {MAX_FILE_BYTES + 1} bytes, more than the 16 MiB"


def _symlink_loop(folder, reference):
    mesh = folder / "urdf" / reference
    mesh.unlink()
    mesh.symlink_to(mesh.name)
    return "cannot"


def _missing(folder, reference):
    (folder / "urdf" / reference).unlink()
    return "is missing"


MESH_ESCAPES: dict[str, Callable[[Path, str], str]] = {
    f.__name__.strip("_"): f for f in (_absolute, _file_url, _package_url, _empty, _dot_dot, _dot_dot_through_meshes,
                                       _symlink_outside, _symlink_dev_zero, _meshes_folder_outside, _folder,
                                       _oversize, _symlink_loop, _missing)
}


@pytest.mark.parametrize("escape", MESH_ESCAPES)
@pytest.mark.parametrize("which", range(MESH_COUNT))
def test_every_mesh_reference_stays_inside_the_folder(written, tmp_path, escape, which):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    reference = _mesh_references(folder)[which]
    fragment = MESH_ESCAPES[escape](folder, reference)
    message = format_error(lambda: read_puzzle_dir(folder))
    assert message.startswith(f"{urdf_file(folder)}: link 'obj_01' <") and fragment in message, message


def test_a_mesh_socket_is_refused(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "c")
    mesh = mesh_files(folder)[0]
    mesh.unlink()
    with _socket_at(mesh):
        message = format_error(lambda: read_puzzle_dir(folder))
    assert "is a socket, not a regular file" in message, message


def test_symlinks_inside_the_folder_are_followed(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    for mesh in mesh_files(folder):
        kept = folder / "library" / mesh.name
        kept.parent.mkdir(exist_ok=True)
        mesh.rename(kept)
        mesh.symlink_to(Path("..") / "library" / mesh.name)
    assert read_puzzle_dir(folder).chain == read_puzzle_dir(written).chain
    # The folder itself may be reached through a link.
    link = tmp_path / "link"
    link.symlink_to(folder, target_is_directory=True)
    assert read_puzzle_dir(link).chain == read_puzzle_dir(written).chain


# -- puzzle.json and the URDF ------------------------------------------------------------------
def _entry(folder: Path, which: str) -> Path:
    return folder / "puzzle.json" if which == "puzzle.json" else urdf_file(folder)


def _file_symlink_outside(path: Path) -> str:
    outside = path.parent.parent.parent / f"outside_{path.name}"
    path.rename(outside)
    path.symlink_to(outside)
    return OUTSIDE


def _file_symlink_device(target: str) -> Callable[[Path], str]:
    def damage(path: Path) -> str:
        path.unlink()
        path.symlink_to(target)
        return f"resolves to {target}"
    damage.__name__ = f"symlink{target.replace('/', '_')}"
    return damage


def _file_folder(path: Path) -> str:
    path.unlink()
    path.mkdir()
    return "is a folder, not a regular file"


def _file_oversize(path: Path) -> str:
    with path.open("ab") as handle:
        handle.truncate(MAX_FILE_BYTES + 1)
    return "more than the 16 MiB"


FILE_ESCAPES = {
    "symlink_outside": _file_symlink_outside,
    "symlink_dev_zero": _file_symlink_device("/dev/zero"),
    "symlink_dev_null": _file_symlink_device("/dev/null"),
    "folder": _file_folder,
    "oversize": _file_oversize,
}


@pytest.mark.parametrize("escape", FILE_ESCAPES)
@pytest.mark.parametrize("which", ["puzzle.json", "urdf"])
def test_puzzle_json_and_the_urdf_are_regular_files_inside_the_folder(written, tmp_path, which, escape):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    path = _entry(folder, which)
    fragment = FILE_ESCAPES[escape](path)
    message = format_error(lambda: read_puzzle_dir(folder))
    assert message.startswith(f"{path}: ") and fragment in message, message
    if which == "puzzle.json":
        with pytest.raises(PuzzleFormatError, match=fragment.replace("(", r"\(")):
            PuzzleFolder.open(folder)


def test_the_urdf_folder_cannot_lie_outside(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    outside = tmp_path / "urdf_elsewhere"
    (folder / "urdf").rename(outside)
    (folder / "urdf").symlink_to(outside, target_is_directory=True)
    assert OUTSIDE in format_error(lambda: read_puzzle_dir(folder))


@pytest.mark.parametrize("which", ["puzzle.json", "urdf"])
def test_a_socket_instead_of_a_file_is_refused(written, tmp_path, which):  # noqa: F811
    folder = copy_folder(written, tmp_path / "c")
    path = _entry(folder, which)
    path.unlink()
    with _socket_at(path):
        assert "is a socket, not a regular file" in format_error(lambda: read_puzzle_dir(folder))


# -- FIFOs: refused before they are opened -----------------------------------------------------
_GUARDED = textwrap.dedent("""
    import builtins, io, os, sys
    fifo = os.path.realpath(sys.argv[1])

    def guard(real):
        def opener(path, *args, **kwargs):
            if isinstance(path, (str, bytes, os.PathLike)) and os.path.realpath(path) == fifo:
                print("OPENED THE FIFO", file=sys.stderr)
                os._exit(3)
            return real(path, *args, **kwargs)
        return opener

    os.open, builtins.open, io.open = guard(os.open), guard(builtins.open), guard(io.open)
    from pathlib import Path
    try:
        {call}
    except ValueError as exc:
        print(type(exc).__name__ + ": " + str(exc))
        sys.exit(0)
    print("NO ERROR")
    sys.exit(1)
""")


def _run_guarded(fifo: Path, call: str) -> str:
    result = subprocess.run([sys.executable, "-c", _GUARDED.replace("{call}", call), str(fifo)], cwd=REPOSITORY,
                            env={**os.environ, "PYTHONPATH": str(REPOSITORY)}, capture_output=True, text=True,
                            timeout=20)
    assert result.returncode == 0, (result.returncode, result.stdout, result.stderr)
    assert result.stdout.count("\n") == 1, result.stdout
    return result.stdout


@pytest.mark.parametrize("which", ["puzzle.json", "urdf", "mesh", "solution"])
def test_a_fifo_is_refused_before_it_is_opened(written, tmp_path, which):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    path = {"puzzle.json": folder / "puzzle.json", "urdf": urdf_file(folder), "mesh": mesh_files(folder)[-1],
            "solution": folder / BEST_SOLUTION}[which]
    path.parent.mkdir(exist_ok=True)
    path.unlink(missing_ok=True)
    os.mkfifo(path)
    if which == "solution":
        call = ("from manipulation.solution import load_solution; "
                f"load_solution(Path({str(folder)!r}), {hostile_puzzle().joint_order!r}, [])")
    else:
        call = f"from phyrogen_core.export import read_puzzle_dir; read_puzzle_dir({str(folder)!r})"
    out = _run_guarded(path, call)
    assert out.startswith("PuzzleFormatError: ") and "is a FIFO, not a regular file" in out, out


def test_finding_puzzles_refuses_a_fifo_puzzle_json(written, tmp_path):  # noqa: F811
    root = tmp_path / "out"
    copy_folder(written, root / "hostile" / "hostile_1")
    copy_folder(written, root / "hostile" / "hostile_2")
    fifo = root / "hostile" / "hostile_2" / "puzzle.json"
    fifo.unlink()
    os.mkfifo(fifo)
    call = f"from phyrogen_core.folder import find_puzzle_folders; find_puzzle_folders({str(root)!r})"
    out = _run_guarded(fifo, call)
    assert out.startswith(f"PuzzleFormatError: {fifo}: puzzle.json is a FIFO"), out


def test_check_on_a_fifo_ends_with_one_line_and_exit_2(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    (folder / "puzzle.json").unlink()
    os.mkfifo(folder / "puzzle.json")
    result = subprocess.run([sys.executable, "-m", "phyrogen", "check", str(folder)], cwd=REPOSITORY,
                            env={**os.environ, "PYTHONPATH": str(REPOSITORY)}, capture_output=True, text=True,
                            timeout=20)
    assert result.returncode == 2 and result.stdout == "", result
    assert result.stderr.count("\n") == 1 and "is a FIFO, not a regular file" in result.stderr, result.stderr


# -- the solution file -------------------------------------------------------------------------
def _solution_text(folder: Path) -> str:
    loaded = read_puzzle_dir(folder)
    return json.dumps({"joint_order": list(loaded.joint_order), "path": [list(s) for s in loaded.certificate]})


@pytest.mark.parametrize("escape", ["symlink_outside", "symlink_dev_zero", "solutions_outside", "folder", "oversize"])
def test_the_solution_file_is_a_regular_file_inside_the_folder(written, tmp_path, escape):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    file = folder / BEST_SOLUTION
    file.parent.mkdir()
    file.write_text(_solution_text(folder))
    loaded = read_puzzle_dir(folder)
    assert load_solution(folder, loaded.joint_order, loaded.certificate).source == str(file)
    if escape == "solutions_outside":
        outside = tmp_path / "solutions_elsewhere"
        file.parent.rename(outside)
        file.parent.symlink_to(outside, target_is_directory=True)
        fragment = OUTSIDE
    else:
        fragment = {**FILE_ESCAPES, "symlink_dev_zero": _file_symlink_device("/dev/zero")}[escape](file)
    message = format_error(lambda: load_solution(folder, loaded.joint_order, loaded.certificate))
    assert message.startswith(f"{file}: solution file ") and fragment in message, message


# -- names -------------------------------------------------------------------------------------
BAD_NAMES = ["../x", "..", ".", "/etc/passwd", "a/b", "a\\b", ".hidden", "", "x\ny", "tab\there",
             "n" * (MAX_NAME_LENGTH + 1), 5, None, ["x"]]


@pytest.mark.parametrize("name", BAD_NAMES, ids=repr)
def test_a_name_cannot_build_paths_outside_the_folder(written, tmp_path, name):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    edit_json(folder, lambda m: m.__setitem__("name", name))
    message = format_error(lambda: read_puzzle_dir(folder))
    assert message.startswith(f"{folder / 'puzzle.json'}: name"), message
    with pytest.raises(PuzzleFormatError, match="name"):
        PuzzleFolder.open(folder)
    with pytest.raises(ValueError, match="cannot name a puzzle folder"):
        PuzzleFolder.at(tmp_path, "generator", name)
    with pytest.raises(ValueError, match="cannot name a puzzle folder"):
        PuzzleFolder.at(tmp_path, name, "puzzle_1")


@pytest.mark.parametrize("name", ["hostile_1", "my puzzle", "a.b-c_2", "n" * MAX_NAME_LENGTH])
def test_good_names_pass_every_reader(written, tmp_path, name):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    edit_json(folder, lambda m: m.__setitem__("name", name))
    urdf = folder / "urdf" / "hostile_1.urdf"
    urdf.rename(urdf.with_name(f"{name}.urdf"))
    assert read_puzzle_dir(folder).name == name
    assert PuzzleFolder.open(folder).urdf == folder / "urdf" / f"{name}.urdf"
    assert PuzzleFolder.at(tmp_path, "generator", name).name == name
    assert [f.name for f in find_puzzle_folders(folder)] == [name]


# -- the command line --------------------------------------------------------------------------
@pytest.mark.parametrize("escape", ["dot_dot", "absolute", "symlink_dev_zero", "oversize"])
def test_check_rejects_an_escaping_mesh_with_one_line(written, tmp_path, escape):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    fragment = MESH_ESCAPES[escape](folder, _mesh_references(folder)[0])
    assert_cli_rejects(folder, str(urdf_file(folder)), fragment)


def test_check_rejects_an_escaping_name_with_one_line(written, tmp_path):  # noqa: F811
    folder = copy_folder(written, tmp_path / "copy")
    edit_json(folder, lambda m: m.__setitem__("name", "../../x"))
    assert_cli_rejects(folder, "puzzle.json", "name '../../x'")
