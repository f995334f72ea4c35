"""The puzzle in a Blender scene written to its puzzle folder, with the core's writers.

Only the export stage's entries are replaced (URDF, SRDF, meshes,
``puzzle.json``); a user's files stay, and so do renders and solutions while
the puzzle is unchanged. When the scene was edited after the puzzle was built,
``puzzle.json`` is rewritten to agree with the new URDF and its certificate is
marked as not verified for it; the renders and solutions of the puzzle before
the edit move into ``stale/<n>/`` with it.
"""

from __future__ import annotations

from pathlib import Path

import bpy

from phyrogen_core.export import write_export_files
from phyrogen_core.export.metadata import record_for_chain
from phyrogen_core.folder import PuzzleFolder, Stage, stage_directory
from phyrogen_core.record import PuzzleRecord

from . import annotations as keys
from .scene import read_chain, urdf_digest


def export_collection(collection: bpy.types.Collection, folder: str | Path,
                      notices: list[str] | None = None) -> Path:
    """Write the puzzle in ``collection`` into ``folder`` and return the URDF path.

    An edited puzzle's earlier renders and solutions move into ``stale/<n>/``
    of the folder, and a line saying so is appended to ``notices``.

    Raises ValueError when the collection keeps no ``puzzle.json`` (it was not
    built from a generated puzzle) or the edit removed a joint the goal needs.
    """
    chain = read_chain(collection)
    stored = collection.get(keys.METADATA)
    if stored is None:
        raise ValueError(f"{collection.name!r} keeps no puzzle.json; build it with Generate or from a puzzle folder")
    metadata = str(stored)
    if collection.get(keys.URDF_DIGEST) != urdf_digest(chain):
        stored_record = PuzzleRecord.from_json(metadata, f"{collection.name}: puzzle.json")
        metadata = record_for_chain(stored_record, chain).to_json()
    place = PuzzleFolder(Path(folder), chain.name)
    with stage_directory(place.path, Stage.EXPORT, chain.name, notices) as temporary:
        write_export_files(PuzzleFolder(temporary, chain.name), chain, metadata)
    return place.urdf
