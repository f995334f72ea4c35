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
    from .environment import ensure_project_importable

    try:
        ensure_project_importable()
    except ImportError as exc:  # the tab says what is missing and what to do
        from . import missing_dependencies

        missing_dependencies.register(str(exc))
        return
    from . import ui

    ui.register()


def unregister() -> None:
    import sys

    missing = sys.modules.get(f"{__name__}.missing_dependencies")
    if missing is not None:
        missing.unregister()
    ui = sys.modules.get(f"{__name__}.ui")
    if ui is not None:
        ui.unregister()
