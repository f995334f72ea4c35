"""Runs inside the real Blender UI (under Xvfb): clicks the panel's Generate, then (after an edit of
the scene) Re-plan, then Manipulate with xdotool, each a job in a subprocess watched by a modal operator.

    blender --factory-startup --python tests/blender_gui_check.py -- RESULT.json SCREENSHOT.png \
        [BEFORE.png DURING.png [GENERATED.png]]

Started by tests/test_blender_binary.py. The add-on must be installed as
the legacy add-on ``phyrogen`` (BLENDER_USER_SCRIPTS) and PHYROGEN_VENV set.
Writes RESULT.json with what it saw, takes Blender's own screenshots (the 3D view with the panel before
the first click, after Generate and after the last job; the whole window, status bar included, while
Manipulate runs),
quits. Nothing zooms or moves the view and nothing is removed from Blender's factory scene (its default
cube included): what the screenshots show is what the panel did, at the sidebar's default width; the
last one is taken without moving the mouse after the job ended.
"""

import json
import os
import subprocess
import sys
import time

import bpy
import mathutils

ARGUMENTS = sys.argv[sys.argv.index("--") + 1:]
RESULT, SCREENSHOT = ARGUMENTS[:2]
BEFORE, DURING = (ARGUMENTS[2:4] if len(ARGUMENTS) >= 4 else (None, None))
GENERATED = ARGUMENTS[4] if len(ARGUMENTS) >= 5 else None
PUZZLE = "simple_slider_1"
state = {"clicks": [], "tab_clicks": [], "started": time.monotonic(), "errors": [], "drawn": False, "steps": [],
         "step": 0, "attempt": 0, "clicked_at": None, "running_ticks": 0, "statuses": [], "click": None,
         "ticks_after_click": 0}


class Step:
    """One button of the panel: where to click it (the share of the panel's width, candidate offsets in
    unscaled pixels below the sidebar's top edge) and what its job's label starts with."""

    def __init__(self, label, x_share, offsets, before=None):
        self.label, self.x_share, self.offsets, self.before = label, x_share, offsets, before


def edit_scene():
    """A user's edit before Re-plan: a blocker moves along y (still clear of the others at the start)."""
    bpy.data.objects["obj_01"].location.y += 0.25


# The Generate row comes below the header, the "Generator" label, its drop-down and the seed; Re-plan,
# Benchmark and Manipulate follow it, one a row (about 29 px each). The first candidate that starts a
# job is the button; a miss lands on the panel's background, or on a neighbour whose job runs and
# does not count (its outcome has the wrong label).
STEPS = (Step("Generate", 0.5, (118, 112, 124, 106, 130)),
         Step("Re-plan", 0.5, (152, 146, 158, 140, 164), before=edit_scene),
         Step("Manipulate", 0.5, (210, 204, 216, 198, 222)))
CLICK_TICKS = 10
"""Timer ticks after xdotool has delivered a click before it counts as a miss. A tick runs at most once
per pass of Blender's event loop, and one pass reads the click, runs the button's operator (which
sets the job's status at once) and redraws: ten passes are plenty, however slowly a loaded machine
runs them, where a wait in seconds was too short for a busy machine."""
TICK = 0.1
LIMIT_SECONDS = 300.0
"""Against a hang only (the check takes about 50 s): below the test's 400 s, so that a hung check still
writes its result, saying where it hung, rather than being killed."""


def view3d():
    window = bpy.context.window_manager.windows[0]
    for area in window.screen.areas:
        if area.type == "VIEW_3D":
            return window, area, next(r for r in area.regions if r.type == "UI")
    raise RuntimeError("no 3D viewport in the default screen")


def finish(ok):
    # No mouse move and no zoom: the screenshot shows the view the panel framed and the buttons as
    # the panel redrew them when the job ended.
    bpy.app.timers.register(lambda: screenshot_and_quit(ok), first_interval=1.5)


def screenshot_area(path):
    window, area, _ = view3d()
    with bpy.context.temp_override(window=window, area=area):
        bpy.ops.screen.screenshot_area(filepath=path)  # the 3D view with the panel


def screenshot_and_quit(ok):
    screenshot_area(SCREENSHOT)
    collection = bpy.data.collections.get(PUZZLE)
    objects = sorted(o.name for o in collection.all_objects) if collection else []
    settings = bpy.context.scene.phyrogen
    with open(RESULT, "w") as stream:
        json.dump({"ok": ok, "objects": objects, "clicks": state["clicks"], "tab_clicks": state["tab_clicks"],
                   "errors": state["errors"], "steps": state["steps"],
                   "manipulation_output": settings.manipulation_output, "output": settings.output,
                   "panel": [settings.result_label, settings.result_state, settings.result_message,
                             settings.result_columns, *(row.cells for row in settings.result_rows)],
                   "during": state.get("during"),
                   "view_after_generate": state.get("view_after_generate"),
                   "objects_at_start": state.get("objects_at_start"), "sidebar": state.get("sidebar"),
                   "scene_after_generate": state.get("scene_after_generate"),
                   "buttons_enabled_after": bpy.ops.phyrogen.generate.poll(),
                   "blender": bpy.app.version_string}, stream)
    bpy.ops.wm.quit_blender()


def click_step(step):
    window, area, region = view3d()
    scale = bpy.context.preferences.system.ui_scale
    # Window coordinates grow upwards, the screen's downwards; the tab column is the region's last 20 px.
    x = region.x + int((region.width - 20 * scale) * step.x_share)
    y = window.height - (region.y + region.height) + int(round(step.offsets[state["attempt"]] * scale))
    click(x, y)
    state["clicks"].append([step.label, x, y])


def click(x, y):
    # The pause lets Blender see the pointer over the button (it highlights it) before the click.
    state["click"] = subprocess.Popen(["xdotool", "mousemove", "--sync", str(x), str(y), "sleep", "0.3", "click",
                                       "1"])
    state["ticks_after_click"] = 0


def click_missed():
    """Whether the last click has had CLICK_TICKS ticks since xdotool delivered it (and exited)."""
    code = state["click"].poll()
    if code is None:
        return False
    if code != 0:
        raise RuntimeError(f"xdotool exited with {code}")
    state["ticks_after_click"] += 1
    return state["ticks_after_click"] > CLICK_TICKS


def find_tab():
    """Click down the sidebar's tab column until the PhyRoGen panel draws (a wrong tab is harmless)."""
    if state["drawn"]:
        bpy.app.timers.register(poll, first_interval=1.0)
        return None
    if time.monotonic() - state["started"] > LIMIT_SECONDS:
        last = state["click"] is not None and state["click"].poll() is None
        state["errors"].append(f"hung: the PhyRoGen tab not found in {LIMIT_SECONDS:.0f} s, after "
                               f"{len(state['tab_clicks'])} tab clicks (the last one's xdotool "
                               f"{'still running' if last else 'done'})")
        finish(False)
        return None
    try:
        if state["click"] is not None and not click_missed():
            return TICK  # the last tab's click: not yet delivered, or Blender has not drawn after it yet
    except RuntimeError as exc:
        state["errors"].append(f"clicking a tab: {exc}")
        finish(False)
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
    return TICK


def poll():
    """Click the current step's button, watch its job (the UI keeps running this timer meanwhile: it is
    not frozen) and go on to the next step when its outcome is in the panel."""
    settings = bpy.context.scene.phyrogen
    now = time.monotonic()
    step = STEPS[state["step"]]
    if now - state["started"] > LIMIT_SECONDS:
        clicked = "no click yet" if state["click"] is None else (
            "its click not yet delivered" if state["click"].poll() is None
            else f"{state['ticks_after_click']} ticks after its click")
        state["errors"].append(f"hung: {step.label} not done in {LIMIT_SECONDS:.0f} s (attempt {state['attempt']}, "
                               f"{clicked}, job status {settings.job_status!r}, {state['running_ticks']} ticks "
                               f"running, panel {settings.result_label!r}: {settings.result_message!r})")
        finish(False)
        return None
    if state["clicked_at"] is None:
        if BEFORE is not None and state["step"] == 0 and state["attempt"] == 0:
            screenshot_area(BEFORE)
        if GENERATED is not None and step.label == "Re-plan" and state["attempt"] == 0:
            screenshot_area(GENERATED)  # Generate's outcome, redrawn since (a second has passed)
            window, area, region = view3d()
            state["sidebar"] = {"width": region.width, "ui_scale": bpy.context.preferences.system.ui_scale}
        if step.before is not None and state["attempt"] == 0:
            step.before()
        # Taken before every attempt: a neighbour's job that a missed click started changes it too.
        state["before"] = (settings.result_label, settings.result_message)
        click_step(step)
        state["clicked_at"] = now
        return TICK
    if settings.job_status:
        state["running_ticks"] += 1
        if DURING is not None and step.label == "Manipulate" and state.get("during") is None:
            window, _, _ = view3d()
            with bpy.context.temp_override(window=window):
                bpy.ops.screen.screenshot(filepath=DURING)  # the whole window: the status bar's progress too
            state["during"] = settings.job_status
        if not state["statuses"] or state["statuses"][-1] != settings.job_status:
            state["statuses"].append(settings.job_status)
        return TICK
    outcome = (settings.result_label, settings.result_message)
    if settings.result_label.startswith(step.label) and outcome != state["before"]:
        if step.label == "Generate":  # where Generate left the 3D view (it frames the new puzzle)
            view = view3d()[1].spaces.active.region_3d
            corners = [list(o.matrix_world @ mathutils.Vector(c)) for o in bpy.data.collections[PUZZLE].all_objects
                       if o.type == "MESH" and o.phobostype == "visual" for c in o.bound_box]
            state["scene_after_generate"] = sorted(o.name for o in bpy.context.scene.objects
                                                   if o.name not in bpy.data.collections[PUZZLE].all_objects)
            state["view_after_generate"] = {
                "location": list(view.view_location), "distance": view.view_distance,
                "low": [min(c[i] for c in corners) for i in range(3)],
                "high": [max(c[i] for c in corners) for i in range(3)]}
        state["steps"].append({"step": step.label, "state": settings.result_state,
                               "message": settings.result_message, "statuses": state["statuses"],
                               "ticks_while_running": state["running_ticks"], "offset": step.offsets[state["attempt"]],
                               "seconds": round(now - state["clicked_at"], 1)})
        if settings.result_state != "DONE":
            state["errors"].append(f"{step.label}: {settings.result_message}")
            finish(False)
            return None
        state.update(step=state["step"] + 1, attempt=0, clicked_at=None, running_ticks=0, statuses=[])
        if state["step"] == len(STEPS):
            bpy.app.timers.register(lambda: finish(True), first_interval=1.0)
            return None
        return 1.0
    try:
        # A miss: a neighbour's job ran and ended (its outcome is not this step's), or no job started.
        missed = state["running_ticks"] > 0 or outcome != state["before"] or click_missed()
    except RuntimeError as exc:
        state["errors"].append(f"clicking {step.label}: {exc}")
        finish(False)
        return None
    if missed:
        if state["attempt"] + 1 >= len(step.offsets):
            state["errors"].append(f"no {step.label} job after clicking at every candidate offset")
            finish(False)
            return None
        state.update(attempt=state["attempt"] + 1, clicked_at=None, running_ticks=0, statuses=[])
    return TICK


def start():
    try:
        bpy.ops.preferences.addon_enable(module="phyrogen")
        settings = bpy.context.scene.phyrogen
        settings.generator = "simple_slider"
        settings.seed = 1
        settings.output = os.path.join(os.path.dirname(os.path.abspath(RESULT)), "output")
        # Blender's factory scene stays as it starts (Cube, Camera, Light): Generate must show the puzzle.
        state["objects_at_start"] = sorted(o.name for o in bpy.context.scene.objects)
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
    bpy.app.timers.register(find_tab, first_interval=2.0)
    return None


bpy.app.timers.register(start, first_interval=1.0)
