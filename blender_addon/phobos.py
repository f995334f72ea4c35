"""Phobos (github.com/dfki-ric/phobos, 2.x): the ``phobostype`` property, and export with Phobos.

Phobos stores ``phobostype`` as an ``EnumProperty`` on ``bpy.types.Object``;
a raw custom property of the same name is invisible to it. When Phobos is
installed it has registered the property already and we leave it alone.

When the Phobos add-on is enabled, :func:`export_with_phobos` runs Phobos's own
exporter on a puzzle scene (``deriveRobot`` and ``Robot.export``). Phobos is
never bundled: users install it from its repository.

Phobos 2.1 decides once, when ``phobos.defs`` is imported, whether it runs
inside Blender: only when ``sys.executable`` names "blender", as in
blender.org's builds, which bundle their Python. A Blender that runs the
system's Python (Debian's ``blender`` package) or the ``bpy`` wheel fails that
test, and Phobos then refuses every Blender mesh ("The input type
bpy_types.Mesh of object ... is not recognized"), its own export operator
included. :func:`make_phobos_recognise_blender` is this add-on's shim for it:
it imports Phobos again while ``sys.executable`` names a link called
``blender/python3.X`` to the same interpreter, and restores
``sys.executable`` right after (docs/blender.md, "Phobos on a Blender that runs
the system's Python").
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import bpy

from phyrogen_core.folder import owned_directory, phobos_owns

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


def phobos_recognises_blender() -> bool | None:
    """Whether the loaded Phobos takes itself to run inside Blender (accepts Blender's meshes);
    None when Phobos is not loaded."""
    defs = sys.modules.get(f"{PHOBOS_MODULE}.defs")
    return None if defs is None else bool(getattr(defs, "BPY_AVAILABLE", False))


@contextlib.contextmanager
def executable_named_blender() -> Iterator[str]:
    """``sys.executable`` names "blender" for the duration (a link to the same interpreter in a
    temporary folder named ``blender``, so a pip that Phobos starts runs the same Python); restored after."""
    original = sys.executable
    if "blender" in original.lower():
        yield original
        return
    with tempfile.TemporaryDirectory(prefix="phyrogen-phobos-") as folder:
        link = Path(folder) / "blender" / (Path(original).name or "python")
        link.parent.mkdir()
        os.symlink(original, link)
        sys.executable = str(link)
        try:
            yield str(link)
        finally:
            sys.executable = original


def make_phobos_recognise_blender() -> bool:
    """Reload an enabled Phobos that misdetects this Blender (see the module's docstring); whether it
    was reloaded. Raises RuntimeError when it still does not recognise Blender afterwards."""
    if not phobos_enabled() or phobos_recognises_blender() is not False:
        return False
    import addon_utils

    addon_utils.disable(PHOBOS_MODULE, default_set=False)
    for name in [n for n in sys.modules if n == PHOBOS_MODULE or n.startswith(f"{PHOBOS_MODULE}.")]:
        del sys.modules[name]
    with executable_named_blender():
        addon_utils.enable(PHOBOS_MODULE, default_set=False)
    if not phobos_recognises_blender():
        raise RuntimeError("Phobos does not recognise this Blender even with its Python named 'blender'")
    print(f"PhyRoGen: Phobos reloaded so that it recognises this Blender (its Python, {sys.executable}, "
          "does not name 'blender')")
    return True


def recognise_phobos_when_loaded() -> None:
    """Apply :func:`make_phobos_recognise_blender` now if Phobos is loaded, and again after every file
    load, the start-up file's included: Blender enables its add-ons in the order they were enabled, so
    Phobos may load after this add-on, and at start-up Blender runs the load handlers once all are
    enabled, in a background session too (where timers never run). With a UI, also once shortly after
    start."""
    _recognise_quietly()
    if _recognise_after_load not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(_recognise_after_load)
    if not bpy.app.background:
        bpy.app.timers.register(_recognise_quietly, first_interval=0.5)


def forget_phobos_hooks() -> None:
    """Undo :func:`recognise_phobos_when_loaded`'s load handler (when this add-on is disabled)."""
    while _recognise_after_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_recognise_after_load)


@bpy.app.handlers.persistent
def _recognise_after_load(*_) -> None:
    _recognise_quietly()


def _recognise_quietly() -> None:
    try:
        make_phobos_recognise_blender()
    except Exception as exc:  # noqa: BLE001 (Phobos's own errors are of every kind; Export with Phobos reports them)
        print(f"PhyRoGen: could not make Phobos recognise this Blender: {type(exc).__name__}: {exc}")


def export_with_phobos(collection: bpy.types.Collection, folder: str | Path) -> Path:
    """Export the puzzle in ``collection`` with Phobos as URDF (OBJ meshes) into ``folder``; the URDF's path.

    ``folder`` is swapped in atomically: it ends up holding Phobos's new
    ``urdf/<name>.urdf`` and ``meshes/obj/`` and every other file of the old
    one (a user's notes stay; :func:`~phyrogen_core.folder.phobos_owns`), or,
    when Phobos fails, stays as it was. Raises RuntimeError when Phobos is not
    enabled or fails.
    """
    if not phobos_enabled():
        raise RuntimeError("the Phobos add-on is not enabled; get it from https://github.com/dfki-ric/phobos "
                           "and enable it in Edit > Preferences > Add-ons")
    make_phobos_recognise_blender()
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
        with owned_directory(folder, phobos_owns) as temporary:
            robot.export(outputdir=str(temporary), with_meshes=True, no_smurf=True,
                         export_config=[{"type": "urdf", "mesh_format": "obj", "ros_pathes": False}])
    except RuntimeError:
        raise
    except Exception as exc:  # Phobos's own errors are of every kind; report them as one
        raise RuntimeError(f"Phobos failed to export {collection.name!r}: {type(exc).__name__}: {exc}") from exc
    return Path(folder) / "urdf" / f"{robot.name}.urdf"
