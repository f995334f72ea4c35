"""The ``phobostype`` property, registered exactly as Phobos registers it.

Phobos stores ``phobostype`` as an ``EnumProperty`` on ``bpy.types.Object``;
a raw custom property of the same name is invisible to it. When Phobos is
installed it has registered the property already and we leave it alone.
"""

from __future__ import annotations

import bpy

from .annotations import PHOBOSTYPES

_registered_here = False


def ensure_phobostype() -> None:
    """Register ``Object.phobostype`` unless Phobos (or an earlier call) did."""
    global _registered_here
    if "phobostype" in bpy.types.Object.bl_rna.properties:
        return
    bpy.types.Object.phobostype = bpy.props.EnumProperty(
        items=[(item, item, "") for item in PHOBOSTYPES],
        name="type",
        default="undefined",
        description="Phobos type of the object",
    )
    _registered_here = True


def remove_phobostype() -> None:
    """Undo :func:`ensure_phobostype` (never removes the one Phobos registered)."""
    global _registered_here
    if _registered_here and hasattr(bpy.types.Object, "phobostype"):
        del bpy.types.Object.phobostype
    _registered_here = False


def phobostype(obj: bpy.types.Object) -> str:
    return getattr(obj, "phobostype", "undefined")
