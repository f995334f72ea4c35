"""The ``.blend`` from ``phyrogen render`` opens in the Blender that rendered it.

By default the render workers run the bpy module (Blender 4.5), whose files
Blender 3.x cannot open (the control below: Debian's Blender 3.4.1 crashes on a
cube saved by the bpy wheel). ``phyrogen render --blender PATH`` runs the
workers in that Blender binary, so the scene is saved in its version: Debian's
Blender opens it and finds the puzzle, which reads back to the URDF of the
folder; so does the bpy wheel (newer Blenders open older files).
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from blender_support import tool

REPOSITORY = Path(__file__).resolve().parent.parent
BLENDER = tool("blender")
PUZZLE = ("simple_slider", 11)
"""A seed no other test uses."""

pytestmark = [pytest.mark.blender, pytest.mark.slow,
              pytest.mark.skipif(BLENDER is None, reason="no blender binary here (apt-get install blender)")]

READ_SCENE = r"""
import json, sys
sys.path.insert(0, {repository!r})
from blender_addon.environment import ensure_project_importable
ensure_project_importable()
import bpy
from blender_addon.phobos import ensure_phobostype
from blender_addon.scene import puzzle_collections, read_chain, urdf_digest
ensure_phobostype()  # as the add-on does when enabled: Object.phobostype reads the saved values
found = {{c.name: urdf_digest(read_chain(c)) for c in puzzle_collections(bpy.context.scene)}}
print("SCENE " + json.dumps({{"version": list(bpy.data.version), "puzzles": found}}))
"""


def _environment(home: Path) -> dict[str, str]:
    environment = dict(os.environ)
    environment.update(BLENDER_USER_CONFIG=str(home / "config"), BLENDER_USER_RESOURCES=str(home / "resources"),
                       PHYROGEN_VENV=sys.prefix)
    return environment


def open_in(command: list[str], blend: Path, home: Path) -> subprocess.CompletedProcess:
    """``command`` (a Blender binary, or the bpy wheel's Python) opens ``blend`` and prints its puzzles."""
    script = READ_SCENE.format(repository=str(REPOSITORY))
    if command[0] == sys.executable:
        script = f"import bpy\nbpy.ops.wm.open_mainfile(filepath={str(blend)!r})\n" + script
        arguments = [*command, "-c", script]
    else:
        arguments = [*command, "--background", "--factory-startup", str(blend), "--python-exit-code", "1",
                     "--python-expr", script]
    return subprocess.run(arguments, capture_output=True, text=True, timeout=600, env=_environment(home), cwd=home)


def _scene(run: subprocess.CompletedProcess) -> dict:
    found = re.search(r"^SCENE (.*)$", run.stdout, re.M)
    assert run.returncode == 0 and found, run.stdout[-3000:] + run.stderr[-3000:]
    return json.loads(found[1])


@pytest.fixture(scope="module")
def rendered_with_blender(tmp_path_factory):
    """A puzzle rendered by ``phyrogen render --blender blender``: its folder and the project's digest of it."""
    from phyrogen_core.export import read_puzzle_dir
    from phyrogen_core.export.urdf import chain_to_urdf

    out = tmp_path_factory.mktemp("blend-files")
    generator, seed = PUZZLE
    phyrogen = [sys.executable, "-m", "phyrogen"]
    subprocess.run([*phyrogen, "generate", "--generator", generator, "--seeds", str(seed), "--out", str(out),
                    "--quiet"], check=True, capture_output=True, timeout=600)
    run = subprocess.run([*phyrogen, "render", "--out", str(out), "--blender", BLENDER, "--engine", "cycles",
                          "--size", "64x48", "--views", "top", "--no-animation", "--quiet"],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    folder = out / generator / f"{generator}_{seed}"
    # blender_addon.scene.urdf_digest, without bpy in this process
    return folder, hashlib.sha256(chain_to_urdf(read_puzzle_dir(folder).chain)[0].encode("utf-8")).hexdigest()


def test_render_with_blender_saves_a_file_of_its_version(rendered_with_blender):
    folder, _ = rendered_with_blender
    blend = folder / f"{folder.name}.blend"
    header = blend.read_bytes()[:12]
    assert header == b"BLENDER-v304", header  # Debian's Blender 3.4.1 wrote it
    assert (folder / "images" / f"{folder.name}_00.png").is_file()


def test_debian_blender_opens_the_rendered_file(rendered_with_blender, tmp_path):
    folder, digest = rendered_with_blender
    scene = _scene(open_in([BLENDER], folder / f"{folder.name}.blend", tmp_path))
    assert scene["puzzles"] == {folder.name: digest}


@pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="the bpy wheel is not installed")
def test_the_bpy_wheel_opens_the_file_of_blender_3(rendered_with_blender, tmp_path):
    folder, digest = rendered_with_blender
    scene = _scene(open_in([sys.executable], folder / f"{folder.name}.blend", tmp_path))
    assert scene["puzzles"] == {folder.name: digest}


@pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="the bpy wheel is not installed")
def test_control_blender_3_cannot_open_a_file_of_the_bpy_wheel(tmp_path):
    """Why ``--blender`` exists: Debian's Blender 3.4.1 does not open a file saved by the bpy wheel
    (Blender 4.5), even a cube (it crashes reading the mesh)."""
    blend = tmp_path / "cube.blend"
    subprocess.run([sys.executable, "-c", "import bpy; bpy.ops.wm.read_factory_settings(use_empty=True); "
                    "bpy.ops.mesh.primitive_cube_add(); "
                    f"bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})"],
                   check=True, capture_output=True, timeout=300, env=_environment(tmp_path))
    assert blend.read_bytes()[:12] == b"BLENDER-v405"
    run = open_in([BLENDER], blend, tmp_path)
    assert run.returncode != 0 and "SCENE" not in run.stdout


def test_render_refuses_a_blender_that_does_not_exist(tmp_path):
    run = subprocess.run([sys.executable, "-m", "phyrogen", "render", "--out", str(tmp_path),
                          "--blender", str(tmp_path / "no-blender")], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.strip().count("\n") == 0 and "no-blender" in run.stderr, run.stderr
