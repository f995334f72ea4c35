"""Shared pieces of the hostile-input tests (``test_hostile_*.py``): a small valid puzzle folder
with every shape, motion and role and a valid certificate, and helpers to corrupt it and to
assert that reading it fails with one :class:`PuzzleFormatError` line."""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from phyrogen_core.chain import BLACK, GREEN, RED, Geometry, Role
from phyrogen_core.export import PuzzleFormatError, write_puzzle
from phyrogen_core.geometry import Box, Cylinder, Pose, slot_disc
from phyrogen_core.objects import Motion, PuzzleObject
from phyrogen_core.puzzle import Goal, Puzzle

PARAMETERS = {"size": 1.5, "count": 3, "nested": {"scale": 0.25, "steps": [1, 2.5]}}


def hostile_puzzle() -> Puzzle:
    """Every shape (box, cylinder, prism mesh), motion and role, far enough apart that the target
    slides to its goal along a two-state certificate; parameters with nested numbers."""
    box = Box((1.0, 0.2, 0.2))
    disc = slot_disc(0.5, 0.3)
    objects = (
        PuzzleObject("obj_00", Motion.PRISMATIC, Pose.planar(0.0, 0.0, 0.1), (Geometry(box, color=GREEN),),
                     (Geometry(box, color=GREEN),), Role.TARGET, ((0.0, 1.0),), (1.0, 0.0, 0.0)),
        PuzzleObject("obj_01", Motion.REVOLUTE, Pose.planar(0.0, -4.0, 0.15, 0.3),
                     (Geometry(disc, color=RED), Geometry(Cylinder(0.05, 0.6), Pose((0, 0, 0.3)), BLACK, "hinge")),
                     (Geometry(disc, color=RED),), Role.BLOCKER, ((-3.0, 3.0),)),
        PuzzleObject("obj_02", Motion.SE2, Pose.planar(3.0, 3.0, 0.25, 1.0),
                     (Geometry(Box((0.375, 0.5, 0.5)), color=(0.1, 0.2, 0.3, 1.0)),),
                     (Geometry(Cylinder(0.3, 0.5), color=RED),), Role.BLOCKER,
                     ((-1.0, 1.0), (-2.0, 0.5), (-3.14, 3.14))),
        PuzzleObject("fixed_00_wall", Motion.FIXED, Pose.planar(-5.0, 5.0, 0.25, 0.1),
                     (Geometry(Box((2, 0.1, 0.5))),), (Geometry(Box((2, 0.1, 0.5))),), Role.STATIC),
    )
    puzzle = Puzzle(objects, Goal("obj_00", {"obj_00": 1.0}), "hostile", 1, PARAMETERS)
    start = puzzle.start
    return puzzle.with_certificate([start, (1.0,) + start[1:]])


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> Path:
    """The hostile puzzle's folder, written once per module; tests corrupt copies of it."""
    return write_puzzle(hostile_puzzle(), tmp_path_factory.mktemp("hostile"))


def copy_folder(folder: Path, target: Path) -> Path:
    shutil.copytree(folder, target, symlinks=True)
    return target


def urdf_file(folder: Path) -> Path:
    return folder / "urdf" / f"{json.loads((folder / 'puzzle.json').read_text())['name']}.urdf"


def mesh_files(folder: Path) -> list[Path]:
    return sorted((folder / "meshes").glob("*.obj"))


def edit_json(folder: Path, change: Callable[[dict[str, Any]], Any]) -> None:
    path = folder / "puzzle.json"
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


def format_error(read: Callable[[], Any]) -> str:
    """The message of the :class:`PuzzleFormatError` ``read()`` raises; it must be one line."""
    with pytest.raises(PuzzleFormatError) as caught:
        read()
    message = str(caught.value)
    assert "\n" not in message, message
    return message


def snapshot(root: Path) -> dict[str, object]:
    """Every path under ``root`` with its bytes (a link's target, None for a folder or a FIFO): what
    "nothing created, nothing changed" compares. Links are not followed, FIFOs not opened."""
    def content(path: Path) -> object:
        if path.is_symlink():
            return ("link", os.readlink(path))
        return path.read_bytes() if path.is_file() else None

    return {p.relative_to(root).as_posix(): content(p) for p in sorted(root.rglob("*"))}


def refused(argv: list[str], capsys, root: Path, *fragments: str) -> str:
    """``phyrogen argv`` in this process: exit 2, nothing on stdout, one stderr line holding
    ``fragments`` and no traceback, and ``root`` unchanged; returns that line."""
    from phyrogen.cli import main

    before = snapshot(root)
    code = main(argv)
    out, err = capsys.readouterr()
    assert (code, out) == (2, ""), (code, out, err)
    assert err.count("\n") == 1 and err.startswith("phyrogen: error: ") and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in err, (fragment, err)
    assert snapshot(root) == before
    return err


def cli_check(folder: Path) -> tuple[int, str, str]:
    """``phyrogen check FOLDER`` in this process: exit code, stdout, stderr."""
    from phyrogen.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["check", str(folder)])
    return code, out.getvalue(), err.getvalue()


def assert_cli_rejects(folder: Path, *fragments: str) -> str:
    """``phyrogen check`` on a bad folder: exit 2, nothing on stdout, exactly one line on stderr."""
    code, out, err = cli_check(folder)
    assert code == 2, (code, out, err)
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("phyrogen: error: "), err
    for fragment in fragments:
        assert fragment in err, (fragment, err)
    return err


NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def numeric_attributes(urdf_text: str) -> Iterator[tuple[str, str, int, str]]:
    """(element tag, attribute, occurrence index among attributes of that name, value) of every
    attribute of the URDF whose value is one or more numbers: what a corruption test must cover."""
    seen: dict[str, int] = {}
    for element in ET.fromstring(urdf_text).iter():
        for name, value in element.attrib.items():
            if value.split() and all(NUMBER.fullmatch(token) for token in value.split()):
                index = seen.get(name, 0)
                seen[name] = index + 1
                yield element.tag, name, index, value


def replace_attribute(urdf_text: str, name: str, index: int, new_value: str) -> str:
    """``urdf_text`` with the ``index``-th numeric attribute ``name`` (in document order) set to ``new_value``."""
    count = -1

    def substitute(match: re.Match) -> str:
        nonlocal count
        tokens = match.group(2).split()
        if not tokens or not all(NUMBER.fullmatch(t) for t in tokens):
            return match.group(0)
        count += 1
        return f'{match.group(1)}="{new_value}"' if count == index else match.group(0)

    result = re.sub(rf'(\b{re.escape(name)})="([^"]*)"', substitute, urdf_text)
    assert count >= index, (name, index)
    return result
