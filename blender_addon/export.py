"""URDF, SRDF and meshes written from a Blender scene, with the core's writers."""

from __future__ import annotations

from pathlib import Path

import bpy

from phyrogen_core.export import atomic_directory, chain_to_srdf, chain_to_urdf

from . import annotations as keys
from .scene import read_chain


def export_collection(collection: bpy.types.Collection, folder: str | Path) -> Path:
    """Write the puzzle in ``collection`` to ``folder`` (replaced atomically) and return the URDF path.

    The folder gets ``urdf/<name>.urdf``, ``srdf/<name>.srdf``, ``meshes/``
    when the chain has prisms, and ``puzzle.json`` when the scene keeps one.
    """
    chain = read_chain(collection)
    urdf_text, meshes = chain_to_urdf(chain)
    metadata = collection.get(keys.METADATA)
    folder = Path(folder)
    with atomic_directory(folder) as temporary:
        _write(temporary / "urdf" / f"{chain.name}.urdf", urdf_text)
        for file_name, text in meshes.items():
            _write(temporary / "meshes" / file_name, text)
        _write(temporary / "srdf" / f"{chain.name}.srdf", chain_to_srdf(chain))
        if metadata is not None:
            _write(temporary / "puzzle.json", str(metadata))
    return folder / "urdf" / f"{chain.name}.urdf"


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
