"""Run in a background Blender by tests/test_blender_phobos_install.py, with the user's preferences (no
--factory-startup): Phobos and PhyRoGen enabled there, as a user leaves them.

    blender --background --python-exit-code 1 --python tests/blender_phobos_session.py -- RESULT.json OUT MODE

MODE ``full``: the panel's Generate (a fresh puzzle), then Phobos's own Export Model before anything of
ours touched Phobos, then Validate, Re-plan, Export with Phobos and Export Model once more.
MODE ``validate``: Generate, then Validate only (its report is recorded, success or error).
RESULT.json says what each step did: {"steps": [[name, "ok" | error message], ...], ...}.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
from phobos_export_script import export_with_phobos_operator  # noqa: E402

ARGUMENTS = sys.argv[sys.argv.index("--") + 1:]
RESULT, OUT, MODE = Path(ARGUMENTS[0]), Path(ARGUMENTS[1]), ARGUMENTS[2]
GENERATOR, SEED = "simple_slider", 5


def main() -> None:
    import addon_utils

    shim = sys.modules.get("phyrogen_blender.phobos")
    result: dict = {"steps": [], "addons": list(bpy.context.preferences.addons.keys()),
                    "executable": sys.executable,
                    "phobos_loaded": addon_utils.check("phobos")[1],
                    "recognised_at_start": shim.phobos_recognises_blender() if shim else None}
    settings = bpy.context.scene.phyrogen
    settings.generator, settings.seed, settings.output = GENERATOR, SEED, str(OUT)
    name = f"{GENERATOR}_{SEED}"

    def step(label: str, work) -> bool:
        try:
            value = work()
        except Exception as exc:  # noqa: BLE001 (recorded for the test to show)
            result["steps"].append([label, f"{type(exc).__name__}: {exc}"])
            return False
        result["steps"].append([label, "ok"])
        if isinstance(value, str):  # an operator returns a set
            result[label] = value
        return True

    steps = [("generate", bpy.ops.phyrogen.generate)]
    if MODE == "full":
        steps += [("export_model_first", lambda: export_with_phobos_operator(bpy, name, OUT / "own-first")),
                  ("validate", bpy.ops.phyrogen.validate),
                  ("replan", bpy.ops.phyrogen.replan),
                  ("export_with_phobos", bpy.ops.phyrogen.export_phobos),
                  ("export_model", lambda: export_with_phobos_operator(bpy, name, OUT / "own"))]
    else:
        steps += [("validate", bpy.ops.phyrogen.validate)]
    for label, work in steps:
        if not step(label, work) and label == "generate":
            break
    result["panel"] = [settings.result_label, settings.result_state, settings.result_message]
    RESULT.write_text(json.dumps(result, indent=1))


main()
