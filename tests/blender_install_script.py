"""Run by tests/test_blender_extension.py in a fresh Blender: install a PhyRoGen zip, press every job.

    blender --background --factory-startup --python tests/blender_install_script.py -- legacy ZIP OUT RESULT.json
    python tests/blender_install_script.py -- extension ZIP OUT RESULT.json      (the bpy wheel)

``legacy``: the legacy add-on zip through Preferences > Add-ons > Install (``addon_install``) and
``addon_enable``; ``extension``: the extension zip through ``extensions.package_install_files``.
Then Generate (Simple Slider seed 2), Validate, Re-plan, Benchmark, Manipulate and a second Generate
(seed 3), each as ``bpy.ops.phyrogen.<job>()`` (from a script a job is waited for), timed. RESULT.json
says what happened. Nothing of the checkout is used: this file imports only the standard library
before the zip is installed.
"""

import importlib.util
import json
import os
import sys
import time
import traceback

MODULES = ("phyrogen", "phyrogen_core", "solver", "blender_addon", "ompl", "numba", "llvmlite", "tqdm",
           "matplotlib", "pybullet", "imageio", "imageio_ffmpeg")


def main(kind: str, zip_path: str, out: str, result: dict) -> None:
    result["importable_before"] = [m for m in MODULES if importlib.util.find_spec(m) is not None]
    import bpy

    result["blender"] = bpy.app.version_string
    result["executable"] = sys.executable
    if kind == "legacy":
        result["install"] = sorted(bpy.ops.preferences.addon_install(filepath=zip_path))
        result["enable"] = sorted(bpy.ops.preferences.addon_enable(module="phyrogen_blender"))
        module = sys.modules["phyrogen_blender"]
    else:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        result["install"] = sorted(bpy.ops.extensions.package_install_files(
            filepath=zip_path, repo="user_default", enable_on_install=True))
        module = sys.modules["bl_ext.user_default.phyrogen"]
    result["module_file"] = module.__file__
    result["panels"] = sorted(n for n in dir(bpy.types) if n.startswith("PHYROGEN_PT"))
    ui = sys.modules[f"{module.__name__}.ui"]
    environment = sys.modules[f"{module.__name__}.environment"]
    result["numba_cache"] = os.environ.get("NUMBA_CACHE_DIR")
    result["cached_before"] = environment.collision_kernels_cached()
    result["first_run_note"] = ui.first_run_note()
    result["missing"] = {op: ui.missing_modules(op) for op in ("benchmark", "manipulate")}
    settings = bpy.context.scene.phyrogen
    settings.generator, settings.seed, settings.output = "simple_slider", 2, out
    result["seconds"] = {}
    for job in ("generate", "validate", "replan", "benchmark", "manipulate"):
        started = time.perf_counter()
        result[job] = sorted(getattr(bpy.ops.phyrogen, job)())
        result["seconds"][job] = round(time.perf_counter() - started, 2)
        result[f"{job}_table"] = [settings.result_columns, *(row.cells for row in settings.result_rows)]
        result[f"{job}_message"] = settings.result_message
    result["cached_after"] = environment.collision_kernels_cached()
    result["first_run_note_after"] = ui.first_run_note()
    settings.seed = 3
    started = time.perf_counter()
    result["generate_again"] = sorted(bpy.ops.phyrogen.generate())
    result["seconds"]["generate_again"] = round(time.perf_counter() - started, 2)
    result["manipulation_output"] = settings.manipulation_output
    result["origins"] = {m: getattr(importlib.util.find_spec(m), "origin", None) for m in MODULES}
    result["pythonpath"] = os.environ.get("PYTHONPATH", "")
    result["load"] = os.getloadavg()
    # bpy 4.5 hangs at interpreter exit while add-on classes are still registered.
    bpy.ops.preferences.addon_disable(module=module.__name__)


if __name__ == "__main__":
    arguments = sys.argv[sys.argv.index("--") + 1:]
    kind, zip_path, out, result_path = arguments
    result: dict = {}
    try:
        main(kind, zip_path, out, result)
    except Exception:  # noqa: BLE001 (recorded for the test to show)
        result["error"] = traceback.format_exc()
    with open(result_path, "w") as stream:
        json.dump(result, stream)
    sys.stdout.flush()
    sys.stderr.flush()
    if kind == "extension":
        os._exit(0)  # the bpy wheel: leave without the interpreter's clean-up (the results are written)
