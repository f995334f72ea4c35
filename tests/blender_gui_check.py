"""Runs inside the real Blender UI (under Xvfb): clicks the panel's Generate with xdotool.

    blender --factory-startup --python tests/blender_gui_check.py -- RESULT.json SCREENSHOT.png

Started by tests/test_blender_binary.py. The add-on must be installed as
the legacy add-on ``phyrogen`` (BLENDER_USER_SCRIPTS) and PHYROGEN_VENV set.
Writes RESULT.json with what it saw, takes Blender's own screenshot, quits.
"""

import json
import os
import subprocess
import sys
import time

import bpy

RESULT, SCREENSHOT = sys.argv[sys.argv.index("--") + 1:][:2]
PUZZLE = "simple_slider_1"
state = {"clicks": [], "tab_clicks": [], "started": time.monotonic(), "errors": [], "drawn": False}


def view3d():
    window = bpy.context.window_manager.windows[0]
    for area in window.screen.areas:
        if area.type == "VIEW_3D":
            return window, area, next(r for r in area.regions if r.type == "UI")
    raise RuntimeError("no 3D viewport in the default screen")


def finish(ok):
    window, area, _ = view3d()
    main_region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window, area=area, region=main_region):
        if ok:
            bpy.ops.view3d.view_all()
    bpy.app.timers.register(lambda: screenshot_and_quit(ok), first_interval=1.0)


def screenshot_and_quit(ok):
    window, area, _ = view3d()
    with bpy.context.temp_override(window=window, area=area):
        bpy.ops.screen.screenshot(filepath=SCREENSHOT)
    collection = bpy.data.collections.get(PUZZLE)
    objects = sorted(o.name for o in collection.all_objects) if collection else []
    with open(RESULT, "w") as stream:
        json.dump({"ok": ok, "objects": objects, "clicks": state["clicks"], "tab_clicks": state["tab_clicks"],
                   "errors": state["errors"],
                   "blender": bpy.app.version_string}, stream)
    bpy.ops.wm.quit_blender()


def click_generate():
    window, area, region = view3d()
    scale = bpy.context.preferences.system.ui_scale
    # Window coordinates grow upwards, the screen's downwards. The Generate button is the
    # third row of the panel, below the header, generator and seed rows.
    x = region.x + region.width // 2
    y = window.height - (region.y + region.height) + int(round(state["offset"] * scale))
    click(x, y)
    state["clicks"].append([x, y])


def click(x, y):
    subprocess.Popen(["xdotool", "mousemove", "--sync", str(x), str(y), "click", "1"])


def find_tab():
    """Click down the sidebar's tab column until the PhyRoGen panel draws (a wrong tab is harmless)."""
    if state["drawn"]:
        bpy.app.timers.register(poll, first_interval=1.0)
        return None
    window, _, region = view3d()
    top = window.height - (region.y + region.height)
    offset = 12 + 14 * len(state["tab_clicks"])
    if offset > region.height - 20:
        state["errors"].append("the PhyRoGen tab was not found")
        finish(False)
        return None
    x = region.x + region.width - 9
    click(x, top + offset)
    state["tab_clicks"].append([x, top + offset])
    return 0.8


def poll():
    collection = bpy.data.collections.get(PUZZLE)
    if collection is not None and len(collection.all_objects) > 0:
        bpy.app.timers.register(lambda: finish(True), first_interval=1.0)
        return None
    elapsed = time.monotonic() - state["started"]
    if elapsed > 120:
        state["errors"].append("no puzzle after 120 s")
        finish(False)
        return None
    if not state["clicks"] or (len(state["clicks"]) < len(OFFSETS) and elapsed > state["next_click"]):
        state["offset"] = OFFSETS[len(state["clicks"])]
        click_generate()
        state["next_click"] = elapsed + 8.0
    return 0.5


# Candidate offsets (unscaled pixels from the top of the sidebar) of the Generate row; the
# first hit generates, later ones are never clicked.
OFFSETS = (96, 88, 104)


def start():
    try:
        bpy.ops.preferences.addon_enable(module="phyrogen")
        settings = bpy.context.scene.phyrogen
        settings.generator = "simple_slider"
        settings.seed = 1
        settings.output = os.path.join(os.path.dirname(os.path.abspath(RESULT)), "output")
        cube = bpy.data.objects.get("Cube")
        if cube is not None:
            bpy.data.objects.remove(cube)
        window, area, region = view3d()
        area.spaces[0].show_region_ui = True
        area.tag_redraw()
        panel = bpy.types.PHYROGEN_PT_panel
        draw = panel.draw

        def recording_draw(self, context):
            state["drawn"] = True
            draw(self, context)

        panel.draw = recording_draw
    except Exception as exc:  # report instead of hanging the UI
        state["errors"].append(repr(exc))
        finish(False)
        return None
    state["next_click"] = 0.0
    bpy.app.timers.register(find_tab, first_interval=2.0)
    return None


bpy.app.timers.register(start, first_interval=1.0)
