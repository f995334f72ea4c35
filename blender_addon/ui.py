"""The sidebar panel, its settings and the operators Generate, Validate, Export URDF, Render
(and Export with Phobos, shown while the Phobos add-on is enabled).

The parameter fields are made from the registry: one property group per
generator, one property per field of its parameter dataclass, so a new
generator appears in the panel without touching this file.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import typing
from collections.abc import Callable
from pathlib import Path

import bpy

from phyrogen_core.folder import PuzzleFolder, name_problem
from phyrogen_core.registry import ParameterError, all_generators

from .environment import worker_python
from .phobos import PHOBOS_FOLDER, ensure_phobostype, phobos_enabled, remove_phobostype

_PROPERTY_OF_TYPE = {bool: bpy.props.BoolProperty, int: bpy.props.IntProperty, float: bpy.props.FloatProperty,
                     str: bpy.props.StringProperty}


def editable_fields(params_type: type) -> list[dataclasses.Field]:
    """The fields of a parameter dataclass the panel can show (bool, int, float, str)."""
    hints = typing.get_type_hints(params_type)
    return [f for f in dataclasses.fields(params_type) if hints[f.name] in _PROPERTY_OF_TYPE]


def _parameter_group(name: str, params_type: type) -> type:
    hints = typing.get_type_hints(params_type)
    annotations = {f.name: _PROPERTY_OF_TYPE[hints[f.name]](name=f.name.replace("_", " ").capitalize(),
                                                            default=f.default,
                                                            description=str(f.metadata.get("doc", "")))
                   for f in editable_fields(params_type)}
    return type(f"PHYROGEN_PG_{name}", (bpy.types.PropertyGroup,), {"__annotations__": annotations})


def _settings_class(groups: dict[str, type]) -> type:
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


def _output(settings) -> Path:
    return _path(settings.output)


def _path(text: str) -> Path:
    # "//" means the .blend file's folder; an unsaved file has none, so the working folder stands in.
    if text.startswith("//"):
        return Path(bpy.path.abspath(text)) if bpy.data.filepath else Path(text[2:] or ".")
    return Path(text)


def puzzle_folder(settings, collection) -> PuzzleFolder:
    """The folder of the scene's puzzle under the panel's output folder."""
    generator = json.loads(collection.get("phyrogen/metadata", "{}")).get("generator", "scene")
    return PuzzleFolder.at(_output(settings), generator, collection.name)


def run_reported(operator: bpy.types.Operator, work: Callable[[], str]) -> set[str]:
    """Run an operator's work and report its message; bad input or a failed step is reported
    as an error (the operator is cancelled) instead of a traceback in the console."""
    try:
        message = work()
    except (ParameterError, ValueError, KeyError, OSError, RuntimeError) as exc:
        operator.report({"ERROR"}, str(exc))
        return {"CANCELLED"}
    operator.report({"INFO"}, message)
    return {"FINISHED"}


class PHYROGEN_OT_generate(bpy.types.Operator):  # noqa: N801 (Blender's naming)
    """Generate and certify the puzzle, then build it in the scene"""

    bl_idname = "phyrogen.generate"
    bl_label = "Generate"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        return run_reported(self, lambda: self.generate(context))

    @staticmethod
    def generate(context) -> str:
        from .scene import build_puzzle_folder

        settings = context.scene.phyrogen
        spec, params = chosen_params(settings)
        spec.check(settings.seed, params)
        folder = generate_folder(spec.name, settings.seed, params, _output(settings))
        old = bpy.data.collections.get(folder.name)
        if old is not None:
            _remove_collection(old)
        built = build_puzzle_folder(folder, context.scene)
        settings.puzzle = built.collection.name
        return f"{folder.name}: written to {folder}"


def generate_folder(generator: str, seed: int, params, out: Path) -> Path:
    """Generate and certify a puzzle with ``phyrogen generate`` in the project's Python; its folder.

    A separate process keeps generation deterministic (OMPL is seeded once per
    process) and works inside a Blender binary, whose own Python lacks our dependencies.
    """
    overrides = [f"--set={f.name}={getattr(params, f.name)!r}" for f in dataclasses.fields(params)]
    command = [worker_python(), "-m", "phyrogen", "generate", "--generator", generator, "--seeds", str(seed),
               "--out", str(out), "--workers", "1", "--quiet", *overrides]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        lines = [line for line in (result.stderr + result.stdout).splitlines() if "error" in line or "FAILED" in line]
        raise RuntimeError(lines[-1] if lines else f"generation failed with exit code {result.returncode}")
    return PuzzleFolder.at(out, generator, f"{generator}_{seed}").path


def _remove_collection(collection: bpy.types.Collection) -> None:
    for obj in list(collection.all_objects):
        bpy.data.objects.remove(obj)
    for child in list(collection.children_recursive):
        bpy.data.collections.remove(child)
    bpy.data.collections.remove(collection)


class PHYROGEN_OT_validate(bpy.types.Operator):  # noqa: N801
    """Check the puzzle's solution certificate against the scene as it is now"""

    bl_idname = "phyrogen.validate"
    bl_label = "Validate"

    def execute(self, context):
        return run_reported(self, lambda: self.validate(context))

    @staticmethod
    def validate(context) -> str:
        from phyrogen_core.puzzle import Goal
        from solver.problem import verify_certificate

        from . import annotations as keys
        from .scene import read_chain

        collection = current_collection(context)
        if keys.METADATA not in collection:
            raise ValueError(f"{collection.name!r} keeps no puzzle.json: nothing to validate against")
        metadata = json.loads(collection[keys.METADATA])
        chain = read_chain(collection)
        stored = metadata["goal"]
        goal = Goal(stored["target"], stored["values"], stored["tolerance"])
        problems = verify_certificate(chain, metadata["certificate"], goal)
        if problems:
            raise ValueError(f"{collection.name}: INVALID: " + "; ".join(problems))
        return f"{collection.name}: certificate valid ({len(metadata['certificate'])} states)"


class PHYROGEN_OT_export_urdf(bpy.types.Operator):  # noqa: N801
    """Write the puzzle in the scene to its folder: URDF, SRDF, meshes and puzzle.json (other files stay)"""

    bl_idname = "phyrogen.export_urdf"
    bl_label = "Export URDF"

    def execute(self, context):
        from .export import export_collection

        def export() -> str:
            collection = current_collection(context)
            notices: list[str] = []  # a changed puzzle's old renders and solutions moved aside
            urdf = export_collection(collection, puzzle_folder(context.scene.phyrogen, collection).path, notices)
            return "; ".join([f"wrote {urdf}", *notices])

        return run_reported(self, export)


class PHYROGEN_OT_export_phobos(bpy.types.Operator):  # noqa: N801
    """Export the puzzle in the scene with Phobos (URDF, OBJ meshes) into the puzzle folder's phobos/
    (or the Phobos output folder's <puzzle>/)"""

    bl_idname = "phyrogen.export_phobos"
    bl_label = "Export with Phobos"

    @classmethod
    def poll(cls, context):
        return phobos_enabled()

    def execute(self, context):
        from .phobos import export_with_phobos

        def export() -> str:
            collection = current_collection(context)
            urdf = export_with_phobos(collection, phobos_folder(context.scene.phyrogen, collection))
            return f"Phobos wrote {urdf}"

        return run_reported(self, export)


def phobos_folder(settings, collection) -> Path:
    """Where Export with Phobos writes (replacing it): the chosen folder's ``<puzzle>/``, else the puzzle
    folder's ``phobos/`` (an entry of the interop stage, see ``phyrogen_core.folder``)."""
    if settings.phobos_output:
        problem = name_problem(collection.name)
        if problem is not None:
            raise ValueError(f"{collection.name!r} cannot name a folder: it {problem}")
        return _path(settings.phobos_output) / collection.name
    return puzzle_folder(settings, collection).path / PHOBOS_FOLDER


class PHYROGEN_OT_render(bpy.types.Operator):  # noqa: N801
    """Render the puzzle's views into <output>/<generator>/<puzzle>/images"""

    bl_idname = "phyrogen.render"
    bl_label = "Render"

    def execute(self, context):
        return run_reported(self, lambda: self.render(context))

    @staticmethod
    def render(context) -> str:
        from phyrogen_core.folder import atomic_directory

        from .render import render_views, setup_stage

        settings = context.scene.phyrogen
        collection = current_collection(context)
        setup_stage(context.scene, collection, settings.engine, (480, 360))
        with atomic_directory(puzzle_folder(settings, collection).images) as folder:
            paths = render_views(context.scene, collection, folder, collection.name)
        return f"rendered {len(paths)} views of {collection.name}"


class PHYROGEN_PT_panel(bpy.types.Panel):  # noqa: N801
    bl_label = "PhyRoGen"
    bl_idname = "PHYROGEN_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "PhyRoGen"

    def draw(self, context):
        draw_panel(self.layout, context.scene.phyrogen)


def draw_panel(layout, settings, phobos: bool | None = None) -> None:
    """The panel's content (a function of the settings, so a test can draw it into a fake layout);
    ``phobos``: whether to show Export with Phobos, by default while the Phobos add-on is enabled."""
    layout.prop(settings, "generator")
    layout.prop(settings, "seed")
    row = layout.row()
    row.scale_y = 1.6
    row.operator("phyrogen.generate", icon="MOD_BUILD")
    row = layout.row(align=True)
    row.operator("phyrogen.validate", icon="CHECKMARK")
    row.operator("phyrogen.export_urdf", icon="EXPORT")
    row.operator("phyrogen.render", icon="RENDER_STILL")
    spec = all_generators()[settings.generator]
    box = layout.box()
    box.label(text=f"{spec.title} parameters")
    group = getattr(settings, f"params_{spec.name}")
    for field in editable_fields(spec.params):
        box.prop(group, field.name)
    layout.prop(settings, "output")
    layout.prop(settings, "engine")
    show_phobos = phobos_enabled() if phobos is None else phobos
    if show_phobos:
        box = layout.box()
        box.operator("phyrogen.export_phobos", icon="EXPORT")
        box.prop(settings, "phobos_output")


_OPERATORS = (PHYROGEN_OT_generate, PHYROGEN_OT_validate, PHYROGEN_OT_export_urdf, PHYROGEN_OT_export_phobos,
              PHYROGEN_OT_render, PHYROGEN_PT_panel)
_registered: list[type] = []


def register() -> None:
    ensure_phobostype()
    groups = {name: _parameter_group(name, spec.params) for name, spec in all_generators().items()}
    classes = [*groups.values(), _settings_class(groups), *_OPERATORS]
    for cls in classes:
        bpy.utils.register_class(cls)
        _registered.append(cls)
    bpy.types.Scene.phyrogen = bpy.props.PointerProperty(type=classes[len(groups)])


def unregister() -> None:
    if hasattr(bpy.types.Scene, "phyrogen"):
        del bpy.types.Scene.phyrogen
    while _registered:
        bpy.utils.unregister_class(_registered.pop())
    remove_phobostype()
