"""Run inside Blender by tests/test_phobos_export.py: enable Phobos, build puzzles, Export with Phobos.

    blender --background --factory-startup --python tests/phobos_export_script.py -- \
        RESULT.json REQUIREMENTS_DIR OUTPUT_ROOT CHOSEN_DIR PUZZLE_FOLDER...
    python tests/phobos_export_script.py -- RESULT.json ...        (with the bpy wheel)

Phobos must already be installed as the add-on ``phobos`` in $BLENDER_USER_SCRIPTS/addons, its
requirements in REQUIREMENTS_DIR. Each puzzle folder (under OUTPUT_ROOT/<generator>/) is built
with the add-on's scene builder and exported with the add-on's Export with Phobos operator, the
first one also into CHOSEN_DIR. RESULT.json says what happened, per puzzle.
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


def main(arguments: list[str]) -> int:
    result_path, requirements, output_root, chosen = (Path(a) for a in arguments[:4])
    folders = [Path(a) for a in arguments[4:]]
    result: dict = {"puzzles": {}}
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
    if "blender" not in sys.executable.lower():
        # Phobos (phobos/defs.py) takes itself to run inside Blender only when the path of Python's
        # executable names "blender", as in blender.org's builds, which bundle their Python.
        # Distribution packages run the system Python, so this stands in for the bundled one.
        link = output_root.parent / "blender-python" / Path(sys.executable).name
        link.parent.mkdir(parents=True, exist_ok=True)
        if not link.exists():
            link.symlink_to(sys.executable)
        sys.executable = str(link)
    import bpy

    bpy.ops.preferences.addon_enable(module="phobos")
    import phobos

    result["phobos"] = phobos.version
    result["blender"] = bpy.app.version_string
    from blender_addon import ui
    from blender_addon.scene import build_puzzle_folder

    ui.register()
    settings = bpy.context.scene.phyrogen
    settings.output = str(output_root)
    for index, folder in enumerate(folders):
        for obj in list(bpy.data.objects):
            bpy.data.objects.remove(obj)
        entry: dict = {}
        try:
            built = build_puzzle_folder(folder)
            settings.puzzle = built.collection.name
            settings.phobos_output = ""
            bpy.ops.phyrogen.export_phobos()
            entry["urdf"] = str(folder / "phobos" / "urdf" / f"{built.collection.name}.urdf")
            if index == 0:
                settings.phobos_output = str(chosen)
                bpy.ops.phyrogen.export_phobos()
                entry["chosen_urdf"] = str(chosen / built.collection.name / "urdf" / f"{built.collection.name}.urdf")
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
