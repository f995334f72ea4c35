"""The panel's settings (a property group per scene) and what they point to: the chosen generator's
parameters, the scene's puzzle collection and its folder under the output folder.

The parameter fields are made from the registry: one property group per
generator, one property per field of its parameter dataclass, so a new
generator appears in the panel without touching this file.
"""

from __future__ import annotations

import dataclasses
import json
import typing
from pathlib import Path

import bpy

from phyrogen_core.folder import PuzzleFolder
from phyrogen_core.registry import all_generators

_PROPERTY_OF_TYPE = {bool: bpy.props.BoolProperty, int: bpy.props.IntProperty, float: bpy.props.FloatProperty,
                     str: bpy.props.StringProperty}


def editable_fields(params_type: type) -> list[dataclasses.Field]:
    """The fields of a parameter dataclass the panel can show (bool, int, float, str)."""
    hints = typing.get_type_hints(params_type)
    return [f for f in dataclasses.fields(params_type) if hints[f.name] in _PROPERTY_OF_TYPE]


def parameter_group(name: str, params_type: type) -> type:
    hints = typing.get_type_hints(params_type)
    annotations = {f.name: _PROPERTY_OF_TYPE[hints[f.name]](name=f.name.replace("_", " ").capitalize(),
                                                            default=f.default,
                                                            description=str(f.metadata.get("doc", "")))
                   for f in editable_fields(params_type)}
    return type(f"PHYROGEN_PG_{name}", (bpy.types.PropertyGroup,), {"__annotations__": annotations})


class PHYROGEN_PG_result_row(bpy.types.PropertyGroup):  # noqa: N801 (Blender's naming)
    """One row of the last job's result table: its cells, tab-separated."""

    cells: bpy.props.StringProperty(name="Cells")


def settings_class(groups: dict[str, type]) -> type:
    generators = all_generators()
    annotations = {
        "generator": bpy.props.EnumProperty(
            name="Generator",
            items=[(n, s.title, s.doc.splitlines()[0] if s.doc else "") for n, s in generators.items()]),
        "seed": bpy.props.IntProperty(name="Seed", default=1, min=1),
        "output": bpy.props.StringProperty(name="Output", default="output", subtype="DIR_PATH",
                                           description="Folder for exported puzzles and renders"),
        "engine": bpy.props.EnumProperty(name="Engine", items=[("WORKBENCH", "Workbench", "fast"),
                                                               ("CYCLES", "Cycles", "CPU path tracing")]),
        "puzzle": bpy.props.StringProperty(name="Puzzle", description="Collection of the current puzzle"),
        "job_status": bpy.props.StringProperty(name="Job", description="Progress of the running job"),
        "result_label": bpy.props.StringProperty(name="Last run", description="The last job that ended"),
        "result_state": bpy.props.EnumProperty(
            name="Outcome", items=[("NONE", "None", "no job has ended"), ("DONE", "Done", "finished"),
                                   ("FAILED", "Failed", "the command failed"),
                                   ("CANCELLED", "Cancelled", "stopped by the user")]),
        "result_message": bpy.props.StringProperty(name="Message", description="What the last job said"),
        "result_columns": bpy.props.StringProperty(name="Columns", description="Titles of the last job's "
                                                                               "result table, tab-separated"),
        "result_rows": bpy.props.CollectionProperty(type=PHYROGEN_PG_result_row, name="Result",
                                                    description="The last job's result table"),
        "result_row_index": bpy.props.IntProperty(name="Row", default=-1),
        "manipulation_output": bpy.props.StringProperty(
            name="Manipulation output", subtype="DIR_PATH",
            description="The last manipulation run's folder: frames/, the video, report.json"),
        "phobos_output": bpy.props.StringProperty(
            name="Phobos output", default="", subtype="DIR_PATH",
            description="Folder for Export with Phobos (the puzzle goes to <folder>/<puzzle>); "
                        "empty: the puzzle folder's phobos/"),
    }
    for name, group in groups.items():
        annotations[f"params_{name}"] = bpy.props.PointerProperty(type=group)
    return type("PHYROGEN_PG_settings", (bpy.types.PropertyGroup,), {"__annotations__": annotations})


def chosen_params(settings):
    """The selected generator's spec and its parameter dataclass, from the panel's fields."""
    spec = all_generators()[settings.generator]
    group = getattr(settings, f"params_{spec.name}")
    values = {f.name: _exact(getattr(group, f.name)) for f in editable_fields(spec.params)}
    return spec, spec.params(**values)


def _exact(value):
    # Blender keeps float properties in single precision: 0.15 comes back as 0.15000000596.
    # Seven significant digits give back the number that was typed.
    return float(f"{value:.7g}") if isinstance(value, float) else value


def current_collection(context) -> bpy.types.Collection:
    from .scene import puzzle_collections

    settings = context.scene.phyrogen
    collection = bpy.data.collections.get(settings.puzzle) if settings.puzzle else None
    if collection is None:
        found = puzzle_collections(context.scene)
        if not found:
            raise ValueError("the scene holds no puzzle; press Generate first")
        collection = found[-1]
    return collection


def output_folder(settings) -> Path:
    return panel_path(settings.output)


def panel_path(text: str) -> Path:
    # "//" means the .blend file's folder; an unsaved file has none, so the working folder stands in.
    if text.startswith("//"):
        return Path(bpy.path.abspath(text)) if bpy.data.filepath else Path(text[2:] or ".")
    return Path(text)


def puzzle_folder(settings, collection) -> PuzzleFolder:
    """The folder of the scene's puzzle under the panel's output folder."""
    from phyrogen_core.record import folder_identity

    _, generator, _ = folder_identity(json.loads(collection.get("phyrogen/metadata", "{}")), generator="scene")
    return PuzzleFolder.at(output_folder(settings), generator, collection.name)
