"""The sidebar panel: its fields, its buttons, and the last job's outcome with its result table."""

from __future__ import annotations

import bpy

from phyrogen_core.registry import all_generators

from .job_control import OPERATIONS, missing_modules, result_table, running_job
from .panel_settings import editable_fields
from .phobos import phobos_enabled
from .text import wrap_lines


class PHYROGEN_UL_results(bpy.types.UIList):  # noqa: N801 (Blender's naming)
    """The last job's result table, one row per item (the columns' titles are drawn above it)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0, flt_flag=0):
        draw_cells(layout, item.cells.split("\t"))


def draw_cells(layout, cells) -> None:
    """A table row: the first cell (a name) takes half the width, the others share the rest."""
    split = layout.split(factor=0.5)
    split.label(text=cells[0] if cells else "")
    row = split.row()
    for cell in cells[1:]:
        row.label(text=cell)


class PHYROGEN_PT_panel(bpy.types.Panel):  # noqa: N801
    bl_label = "PhyRoGen"
    bl_idname = "PHYROGEN_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "PhyRoGen"

    def draw(self, context):
        # Labels do not wrap: the job's message is wrapped to about as many characters as fit.
        # At most 7 pixels a character of the default font (5.5 on average in the panel's messages, measured
        # in Blender 3.4's screenshots), less the box's margins, the tab column and an icon.
        characters = int(context.region.width / (7 * context.preferences.system.ui_scale)) - 5
        draw_panel(self.layout, context.scene.phyrogen, width=max(characters, 20))


def draw_panel(layout, settings, phobos: bool | None = None, width: int = 60) -> None:
    """The panel's content (a function of the settings, so a test can draw it into a fake layout);
    ``phobos``: whether to show Export with Phobos, by default while the Phobos add-on is enabled;
    ``width``: characters per line of the job's message.

    Every field's name is a label of its own above the field: beside it, in the sidebar's default
    width, names were cut ("Gene..."). Buttons are one per row for the same reason. While a job runs,
    its progress and Cancel take the job buttons' place: Blender keeps drawing a clicked button that
    its operator disabled greyed until the pointer leaves it, so the buttons are not drawn disabled
    but left out, and come back enabled when the job ends."""
    _labelled(layout, settings, "generator", "Generator")
    layout.prop(settings, "seed")
    if running_job() is not None:
        draw_job(layout, settings, width)
    else:
        row = layout.row()
        row.scale_y = 1.6
        row.operator("phyrogen.generate", icon="MOD_BUILD")
        column = layout.column(align=True)
        column.scale_y = 1.2
        column.operator("phyrogen.replan", icon="FILE_REFRESH")
        for operation, icon in (("benchmark", "TIME"), ("manipulate", "ARMATURE_DATA")):
            missing = missing_modules(operation)
            if missing:  # hidden, with one line saying what to install
                column.label(text=f"{OPERATIONS[operation].label} needs {', '.join(missing)}", icon="INFO")
            else:
                column.operator(f"phyrogen.{operation}", icon=icon)
    column = layout.column(align=True)
    column.operator("phyrogen.validate", icon="CHECKMARK")
    column.operator("phyrogen.export_urdf", icon="EXPORT")
    column.operator("phyrogen.render", icon="RENDER_STILL")
    if running_job() is None:
        draw_job(layout, settings, width)
    spec = all_generators()[settings.generator]
    box = layout.box()
    box.label(text=f"{spec.title} parameters")
    group = getattr(settings, f"params_{spec.name}")
    for field in editable_fields(spec.params):
        box.prop(group, field.name)
    _labelled(layout, settings, "output", "Output folder")
    _labelled(layout, settings, "engine", "Render engine")
    show_phobos = phobos_enabled() if phobos is None else phobos
    if show_phobos:
        box = layout.box()
        box.operator("phyrogen.export_phobos", icon="EXPORT")
        _labelled(box, settings, "phobos_output", "Phobos output (empty: the puzzle's phobos/)")


def _labelled(layout, data, name: str, text: str) -> None:
    """A field with its name on the line above."""
    column = layout.column(align=True)
    column.label(text=text)
    column.prop(data, name, text="")


def draw_job(layout, settings, width: int = 60) -> None:
    """The running job's progress and a Cancel button, else the last job's outcome: a line, its message
    (wrapped at ``width`` characters) and its result table as a UI list."""
    if running_job() is not None:
        box = layout.box()
        for index, part in enumerate(wrap_lines(settings.job_status or "running", width, "  ") or ["running"]):
            box.label(text=part, icon="SORTTIME" if index == 0 else "NONE")
        box.operator("phyrogen.cancel_job", icon="CANCEL")
        return
    if settings.result_state == "NONE":
        return
    box = layout.box()
    icon = {"DONE": "CHECKMARK", "FAILED": "ERROR", "CANCELLED": "CANCEL"}[settings.result_state]
    state = {"DONE": "done", "FAILED": "failed", "CANCELLED": "cancelled"}[settings.result_state]
    box.label(text=f"{settings.result_label.split(' ')[0]}: {state}", icon=icon)  # the message names the puzzle
    for part in wrap_lines(settings.result_message, width, "  "):
        box.label(text=part)
    table = result_table(settings)
    if table is not None and table.rows:
        if len(table.columns) == 2:  # a title and a name (Puzzle, simple_slider_1): the name gets the whole width
            for part in wrap_lines(": ".join(table.columns), width, "  "):
                box.label(text=part)
        else:
            draw_cells(box, table.columns)
        box.template_list("PHYROGEN_UL_results", "", settings, "result_rows", settings, "result_row_index",
                          rows=min(max(len(table.rows), 1), 5))
    if settings.result_label.startswith("Manipulate") and settings.manipulation_output:
        row = box.row(align=True)
        row.operator("phyrogen.open_manipulation", text="Video", icon="FILE_MOVIE").what = "VIDEO"
        row.operator("phyrogen.open_manipulation", text="Frames", icon="FILE_FOLDER").what = "FRAMES"
