"""Which stage owns which entry of a puzzle folder, file by file.

Every stage writes only the files it owns, by exact name (:func:`stage_owns`); any other file,
even one inside a folder the stage writes, is a user's or another stage's.
"""

from __future__ import annotations

import os
import re
from enum import StrEnum
from pathlib import Path

from .folder_layout import BEST_SOLUTION, METADATA_FILE, STALE_FOLDER


class Stage(StrEnum):
    """A stage that writes into puzzle folders."""

    EXPORT = "export"
    BENCHMARK = "benchmark"
    RENDER = "render"
    INTEROP = "interop"  # files for other tools (MJCF; Phobos's URDF from the Blender add-on), made from the export


def stage_entries(stage: Stage, name: str) -> tuple[str, ...]:
    """The top-level entries of puzzle ``name``'s folder that ``stage`` owns."""
    return {
        Stage.EXPORT: ("urdf", "srdf", "meshes", METADATA_FILE),
        Stage.BENCHMARK: ("solutions",),
        Stage.RENDER: ("images", f"{name}.blend"),
        Stage.INTEROP: ("mjcf", "phobos"),
    }[stage]


MESH_FILE = re.compile(r"[^/]+_(?:visual|collision)_\d+_\d+\.obj")
"""The name of a mesh file the export stage writes (``<link>_<visual|collision>_<geometry>_<piece>.obj``)."""


PHOBOS_FILE = re.compile(r"phobos/(?:urdf/[^/]+\.urdf|meshes/obj/[^/]+)")
"""A file the Blender add-on's Export with Phobos writes (``blender_addon.phobos``): Phobos's URDF
and its OBJ meshes; anything else in ``phobos/`` is a user's."""


def phobos_owns(relative: str) -> bool:
    """Whether ``relative`` (a POSIX path inside a folder Export with Phobos writes) is Phobos's own
    file (:data:`PHOBOS_FILE`): what :func:`owned_directory` replaces there, keeping the rest."""
    return PHOBOS_FILE.fullmatch(f"phobos/{relative}") is not None


def stage_owns(stage: Stage, name: str, relative: str) -> bool:
    """Whether ``relative`` (a POSIX path inside puzzle ``name``'s folder) is a file ``stage`` writes.

    Ownership is by file, not by folder: a stage replaces, and moves into ``stale/``, only files
    of its own exact names; any other file, even one inside a folder the stage writes (a user's
    ``urdf/my_robot.urdf`` or ``images/notes.txt``), is a user's and stays where it is.
    """
    parts = relative.split("/")
    inner = parts[1] if len(parts) == 2 else None
    if stage is Stage.EXPORT:
        return (relative in (METADATA_FILE, f"urdf/{name}.urdf", f"srdf/{name}.srdf")
                or (parts[0] == "meshes" and inner is not None and MESH_FILE.fullmatch(inner) is not None))
    if stage is Stage.BENCHMARK:
        return relative == BEST_SOLUTION.as_posix()
    if stage is Stage.RENDER:
        # blender_addon.views.image_name and animation_name
        return relative == f"{name}.blend" or (
            parts[0] == "images" and inner is not None
            and re.fullmatch(rf"{re.escape(name)}_(?:\d{{2,}}\.png|solution\.webp)", inner) is not None)
    return relative == f"mjcf/{name}.xml" or PHOBOS_FILE.fullmatch(relative) is not None


def owned_files(folder: str | Path, stage: Stage, name: str) -> list[str]:
    """The files of ``stage`` (:func:`stage_owns`) present in ``folder``, as POSIX paths inside it, sorted.
    A symbolic link stands for itself: a linked folder is not walked."""
    folder = Path(folder)
    found = []
    pending = [entry for entry in stage_entries(stage, name) if os.path.lexists(folder / entry)]
    while pending:
        relative = pending.pop()
        path = folder / relative
        is_folder = path.is_dir() and not path.is_symlink()
        if stage_owns(stage, name, relative) and (not is_folder or "/" not in relative):
            found.append(relative)
        elif is_folder:
            try:
                pending += [f"{relative}/{child}" for child in os.listdir(path)]
            except OSError:
                continue
    return sorted(found)


def derived_stages(stage: Stage) -> tuple[Stage, ...]:
    """The stages whose entries are computed from ``stage``'s, and go stale when those change."""
    return (Stage.BENCHMARK, Stage.RENDER, Stage.INTEROP) if stage is Stage.EXPORT else ()


def large_file_allowed(relative: str, name: str) -> bool:
    """Whether ``relative`` (a POSIX path inside puzzle ``name``'s folder) may hold more than
    :data:`MAX_FILE_BYTES`: the render stage's own images, animation and ``.blend``, in the folder
    or in a ``stale/<n>/`` snapshot of it, which no reader reads and whose size the render's
    ``--size`` bounds (an 8192 x 8192 image is tens of MiB)."""
    inner = re.sub(rf"^{STALE_FOLDER}(?:/\d+|-\d+)/", "", relative, count=1)  # (:func:`_stale_slot`)
    return stage_owns(Stage.RENDER, name, inner)
