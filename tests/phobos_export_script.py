"""Run inside Blender by tests/test_phobos_export.py: enable Phobos, build puzzles, export them with Phobos.

    blender --background --factory-startup --python tests/phobos_export_script.py -- \
        RESULT.json REQUIREMENTS_DIR OUTPUT_ROOT CHOSEN_DIR OWN_DIR PUZZLE_FOLDER...
    python tests/phobos_export_script.py -- RESULT.json ...        (with the bpy wheel)

Phobos must already be installed as the add-on ``phobos`` in $BLENDER_USER_SCRIPTS/addons, its
requirements in REQUIREMENTS_DIR. Nothing here touches ``sys.executable``: Phobos is enabled as a
user enables it, and it is the add-on's own shim (``blender_addon/phobos.py``) that makes Phobos
recognise a Blender running the system's Python when the add-on registers.

First, before the add-on registers, the first puzzle is built with the scene builder and exported
with Phobos's own operator (``phobos.export_model``): the control, which fails where Phobos
misdetects Blender. Then the add-on registers, and each puzzle folder (under
OUTPUT_ROOT/<generator>/) is built and exported twice: with the add-on's Export with Phobos (the
first puzzle also into CHOSEN_DIR) and with Phobos's own operator into OWN_DIR/<puzzle>/.
RESULT.json says what happened, per puzzle.
"""

from __future__ import annotations

import importlib
import json
import os
import sys
import traceback
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
PHOBOS_REQUIREMENTS = ("yaml", "numpy", "scipy", "pkg_resources", "collada", "pydot", "lxml", "networkx",
                       "trimesh", "PIL")


def export_with_phobos_operator(bpy, name: str, folder: Path) -> str:
    """Phobos's own Export Model operator, as its panel runs it, set to URDF with OBJ meshes into
    ``folder`` (Phobos adds ``<name>/``); the URDF's path."""
    scene = bpy.context.scene
    settings = scene.phobosexportsettings
    settings.path = str(folder)
    settings.selectedOnly = False
    settings.export_urdf_mesh_type = "obj"
    for kind in ("smurf", "sdf", "joint_limits", "pdf"):
        setattr(scene, f"export_entity_{kind}", False)
    scene.export_entity_urdf = True
    outcome = bpy.ops.phobos.export_model(modelname=name)
    if outcome != {"FINISHED"}:
        raise RuntimeError(f"phobos.export_model returned {outcome}")
    return str(folder / name / "urdf" / f"{name}.urdf")


def clear(bpy) -> None:
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for collection in list(bpy.data.collections):
        bpy.data.collections.remove(collection)


def main(arguments: list[str]) -> int:
    result_path, requirements, output_root, chosen, own = (Path(a) for a in arguments[:5])
    folders = [Path(a) for a in arguments[5:]]
    result: dict = {"puzzles": {}, "executable": sys.executable}
    sys.path.insert(0, str(requirements))
    sys.path.insert(0, str(REPOSITORY))
    from blender_addon.environment import ensure_project_importable

    ensure_project_importable()
    # With a requirement missing, Phobos pip-installs it and opens a popup that crashes background
    # Blender: check them all first.
    for module in PHOBOS_REQUIREMENTS:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            result["error"] = f"Phobos requirement {module} cannot be imported: {exc}"
            result_path.write_text(json.dumps(result))
            return 3
    import bpy

    bpy.ops.preferences.addon_enable(module="phobos")
    import phobos

    from blender_addon import phobos as shim
    from blender_addon import ui
    from blender_addon.scene import build_puzzle_folder

    result["phobos"] = phobos.version
    result["blender"] = bpy.app.version_string
    result["recognised_before"] = shim.phobos_recognises_blender()
    clear(bpy)
    built = build_puzzle_folder(folders[0])
    try:
        result["control_urdf"] = export_with_phobos_operator(bpy, built.collection.name, own / "control")
    except Exception as exc:  # noqa: BLE001 (recorded for the test to show)
        result["control_error"] = f"{type(exc).__name__}: {exc}"

    ui.register()
    result["recognised_after"] = shim.phobos_recognises_blender()
    result["executable_after"] = sys.executable
    settings = bpy.context.scene.phyrogen
    settings.output = str(output_root)
    for index, folder in enumerate(folders):
        clear(bpy)
        entry: dict = {}
        try:
            built = build_puzzle_folder(folder)
            name = built.collection.name
            settings.puzzle = name
            settings.phobos_output = ""
            bpy.ops.phyrogen.export_phobos()
            entry["urdf"] = str(folder / "phobos" / "urdf" / f"{name}.urdf")
            if index == 0:
                settings.phobos_output = str(chosen)
                bpy.ops.phyrogen.export_phobos()
                entry["chosen_urdf"] = str(chosen / name / "urdf" / f"{name}.urdf")
            entry["own_urdf"] = export_with_phobos_operator(bpy, name, own)
        except Exception:  # noqa: BLE001 (recorded for the test to show)
            entry["error"] = traceback.format_exc()
        result["puzzles"][folder.name] = entry
    ui.unregister()
    bpy.ops.preferences.addon_disable(module="phobos")
    result_path.write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    code = main(sys.argv[sys.argv.index("--") + 1:])
    if not any(a in sys.argv for a in ("--python", "-P")):
        # The bpy wheel hung at interpreter exit here, after Phobos had been enabled and disabled again:
        # leave without the interpreter's clean-up (the results are written).
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
