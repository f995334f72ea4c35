"""phyrogen_core.folder_reads.real_path_under: a reader resolves a puzzle folder once and then only the
entries below it, and must get exactly what ``os.path.realpath`` gets for every path, links included,
so that the rule "a file read from a puzzle folder resolves inside it" is the same rule."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from phyrogen_core.errors import PuzzleFormatError
from phyrogen_core.folder_reads import read_folder_file, real_folder, real_path_under


def _tree(tmp_path: Path) -> tuple[Path, Path]:
    """A puzzle folder reached through a linked parent, with links inside it and one out of it."""
    real_parent = tmp_path / "real-parent"
    folder = real_parent / "puzzle"
    (folder / "urdf").mkdir(parents=True)
    (folder / "meshes").mkdir()
    (folder / "urdf" / "p.urdf").write_text("<robot/>")
    (folder / "meshes" / "a.obj").write_text("v 0 0 0\n")
    (tmp_path / "outside.obj").write_text("v 1 1 1\n")
    os.symlink(folder / "meshes" / "a.obj", folder / "meshes" / "inside-link.obj")
    os.symlink(tmp_path / "outside.obj", folder / "meshes" / "outside-link.obj")
    os.symlink(folder / "meshes", folder / "linked-meshes")
    os.symlink("..", folder / "meshes" / "up")
    os.symlink(real_parent, tmp_path / "linked-parent")
    return tmp_path / "linked-parent" / "puzzle", tmp_path


RELATIVE = ["urdf/p.urdf", "meshes/a.obj", "urdf/../meshes/a.obj", "urdf/./../meshes/a.obj", "meshes/inside-link.obj",
            "meshes/outside-link.obj", "linked-meshes/a.obj", "linked-meshes/../urdf/p.urdf", "meshes/up/urdf/p.urdf",
            "../puzzle/meshes/a.obj", "../../outside.obj", "missing/a.obj", "missing/../meshes/a.obj",
            "urdf/p.urdf/../x", "meshes/a.obj/..", "meshes//a.obj", ".", "meshes/"]


@pytest.mark.parametrize("relative", RELATIVE)
def test_the_same_answer_as_realpath(tmp_path, relative):
    folder, _ = _tree(tmp_path)
    root = os.fspath(folder)
    path = root + "/" + relative
    assert real_path_under(path, root, real_folder(root)) == os.path.realpath(path)
    # A root given with a trailing slash, or relative to the working directory, too.
    assert real_path_under(path, root + "/", real_folder(root)) == os.path.realpath(path)
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert real_path_under("linked-parent/puzzle/" + relative, "linked-parent/puzzle",
                               real_folder("linked-parent/puzzle")) == os.path.realpath(path)
    finally:
        os.chdir(cwd)


def test_reads_with_a_known_root_keep_the_rule(tmp_path):
    folder, _ = _tree(tmp_path)
    real_root = real_folder(folder)
    assert read_folder_file(folder / "urdf" / ".." / "meshes" / "inside-link.obj", folder,
                            real_root=real_root) == b"v 0 0 0\n"
    assert read_folder_file(folder / "linked-meshes" / "a.obj", folder, real_root=real_root) == b"v 0 0 0\n"
    # Controls: a link out of the folder, and a path climbing out of it, are refused as before.
    for outside in (folder / "meshes" / "outside-link.obj", folder / ".." / ".." / "outside.obj"):
        for known in (real_root, None):
            with pytest.raises(PuzzleFormatError, match="outside the puzzle folder"):
                read_folder_file(outside, folder, real_root=known)
