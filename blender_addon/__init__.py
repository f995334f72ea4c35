"""PhyRoGen in Blender: build generated puzzles as Phobos-compatible scenes, export, render.

One package is both a legacy add-on (``bl_info``, Blender 3.4+) and an
extension (``blender_manifest.toml``, Blender 4.2+). Outside Blender it is
the library behind ``phyrogen render``: the modules that import ``bpy`` are
imported only by the ones that need them, so ``blender_addon.rendering`` and
``blender_addon.gallery`` work without it.
"""

bl_info = {
    "name": "PhyRoGen",
    "author": "PhyRoGen developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D Viewport > Sidebar > PhyRoGen",
    "description": "Generate robot-manipulation puzzles, validate them, export URDF, render",
    "category": "Object",
}


def register() -> None:
    from .environment import ensure_project_importable, use_numba_cache

    try:
        ensure_project_importable()
    except ImportError as exc:  # the tab says what is missing and what to do
        from . import missing_dependencies

        missing_dependencies.register(str(exc))
        return
    use_numba_cache(_numba_cache_folder())
    from . import ui

    ui.register()


def _numba_cache_folder() -> str | None:
    """Where an installed add-on's jobs keep numba's compiled kernels: the extension's user folder
    (Blender 4.2+), the user's configuration folder for the legacy zip; None in a checkout, whose
    environment keeps them beside the sources, shared with the command line."""
    from pathlib import Path

    import bpy

    if (__package__ or "").startswith("bl_ext."):
        return bpy.utils.extension_path_user(__package__, path="numba-cache", create=True)
    if (Path(__file__).resolve().parent / "site-packages").is_dir():
        return bpy.utils.user_resource("CONFIG", path="phyrogen/numba-cache", create=True)
    return None


def unregister() -> None:
    import sys

    missing = sys.modules.get(f"{__name__}.missing_dependencies")
    if missing is not None:
        missing.unregister()
    ui = sys.modules.get(f"{__name__}.ui")
    if ui is not None:
        ui.unregister()
