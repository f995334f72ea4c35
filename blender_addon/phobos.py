"""Phobos (github.com/dfki-ric/phobos, 2.x): the ``phobostype`` property, and export with Phobos.

Phobos stores ``phobostype`` as an ``EnumProperty`` on ``bpy.types.Object``;
a raw custom property of the same name is invisible to it. When Phobos is
installed it has registered the property already and we leave it alone.

When the Phobos add-on is enabled, :func:`export_with_phobos` runs Phobos's own
exporter on a puzzle scene (``deriveRobot`` and ``Robot.export``). Phobos is
never bundled: users install it from its repository.
"""

from __future__ import annotations

import sys
from pathlib import Path

import bpy

from phyrogen_core.folder import atomic_directory

from .annotations import PHOBOSTYPES

PHOBOS_MODULE = "phobos"
"""The module name Phobos is installed under as a Blender add-on."""
PHOBOS_FOLDER = "phobos"
"""The puzzle folder's entry Phobos's export goes to (``urdf/<name>.urdf``, ``meshes/obj/``)."""

_registered_here = False


def ensure_phobostype() -> None:
    """Register ``Object.phobostype`` unless Phobos (or an earlier call) did."""
    global _registered_here
    if "phobostype" in bpy.types.Object.bl_rna.properties:
        return
    bpy.types.Object.phobostype = bpy.props.EnumProperty(
        items=[(item, item, "") for item in PHOBOSTYPES],
        name="type",
        default="undefined",
        description="Phobos type of the object",
    )
    _registered_here = True


def remove_phobostype() -> None:
    """Undo :func:`ensure_phobostype` (never removes the one Phobos registered)."""
    global _registered_here
    if _registered_here and hasattr(bpy.types.Object, "phobostype"):
        del bpy.types.Object.phobostype
    _registered_here = False


def phobostype(obj: bpy.types.Object) -> str:
    return getattr(obj, "phobostype", "undefined")


def phobos_enabled() -> bool:
    """Whether the Phobos add-on is enabled in this Blender."""
    return PHOBOS_MODULE in bpy.context.preferences.addons


def export_with_phobos(collection: bpy.types.Collection, folder: str | Path) -> Path:
    """Export the puzzle in ``collection`` with Phobos as URDF (OBJ meshes) into ``folder``; the URDF's path.

    ``folder`` is replaced as a whole and atomically: it ends up holding
    Phobos's ``urdf/<name>.urdf`` and ``meshes/obj/``, or, when Phobos fails,
    stays as it was. Raises RuntimeError when Phobos is not enabled or fails.
    """
    if not phobos_enabled():
        raise RuntimeError("the Phobos add-on is not enabled; get it from https://github.com/dfki-ric/phobos "
                           "and enable it in Edit > Preferences > Add-ons")
    from phobos import defs

    if not defs.BPY_AVAILABLE:
        # Phobos takes itself to run inside Blender only when sys.executable's path names "blender", as in
        # blender.org's builds, which bundle their Python; otherwise it refuses Blender's meshes.
        raise RuntimeError(f"Phobos does not recognise this Blender: the path of its Python ({sys.executable}) "
                           "does not name 'blender', as in Linux distributions' packages; use a Blender from "
                           "blender.org")
    from phobos.blender.io.blender2phobos import deriveRobot

    links = [obj for obj in collection.all_objects if phobostype(obj) == "link"]
    roots = [obj for obj in links if obj.parent not in links]
    if len(roots) != 1:
        raise RuntimeError(f"collection {collection.name!r}: Phobos needs exactly one root link, "
                           f"found {sorted(o.name for o in roots)}")
    root = roots[0]
    try:
        # The model is the root and everything under it, whatever Phobos's "selected only" setting says.
        robot = deriveRobot(root, objectlist=[root, *root.children_recursive])
        if robot is None:
            raise RuntimeError(f"Phobos derived no model from {root.name!r}")
        with atomic_directory(folder) as temporary:
            robot.export(outputdir=str(temporary), with_meshes=True, no_smurf=True,
                         export_config=[{"type": "urdf", "mesh_format": "obj", "ros_pathes": False}])
    except RuntimeError:
        raise
    except Exception as exc:  # Phobos's own errors are of every kind; report them as one
        raise RuntimeError(f"Phobos failed to export {collection.name!r}: {type(exc).__name__}: {exc}") from exc
    return Path(folder) / "urdf" / f"{robot.name}.urdf"
