"""The panel shown instead of PhyRoGen's when its dependencies cannot be imported.

The extension zip bundles everything Generate needs for Linux x86-64 and Python
3.11 (``scripts/build_addon.py``). Elsewhere, or from a zip built with
``--no-wheels``, the add-on still enables and its tab says what is missing and
what to do, instead of failing in a traceback that only the console shows.
"""

from __future__ import annotations

import bpy

from .text import wrap_lines

WRAP_CHARACTERS = 48

_message = ""


def panel_lines(message: str) -> list[str]:
    """The panel's text: a heading, then the message wrapped to fit the sidebar."""
    return ["PhyRoGen cannot generate here:",
            *(line for part in message.split(". ") for line in wrap_lines(part.rstrip(".") + ".", WRAP_CHARACTERS))]


class PHYROGEN_PT_missing_dependencies(bpy.types.Panel):  # noqa: N801 (Blender's naming)
    bl_label = "PhyRoGen"
    bl_idname = "PHYROGEN_PT_missing_dependencies"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "PhyRoGen"

    def draw(self, context):
        for index, line in enumerate(panel_lines(_message)):
            self.layout.label(text=line, icon="ERROR" if index == 0 else "NONE")


def register(message: str) -> None:
    global _message
    _message = message
    print(f"PhyRoGen: {message}")
    bpy.utils.register_class(PHYROGEN_PT_missing_dependencies)


def unregister() -> None:
    if PHYROGEN_PT_missing_dependencies.is_registered:
        bpy.utils.unregister_class(PHYROGEN_PT_missing_dependencies)
