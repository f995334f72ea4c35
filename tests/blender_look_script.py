"""Run by tests/test_blender_render.py in the project's Python (the bpy wheel; Workbench, so in a process of
its own): render a puzzle folder's oblique view in the gallery's look and in the same look without
shadows or cavity (the control).

    python tests/blender_look_script.py FOLDER OUT_DIR
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import bpy

from blender_addon import render
from blender_addon.scene import build_puzzle_folder
from blender_addon.views import STILL_SIZE, VIEWS

folder, out = Path(sys.argv[1]), Path(sys.argv[2])
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
built = build_puzzle_folder(folder, scene)
plain = dataclasses.replace(render.GROUND, shadow_intensity=0.0, cavity=None)
for name, look in (("ground", render.GROUND), ("plain", plain)):
    render.setup_stage(scene, built.collection, "WORKBENCH", STILL_SIZE, look)
    scene.camera = render.add_camera(scene, built.collection, VIEWS["oblique"])
    scene.render.filepath = str(out / f"{name}.png")
    bpy.ops.render.render(write_still=True)
